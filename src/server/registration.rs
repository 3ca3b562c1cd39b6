//! The registration job: parse the head, resolve or solve its fit, compute surface
//! distances and the lip region, and encode what viewers download. Blocking (seconds for
//! big heads), run on the blocking pool at most `max_registrations` at a time, with its
//! progress visible in the head's status, and stopped between stages when its head is
//! deleted or the server shuts down.

use std::sync::Arc;

use bytes::Bytes;

use super::bindings::BindingCache;
use super::head::ReadyHead;
use crate::animate::{AnimatedHead, AnimatedHeadError};
use crate::deform::Registration;
use crate::fit::{FitFile, FitFileError, FittedMask, Landmarks, SolveOptions};
use crate::head::{Head, ObjError};
use crate::mask::Mask;
use facewire_proto::mesh::RestMesh;

#[derive(Debug, thiserror::Error)]
pub enum RegistrationError {
    #[error("registration cancelled")]
    Cancelled,
    #[error("head.obj: {0}")]
    Obj(#[from] ObjError),
    #[error("head.obj has {count} vertices; this server accepts at most {limit}")]
    TooManyVertices { count: usize, limit: usize },
    #[error("{0}")]
    Fit(#[from] FitFileError),
    #[error("{0}")]
    Head(#[from] AnimatedHeadError),
}

#[derive(Debug, thiserror::Error)]
pub enum LandmarkError {
    #[error("head.obj: {0}")]
    Obj(#[from] ObjError),
    #[error("landmarks: {0}")]
    Toml(String),
    #[error("{0}")]
    Invalid(String),
}

/// What a registration works from.
pub struct RegistrationInput {
    pub obj: Vec<u8>,
    pub fit_toml: String,
    pub max_vertices: usize,
    pub max_bindings: usize,
}

/// Runs the registration (blocking). `progress` is told the share done (0..1);
/// `cancelled` is asked between stages.
pub fn register(
    input: RegistrationInput,
    cancelled: impl Fn() -> bool,
    progress: impl Fn(f32),
) -> Result<ReadyHead, RegistrationError> {
    let stage = |share: f32| {
        if cancelled() {
            return Err(RegistrationError::Cancelled);
        }
        progress(share);
        Ok(())
    };
    let head = Head::from_obj_bytes("head.obj", &input.obj)?;
    drop(input.obj);
    if head.positions.len() > input.max_vertices {
        return Err(RegistrationError::TooManyVertices {
            count: head.positions.len(),
            limit: input.max_vertices,
        });
    }
    stage(0.2)?;
    let mask = Mask::candide3();
    let fit = FitFile::parse("fit.toml", &input.fit_toml)?.resolve("fit.toml", &mask)?;
    stage(0.3)?;
    let registration = Registration::new(head, FittedMask::new(mask, fit));
    stage(0.9)?;
    let animated = AnimatedHead::new(registration)?;
    let reg = &animated.registration;
    let rest_bin = RestMesh {
        mm_per_unit: reg.mm_per_unit(),
        positions: reg.head.positions.iter().map(|p| p.to_array()).collect(),
        triangles: reg.head.triangles.clone(),
    }
    .encode();
    let mut rest_obj = Vec::new();
    crate::head::obj::write(
        &mut rest_obj,
        &["facewire rest mesh (head units)".to_string()],
        &reg.head.positions,
        &reg.head.triangles,
    )
    .expect("writing to memory cannot fail");
    stage(1.0)?;
    Ok(ReadyHead {
        animated: Arc::new(animated),
        rest_bin: Bytes::from(rest_bin),
        rest_obj: Bytes::from(rest_obj),
        bindings: BindingCache::new(input.max_bindings),
    })
}

/// Solves a fit from a `.landmarks.toml` text for a registration request (blocking).
pub fn fit_from_landmarks(obj: &[u8], landmarks_toml: &str) -> Result<String, LandmarkError> {
    let head = Head::from_obj_bytes("head.obj", obj)?;
    let landmarks: Landmarks =
        toml::from_str(landmarks_toml).map_err(|e| LandmarkError::Toml(e.to_string()))?;
    let mask = Mask::candide3();
    landmarks
        .validate("landmarks", mask.vertices.len(), head.positions.len())
        .map_err(|e| LandmarkError::Invalid(e.to_string()))?;
    let pairs: Vec<(u32, glam::DVec3)> = landmarks
        .landmarks
        .iter()
        .map(|l| (l.mask_vertex, head.positions[l.head_vertex as usize].as_dvec3()))
        .collect();
    let solution = crate::fit::solve_fit(&mask, &pairs, &[], &SolveOptions::default())
        .map_err(|e| LandmarkError::Invalid(e.to_string()))?;
    let mm_per_unit = landmarks
        .mm_per_unit
        .unwrap_or_else(|| crate::fit::Fit::mm_per_unit_from_pupils(&mask, &solution.shape, &solution.pose));
    let fit = crate::fit::Fit {
        pose: solution.pose,
        shape: solution.shape,
        nudges: Vec::new(),
        mm_per_unit,
    };
    Ok(FitFile::from_fit(&fit, &mask, None).to_toml())
}
