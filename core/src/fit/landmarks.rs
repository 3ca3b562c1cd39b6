//! The `.landmarks.toml` file: a handful of mask-vertex -> head-vertex correspondences
//! from which `facewire fit` solves a fit.
//!
//! ```toml
//! head = "makehuman_head.obj"
//! mm_per_unit = 100.0   # optional: millimetres per head unit, if known
//!
//! [[landmark]]
//! mask_vertex = 5        # CANDIDE-3 vertex (nose tip)
//! head_vertex = 1234     # 0-based vertex of the head's OBJ
//! name = "nose tip"      # optional, for people
//! ```

use std::path::Path;

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::limits::{in_range, MM_PER_UNIT_RANGE};
use crate::head::Head;
use crate::input::{read_file, toml_error, utf8, ReadError, MAX_TEXT_BYTES};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Landmarks {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub head: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mm_per_unit: Option<f32>,
    #[serde(rename = "landmark")]
    pub landmarks: Vec<Landmark>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Landmark {
    pub mask_vertex: u32,
    pub head_vertex: u32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
}

#[derive(Debug, thiserror::Error)]
pub enum LandmarkError {
    #[error(transparent)]
    Read(#[from] ReadError),
    #[error("{path}: {message}")]
    Toml { path: String, message: String },
    #[error("{path}: landmark[{index}].{field} = {value} is out of range (must be below {limit})")]
    OutOfRange {
        path: String,
        index: usize,
        field: &'static str,
        value: u32,
        limit: usize,
    },
    #[error("{path}: landmark[{index}] repeats mask vertex {mask_vertex}")]
    Repeated {
        path: String,
        index: usize,
        mask_vertex: u32,
    },
    #[error("{path}: {count} landmark(s); at least 3 are needed for a similarity")]
    TooFew { path: String, count: usize },
    #[error("{path}: field {field}: {reason}")]
    Invalid {
        path: String,
        field: &'static str,
        reason: String,
    },
}

impl Landmarks {
    /// Reads a `.landmarks.toml`: a regular file of at most [`MAX_TEXT_BYTES`], UTF-8.
    pub fn load(path: &Path) -> Result<Landmarks, LandmarkError> {
        let origin = path.display().to_string();
        let bytes = read_file(path, MAX_TEXT_BYTES)?;
        Landmarks::parse(&origin, utf8(&origin, &bytes)?)
    }

    /// Parses TOML text; `origin` names the source in errors. Call [`Landmarks::validate`]
    /// before using the result.
    pub fn parse(origin: &str, text: &str) -> Result<Landmarks, LandmarkError> {
        toml::from_str(text).map_err(|e| LandmarkError::Toml {
            path: origin.to_string(),
            message: toml_error(text, &e),
        })
    }

    /// Checks the file against a mask and a head of the given sizes: at least three
    /// landmarks, indices in range, no mask vertex twice, `mm_per_unit` (when given) a
    /// number in [`MM_PER_UNIT_RANGE`]. The service and every command validate this way.
    pub fn validate(
        &self,
        origin: &str,
        mask_vertices: usize,
        head_vertices: usize,
    ) -> Result<(), LandmarkError> {
        self.check(origin, mask_vertices, Some(head_vertices))
    }

    /// [`Landmarks::validate`] without the head (not at hand): head vertices unchecked.
    pub fn validate_without_head(&self, origin: &str, mask_vertices: usize) -> Result<(), LandmarkError> {
        self.check(origin, mask_vertices, None)
    }

    /// (mask vertex, head position in head units) of every landmark. The landmarks must
    /// have been validated against `head`.
    pub fn targets(&self, head: &Head) -> Vec<(u32, DVec3)> {
        self.landmarks
            .iter()
            .map(|l| (l.mask_vertex, head.positions[l.head_vertex as usize].as_dvec3()))
            .collect()
    }

    fn check(
        &self,
        origin: &str,
        mask_vertices: usize,
        head_vertices: Option<usize>,
    ) -> Result<(), LandmarkError> {
        if let Some(mm) = self.mm_per_unit {
            in_range("mm_per_unit", mm, MM_PER_UNIT_RANGE).map_err(|e| LandmarkError::Invalid {
                path: origin.to_string(),
                field: "mm_per_unit",
                reason: e.reason,
            })?;
        }
        if self.landmarks.len() < 3 {
            return Err(LandmarkError::TooFew {
                path: origin.to_string(),
                count: self.landmarks.len(),
            });
        }
        let mut seen = vec![false; mask_vertices];
        for (index, l) in self.landmarks.iter().enumerate() {
            let mut ranges = vec![("mask_vertex", l.mask_vertex, mask_vertices)];
            ranges.extend(head_vertices.map(|n| ("head_vertex", l.head_vertex, n)));
            for (field, value, limit) in ranges {
                if value as usize >= limit {
                    return Err(LandmarkError::OutOfRange {
                        path: origin.to_string(),
                        index,
                        field,
                        value,
                        limit,
                    });
                }
            }
            if std::mem::replace(&mut seen[l.mask_vertex as usize], true) {
                return Err(LandmarkError::Repeated {
                    path: origin.to_string(),
                    index,
                    mask_vertex: l.mask_vertex,
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SAMPLE: &str = "mm_per_unit = 100.0\n\
        [[landmark]]\nmask_vertex = 20\nhead_vertex = 0\n\
        [[landmark]]\nmask_vertex = 53\nhead_vertex = 1\n\
        [[landmark]]\nmask_vertex = 5\nhead_vertex = 2\n";

    #[test]
    fn a_bad_scale_is_refused_naming_the_field() {
        assert!(Landmarks::parse("l", SAMPLE)
            .unwrap()
            .validate("l", 113, 3)
            .is_ok());
        for bad in ["nan", "0.0", "-5.0", "inf", "1e-30"] {
            let text = SAMPLE.replace("100.0", bad);
            let err = Landmarks::parse("l.toml", &text)
                .unwrap()
                .validate("l.toml", 113, 3)
                .unwrap_err()
                .to_string();
            assert!(err.starts_with("l.toml: field mm_per_unit: "), "{bad}: {err}");
        }
    }

    #[test]
    fn indices_are_checked_with_or_without_the_head() {
        let bad = Landmarks::parse("l", &SAMPLE.replace("mask_vertex = 5\n", "mask_vertex = 999\n")).unwrap();
        let err = bad.validate_without_head("l", 113).unwrap_err().to_string();
        assert_eq!(
            err,
            "l: landmark[2].mask_vertex = 999 is out of range (must be below 113)"
        );
        assert!(bad.validate("l", 113, 3).is_err());
        let far = Landmarks::parse("l", &SAMPLE.replace("head_vertex = 2", "head_vertex = 7")).unwrap();
        assert!(far.validate_without_head("l", 113).is_ok());
        assert!(far
            .validate("l", 113, 3)
            .unwrap_err()
            .to_string()
            .contains("head_vertex = 7"));
        let twice =
            Landmarks::parse("l", &SAMPLE.replace("mask_vertex = 5\n", "mask_vertex = 20\n")).unwrap();
        assert!(matches!(
            twice.validate("l", 113, 3),
            Err(LandmarkError::Repeated { index: 2, .. })
        ));
    }
}
