//! Reader for the CANDIDE-3 `.wfm` text format (report appendix D, plus what the 3.1.6 file
//! really contains). Every section is read; every error names the 1-based line it found.
//!
//! The file is ISO-8859-1: bytes are decoded one to one into `char`s, so "Jörgen" survives
//! and nothing can fail to decode.

use glam::Vec3;

use super::{GlobalMotion, Mask, Unit, UnitKind, MIN_VERTICES};
use crate::quote::quote;

/// What went wrong while reading a `.wfm` file, always with the 1-based line number.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum WfmError {
    #[error("line {line}: expected {expected}, found end of file")]
    Truncated { line: usize, expected: String },
    /// `found` is quoted and cut by [`quote`].
    #[error("line {line}: expected {expected}, found {found}")]
    Expected {
        line: usize,
        expected: String,
        found: String,
    },
    /// `found` is quoted and cut by [`quote`].
    #[error("line {line}: {field} {found} is not a number")]
    NotANumber {
        line: usize,
        field: String,
        found: String,
    },
    #[error("line {line}: {field} {value} is out of range (must be below {limit})")]
    OutOfRange {
        line: usize,
        field: String,
        value: usize,
        limit: usize,
    },
    #[error("line {line}: {field} is {value}, which is not finite")]
    NotFinite { line: usize, field: String, value: f32 },
    #[error("line {line}: count {value} is too large (at most {limit})")]
    CountTooLarge { line: usize, value: usize, limit: usize },
    #[error("line {line}: {value} vertices; facewire addresses CANDIDE-3 vertices up to {} by number (lips, pupils, FAPU), so a mask needs at least {needed}", needed - 1)]
    TooFewVertices {
        line: usize,
        value: usize,
        needed: usize,
    },
}

/// Upper bound for any count in a `.wfm` file: far above CANDIDE's sizes, far below what
/// would let a corrupt count allocate unbounded memory.
const MAX_COUNT: usize = 100_000;

/// Parses the text of a `.wfm` file (already decoded from Latin-1).
pub fn parse(text: &str) -> Result<Mask, WfmError> {
    let mut reader = Reader::new(text);

    reader.expect_section("VERTEX LIST")?;
    let vertex_count = reader.count("vertex count")?;
    if vertex_count < MIN_VERTICES {
        return Err(WfmError::TooFewVertices {
            line: reader.next,
            value: vertex_count,
            needed: MIN_VERTICES,
        });
    }
    let mut vertices = Vec::with_capacity(vertex_count);
    for i in 0..vertex_count {
        let field = format!("vertex {i}");
        let (line, fields) = reader.data_line(&field)?;
        expect_field_count(line, &fields, 3, &field)?;
        vertices.push(parse_vec3(line, &fields, 0, &field)?);
    }

    reader.expect_section("FACE LIST")?;
    let face_count = reader.count("face count")?;
    let mut triangles = Vec::with_capacity(face_count);
    for i in 0..face_count {
        let field = format!("face {i}");
        let (line, fields) = reader.data_line(&field)?;
        expect_field_count(line, &fields, 3, &field)?;
        let mut tri = [0u32; 3];
        for (k, corner) in tri.iter_mut().enumerate() {
            *corner = parse_index(line, fields[k], &format!("{field} corner {k}"), vertex_count)?;
        }
        triangles.push(tri);
    }

    reader.expect_section("ANIMATION UNITS LIST")?;
    let animation_units = read_units(&mut reader, vertex_count, false)?;
    reader.expect_section("SHAPE UNITS LIST")?;
    let shape_units = read_units(&mut reader, vertex_count, true)?;

    reader.expect_section("ANIMATION PARAMETERS")?;
    let animation_params = read_params(&mut reader, animation_units.len(), "animation parameter")?;
    reader.expect_section("SHAPE PARAMETERS")?;
    let shape_params = read_params(&mut reader, shape_units.len(), "shape parameter")?;

    reader.expect_section("TEXTURE")?;
    let texture_count = reader.count("texture coordinate count")?;
    let mut texture = Vec::with_capacity(texture_count);
    for i in 0..texture_count {
        let field = format!("texture coordinate {i}");
        let (line, fields) = reader.data_line(&field)?;
        expect_field_count(line, &fields, 3, &field)?;
        let vertex = parse_index(line, fields[0], &format!("{field} vertex"), vertex_count)?;
        let u = parse_f32(line, fields[1], &format!("{field} u"))?;
        let v = parse_f32(line, fields[2], &format!("{field} v"))?;
        texture.push((vertex, [u, v]));
    }
    let texture_file = if texture_count > 0 {
        Some(reader.data_line("texture file name")?.1.join(" "))
    } else {
        None
    };

    reader.expect_section("GLOBAL MOTION")?;
    let mut rows = [Vec3::ZERO; 3];
    for (row, name) in rows.iter_mut().zip(["rotation", "scale", "translation"]) {
        let field = format!("global motion {name}");
        let (line, fields) = reader.data_line(&field)?;
        expect_field_count(line, &fields, 3, &field)?;
        *row = parse_vec3(line, &fields, 0, &field)?;
    }

    Ok(Mask {
        vertices,
        triangles,
        animation_units,
        shape_units,
        animation_params,
        shape_params,
        texture,
        texture_file,
        global_motion: GlobalMotion {
            rotation_rad: rows[0],
            scale: rows[1],
            translation: rows[2],
        },
    })
}

fn read_units(reader: &mut Reader<'_>, vertex_count: usize, shape: bool) -> Result<Vec<Unit>, WfmError> {
    let what = if shape { "shape unit" } else { "animation unit" };
    let unit_count = reader.count(&format!("{what} count"))?;
    let mut units = Vec::with_capacity(unit_count);
    for index in 0..unit_count {
        let comments = reader.take_comments();
        let title = comments.first().cloned().unwrap_or_default();
        let fapu_comment = comments.get(1).cloned();
        let field = format!("{what} {index}");
        let count = reader.count(&format!("{field} displacement count"))?;
        let mut displacements = Vec::with_capacity(count);
        for k in 0..count {
            let entry = format!("{field} displacement {k}");
            let (line, fields) = reader.data_line(&entry)?;
            expect_field_count(line, &fields, 4, &entry)?;
            let vertex = parse_index(line, fields[0], &format!("{entry} vertex"), vertex_count)?;
            let delta = parse_vec3(line, &fields, 1, &entry)?;
            displacements.push((vertex, delta));
        }
        let kind = if shape {
            UnitKind::Shape
        } else {
            UnitKind::from_title(&title, fapu_comment.as_deref())
        };
        units.push(Unit::new(title, kind, displacements));
    }
    Ok(units)
}

fn read_params(
    reader: &mut Reader<'_>,
    unit_count: usize,
    what: &str,
) -> Result<Vec<(usize, f32)>, WfmError> {
    let count = reader.count(&format!("{what} count"))?;
    let mut params = Vec::with_capacity(count);
    for i in 0..count {
        let field = format!("{what} {i}");
        let (line, fields) = reader.data_line(&field)?;
        expect_field_count(line, &fields, 2, &field)?;
        let unit = parse_index(line, fields[0], &format!("{field} unit"), unit_count)? as usize;
        params.push((unit, parse_f32(line, fields[1], &format!("{field} value"))?));
    }
    Ok(params)
}

/// Line cursor that knows about `#` comments and blank lines.
struct Reader<'a> {
    lines: Vec<&'a str>,
    /// 0-based index of the next unread line.
    next: usize,
}

impl<'a> Reader<'a> {
    fn new(text: &'a str) -> Self {
        Self {
            lines: text.lines().collect(),
            next: 0,
        }
    }

    /// Skips to the `# <title>:` line, passing over comments and blank lines only.
    fn expect_section(&mut self, title: &str) -> Result<(), WfmError> {
        while let Some(raw) = self.lines.get(self.next) {
            let line = raw.trim();
            self.next += 1;
            if line.is_empty() {
                continue;
            }
            if let Some(comment) = line.strip_prefix('#') {
                let comment = comment.trim().trim_end_matches(':').trim();
                if comment.eq_ignore_ascii_case(title) {
                    return Ok(());
                }
                continue;
            }
            return Err(WfmError::Expected {
                line: self.next,
                expected: format!("section \"# {title}:\""),
                found: quote(line),
            });
        }
        Err(WfmError::Truncated {
            line: self.lines.len() + 1,
            expected: format!("section \"# {title}:\""),
        })
    }

    /// Collects the comment lines (text after `#`) before the next data line.
    fn take_comments(&mut self) -> Vec<String> {
        let mut comments = Vec::new();
        while let Some(raw) = self.lines.get(self.next) {
            let line = raw.trim();
            if line.is_empty() {
                self.next += 1;
            } else if let Some(comment) = line.strip_prefix('#') {
                comments.push(comment.trim().to_string());
                self.next += 1;
            } else {
                break;
            }
        }
        comments
    }

    /// The next non-blank, non-comment line, split into fields, with its 1-based number.
    fn data_line(&mut self, expected: &str) -> Result<(usize, Vec<&'a str>), WfmError> {
        while let Some(raw) = self.lines.get(self.next) {
            let line = raw.trim();
            self.next += 1;
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            return Ok((self.next, line.split_whitespace().collect()));
        }
        Err(WfmError::Truncated {
            line: self.lines.len() + 1,
            expected: expected.to_string(),
        })
    }

    fn count(&mut self, field: &str) -> Result<usize, WfmError> {
        let (line, fields) = self.data_line(field)?;
        expect_field_count(line, &fields, 1, field)?;
        let value: usize = fields[0].parse().map_err(|_| WfmError::NotANumber {
            line,
            field: field.to_string(),
            found: quote(fields[0]),
        })?;
        if value > MAX_COUNT {
            return Err(WfmError::CountTooLarge {
                line,
                value,
                limit: MAX_COUNT,
            });
        }
        Ok(value)
    }
}

fn expect_field_count(line: usize, fields: &[&str], count: usize, field: &str) -> Result<(), WfmError> {
    if fields.len() == count {
        Ok(())
    } else {
        Err(WfmError::Expected {
            line,
            expected: format!("{count} number(s) for {field}"),
            found: quote(&fields.join(" ")),
        })
    }
}

fn parse_f32(line: usize, text: &str, field: &str) -> Result<f32, WfmError> {
    let value: f32 = text.parse().map_err(|_| WfmError::NotANumber {
        line,
        field: field.to_string(),
        found: quote(text),
    })?;
    if !value.is_finite() {
        return Err(WfmError::NotFinite {
            line,
            field: field.to_string(),
            value,
        });
    }
    Ok(value)
}

fn parse_vec3(line: usize, fields: &[&str], first: usize, field: &str) -> Result<Vec3, WfmError> {
    let mut xyz = [0.0f32; 3];
    for (k, axis) in ["x", "y", "z"].iter().enumerate() {
        let text = fields.get(first + k).ok_or_else(|| WfmError::Expected {
            line,
            expected: format!("{} numbers for {field}", first + 3),
            found: quote(&fields.join(" ")),
        })?;
        xyz[k] = parse_f32(line, text, &format!("{field} {axis}"))?;
    }
    Ok(Vec3::from_array(xyz))
}

fn parse_index(line: usize, text: &str, field: &str, limit: usize) -> Result<u32, WfmError> {
    let value: usize = text.parse().map_err(|_| WfmError::NotANumber {
        line,
        field: field.to_string(),
        found: quote(text),
    })?;
    if value >= limit {
        return Err(WfmError::OutOfRange {
            line,
            field: field.to_string(),
            value,
            limit,
        });
    }
    Ok(value as u32)
}
