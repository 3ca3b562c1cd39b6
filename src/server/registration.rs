//! The registration job: parse the head and its parts, resolve or solve its fit, compute
//! surface distances and the lip region, settle the parts' roles, and encode what viewers
//! download. Blocking (seconds for
//! big heads), run on the blocking pool at most `max_registrations` at a time, with its
//! progress visible in the head's status, and stopped between stages when its head is
//! deleted or the server shuts down.

use std::sync::Arc;

use bytes::Bytes;

use super::bindings::BindingCache;
use super::head::{HeadTexture, ReadyHead};
use super::store::PartRecord;
use super::texture_image;
use crate::animate::{lip_tint, AnimatedHead, AnimatedHeadError, PartInput};
use crate::cancel::Cancel;
use crate::deform::Registration;
use crate::fit::{AutomaticFitError, FitError, FitFile, FitFileError, FitReport, FittedMask, Landmarks};
use crate::head::{obj, raster_cost, Head, MeshBudget, ObjError, OverBudget, RasterCostError};
use crate::mask::Mask;
use facewire_proto::mesh::RestMesh;
use facewire_proto::messages::FitSummary;
use facewire_proto::texture_coords::TextureCoords;
use facewire_proto::vertex_weights::VertexWeights;

#[derive(Debug, thiserror::Error)]
pub enum RegistrationError {
    #[error("registration cancelled")]
    Cancelled,
    #[error(transparent)]
    Read(#[from] MeshReadError),
    #[error("{0}")]
    Fit(#[from] FitFileError),
    #[error("{0}")]
    Head(#[from] AnimatedHeadError),
    #[error("{0}")]
    Unanimatable(#[from] crate::deform::RegistrationError),
    #[error("{0}")]
    Texture(String),
}

#[derive(Debug, thiserror::Error)]
pub enum LandmarkError {
    #[error(transparent)]
    Read(#[from] MeshReadError),
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
    /// The texture image, checked ([`super::texture_image`]).
    pub texture: Option<Vec<u8>>,
    /// The head and its parts together: at most `max_vertices` and `max_triangles`.
    pub budget: MeshBudget,
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
    let mut budget = input.budget;
    let (head, texture_coords) = read_head(&input.obj, &mut budget)?;
    drop(input.obj);
    let mut parts = Vec::with_capacity(input.parts.len());
    for part in input.parts {
        let mesh = read_mesh(&format!("parts/{}.obj", part.name), &part.obj, &mut budget)?;
        parts.push(PartInput {
            name: part.name,
            role: part.role,
            mesh,
        });
    }
    stage(0.2)?;
    let mask = Mask::candide3();
    let fit_file = FitFile::parse("fit.toml", &input.fit_toml)?;
    let fit = fit_file.resolve("fit.toml", &mask)?;
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
    let lips_bin = Bytes::from(
        VertexWeights {
            weights: lip_tint(reg),
        }
        .encode(),
    );
    let tongue_bin = animated.tongue.as_ref().map(|(index, shaper)| {
        let weights = shaper
            .free_vertices()
            .iter()
            .map(|&free| if free { 255 } else { 0 });
        let bin = VertexWeights {
            weights: weights.collect(),
        };
        (*index, Bytes::from(bin.encode()))
    });
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
    }
    .with_fit_notes(&fit_file.warnings);
    // Drawn when the image has coordinates to go by, on every triangle of the rest mesh.
    let input_had_texture = input.texture.is_some();
    let texture = match (input.texture, texture_coords) {
        (Some(image), Some(coords)) if coords.corners.len() == reg.head.triangles.len() => {
            let format =
                texture_image::check(&image).map_err(|e| RegistrationError::Texture(e.to_string()))?;
            let uv = TextureCoords {
                coords: coords.coords,
                corners: coords.corners,
            };
            Some(HeadTexture {
                uv_bin: Bytes::from(uv.encode()),
                image: Bytes::from(image),
                content_type: format.content_type(),
            })
        }
        _ => None,
    };
    let untextured = (input_had_texture && texture.is_none()).then(|| {
        "a texture was given, but head.obj has no texture coordinates on every face (`vt` \
         records and `f v/vt` corners): it is not drawn"
            .to_string()
    });
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
            .chain(untextured)
            .chain(fit_report.warnings.iter().map(|w| w.message.clone()))
            .collect(),
    };
    stage(1.0)?;
    Ok(ReadyHead {
        animated: Arc::new(animated),
        rest_bin,
        lips_bin,
        part_bins,
        tongue_bin,
        texture,
        fit,
        fit_report,
        fit_pictures: Default::default(),
        rest_obj: Bytes::from(rest_obj),
        bindings: BindingCache::new(input.max_bindings),
    })
}

/// Why an uploaded mesh was not read; each names its file (`head.obj`, `parts/teeth.obj`).
#[derive(Debug, thiserror::Error)]
pub enum MeshReadError {
    #[error("{mesh}: {source}")]
    Obj { mesh: String, source: ObjError },
    #[error(transparent)]
    OverBudget(#[from] OverBudget),
    #[error("{mesh}: {source}")]
    RasterCost { mesh: String, source: RasterCostError },
}

/// Parses `bytes` (the upload's file `name`) and spends its vertices and triangles from
/// `budget` before building its topology and indexes: a mesh over the budget costs no
/// more than its parse.
fn read_mesh(name: &str, bytes: &[u8], budget: &mut MeshBudget) -> Result<Head, MeshReadError> {
    let mesh = mesh_within(name, bytes, budget)?;
    Ok(Head::new(name, mesh.positions, mesh.triangles))
}

/// [`read_mesh`] for `head.obj`, which is also drawn (by the automatic fit, in fit
/// pictures): refused before its topology is built when drawing it would cost too much.
fn read_head(
    bytes: &[u8],
    budget: &mut MeshBudget,
) -> Result<(Head, Option<obj::TextureCoords>), MeshReadError> {
    let name = "head.obj";
    let mesh = mesh_within(name, bytes, budget)?;
    raster_cost::check(&mesh.positions, &mesh.triangles).map_err(|source| MeshReadError::RasterCost {
        mesh: name.to_string(),
        source,
    })?;
    Ok((Head::new(name, mesh.positions, mesh.triangles), mesh.texture))
}

fn mesh_within(name: &str, bytes: &[u8], budget: &mut MeshBudget) -> Result<obj::ObjMesh, MeshReadError> {
    let mesh = obj::parse(&String::from_utf8_lossy(bytes)).map_err(|source| MeshReadError::Obj {
        mesh: name.to_string(),
        source,
    })?;
    budget.spend(name, &mesh)?;
    Ok(mesh)
}

/// Why a head with neither fit nor landmarks could not be fitted.
#[derive(Debug, thiserror::Error)]
pub enum AutomaticFitFailure {
    #[error(transparent)]
    Read(#[from] MeshReadError),
    #[error(transparent)]
    Fit(#[from] AutomaticFitError),
}

/// Finds the face and fits the mask with no landmarks, for a registration request
/// (blocking; about a second for a 30,000-triangle head), stopping when `cancel` is set.
pub fn fit_automatically(
    obj: &[u8],
    mm_per_unit: Option<f32>,
    mut budget: MeshBudget,
    cancel: &Cancel,
) -> Result<String, AutomaticFitFailure> {
    let (head, _) = read_head(obj, &mut budget)?;
    let mask = Mask::candide3();
    let found = crate::fit::fit_automatically_unless(&head, &mask, mm_per_unit, cancel)?;
    let file = FitFile {
        warnings: found.warnings.iter().map(|w| w.message()).collect(),
        ..FitFile::from_fit(&found.fit, &mask, None)
    };
    Ok(file.to_toml())
}

/// Solves a fit from a `.landmarks.toml` text for a registration request (blocking).
pub fn fit_from_landmarks(
    obj: &[u8],
    landmarks_toml: &str,
    mut budget: MeshBudget,
) -> Result<String, LandmarkError> {
    let (head, _) = read_head(obj, &mut budget)?;
    let landmarks = Landmarks::parse("landmarks", landmarks_toml)?;
    let mask = Mask::candide3();
    let solved = crate::fit::fit_from_landmarks(&head, &landmarks, "landmarks", &mask)?;
    Ok(FitFile::from_fit(&solved.fit, &mask, None).to_toml())
}
