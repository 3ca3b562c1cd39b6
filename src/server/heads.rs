//! HTTP resources of heads: register, list, get, delete, their rest meshes, and the
//! algorithm catalogue. Registration holds one of `max_registrations` slots from before
//! its body is read until its background job ends, so concurrent uploads are bounded.

use std::time::Duration;

use axum::body::Body;
use axum::extract::rejection::QueryRejection;
use axum::extract::{Path, Query, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use bytes::Bytes;
use serde::{Deserialize, Serialize};

use super::error::ApiError;
use super::glb_upload::{self, GlbQuery};
use super::head::HeadTexture;
use super::ids::valid_id;
use super::registration::{fit_automatically, fit_from_landmarks, own_arkit_basis, AutomaticFitFailure};
use super::store::{HeadMeta, HeadRecord, PartRecord};
use super::texture_image;
use super::AppState;
use crate::cancel::Cancel;
use crate::deform::AlgoSpec;
use crate::fit::AutomaticFitError;
use crate::fit::FitReport;
use crate::head::{check_part_names, PartRole, MM_PER_METRE};
use crate::targets::ExpressionTarget;
use facewire_proto::messages::{HeadInfo, HeadSource, RecordingInfo};

/// How long a registration request waits for a free registration slot.
const SLOT_WAIT: Duration = Duration::from_secs(10);

/// `POST /v1/heads` body.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegisterRequest {
    pub id: String,
    /// The head as OBJ text.
    pub obj: String,
    /// A `.fit.toml` text, or
    #[serde(default)]
    pub fit: Option<String>,
    /// a `.landmarks.toml` text to solve the fit from; with neither, the fit is found
    /// automatically.
    #[serde(default)]
    pub landmarks: Option<String>,
    /// This head's own producer token (stored as a digest).
    #[serde(default)]
    pub producer_token: Option<String>,
    /// Teeth, gums, tongue: at most `head::MAX_PARTS`.
    #[serde(default)]
    pub parts: Vec<PartUpload>,
    /// The head's texture image (its material's `map_Kd`), PNG or JPEG, base64: drawn
    /// with the OBJ's texture coordinates.
    #[serde(default)]
    pub texture: Option<String>,
}

/// A registration's texture, decoded and checked.
fn texture_bytes(base64_text: Option<&str>) -> Result<Option<Vec<u8>>, ApiError> {
    use base64::Engine;
    let Some(text) = base64_text else {
        return Ok(None);
    };
    let bytes = base64::engine::general_purpose::STANDARD
        .decode(text.trim())
        .map_err(|e| ApiError::BadRequest(format!("texture: not base64: {e}")))?;
    texture_image::check(&bytes).map_err(|e| ApiError::BadRequest(e.to_string()))?;
    Ok(Some(bytes))
}

/// A part in a registration request.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PartUpload {
    /// 1-64 of `a-z 0-9 - _`, unique on the head.
    pub name: String,
    /// The part as OBJ text, in the head's units and frame.
    pub obj: String,
    /// `skull`, `jaw` or `tongue`; left out, it is inferred (skull or jaw).
    #[serde(default)]
    pub role: Option<String>,
}

/// The parts of a request, checked: names valid and unique, roles known, at most
/// [`crate::head::MAX_PARTS`].
fn part_records(parts: Vec<PartUpload>) -> Result<Vec<PartRecord>, ApiError> {
    check_part_names(parts.iter().map(|p| p.name.as_str()))
        .map_err(|e| ApiError::BadRequest(e.to_string()))?;
    let mut records = Vec::with_capacity(parts.len());
    for part in parts {
        if !valid_id(&part.name) {
            return Err(ApiError::BadId {
                what: "part name",
                id: part.name,
            });
        }
        let role = part
            .role
            .as_deref()
            .map(str::parse::<PartRole>)
            .transpose()
            .map_err(|e| ApiError::BadRequest(format!("part {:?}: {e}", part.name)))?;
        records.push(PartRecord {
            name: part.name,
            role,
            obj: part.obj.into_bytes(),
        });
    }
    Ok(records)
}

pub async fn register_head(
    State(state): State<AppState>,
    headers: HeaderMap,
    query: Result<Query<GlbQuery>, QueryRejection>,
    body: Body,
) -> Result<(StatusCode, Json<HeadInfo>), ApiError> {
    state.registry.check_room()?;
    let slot = state.registry.registration_slot(SLOT_WAIT).await?;
    let limit = state.config.limits.max_upload_bytes;
    let bytes = axum::body::to_bytes(body, limit)
        .await
        .map_err(|_| ApiError::TooLarge { limit })?;
    let glb = headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| {
            v.split(';')
                .next()
                .is_some_and(|t| t.trim() == glb_upload::CONTENT_TYPE)
        });
    let Query(query) =
        query.map_err(|e| ApiError::BadRequest(format!("registration query: {}", e.body_text())))?;
    let upload = if glb {
        let id = query
            .id
            .ok_or_else(|| ApiError::BadRequest("a glTF registration names its head with `?id=`".into()))?;
        let producer_token = headers
            .get(PRODUCER_TOKEN_HEADER)
            .map(|v| v.to_str().map(String::from))
            .transpose()
            .map_err(|_| ApiError::BadRequest(format!("{PRODUCER_TOKEN_HEADER}: not visible ASCII")))?;
        let from_file =
            tokio::task::spawn_blocking(move || glb_upload::glb_upload(&bytes, query.roles.as_deref()))
                .await
                .map_err(ApiError::internal)??;
        Upload {
            id,
            obj: from_file.obj,
            fit: None,
            landmarks: None,
            producer_token,
            parts: from_file.parts,
            texture: from_file.texture,
            arkit_targets: from_file.arkit_targets,
            mm_per_unit: Some(MM_PER_METRE),
            source: Some(from_file.source),
        }
    } else {
        if query.id.is_some() || query.roles.is_some() {
            return Err(ApiError::BadRequest(format!(
                "`id` and `roles` in the query are for glTF registrations (Content-Type: {})",
                glb_upload::CONTENT_TYPE
            )));
        }
        let request: RegisterRequest = serde_json::from_slice(&bytes)
            .map_err(|e| ApiError::BadRequest(format!("registration request: {e}")))?;
        drop(bytes);
        Upload {
            id: request.id,
            obj: request.obj,
            fit: request.fit,
            landmarks: request.landmarks,
            producer_token: request.producer_token,
            parts: part_records(request.parts)?,
            texture: texture_bytes(request.texture.as_deref())?,
            arkit_targets: Vec::new(),
            mm_per_unit: None,
            source: None,
        }
    };
    register(&state, slot, upload).await
}

/// The header that carries a glTF registration's own producer token (a JSON
/// registration has it in its body).
const PRODUCER_TOKEN_HEADER: &str = "x-facewire-producer-token";

/// A registration, from a JSON body or from a glTF file.
struct Upload {
    id: String,
    obj: String,
    fit: Option<String>,
    landmarks: Option<String>,
    producer_token: Option<String>,
    parts: Vec<PartRecord>,
    texture: Option<Vec<u8>>,
    /// Morph targets that make ARKit blendshapes (named by ARKit, head units).
    arkit_targets: Vec<ExpressionTarget>,
    /// Known from the file's format (glTF: metres), for the automatic fit.
    mm_per_unit: Option<f32>,
    source: Option<HeadSource>,
}

/// Fits (unless a fit was given) and registers `upload`, holding `slot` throughout.
async fn register(
    state: &AppState,
    slot: tokio::sync::OwnedSemaphorePermit,
    upload: Upload,
) -> Result<(StatusCode, Json<HeadInfo>), ApiError> {
    let budget = state.registry.budget();
    // A fit runs on the blocking pool holding the slot until it has stopped, even when
    // this request ends first (timed out, or its client left): `stop` cancels it then.
    let cancel = Cancel::new();
    let _stop = cancel.on_drop();
    let obj = upload.obj;
    let (slot, obj, fit_toml) = match (upload.fit, upload.landmarks) {
        (Some(fit), None) => (slot, obj, fit),
        (None, Some(landmarks)) => {
            let (slot, obj, fit) = tokio::task::spawn_blocking(move || {
                let fit = fit_from_landmarks(obj.as_bytes(), &landmarks, budget);
                (slot, obj, fit)
            })
            .await
            .map_err(ApiError::internal)?;
            (slot, obj, fit.map_err(|e| ApiError::BadLandmarks(e.to_string()))?)
        }
        (None, None) => {
            let telemetry = state.telemetry.clone();
            let mm_per_unit = upload.mm_per_unit;
            let (slot, obj, fit) = tokio::task::spawn_blocking(move || {
                let fit = fit_automatically(obj.as_bytes(), mm_per_unit, budget, &cancel);
                if let Err(AutomaticFitFailure::Fit(AutomaticFitError::Cancelled { .. })) = fit {
                    telemetry.fits_cancelled.inc();
                }
                (slot, obj, fit)
            })
            .await
            .map_err(ApiError::internal)?;
            (slot, obj, fit.map_err(|e| ApiError::BadHead(e.to_string()))?)
        }
        (Some(_), Some(_)) => {
            return Err(ApiError::BadRequest(
                "give at most one of `fit` and `landmarks` (neither: the fit is found automatically)".into(),
            ))
        }
    };
    // Only a glTF file's ARKit morph targets have a basis to derive.
    let targets = upload.arkit_targets;
    let (slot, obj, fit_toml, own_arkit) = if targets.is_empty() {
        (slot, obj, fit_toml, None)
    } else {
        let (slot, obj, fit_toml, own) = tokio::task::spawn_blocking(move || {
            let own = own_arkit_basis(obj.as_bytes(), &fit_toml, &targets, budget);
            (slot, obj, fit_toml, own)
        })
        .await
        .map_err(ApiError::internal)?;
        (
            slot,
            obj,
            fit_toml,
            own.map_err(|e| ApiError::BadHead(e.to_string()))?,
        )
    };
    let mut meta = HeadMeta::with_producer_token(upload.producer_token.as_deref());
    let arkit_basis = own_arkit.map(|own| {
        meta.arkit_blendshapes = own.blendshapes;
        own.basis
    });
    let record = HeadRecord {
        id: upload.id,
        obj: obj.into_bytes(),
        fit_toml,
        parts: upload.parts,
        texture: upload.texture,
        arkit_basis,
        meta,
    };
    let entry = state.registry.register(record, true, slot).await?;
    state.telemetry.heads.set(state.registry.list().len() as i64);
    let mut info = entry.info();
    info.source = upload.source;
    Ok((StatusCode::ACCEPTED, Json(info)))
}

pub async fn list_heads(State(state): State<AppState>) -> Json<Vec<HeadInfo>> {
    Json(state.registry.list().iter().map(|h| h.info()).collect())
}

pub async fn get_head(
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<HeadInfo>, ApiError> {
    Ok(Json(state.registry.head(&id)?.info()))
}

pub async fn delete_head(
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<StatusCode, ApiError> {
    state.registry.delete(&id).await?;
    state.telemetry.heads.set(state.registry.list().len() as i64);
    Ok(StatusCode::NO_CONTENT)
}

pub async fn mesh_bin(State(state): State<AppState>, Path(id): Path<String>) -> Result<Response, ApiError> {
    let ready = state.registry.head(&id)?.ready()?;
    Ok((
        [(header::CONTENT_TYPE, "application/octet-stream")],
        ready.rest_bin.clone(),
    )
        .into_response())
}

/// `GET /v1/heads/{id}/recordings`: the head's recorded streams, by name.
pub async fn list_recordings(
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<Vec<RecordingInfo>>, ApiError> {
    Ok(Json(state.registry.head(&id)?.recordings.list()))
}

/// `DELETE /v1/heads/{id}/recordings/{name}`; replays already playing it go on.
pub async fn delete_recording(
    State(state): State<AppState>,
    Path((id, name)): Path<(String, String)>,
) -> Result<StatusCode, ApiError> {
    state.registry.head(&id)?.recordings.delete(&id, &name)?;
    Ok(StatusCode::NO_CONTENT)
}

/// `GET /v1/heads/{id}/lips.bin`: where the rest mesh's lips are (`FWL1`).
pub async fn lips_bin(State(state): State<AppState>, Path(id): Path<String>) -> Result<Response, ApiError> {
    let ready = state.registry.head(&id)?.ready()?;
    Ok((
        [(header::CONTENT_TYPE, "application/octet-stream")],
        ready.lips_bin.clone(),
    )
        .into_response())
}

/// `GET /v1/heads/{id}/parts/{part}/mesh.bin`.
pub async fn part_mesh_bin(
    State(state): State<AppState>,
    Path((id, part)): Path<(String, String)>,
) -> Result<Response, ApiError> {
    let ready = state.registry.head(&id)?.ready()?;
    let bin = ready
        .part_bin(&part)
        .ok_or_else(|| ApiError::NotFound(format!("part {part} of head {id}")))?;
    Ok(([(header::CONTENT_TYPE, "application/octet-stream")], bin.clone()).into_response())
}

/// `GET /v1/heads/{id}/parts/{part}/tongue.bin`: which of the tongue part's vertices are
/// the tongue itself (`FWL1`).
pub async fn part_tongue_bin(
    State(state): State<AppState>,
    Path((id, part)): Path<(String, String)>,
) -> Result<Response, ApiError> {
    let ready = state.registry.head(&id)?.ready()?;
    let bin = ready
        .tongue_bin(&part)
        .ok_or_else(|| ApiError::NotFound(format!("tongue weights of part {part} of head {id}")))?;
    Ok(([(header::CONTENT_TYPE, "application/octet-stream")], bin.clone()).into_response())
}

/// What `serve` makes of head `id`'s texture; not found for a head without one.
fn with_texture(
    state: &AppState,
    id: &str,
    serve: impl FnOnce(&HeadTexture) -> Response,
) -> Result<Response, ApiError> {
    let ready = state.registry.head(id)?.ready()?;
    let texture = ready
        .texture
        .as_ref()
        .ok_or_else(|| ApiError::NotFound(format!("a texture of head {id}")))?;
    Ok(serve(texture))
}

/// `GET /v1/heads/{id}/uv.bin`: where the rest mesh sits on the head's texture (`FWU1`).
pub async fn uv_bin(State(state): State<AppState>, Path(id): Path<String>) -> Result<Response, ApiError> {
    with_texture(&state, &id, |texture| {
        (
            [(header::CONTENT_TYPE, "application/octet-stream")],
            texture.uv_bin.clone(),
        )
            .into_response()
    })
}

/// `GET /v1/heads/{id}/texture`: the head's texture image, PNG or JPEG, as uploaded.
pub async fn texture(State(state): State<AppState>, Path(id): Path<String>) -> Result<Response, ApiError> {
    with_texture(&state, &id, |texture| {
        (
            [(header::CONTENT_TYPE, texture.content_type)],
            texture.image.clone(),
        )
            .into_response()
    })
}

/// `GET /v1/heads/{id}/fit`: the fit report.
pub async fn fit_report(
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<FitReport>, ApiError> {
    Ok(Json(state.registry.head(&id)?.ready()?.fit_report.clone()))
}

/// `fit.png`'s query: which side of the face, `front` (the default) or `side`. Other keys
/// (a cache-busting one, say) are ignored.
#[derive(Debug, Deserialize)]
pub struct PictureQuery {
    view: Option<String>,
}

/// Pixels across `fit.png`.
const FIT_PICTURE_SIZE: usize = 800;

/// `GET /v1/heads/{id}/fit.png?view=front|side`: the fitted mask on the head, drawn once
/// per view (off the runtime's threads) and kept.
pub async fn fit_png(
    State(state): State<AppState>,
    Path(id): Path<String>,
    Query(query): Query<PictureQuery>,
) -> Result<Response, ApiError> {
    let ready = state.registry.head(&id)?.ready()?;
    let (picture, view) = match query.view.as_deref() {
        None | Some("front") => (0, crate::render::View::Front),
        Some("side") => (1, crate::render::View::Side),
        Some(other) => {
            return Err(ApiError::BadRequest(format!(
                "view: expected front or side, found {}",
                crate::quote::clip(other)
            )))
        }
    };
    let png = match ready.fit_pictures[picture].get() {
        Some(png) => png.clone(),
        None => {
            // Drawn in a registration slot, held until the drawing is done.
            let work_slot = state.registry.registration_slot(SLOT_WAIT).await?;
            let drawing = ready.clone();
            let png = tokio::task::spawn_blocking(move || {
                let _held = work_slot;
                let reg = &drawing.animated.registration;
                crate::render::fitted_mask_png(&reg.head, &reg.fitted, view, FIT_PICTURE_SIZE)
            })
            .await
            .map_err(ApiError::internal)?
            .map_err(|e| ApiError::BadHead(format!("fit.png of head {id}: {e}")))?;
            ready.fit_pictures[picture]
                .get_or_init(|| Bytes::from(png))
                .clone()
        }
    };
    Ok(([(header::CONTENT_TYPE, "image/png")], png).into_response())
}

pub async fn mesh_obj(State(state): State<AppState>, Path(id): Path<String>) -> Result<Response, ApiError> {
    let ready = state.registry.head(&id)?.ready()?;
    Ok((
        [(header::CONTENT_TYPE, "text/plain; charset=utf-8")],
        ready.rest_obj.clone(),
    )
        .into_response())
}

#[derive(Serialize)]
pub struct AlgorithmInfo {
    letter: char,
    spec: String,
    linear: bool,
    description: &'static str,
    default: bool,
    /// False when the server's allow-list leaves it out.
    allowed: bool,
}

pub async fn algorithms(State(state): State<AppState>) -> Json<Vec<AlgorithmInfo>> {
    Json(
        AlgoSpec::presets()
            .into_iter()
            .map(|(letter, spec, description)| AlgorithmInfo {
                letter,
                spec: spec.to_string(),
                linear: spec.is_linear(),
                description,
                default: spec == state.default_spec,
                allowed: state.allowed_specs.as_ref().is_none_or(|a| a.contains(&spec)),
            })
            .collect(),
    )
}
