//! The registration job: parse the head and its parts, resolve or solve its fit, compute
//! surface distances and the lip region, settle the parts' roles, and encode what viewers
//! download. Blocking (seconds for
//! big heads), run on the blocking pool at most `max_registrations` at a time, with its
//! progress visible in the head's status, and stopped between stages when its head is
//! deleted or the server shuts down.

use std::sync::Arc;

use bytes::Bytes;

use super::bindings::BindingCache;
use super::head::ReadyHead;
use super::store::PartRecord;
use crate::animate::{AnimatedHead, AnimatedHeadError, PartInput};
use crate::deform::Registration;
use crate::fit::{AutomaticFitError, FitError, FitFile, FitFileError, FitReport, FittedMask, Landmarks};
use crate::head::{Head, ObjError};
use crate::mask::Mask;
use facewire_proto::mesh::RestMesh;
use facewire_proto::messages::FitSummary;

#[derive(Debug, thiserror::Error)]
pub enum RegistrationError {
    #[error("registration cancelled")]
    Cancelled,
    #[error("head.obj: {0}")]
    Obj(#[from] ObjError),
    #[error("head.obj has {count} vertices; this server accepts at most {limit}")]
    TooManyVertices { count: usize, limit: usize },
    #[error("parts/{name}.obj: {source}")]
    PartObj { name: String, source: ObjError },
    #[error("the parts have {count} vertices together; this server accepts at most {limit}")]
    TooManyPartVertices { count: usize, limit: usize },
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
    pub parts: Vec<PartRecord>,
    /// For the head, and for its parts together.
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
    let mut parts = Vec::with_capacity(input.parts.len());
    let mut part_vertices = 0;
    for part in input.parts {
        let mesh =
            Head::from_obj_bytes(&format!("parts/{}.obj", part.name), &part.obj).map_err(|source| {
                RegistrationError::PartObj {
                    name: part.name.clone(),
                    source,
                }
            })?;
        part_vertices += mesh.positions.len();
        if part_vertices > input.max_vertices {
            return Err(RegistrationError::TooManyPartVertices {
                count: part_vertices,
                limit: input.max_vertices,
            });
        }
        parts.push(PartInput {
            name: part.name,
            role: part.role,
            mesh,
        });
    }
    stage(0.2)?;
    let mask = Mask::candide3();
    let fit = FitFile::parse("fit.toml", &input.fit_toml)?.resolve("fit.toml", &mask)?;
    stage(0.3)?;
    let registration = Registration::try_new(head, FittedMask::new(mask, fit))?;
    stage(0.9)?;
    let animated = AnimatedHead::with_parts(registration, parts)?;
    let reg = &animated.registration;
    let mesh_bin = |mesh: &Head| {
        Bytes::from(
            RestMesh {
                mm_per_unit: reg.mm_per_unit(),
                positions: mesh.positions.iter().map(|p| p.to_array()).collect(),
                triangles: mesh.triangles.clone(),
            }
            .encode(),
        )
    };
    let rest_bin = mesh_bin(&reg.head);
    let part_bins = animated
        .parts
        .iter()
        .map(|p| &p.mesh)
        .chain(animated.eyes.iter().map(|e| &e.mesh))
        .map(mesh_bin)
        .collect();
    let mut rest_obj = Vec::new();
    crate::head::obj::write(
        &mut rest_obj,
        &["facewire rest mesh (head units)".to_string()],
        &reg.head.positions,
        &reg.head.triangles,
    )
    .expect("writing to memory cannot fail");
    let fit_report = FitReport {
        mouth_closed: reg.mouth_calibration,
        ..crate::fit::report(&reg.head, &reg.fitted)
    };
    let closed = reg.mouth_calibration.map(|c| {
        format!(
            "the inner lips were {:.1} mm apart at rest: registration closed them, raising the lower lip {:.1} mm",
            c.open_mm, c.raised_mm
        )
    });
    let fit = FitSummary {
        surface_mean_mm: fit_report.surface.mean_mm,
        surface_max_mm: fit_report.surface.max_mm,
        worst_mask_vertex: fit_report.surface.worst_mask_vertex,
        warnings: closed
            .into_iter()
            .chain(fit_report.warnings.iter().map(|w| w.message.clone()))
            .collect(),
    };
    stage(1.0)?;
    Ok(ReadyHead {
        animated: Arc::new(animated),
        rest_bin,
        part_bins,
        fit,
        fit_report,
        fit_pictures: Default::default(),
        rest_obj: Bytes::from(rest_obj),
        bindings: BindingCache::new(input.max_bindings),
    })
}

/// Why a head with neither fit nor landmarks could not be fitted.
#[derive(Debug, thiserror::Error)]
pub enum AutomaticFitFailure {
    #[error("head.obj: {0}")]
    Obj(#[from] ObjError),
    #[error(transparent)]
    Fit(#[from] AutomaticFitError),
}

/// Finds the face and fits the mask with no landmarks, for a registration request
/// (blocking; about a second for a 30,000-triangle head).
pub fn fit_automatically(obj: &[u8]) -> Result<String, AutomaticFitFailure> {
    let head = Head::from_obj_bytes("head.obj", obj)?;
    let mask = Mask::candide3();
    let found = crate::fit::fit_automatically(&head, &mask, None)?;
    Ok(FitFile::from_fit(&found.fit, &mask, None).to_toml())
}

/// Solves a fit from a `.landmarks.toml` text for a registration request (blocking).
pub fn fit_from_landmarks(obj: &[u8], landmarks_toml: &str) -> Result<String, LandmarkError> {
    let head = Head::from_obj_bytes("head.obj", obj)?;
    let landmarks = Landmarks::parse("landmarks", landmarks_toml)?;
    let mask = Mask::candide3();
    let solved = crate::fit::fit_from_landmarks(&head, &landmarks, "landmarks", &mask)?;
    Ok(FitFile::from_fit(&solved.fit, &mask, None).to_toml())
}
