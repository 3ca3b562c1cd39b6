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

use serde::{Deserialize, Serialize};

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
    #[error("cannot read {path}: {source}")]
    Io { path: String, source: std::io::Error },
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
}

impl Landmarks {
    pub fn load(path: &Path) -> Result<Landmarks, LandmarkError> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| LandmarkError::Io {
            path: origin.clone(),
            source,
        })?;
        toml::from_str(&text).map_err(|e| LandmarkError::Toml {
            path: origin,
            message: e.to_string(),
        })
    }

    /// Checks indices against a mask and a head of the given sizes.
    pub fn validate(
        &self,
        origin: &str,
        mask_vertices: usize,
        head_vertices: usize,
    ) -> Result<(), LandmarkError> {
        if self.landmarks.len() < 3 {
            return Err(LandmarkError::TooFew {
                path: origin.to_string(),
                count: self.landmarks.len(),
            });
        }
        for (index, l) in self.landmarks.iter().enumerate() {
            for (field, value, limit) in [
                ("mask_vertex", l.mask_vertex, mask_vertices),
                ("head_vertex", l.head_vertex, head_vertices),
            ] {
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
            if self.landmarks[..index]
                .iter()
                .any(|o| o.mask_vertex == l.mask_vertex)
            {
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
