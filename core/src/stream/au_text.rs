//! Plain AU text, the animation files of the legacy tool: one frame per line, the weights
//! of the mask's animation units in the model's order, separated by whitespace. Kept so
//! the thesis-era animations play unchanged.
//!
//! ```text
//! # columns: time jaw_drop lip_stretcher     optional header (before the first frame)
//! 0.000  0.0  0.0
//! 0.033  0.1  0.05
//! ```
//! Without a `# columns:` header the columns are the first N animation units (N = the
//! values on the first line, the same on every line) and there is a leading time column
//! only if [`AuTextOptions::headerless_time_column`] says so; frames are then
//! [`AuTextOptions::fps`] apart. Other `#` lines and blank lines are skipped.

use std::io::{BufRead, Write};

use super::check::{fps_in_range, FPS_EXPECTED};
use super::error::{parse_finite, Location, StreamError};
use super::frame::Frame;
use super::lines::{Decoding, LineReader};
use super::reader::{FrameReader, LineFormat};
use crate::mask::Mask;

/// The header comment that names the columns.
pub const COLUMNS_HEADER: &str = "# columns:";
/// Frame rate of a file without a time column, unless told otherwise.
pub const DEFAULT_FPS: f64 = 30.0;

/// How to read AU text that has no `# columns:` header.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AuTextOptions {
    /// Frames per second when there is no time column. Default 30.
    pub fps: f64,
    /// Whether each line of a headerless file starts with a time in seconds. Default
    /// `false`. A header, when present, decides instead (`time` as its first column).
    pub headerless_time_column: bool,
}

impl Default for AuTextOptions {
    fn default() -> Self {
        AuTextOptions {
            fps: DEFAULT_FPS,
            headerless_time_column: false,
        }
    }
}

/// The column layout, fixed by the header or by the first frame line.
#[derive(Debug)]
struct Columns {
    time: bool,
    /// Animation unit of each weight column.
    units: Vec<u16>,
}

/// Reads AU text frames from any [`BufRead`], one line at a time.
pub type AuTextReader<'m, R> = FrameReader<R, AuTextFormat<'m>>;

/// AU text's lines: an optional `# columns:` header, then one frame per line.
pub struct AuTextFormat<'m> {
    mask: &'m Mask,
    options: AuTextOptions,
    columns: Option<Columns>,
}

impl<'m, R: BufRead> AuTextReader<'m, R> {
    /// Fails if `options.fps` is outside [`crate::stream::MIN_FPS`]..=[`crate::stream::MAX_FPS`].
    pub fn new(input: R, mask: &'m Mask, options: AuTextOptions) -> Result<Self, StreamError> {
        if !fps_in_range(options.fps) {
            return Err(StreamError::InvalidOption {
                option: "AU text fps",
                expected: FPS_EXPECTED,
                found: options.fps.to_string(),
            });
        }
        Ok(FrameReader::with_format(
            input,
            AuTextFormat {
                mask,
                options,
                columns: None,
            },
        ))
    }
}

impl AuTextFormat<'_> {
    /// The next line holding a frame; a `# columns:` header seen before the first frame
    /// sets the columns.
    fn next_frame_line<R: BufRead>(
        &mut self,
        lines: &mut LineReader<R>,
        line: &mut String,
    ) -> Result<bool, StreamError> {
        loop {
            if !lines.read_data_line(line, false)? {
                return Ok(false);
            }
            let trimmed = line.trim();
            if !trimmed.starts_with('#') {
                return Ok(true);
            }
            let Some(names) = strip_prefix_ignore_case(trimmed, COLUMNS_HEADER) else {
                continue;
            };
            let at = lines.location();
            if self.columns.is_some() {
                return Err(StreamError::syntax(
                    &at,
                    "columns",
                    "the columns header must come once, before the first frame",
                ));
            }
            self.columns = Some(parse_columns_header(&at, names, self.mask)?);
        }
    }
}

impl LineFormat for AuTextFormat<'_> {
    const DECODING: Decoding = Decoding::Latin1;
    const SEQ_FIELD: &'static str = "line";
    const TIME_FIELD: &'static str = "column 1 (time)";

    fn read_frame<R: BufRead>(
        &mut self,
        lines: &mut LineReader<R>,
        line: &mut String,
        frames_read: u64,
    ) -> Result<Option<(Frame, Location)>, StreamError> {
        if !self.next_frame_line(lines, line)? {
            return Ok(None);
        }
        let at = lines.location();
        let tokens: Vec<&str> = line.split_whitespace().collect();
        let columns = match self.columns.take() {
            Some(columns) => columns,
            None => headerless_columns(&at, tokens.len(), self.mask, self.options)?,
        };
        let columns = &*self.columns.insert(columns);
        let expected = columns.units.len() + usize::from(columns.time);
        if tokens.len() != expected {
            return Err(StreamError::WrongLength {
                at,
                field: "values".to_string(),
                found: tokens.len(),
                expected: format!(
                    "{expected} ({}{} animation unit weights)",
                    if columns.time { "a time and " } else { "" },
                    columns.units.len()
                ),
            });
        }
        let seq = frames_read;
        let mut weights = tokens.as_slice();
        let time_s = match weights.split_first() {
            Some((time, rest)) if columns.time => {
                weights = rest;
                parse_finite(&at, time, "column 1 (time)")?
            }
            _ => seq as f64 / self.options.fps,
        };
        let mut frame = Frame::at(seq, time_s);
        let first_weight_column = 1 + usize::from(columns.time);
        for (k, (&unit, text)) in columns.units.iter().zip(weights).enumerate() {
            let key = &self.mask.animation_units[usize::from(unit)].key;
            let field = format!("column {} ({key})", first_weight_column + k);
            let weight: f32 = parse_finite(&at, text, &field)?;
            if weight != 0.0 {
                frame.animation.push((unit, weight));
            }
        }
        frame.animation.sort_by_key(|&(unit, _)| unit);
        frame.check_at(&at, Some(self.mask))?;
        Ok(Some((frame, at)))
    }
}

fn strip_prefix_ignore_case<'t>(text: &'t str, prefix: &str) -> Option<&'t str> {
    let head = text.get(..prefix.len())?;
    head.eq_ignore_ascii_case(prefix).then(|| &text[prefix.len()..])
}

fn parse_columns_header(at: &Location, names: &str, mask: &Mask) -> Result<Columns, StreamError> {
    let mut time = false;
    let mut units: Vec<u16> = Vec::new();
    for (k, name) in names.split_whitespace().enumerate() {
        let field = format!("columns[{}]", k + 1);
        if name.eq_ignore_ascii_case("time") {
            if k != 0 {
                return Err(StreamError::syntax(
                    at,
                    &field,
                    "time can only be the first column",
                ));
            }
            time = true;
            continue;
        }
        let unit = mask
            .animation_unit(name)
            .map_err(|source| StreamError::UnknownUnit {
                at: at.clone(),
                field: field.clone(),
                source: Box::new(source),
            })?;
        let unit = u16::try_from(unit).map_err(|_| StreamError::OutOfRange {
            at: at.clone(),
            field: field.clone(),
            found: unit.to_string(),
            expected: "a unit index below 65536".to_string(),
        })?;
        if let Some(first) = units.iter().position(|&u| u == unit) {
            return Err(StreamError::Duplicate {
                at: at.clone(),
                field,
                what: "animation unit",
                other: format!("\"columns[{}]\"", first + 1 + usize::from(time)),
            });
        }
        units.push(unit);
    }
    if units.is_empty() {
        return Err(StreamError::syntax(at, "columns", "names no animation unit"));
    }
    Ok(Columns { time, units })
}

fn headerless_columns(
    at: &Location,
    values: usize,
    mask: &Mask,
    options: AuTextOptions,
) -> Result<Columns, StreamError> {
    let time = options.headerless_time_column;
    let weights = values.saturating_sub(usize::from(time));
    let unit_count = mask.animation_units.len().min(usize::from(u16::MAX));
    if weights == 0 || weights > unit_count {
        return Err(StreamError::WrongLength {
            at: at.clone(),
            field: "values".to_string(),
            found: values,
            expected: format!(
                "{}1 to {unit_count} weights (the mask's animation units in order)",
                if time { "a time and " } else { "" }
            ),
        });
    }
    Ok(Columns {
        time,
        units: (0..weights as u16).collect(),
    })
}

/// Writes AU text: a `# columns:` header naming the first `unit_count` animation units
/// (after `time` when `time_column` is set), then one line per frame with every column,
/// zeros included. Weights are written with Rust's shortest round-trip formatting, so
/// they read back bit for bit.
///
/// Only `animation` entries below `unit_count` can be written (the label is dropped);
/// FAPs, ARKit weights, head motion and controls are refused with
/// [`StreamError::Unrepresentable`].
pub struct AuTextWriter<W> {
    out: W,
    unit_count: usize,
    time_column: bool,
    weights: Vec<f32>,
    line: String,
}

impl<W: Write> AuTextWriter<W> {
    /// Writes the header. `unit_count` must be between 1 and the mask's unit count.
    pub fn new(mut out: W, mask: &Mask, unit_count: usize, time_column: bool) -> Result<Self, StreamError> {
        if unit_count == 0 || unit_count > mask.animation_units.len() {
            return Err(StreamError::InvalidOption {
                option: "AU text unit count",
                expected: "between 1 and the mask's animation unit count",
                found: unit_count.to_string(),
            });
        }
        let mut header = String::from(COLUMNS_HEADER);
        if time_column {
            header.push_str(" time");
        }
        for unit in &mask.animation_units[..unit_count] {
            header.push(' ');
            header.push_str(&unit.key);
        }
        writeln!(out, "{header}")?;
        Ok(AuTextWriter {
            out,
            unit_count,
            time_column,
            weights: vec![0.0; unit_count],
            line: String::new(),
        })
    }

    pub fn write_frame(&mut self, frame: &Frame) -> Result<(), StreamError> {
        let seq = frame.seq;
        if let Some(field) = frame.content().find(|&field| field != "au") {
            return Err(StreamError::Unrepresentable {
                seq,
                field: field.to_string(),
                format: "AU text",
            });
        }
        frame.check_at(&Location::Frame { seq }, None)?;
        let invalid = |field: String, reason: String| StreamError::InvalidFrame { seq, field, reason };
        self.weights.fill(0.0);
        for &(unit, weight) in &frame.animation {
            let field = format!("au[{unit}]");
            let slot = self.weights.get_mut(usize::from(unit)).ok_or_else(|| {
                invalid(
                    field.clone(),
                    format!("only the first {} units are written", self.unit_count),
                )
            })?;
            if !weight.is_finite() {
                return Err(invalid(field, format!("{weight} is not finite")));
            }
            *slot += weight;
        }
        self.line.clear();
        if self.time_column {
            if !frame.time_s.is_finite() {
                return Err(invalid(
                    "t".to_string(),
                    format!("{} is not finite", frame.time_s),
                ));
            }
            self.line.push_str(&frame.time_s.to_string());
        }
        for weight in &self.weights {
            if !self.line.is_empty() {
                self.line.push(' ');
            }
            self.line.push_str(&weight.to_string());
        }
        self.line.push('\n');
        self.out.write_all(self.line.as_bytes())?;
        Ok(())
    }

    /// Flushes and returns the underlying writer.
    pub fn into_inner(mut self) -> Result<W, StreamError> {
        self.out.flush()?;
        Ok(self.out)
    }
}
