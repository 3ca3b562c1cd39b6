//! The registration job: parse the head and its parts, resolve or solve its fit, compute
//! surface distances and the lip region, settle the parts' roles, and encode what viewers
//! download. Blocking (seconds for
//! big heads), run on the blocking pool at most `max_registrations` at a time, with its
//! progress visible in the head's status, and stopped between stages when its head is
//! deleted or the server shuts down.

use std::sync::{Arc, LazyLock};

use bytes::Bytes;

use super::bindings::BindingCache;
use super::head::{HeadTexture, ReadyHead};
use super::store::PartRecord;
use super::texture_image;
use crate::animate::{lip_tint, AnimatedHead, AnimatedHeadError, PartInput};
use crate::cancel::Cancel;
use crate::deform::Registration;
use crate::fit::{
    anchor_mask, AutomaticFitError, FitError, FitFile, FitFileError, FitReport, FittedMask, Landmarks,
};
use crate::head::{obj, raster_cost, Head, MeshBudget, ObjError, OverBudget, RasterCostError};
use crate::mask::Mask;
use crate::stream::{arkit_index, ArkitBasis, ArkitBasisError, ARKIT_BLENDSHAPES};
use crate::targets::ExpressionTarget;
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
    #[error("{0}")]
    Arkit(#[from] OwnArkitError),
}

/// Why a head's own ARKit basis was not derived or not taken.
#[derive(Debug, thiserror::Error)]
pub enum OwnArkitError {
    #[error(transparent)]
    Read(#[from] MeshReadError),
    #[error("{0}")]
    Fit(#[from] FitFileError),
    #[error("the ARKit morph targets: {0}")]
    Derive(#[from] ArkitBasisError),
    /// Names `arkit_basis.tsv`, its line and field.
    #[error("{0}")]
    Stored(ArkitBasisError),
    #[error("arkit_blendshapes: {name:?} is not an ARKit blendshape")]
    UnknownBlendshape { name: String },
    #[error("arkit_blendshapes lists {listed} blendshapes but arkit_basis.tsv is {basis}")]
    Mismatch { listed: usize, basis: &'static str },
    #[error("arkit_basis.tsv moves {shape}, which arkit_blendshapes does not list")]
    Unlisted { shape: &'static str },
    #[error("arkit_basis.tsv moves mask vertex {vertex}; the mask has {count}")]
    Vertex { vertex: u32, count: usize },
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
    /// Its own ARKit basis's text and the blendshapes it defines.
    pub arkit_basis: Option<String>,
    pub arkit_blendshapes: Vec<String>,
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
    let arkit = arkit_basis(
        input.arkit_basis.as_deref(),
        &input.arkit_blendshapes,
        mask.vertices.len(),
    )?;
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
        arkit,
    })
}

/// The shipped ARKit basis, parsed once for every head that has no targets of its own.
static SHIPPED_ARKIT: LazyLock<Arc<ArkitBasis>> = LazyLock::new(|| Arc::new(ArkitBasis::shipped()));

/// What ARKit weights do to a head's mask (of `mask_vertices` vertices): the shipped basis,
/// or its own (`basis`, defining `blendshapes`) completed by the shipped one. Nothing in a
/// stored or shared basis is believed unchecked: its names, that it moves only what it
/// lists, and only vertices the mask has.
fn arkit_basis(
    basis: Option<&str>,
    blendshapes: &[String],
    mask_vertices: usize,
) -> Result<Arc<ArkitBasis>, OwnArkitError> {
    let text = match (basis, blendshapes.is_empty()) {
        (None, true) => return Ok(SHIPPED_ARKIT.clone()),
        (Some(text), false) => text,
        (None, false) | (Some(_), true) => {
            return Err(OwnArkitError::Mismatch {
                listed: blendshapes.len(),
                basis: if basis.is_some() { "there" } else { "missing" },
            })
        }
    };
    let own = ArkitBasis::parse(ARKIT_BASIS_ORIGIN, text).map_err(OwnArkitError::Stored)?;
    let listed = blendshapes
        .iter()
        .map(|name| arkit_index(name).ok_or_else(|| OwnArkitError::UnknownBlendshape { name: name.clone() }))
        .collect::<Result<Vec<u8>, _>>()?;
    if let Some(shape) = (0..52u8).find(|s| !listed.contains(s) && !own.blendshape_offsets(*s).is_empty()) {
        return Err(OwnArkitError::Unlisted {
            shape: ARKIT_BLENDSHAPES[usize::from(shape)],
        });
    }
    if let Some(vertex) = own.max_vertex().filter(|&v| v as usize >= mask_vertices) {
        return Err(OwnArkitError::Vertex {
            vertex,
            count: mask_vertices,
        });
    }
    Ok(Arc::new(own.completed_by(&listed, &SHIPPED_ARKIT)))
}

/// How a head's own basis is named in errors.
const ARKIT_BASIS_ORIGIN: &str = "arkit_basis.tsv";

/// A head's own ARKit basis, as its record keeps it.
pub struct OwnArkit {
    /// `ArkitBasis` text (mask units).
    pub basis: String,
    /// The blendshapes it defines, by ARKit's names.
    pub blendshapes: Vec<String>,
}

/// Derives a head's own ARKit basis from `targets` (named by ARKit, head units) and its
/// fit, as `facewire arkit-basis` derives the shipped one: each target's displacement at
/// the anchor of every mask vertex, in mask units (blocking: it reads the head again and
/// anchors the mask, tens of milliseconds beside the fit's second). `None` without targets.
pub fn own_arkit_basis(
    obj: &[u8],
    fit_toml: &str,
    targets: &[ExpressionTarget],
    mut budget: MeshBudget,
) -> Result<Option<OwnArkit>, OwnArkitError> {
    if targets.is_empty() {
        return Ok(None);
    }
    let (head, _) = read_head(obj, &mut budget)?;
    let mask = Mask::candide3();
    let fit = FitFile::parse("fit.toml", fit_toml)?.resolve("fit.toml", &mask)?;
    let fitted = FittedMask::new(mask, fit);
    let anchors = anchor_mask(&head, &fitted.neutral, fitted.fit.mm_per_unit);
    let basis = ArkitBasis::derive(&fitted, &anchors, targets)?;
    let blendshapes: Vec<String> = targets.iter().map(|t| t.name.clone()).collect();
    let text = basis.to_tsv_from(
        OWN_BASIS_SOURCES,
        &format!(
            "POST /v1/heads (glTF; {} morph targets: {})",
            blendshapes.len(),
            blendshapes.join(" ")
        ),
    );
    Ok(Some(OwnArkit {
        basis: text,
        blendshapes,
    }))
}

/// The header's sources paragraph of a head's own basis.
const OWN_BASIS_SOURCES: &str =
    "# Derived at registration from the morph targets of the head's own glTF file\n\
     # (under the file's licence): each offset is a target's displacement d at the anchor\n\
     # of a mask vertex used by a triangle, taken into mask units with the head's fit: S^-1 R^T d.\n\
     # The blendshapes the generator line does not name move as the shipped basis says.\n";

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

#[cfg(test)]
mod tests {
    use super::*;

    fn error(basis: Option<&str>, blendshapes: &[&str]) -> String {
        let names: Vec<String> = blendshapes.iter().map(|n| n.to_string()).collect();
        arkit_basis(basis, &names, 113).unwrap_err().to_string()
    }

    #[test]
    fn a_stored_own_basis_is_checked_before_it_is_used() {
        let shipped = arkit_basis(None, &[], 113).unwrap();
        assert!(Arc::ptr_eq(&shipped, &SHIPPED_ARKIT));
        let own = arkit_basis(
            Some("jawOpen 3 0 -1 0\n"),
            &["jawOpen".into(), "tongueOut".into()],
            113,
        )
        .unwrap();
        assert_eq!(own.blendshape_offsets(17), [(3, glam::Vec3::NEG_Y)]);
        assert!(
            own.blendshape_offsets(51).is_empty(),
            "the head's tongueOut moves nothing"
        );
        assert_eq!(own.blendshape_offsets(0), SHIPPED_ARKIT.blendshape_offsets(0));

        assert_eq!(
            error(Some("jawOpen 3 0 -1 0\n"), &[]),
            "arkit_blendshapes lists 0 blendshapes but arkit_basis.tsv is there"
        );
        assert_eq!(
            error(None, &["jawOpen"]),
            "arkit_blendshapes lists 1 blendshapes but arkit_basis.tsv is missing"
        );
        assert_eq!(
            error(Some("jawOpen 3 0 -1 0\n"), &["jawOpen", "smile"]),
            "arkit_blendshapes: \"smile\" is not an ARKit blendshape"
        );
        assert_eq!(
            error(Some("jawOpen 3 0 -1 0\nmouthClose 2 0 1 0\n"), &["jawOpen"]),
            "arkit_basis.tsv moves mouthClose, which arkit_blendshapes does not list"
        );
        assert_eq!(
            error(Some("jawOpen 113 0 -1 0\n"), &["jawOpen"]),
            "arkit_basis.tsv moves mask vertex 113; the mask has 113"
        );
        assert_eq!(
            error(Some("jawOpen 3 0 x 0\n"), &["jawOpen"]),
            "arkit_basis.tsv: line 1: dy: \"x\" is not a number"
        );
    }
}
