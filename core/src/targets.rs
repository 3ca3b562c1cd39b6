//! Expression targets: artist-made displacements of a head's vertices, the ground truth
//! that fidelity is scored against (`data/heads/makehuman_arkit/*.target`, ARKit names,
//! CC0). The format: `#` comment lines, then one line `vertex dx dy dz` per moved vertex,
//! 0-based head vertex index and displacement in head units. Vertices not listed do not
//! move. Every error names the file, the 1-based line and the field.

use std::path::Path;

use glam::Vec3;

use crate::fit::Anchors;
use crate::input::{read_text, ReadError, MAX_TEXT_BYTES};
use crate::text_table::{self, FieldProblem, Row};

/// A malformed target file, or inputs that do not fit the target.
#[derive(Debug, thiserror::Error)]
pub enum TargetError {
    #[error(transparent)]
    Read(#[from] ReadError),
    #[error("cannot list {path}: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("{origin}: line {line}: expected 4 fields `vertex dx dy dz`, found {found}")]
    FieldCount {
        origin: String,
        line: usize,
        found: usize,
    },
    /// `found` is quoted and cut (see [`text_table::FieldProblem`]).
    #[error("{origin}: line {line}: field {field}: {found} {problem}")]
    Field {
        origin: String,
        line: usize,
        field: &'static str,
        found: String,
        problem: &'static str,
    },
    #[error("{origin}: line {line}: vertex {vertex} is out of range: the head has {count} vertices")]
    VertexOutOfRange {
        origin: String,
        line: usize,
        vertex: u32,
        count: usize,
    },
    #[error("{origin}: line {line}: vertex {vertex} is listed again (first on line {first_line})")]
    Repeated {
        origin: String,
        line: usize,
        vertex: u32,
        first_line: usize,
    },
    #[error("target {name}: {what}: expected {expected} values, found {found}")]
    Length {
        name: String,
        what: &'static str,
        expected: usize,
        found: usize,
    },
}

/// One expression as a displacement per head vertex (head units).
#[derive(Debug, Clone, PartialEq)]
pub struct ExpressionTarget {
    /// The file stem (`jawOpen`).
    pub name: String,
    /// One displacement per head vertex; zero for the vertices the file does not list.
    pub displacements: Vec<Vec3>,
    /// Vertices the file lists, in file order.
    pub listed: Vec<u32>,
}

impl ExpressionTarget {
    /// Reads a `.target` file for a head of `vertex_count` vertices.
    pub fn load(path: &Path, vertex_count: usize) -> Result<ExpressionTarget, TargetError> {
        let origin = path.display().to_string();
        let text = read_text(path, MAX_TEXT_BYTES)?;
        let name = path
            .file_stem()
            .map_or_else(|| origin.clone(), |s| s.to_string_lossy().into_owned());
        ExpressionTarget::parse(&name, &origin, &text, vertex_count)
    }

    /// Every `*.target` file of a folder, sorted by name.
    pub fn load_dir(dir: &Path, vertex_count: usize) -> Result<Vec<ExpressionTarget>, TargetError> {
        let io = |source| TargetError::Io {
            path: dir.display().to_string(),
            source,
        };
        let mut paths = Vec::new();
        for entry in std::fs::read_dir(dir).map_err(io)? {
            let path = entry.map_err(io)?.path();
            if path.extension().is_some_and(|e| e == "target") {
                paths.push(path);
            }
        }
        paths.sort();
        paths
            .iter()
            .map(|p| ExpressionTarget::load(p, vertex_count))
            .collect()
    }

    /// A target from one displacement per head vertex (head units), as a glTF morph
    /// target gives it; the vertices it moves are the ones it lists.
    pub fn from_displacements(name: &str, displacements: Vec<Vec3>) -> ExpressionTarget {
        let listed = (0..displacements.len() as u32)
            .filter(|&v| displacements[v as usize] != Vec3::ZERO)
            .collect();
        ExpressionTarget {
            name: name.to_string(),
            displacements,
            listed,
        }
    }

    /// Parses a target's text; `origin` names it in errors.
    pub fn parse(
        name: &str,
        origin: &str,
        text: &str,
        vertex_count: usize,
    ) -> Result<ExpressionTarget, TargetError> {
        let mut displacements = vec![Vec3::ZERO; vertex_count];
        let mut listed = Vec::new();
        let mut listed_on = vec![0usize; vertex_count];
        for Row { line, fields } in text_table::rows(text) {
            let &[vertex, dx, dy, dz] = fields.as_slice() else {
                return Err(TargetError::FieldCount {
                    origin: origin.to_string(),
                    line,
                    found: fields.len(),
                });
            };
            let field_error = |p: FieldProblem| TargetError::Field {
                origin: origin.to_string(),
                line,
                field: p.field,
                found: p.found,
                problem: p.problem,
            };
            let vertex = text_table::index("vertex", vertex, "is not a vertex index").map_err(field_error)?;
            let d = text_table::vec3(["dx", "dy", "dz"], [dx, dy, dz]).map_err(field_error)?;
            let Some(first_line) = listed_on.get_mut(vertex as usize) else {
                return Err(TargetError::VertexOutOfRange {
                    origin: origin.to_string(),
                    line,
                    vertex,
                    count: vertex_count,
                });
            };
            if *first_line != 0 {
                return Err(TargetError::Repeated {
                    origin: origin.to_string(),
                    line,
                    vertex,
                    first_line: *first_line,
                });
            }
            *first_line = line;
            displacements[vertex as usize] = d;
            listed.push(vertex);
        }
        Ok(ExpressionTarget {
            name: name.to_string(),
            displacements,
            listed,
        })
    }

    /// The target head at `weight` (1 = the full expression): `rest + weight * d`, into
    /// `out`. Allocates nothing.
    pub fn apply_into(&self, rest: &[Vec3], weight: f32, out: &mut [Vec3]) -> Result<(), TargetError> {
        self.check_length("rest positions", rest.len())?;
        self.check_length("output positions", out.len())?;
        for ((o, &r), &d) in out.iter_mut().zip(rest).zip(&self.displacements) {
            *o = r + weight * d;
        }
        Ok(())
    }

    /// The target's displacement at each mask vertex's anchor, times `weight`: the control
    /// displacements `delta_j` that ask an algorithm to reproduce the target.
    pub fn controls_into(&self, anchors: &Anchors, weight: f32, out: &mut [Vec3]) -> Result<(), TargetError> {
        if out.len() != anchors.vertex.len() {
            return Err(TargetError::Length {
                name: self.name.clone(),
                what: "control displacements (one per anchor)",
                expected: anchors.vertex.len(),
                found: out.len(),
            });
        }
        for (o, &vertex) in out.iter_mut().zip(&anchors.vertex) {
            let &d = self
                .displacements
                .get(vertex as usize)
                .ok_or_else(|| TargetError::Length {
                    name: self.name.clone(),
                    what: "head vertices (an anchor is beyond them)",
                    expected: vertex as usize + 1,
                    found: self.displacements.len(),
                })?;
            *o = weight * d;
        }
        Ok(())
    }

    fn check_length(&self, what: &'static str, found: usize) -> Result<(), TargetError> {
        if found == self.displacements.len() {
            Ok(())
        } else {
            Err(TargetError::Length {
                name: self.name.clone(),
                what,
                expected: self.displacements.len(),
                found,
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<ExpressionTarget, TargetError> {
        ExpressionTarget::parse("t", "t.target", text, 3)
    }

    #[test]
    fn reads_listed_vertices_and_leaves_the_rest_still() {
        let t = parse("# header\n\n2 0.5 -1 0.25\n  0 1e-3 0 0  \n").unwrap();
        assert_eq!(
            t.displacements,
            vec![Vec3::new(1e-3, 0.0, 0.0), Vec3::ZERO, Vec3::new(0.5, -1.0, 0.25)]
        );
        assert_eq!(t.listed, vec![2, 0]);
    }

    #[test]
    fn errors_name_the_line_and_field() {
        let err = parse("# c\n1 0 0\n").unwrap_err();
        assert_eq!(
            err.to_string(),
            "t.target: line 2: expected 4 fields `vertex dx dy dz`, found 3"
        );
        let err = parse("0 0 0 0\n1 0 x 0\n").unwrap_err();
        assert_eq!(
            err.to_string(),
            "t.target: line 2: field dy: \"x\" is not a number"
        );
        let err = parse("-1 0 0 0\n").unwrap_err();
        assert!(
            matches!(
                err,
                TargetError::Field {
                    line: 1,
                    field: "vertex",
                    ..
                }
            ),
            "{err}"
        );
        let err = parse("0 0 0 inf\n").unwrap_err();
        assert_eq!(
            err.to_string(),
            "t.target: line 1: field dz: \"inf\" is not a finite number"
        );
        let err = parse("3 0 0 0\n").unwrap_err();
        assert_eq!(
            err.to_string(),
            "t.target: line 1: vertex 3 is out of range: the head has 3 vertices"
        );
        let err = parse("1 0 0 0\n#\n1 0 0 1\n").unwrap_err();
        assert!(
            matches!(
                err,
                TargetError::Repeated {
                    line: 3,
                    vertex: 1,
                    first_line: 1,
                    ..
                }
            ),
            "{err}"
        );
    }

    #[test]
    fn applies_and_samples_at_anchors() {
        let t = parse("1 0 2 0\n").unwrap();
        let rest = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let mut out = [Vec3::ZERO; 3];
        t.apply_into(&rest, 0.5, &mut out).unwrap();
        assert_eq!(out, [Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Y]);
        assert!(t.apply_into(&rest[..2], 1.0, &mut out).is_err());
        let anchors = Anchors {
            vertex: vec![1, 1, 0],
            distance: vec![0.0; 3],
        };
        let mut controls = [Vec3::ONE; 3];
        t.controls_into(&anchors, 1.0, &mut controls).unwrap();
        assert_eq!(
            controls,
            [Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 2.0, 0.0), Vec3::ZERO]
        );
        let beyond = Anchors {
            vertex: vec![7],
            distance: vec![0.0],
        };
        assert!(t.controls_into(&beyond, 1.0, &mut controls[..1]).is_err());
    }
}
