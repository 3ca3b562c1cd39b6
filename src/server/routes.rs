//! HTTP resources: heads (register, list, get, delete), their rest meshes, and the
//! algorithm catalogue.

use axum::extract::{Path, Query, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::{Deserialize, Serialize};

use super::error::ApiError;
use super::registry::{fit_from_landmarks, HeadStatus, RegistryError};
use super::store::{HeadMeta, HeadRecord};
use super::{check_token, AppState};
use crate::deform::AlgoSpec;
use facewire_proto::messages::HeadInfo;

#[derive(Debug, Deserialize)]
pub struct TokenQuery {
    pub token: Option<String>,
}

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
    /// a `.landmarks.toml` text to solve the fit from.
    #[serde(default)]
    pub landmarks: Option<String>,
    /// This head's own producer token.
    #[serde(default)]
    pub producer_token: Option<String>,
}

fn registry_error(e: RegistryError) -> ApiError {
    match e {
        RegistryError::BadId(_) => ApiError::bad_request("bad_id", e.to_string()),
        RegistryError::Exists(_) => ApiError::new(StatusCode::CONFLICT, "head_exists", e.to_string()),
        RegistryError::Unknown(id) => ApiError::unknown_head(&id),
        RegistryError::Store(_) => ApiError::new(
            StatusCode::INTERNAL_SERVER_ERROR,
            "storage",
            format!("could not store the head: {e}"),
        ),
    }
}

pub async fn register_head(
    State(state): State<AppState>,
    Query(query): Query<TokenQuery>,
    headers: HeaderMap,
    body: Result<Json<RegisterRequest>, axum::extract::rejection::JsonRejection>,
) -> Result<(StatusCode, Json<HeadInfo>), ApiError> {
    check_token(
        state.config.auth.admin_token.as_deref(),
        query.token.as_deref(),
        &headers,
        "admin",
    )?;
    let Json(request) = body.map_err(|e| {
        let code = if e.status() == StatusCode::PAYLOAD_TOO_LARGE {
            "too_large"
        } else {
            "bad_request"
        };
        ApiError::new(e.status(), code, e.body_text())
    })?;
    let fit_toml = match (request.fit, request.landmarks) {
        (Some(fit), None) => fit,
        (None, Some(landmarks)) => {
            let obj = request.obj.clone();
            tokio::task::spawn_blocking(move || fit_from_landmarks(obj.as_bytes(), &landmarks))
                .await
                .map_err(|e| ApiError::new(StatusCode::INTERNAL_SERVER_ERROR, "internal", e.to_string()))?
                .map_err(|e| ApiError::bad_request("bad_landmarks", e))?
        }
        _ => {
            return Err(ApiError::bad_request(
                "bad_request",
                "give exactly one of `fit` and `landmarks`",
            ))
        }
    };
    let record = HeadRecord {
        id: request.id,
        obj: request.obj.into_bytes(),
        fit_toml,
        meta: HeadMeta {
            producer_token: request.producer_token.filter(|t| !t.is_empty()),
        },
    };
    let entry = state.registry.register(record, true).map_err(registry_error)?;
    state.telemetry.heads.set(state.registry.list().len() as i64);
    Ok((StatusCode::ACCEPTED, Json(entry.info())))
}

pub async fn list_heads(State(state): State<AppState>) -> Json<Vec<HeadInfo>> {
    Json(state.registry.list().iter().map(|h| h.info()).collect())
}

pub async fn get_head(
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<HeadInfo>, ApiError> {
    let head = state
        .registry
        .get(&id)
        .ok_or_else(|| ApiError::unknown_head(&id))?;
    Ok(Json(head.info()))
}

pub async fn delete_head(
    State(state): State<AppState>,
    Path(id): Path<String>,
    Query(query): Query<TokenQuery>,
    headers: HeaderMap,
) -> Result<StatusCode, ApiError> {
    check_token(
        state.config.auth.admin_token.as_deref(),
        query.token.as_deref(),
        &headers,
        "admin",
    )?;
    state.registry.delete(&id).map_err(registry_error)?;
    state.telemetry.heads.set(state.registry.list().len() as i64);
    Ok(StatusCode::NO_CONTENT)
}

pub(super) fn ready_head(
    state: &AppState,
    id: &str,
) -> Result<std::sync::Arc<super::registry::ReadyHead>, ApiError> {
    let head = state.registry.get(id).ok_or_else(|| ApiError::unknown_head(id))?;
    match head.status() {
        HeadStatus::Ready(r) => Ok(r),
        HeadStatus::Registering { progress } => Err(ApiError::new(
            StatusCode::SERVICE_UNAVAILABLE,
            "registering",
            format!("head {id:?} is still registering ({:.0} %)", progress * 100.0),
        )),
        HeadStatus::Failed(e) => Err(ApiError::new(
            StatusCode::CONFLICT,
            "registration_failed",
            format!("head {id:?} failed to register: {e}"),
        )),
    }
}

pub async fn mesh_bin(State(state): State<AppState>, Path(id): Path<String>) -> Result<Response, ApiError> {
    let head = ready_head(&state, &id)?;
    Ok((
        [(header::CONTENT_TYPE, "application/octet-stream")],
        head.rest_bin.clone(),
    )
        .into_response())
}

pub async fn mesh_obj(State(state): State<AppState>, Path(id): Path<String>) -> Result<Response, ApiError> {
    let head = ready_head(&state, &id)?;
    Ok((
        [(header::CONTENT_TYPE, "text/plain; charset=utf-8")],
        head.rest_obj.clone(),
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
            })
            .collect(),
    )
}
