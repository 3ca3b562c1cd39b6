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
use crate::fit::{FitError, FitFile, FitFileError, FittedMask, Landmarks};
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
    #[error("{0}")]
    Unanimatable(#[from] crate::deform::RegistrationError),
}

#[derive(Debug, thiserror::Error)]
pub enum LandmarkError {
    #[error("head.obj: {0}")]
    Obj(#[from] ObjError),
    #[error(transparent)]
    Landmarks(#[from] crate::fit::LandmarkError),
    #[error(transparent)]
    Fit(#[from] FitError),
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
    let registration = Registration::try_new(head, FittedMask::new(mask, fit))?;
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
    let landmarks = Landmarks::parse("landmarks", landmarks_toml)?;
    let mask = Mask::candide3();
    let solved = crate::fit::fit_from_landmarks(&head, &landmarks, "landmarks", &mask)?;
    Ok(FitFile::from_fit(&solved.fit, &mask, None).to_toml())
}
