//! MPEG-4 `.fap` files, as Xface and Greta read and write them
//! (`data/candide3/NOTES.md` section 7), so that existing MPEG-4 animations drive facewire
//! and facewire's FAP streams play in those tools.
//!
//! ```text
//! 2.1 joy 25 108                 version, name (may contain spaces), fps, frame count
//! # comment                      '#' lines and blank lines are skipped anywhere
//! 0 0 1 1 0 ... 0                mask: 68 (Greta: 69) entries 0/1, one per FAP 1..=68
//! 0 120 -40                      frame number, then the value of every masked FAP
//! ```
//! A masked FAP 1 (viseme) contributes 4 values and FAP 2 (expression) 6. A FAP whose mask
//! bit is 0 is at rest in that frame. Time is `frame number / fps`; the frame number is
//! also the frame's `seq`.

use std::io::{BufRead, Write};

use super::check::{fps_in_range, FPS_EXPECTED};
use super::error::{parse_finite, Location, StreamError};
use super::frame::{ExpressionFap, Frame, VisemeFap, HEAD_ROTATION_FAPS, RADIANS_PER_ANGLE_COUNT};
use super::lines::{Decoding, LineReader};
use super::reader::{FrameReader, LineFormat};
use crate::mask::fap::fap_info;

/// Entries of a standard mask line: one per FAP 1..=68.
pub const FAP_COUNT: usize = 68;
/// Greta writes one more, a dummy slot that must be 0.
pub const GRETA_MASK_LENGTH: usize = 69;

/// The first line of a `.fap` file.
#[derive(Debug, Clone, PartialEq)]
pub struct FapHeader {
    /// Format version as written (`2.1`); recorded, not interpreted.
    pub version: String,
    /// Free-form name; runs of whitespace inside it read back as one space.
    pub name: String,
    pub fps: f64,
    /// Number of frames the file holds.
    pub frame_count: u64,
}

/// Reads `.fap` frames from any [`BufRead`], two lines per frame. The header is read on
/// the first call to [`FapReader::header`] or `next`.
pub type FapReader<R> = FrameReader<R, FapFormat>;

/// A `.fap` file's lines: the header, then a mask line and a values line per frame.
pub struct FapFormat {
    header: Header,
}

/// The header, once read.
enum Header {
    NotRead,
    Read(FapHeader),
    /// Reading it failed: the reader yields no frames.
    Failed,
}

impl<R: BufRead> FapReader<R> {
    pub fn new(input: R) -> Self {
        FrameReader::with_format(
            input,
            FapFormat {
                header: Header::NotRead,
            },
        )
    }

    /// The file's header, reading it if no frame has been read yet. After a header error
    /// the reader yields no frames.
    pub fn header(&mut self) -> Result<&FapHeader, StreamError> {
        let (format, lines, line) = self.format_and_lines();
        format.header(lines, line)
    }
}

impl FapFormat {
    fn header<R: BufRead>(
        &mut self,
        lines: &mut LineReader<R>,
        line: &mut String,
    ) -> Result<&FapHeader, StreamError> {
        if matches!(self.header, Header::NotRead) {
            self.header = match read_header(lines, line) {
                Ok(header) => Header::Read(header),
                Err(e) => {
                    self.header = Header::Failed;
                    return Err(e);
                }
            };
        }
        match &self.header {
            Header::Read(header) => Ok(header),
            Header::NotRead | Header::Failed => Err(StreamError::Truncated {
                at: lines.location(),
                field: "header".to_string(),
                expected: "a valid header line (reading it failed before)".to_string(),
            }),
        }
    }
}

impl LineFormat for FapFormat {
    const DECODING: Decoding = Decoding::Latin1;
    const SEQ_FIELD: &'static str = "frame number";
    const TIME_FIELD: &'static str = "frame number";

    fn read_frame<R: BufRead>(
        &mut self,
        lines: &mut LineReader<R>,
        line: &mut String,
        frames_read: u64,
    ) -> Result<Option<(Frame, Location)>, StreamError> {
        let (fps, frame_count) = match self.header {
            Header::Failed => return Ok(None),
            _ => {
                let header = self.header(lines, line)?;
                (header.fps, header.frame_count)
            }
        };
        let frame_index = frames_read + 1;
        if frames_read == frame_count {
            if lines.read_data_line(line, true)? {
                return Err(StreamError::TrailingData {
                    at: lines.location(),
                    frames: frame_count,
                });
            }
            return Ok(None);
        }
        let of_frames = format!("frame {frame_index} of {frame_count}");

        if !lines.read_data_line(line, true)? {
            return Err(StreamError::Truncated {
                at: lines.location(),
                field: "mask".to_string(),
                expected: format!("the mask line of {of_frames}"),
            });
        }
        let mask = parse_mask(&lines.location(), line)?;

        if !lines.read_data_line(line, true)? {
            return Err(StreamError::Truncated {
                at: lines.location(),
                field: "values".to_string(),
                expected: format!("the values line of {of_frames}"),
            });
        }
        let at = lines.location();
        let frame = parse_values(&at, line, &mask, fps)?;
        frame.check_at(&at, None)?;
        Ok(Some((frame, at)))
    }
}

fn read_header<R: BufRead>(lines: &mut LineReader<R>, line: &mut String) -> Result<FapHeader, StreamError> {
    if !lines.read_data_line(line, true)? {
        return Err(StreamError::Truncated {
            at: lines.location(),
            field: "header".to_string(),
            expected: "the header line \"version name fps frames\"".to_string(),
        });
    }
    let at = lines.location();
    let tokens: Vec<&str> = line.split_whitespace().collect();
    if tokens.len() < 3 {
        return Err(StreamError::WrongLength {
            at,
            field: "header".to_string(),
            found: tokens.len(),
            expected: "at least 3 (version [name] fps frames)".to_string(),
        });
    }
    let fps_text = tokens[tokens.len() - 2];
    let fps: f64 = parse_finite(&at, fps_text, "header fps")?;
    if !fps_in_range(fps) {
        return Err(StreamError::OutOfRange {
            at,
            field: "header fps".to_string(),
            found: fps_text.to_string(),
            expected: FPS_EXPECTED.to_string(),
        });
    }
    let count_text = tokens[tokens.len() - 1];
    let frame_count = count_text.parse::<u64>().map_err(|_| StreamError::NotANumber {
        at: at.clone(),
        field: "header frame count".to_string(),
        found: format!("{count_text:?}"),
        expected: "a non-negative integer",
    })?;
    Ok(FapHeader {
        version: tokens[0].to_string(),
        name: tokens[1..tokens.len() - 2].join(" "),
        fps,
        frame_count,
    })
}

/// Which of FAPs 1..=68 a mask line switches on.
fn parse_mask(at: &Location, line: &str) -> Result<[bool; FAP_COUNT], StreamError> {
    let tokens: Vec<&str> = line.split_whitespace().collect();
    if tokens.len() != FAP_COUNT && tokens.len() != GRETA_MASK_LENGTH {
        return Err(StreamError::WrongLength {
            at: at.clone(),
            field: "mask".to_string(),
            found: tokens.len(),
            expected: format!("{FAP_COUNT} (or Greta's {GRETA_MASK_LENGTH})"),
        });
    }
    let mut mask = [false; FAP_COUNT];
    for (i, token) in tokens.iter().enumerate() {
        let on = match *token {
            "0" => false,
            "1" => true,
            other => {
                return Err(StreamError::OutOfRange {
                    at: at.clone(),
                    field: format!("mask[{i}] (FAP {})", i + 1),
                    found: format!("{other:?}"),
                    expected: "0 or 1".to_string(),
                })
            }
        };
        match mask.get_mut(i) {
            Some(slot) => *slot = on,
            None if on => {
                return Err(StreamError::OutOfRange {
                    at: at.clone(),
                    field: format!("mask[{i}] (Greta's dummy slot)"),
                    found: "1".to_string(),
                    expected: "0".to_string(),
                })
            }
            None => {}
        }
    }
    Ok(mask)
}

/// Values a masked FAP contributes: 4 for the viseme, 6 for the expression, else 1.
fn value_count(fap: u8) -> usize {
    match fap {
        1 => 4,
        2 => 6,
        _ => 1,
    }
}

fn fap_field(fap: u8, position: usize) -> String {
    let name = fap_info(fap).map_or("?", |info| info.name);
    format!("values[{position}] (FAP {fap} {name})")
}

fn parse_int(at: &Location, text: &str, field: &str) -> Result<i32, StreamError> {
    text.parse().map_err(|_| StreamError::NotANumber {
        at: at.clone(),
        field: field.to_string(),
        found: format!("{text:?}"),
        expected: "an integer",
    })
}

fn parse_values(at: &Location, line: &str, mask: &[bool; FAP_COUNT], fps: f64) -> Result<Frame, StreamError> {
    let tokens: Vec<&str> = line.split_whitespace().collect();
    let masked = (1..=FAP_COUNT as u8).filter(|&fap| mask[usize::from(fap - 1)]);
    let expected: usize = masked.clone().map(value_count).sum();
    if tokens.len() != expected + 1 {
        return Err(StreamError::WrongLength {
            at: at.clone(),
            field: "values".to_string(),
            found: tokens.len(),
            expected: format!(
                "{} (the frame number and {expected} values for the {} FAPs the mask switches on)",
                expected + 1,
                masked.clone().count()
            ),
        });
    }
    let seq = tokens[0].parse::<u64>().map_err(|_| StreamError::NotANumber {
        at: at.clone(),
        field: "frame number".to_string(),
        found: tokens[0].to_string(),
        expected: "a non-negative integer",
    })?;
    let mut frame = Frame::at(seq, seq as f64 / fps);
    let mut position = 1;
    for fap in masked {
        let values = &tokens[position..position + value_count(fap)];
        let field = fap_field(fap, position - 1);
        match fap {
            1 => {
                let [s1, s2, blend, def] = [0, 1, 2, 3].map(|k| parse_int(at, values[k], &field));
                frame.viseme = Some(VisemeFap {
                    select1: s1?,
                    select2: s2?,
                    blend: blend?,
                    definition: def?,
                });
            }
            2 => {
                let [s1, i1, s2, i2, init, def] =
                    [0, 1, 2, 3, 4, 5].map(|k| parse_int(at, values[k], &field));
                frame.expression = Some(ExpressionFap {
                    select1: s1?,
                    intensity1: i1?,
                    select2: s2?,
                    intensity2: i2?,
                    init_face: init?,
                    definition: def?,
                });
            }
            _ => frame.faps.push((fap, parse_finite(at, values[0], &field)?)),
        }
        position += values.len();
    }
    Ok(frame)
}

/// Writes `.fap` files: the header first, then two lines per frame, LF line endings.
/// Values are written as integers (the format's unit), rounded to the nearest count.
///
/// A frame's `faps`, `viseme`, `expression` and `head_rotation_rad` (as FAPs 48-50, added
/// to any already there) are written; its label is dropped (the format has no place for
/// it); animation units, ARKit weights, head translation and controls are refused with
/// [`StreamError::Unrepresentable`] rather than lost.
pub struct FapWriter<W> {
    out: W,
    fps: f64,
    announced: u64,
    written: u64,
    previous_frame_number: Option<u64>,
    line: String,
}

impl<W: Write> FapWriter<W> {
    /// Writes the header. The name must be one line and not empty, the version one word.
    pub fn new(mut out: W, header: &FapHeader) -> Result<Self, StreamError> {
        let one_word = !header.version.is_empty() && !header.version.contains(char::is_whitespace);
        if !one_word {
            return Err(StreamError::InvalidOption {
                option: "FAP header version",
                expected: "one word such as 2.1",
                found: format!("{:?}", header.version),
            });
        }
        if header.name.trim().is_empty() || header.name.contains(['\n', '\r']) {
            return Err(StreamError::InvalidOption {
                option: "FAP header name",
                expected: "a non-empty single line",
                found: format!("{:?}", header.name),
            });
        }
        if !fps_in_range(header.fps) {
            return Err(StreamError::InvalidOption {
                option: "FAP header fps",
                expected: FPS_EXPECTED,
                found: header.fps.to_string(),
            });
        }
        writeln!(
            out,
            "{} {} {} {}",
            header.version, header.name, header.fps, header.frame_count
        )?;
        Ok(FapWriter {
            out,
            fps: header.fps,
            announced: header.frame_count,
            written: 0,
            previous_frame_number: None,
            line: String::new(),
        })
    }

    /// Writes one frame. Its frame number is `round(time_s * fps)`, which must increase
    /// from frame to frame.
    pub fn write_frame(&mut self, frame: &Frame) -> Result<(), StreamError> {
        let seq = frame.seq;
        if let Some(field) = frame
            .content()
            .find(|&field| field != "fap" && field != "head_rotation_rad")
        {
            return Err(StreamError::Unrepresentable {
                seq,
                field: field.to_string(),
                format: ".fap",
            });
        }
        frame.check_at(&Location::Frame { seq }, None)?;
        let invalid = |field: String, reason: String| StreamError::InvalidFrame { seq, field, reason };
        if self.written == self.announced {
            return Err(invalid(
                "frame".to_string(),
                format!("the header announced {} frames", self.announced),
            ));
        }

        let frame_number = (frame.time_s * self.fps).round();
        if !(frame_number.is_finite() && frame_number >= 0.0) {
            return Err(invalid(
                "t".to_string(),
                format!("{} s is not a time at or after 0", frame.time_s),
            ));
        }
        let frame_number = frame_number as u64;
        if let Some(previous) = self.previous_frame_number {
            if frame_number <= previous {
                return Err(invalid(
                    "t".to_string(),
                    format!(
                        "{} s falls on frame {frame_number}, not after the previous frame {previous}",
                        frame.time_s
                    ),
                ));
            }
        }

        let mut values: [Option<f32>; FAP_COUNT] = [None; FAP_COUNT];
        for &(fap, count) in &frame.faps {
            let slot = fap_info(fap)
                .filter(|info| info.number > 2)
                .and_then(|_| values.get_mut(usize::from(fap) - 1))
                .ok_or_else(|| invalid(format!("fap[{fap}]"), "not a FAP 3..=68".to_string()))?;
            *slot = Some(slot.unwrap_or(0.0) + count);
        }
        if let Some(rotation) = frame.head_rotation_rad {
            for (fap, radians) in HEAD_ROTATION_FAPS.into_iter().zip(rotation) {
                let slot = &mut values[usize::from(fap) - 1];
                *slot = Some(slot.unwrap_or(0.0) + radians / RADIANS_PER_ANGLE_COUNT);
            }
        }

        self.line.clear();
        let on = |present: bool| if present { "1" } else { "0" };
        let mut bits = vec![on(frame.viseme.is_some()), on(frame.expression.is_some())];
        bits.extend(values[2..].iter().map(|v| on(v.is_some())));
        self.line.push_str(&bits.join(" "));
        self.line.push('\n');
        self.line.push_str(&frame_number.to_string());
        if let Some(v) = frame.viseme {
            for value in [v.select1, v.select2, v.blend, v.definition] {
                self.line.push_str(&format!(" {value}"));
            }
        }
        if let Some(e) = frame.expression {
            for value in [
                e.select1,
                e.intensity1,
                e.select2,
                e.intensity2,
                e.init_face,
                e.definition,
            ] {
                self.line.push_str(&format!(" {value}"));
            }
        }
        for (i, value) in values.iter().enumerate() {
            if let Some(value) = value {
                let rounded = value.round();
                if !rounded.is_finite() || rounded.abs() > i32::MAX as f32 {
                    let fap = i as u8 + 1;
                    return Err(invalid(
                        format!("fap.{}", fap_info(fap).map_or("?", |f| f.name)),
                        format!("{value} is not a finite 32-bit count"),
                    ));
                }
                self.line.push_str(&format!(" {}", rounded as i32));
            }
        }
        self.line.push('\n');
        self.out.write_all(self.line.as_bytes())?;
        self.previous_frame_number = Some(frame_number);
        self.written += 1;
        Ok(())
    }

    /// Checks that as many frames were written as the header announced, flushes and
    /// returns the underlying writer.
    pub fn finish(mut self) -> Result<W, StreamError> {
        if self.written != self.announced {
            return Err(StreamError::FrameCountMismatch {
                announced: self.announced,
                written: self.written,
            });
        }
        self.out.flush()?;
        Ok(self.out)
    }
}
