//! Viewers: a WebSocket per head stream and algorithm. A snapshot first (what to
//! download, how to decode), then one binary frame per deformed frame and `end` when the
//! stream ends. Each viewer reads its pipeline's newest frame when it is ready for one, so a
//! slow viewer skips frames (never the last before an end) and holds nobody up; memory per
//! viewer is constant.

use std::sync::Arc;
use std::time::Duration;

use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Path, Query, State};
use axum::response::Response;
use serde::Deserialize;
use tokio::sync::watch;

use super::error::ApiError;
use super::head::HeadEntry;
use super::pipeline::{Encoded, Pipeline, PipelineKey};
use super::socket::{close, refuse, text};
use super::timeline::{Step, Timeline};
use super::AppState;
use crate::animate::{FrameJob, Heat};
use crate::deform::AlgoSpec;
use crate::mask::LIP_VERTICES;
use facewire_proto::codes::{CloseCode, EndReason, ErrorCode};
use facewire_proto::messages::{ServerMessage, Snapshot};

#[derive(Debug, Deserialize)]
pub struct ViewQuery {
    /// Algorithm spec or letter; the server's default when absent.
    pub algo: Option<String>,
    /// `1` or `true`: frames carry per-vertex face roughness (as `heat=roughness`).
    pub face: Option<String>,
    /// `roughness` or `folds`: what the frames' per-vertex values measure.
    pub heat: Option<String>,
}

impl ViewQuery {
    /// The per-vertex values asked for: `heat` by name, else `face`.
    fn heat(&self) -> Result<Heat, ApiError> {
        match (self.heat.as_deref(), self.face.as_deref()) {
            (Some("roughness"), _) => Ok(Heat::Roughness),
            (Some("folds"), _) => Ok(Heat::Folds),
            (Some("none" | ""), _) => Ok(Heat::None),
            (Some(other), _) => Err(ApiError::BadRequest(format!(
                "heat={}: expected roughness, folds or none",
                crate::quote::clip(other)
            ))),
            (None, Some("1" | "true")) => Ok(Heat::Roughness),
            (None, _) => Ok(Heat::None),
        }
    }
}

/// How long a viewer waits for a head that is still registering.
const REGISTRATION_WAIT: Duration = Duration::from_secs(120);

/// `GET /v1/heads/{id}/streams/{stream}/view` (the token is checked by the route layer).
/// Refusals come after the upgrade, as an `error` and a close code, because browsers do
/// not show a refused upgrade's status.
pub async fn view(
    ws: WebSocketUpgrade,
    State(state): State<AppState>,
    Path((id, stream)): Path<(String, String)>,
    Query(query): Query<ViewQuery>,
) -> Response {
    let session = state.sessions.token();
    ws.on_upgrade(move |mut socket| async move {
        match open_view(&state, &id, &stream, &query).await {
            Ok(view) => view.run(&mut socket, &state).await,
            Err((error, close_code)) => {
                refuse(&mut socket, error.code(), close_code, error.to_string()).await;
            }
        }
        drop(session);
    })
}

/// A viewer's place: the slot it holds, its head and stream, and its pipeline's frames.
struct View {
    _slot: tokio::sync::OwnedSemaphorePermit,
    _hold: super::stream::ViewerHold,
    head: Arc<HeadEntry>,
    snapshot: Snapshot,
    frames: watch::Receiver<Timeline<Encoded>>,
}

fn close_code_for(error: &ApiError) -> CloseCode {
    match error.code() {
        ErrorCode::UnknownHead => CloseCode::UnknownHead,
        ErrorCode::RegistrationFailed => CloseCode::RegistrationFailed,
        ErrorCode::BadAlgorithm | ErrorCode::BadId => CloseCode::BadRequest,
        ErrorCode::ShuttingDown => CloseCode::GoingAway,
        _ => CloseCode::TryLater,
    }
}

async fn open_view(
    state: &AppState,
    id: &str,
    name: &str,
    query: &ViewQuery,
) -> Result<View, (ApiError, CloseCode)> {
    let refused = |e: ApiError| {
        let code = close_code_for(&e);
        (e, code)
    };
    let slot = state.viewer_slots.clone().try_acquire_owned().map_err(|_| {
        refused(ApiError::LimitReached(format!(
            "{} viewers are watching, the most this server takes; try again later",
            state.config.limits.max_viewers
        )))
    })?;
    let head = state.registry.head(id).map_err(refused)?;
    let spec = state.viewer_algorithm(query.algo.as_deref()).map_err(refused)?;
    let heat = query.heat().map_err(refused)?;
    let ready = tokio::select! {
        ready = head.wait_ready(REGISTRATION_WAIT) => ready.map_err(refused)?,
        _ = head.deleted.cancelled() => return Err(refused(ApiError::UnknownHead(id.to_string()))),
        _ = state.shutdown.cancelled() => return Err(refused(ApiError::ShuttingDown)),
    };
    let stream = head.stream(name).map_err(refused)?;
    let hold = stream.hold();
    let binding = ready
        .bindings
        .get(&ready.animated, &spec)
        .await
        .map_err(refused)?;
    let key = PipelineKey {
        spec: spec.to_string(),
        heat,
    };
    let frames = stream
        .pipeline(key, |params| {
            let job = FrameJob::new(ready.animated.clone(), binding, state.arkit.clone(), heat)
                .map_err(ApiError::internal)?;
            Ok(Pipeline::start(job, params, state.telemetry.clone()))
        })
        .map_err(refused)?;
    let reg = &ready.animated.registration;
    let snapshot = Snapshot {
        protocol: facewire_proto::PROTOCOL_VERSION.into(),
        head: id.to_string(),
        stream: name.to_string(),
        algorithm: spec.to_string(),
        vertices: reg.vertex_count() as u32,
        triangles: reg.head.triangles.len() as u32,
        rest_mesh: format!("/v1/heads/{id}/mesh.bin"),
        rest_obj: format!("/v1/heads/{id}/mesh.obj"),
        mm_per_unit: reg.mm_per_unit(),
        step: ready.animated.step,
        lip_vertices: LIP_VERTICES.iter().map(|&v| v as u32).collect(),
        face_roughness: heat == Heat::Roughness,
        heat: heat.name().map(str::to_string),
        mouth: ready.animated.mouth().to_array(),
        parts: ready.part_infos(id),
    };
    Ok(View {
        _slot: slot,
        _hold: hold,
        head,
        snapshot,
        frames,
    })
}

impl View {
    async fn run(mut self, socket: &mut WebSocket, state: &AppState) {
        state.telemetry.viewers.inc();
        if socket
            .send(text(&ServerMessage::Snapshot(self.snapshot.clone())))
            .await
            .is_ok()
        {
            let ending = self.send_frames(socket, state).await;
            if let Some((reason, code)) = ending {
                let _ = socket.send(text(&ServerMessage::end(reason))).await;
                close(socket, code, reason.message()).await;
            }
        }
        state.telemetry.viewers.dec();
    }

    /// Sends frames and ends until the viewer leaves (None) or the server closes the
    /// socket (the end to send and the close code).
    async fn send_frames(
        &mut self,
        socket: &mut WebSocket,
        state: &AppState,
    ) -> Option<(EndReason, CloseCode)> {
        let mut done = self.frames.borrow().join_point();
        let mut last_frame: Option<u64> = None;
        self.frames.mark_changed();
        loop {
            tokio::select! {
                _ = state.shutdown.cancelled() => return Some((EndReason::ServerShutdown, CloseCode::GoingAway)),
                _ = self.head.deleted.cancelled() => return Some((EndReason::HeadDeleted, CloseCode::HeadDeleted)),
                changed = self.frames.changed() => if changed.is_err() {
                    return Some((EndReason::ServerShutdown, CloseCode::TryLater));
                },
                incoming = socket.recv() => match incoming {
                    None | Some(Err(_)) | Some(Ok(Message::Close(_))) => return None,
                    Some(Ok(_)) => continue,
                },
            }
            // The steps own their frames: the channel's lock is released before any await.
            let steps = self.frames.borrow_and_update().steps_after(done);
            for step in steps {
                done = step.serial();
                let message = match step {
                    Step::Frame(encoded) => {
                        if let Some(skipped) = last_frame
                            .map(|l| encoded.serial.saturating_sub(l + 1))
                            .filter(|&s| s > 0)
                        {
                            state.telemetry.skipped("viewer", skipped);
                        }
                        last_frame = Some(encoded.serial);
                        state.telemetry.frames_out.inc();
                        state.telemetry.bytes_out.inc_by(encoded.value.bytes.len() as u64);
                        state
                            .telemetry
                            .latency("publish_to_send", encoded.value.published.elapsed().as_secs_f64());
                        Message::Binary(encoded.value.bytes.clone())
                    }
                    Step::End { reason, .. } => {
                        last_frame = None;
                        text(&ServerMessage::end(reason))
                    }
                };
                if socket.send(message).await.is_err() {
                    return None;
                }
            }
        }
    }
}

impl AppState {
    /// The algorithm a viewer asks for, checked against the allow-list.
    fn viewer_algorithm(&self, asked: Option<&str>) -> Result<AlgoSpec, ApiError> {
        let spec = match asked.filter(|a| !a.is_empty()) {
            None => return Ok(self.default_spec),
            Some(text) => text
                .parse::<AlgoSpec>()
                .map_err(|e| ApiError::BadAlgorithm(e.to_string()))?,
        };
        match &self.allowed_specs {
            Some(allowed) if !allowed.contains(&spec) => Err(ApiError::BadAlgorithm(format!(
                "{spec} is not allowed on this server; allowed: {}",
                allowed
                    .iter()
                    .map(ToString::to_string)
                    .collect::<Vec<_>>()
                    .join(", ")
            ))),
            _ => Ok(spec),
        }
    }
}
