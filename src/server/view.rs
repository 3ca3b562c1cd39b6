//! Viewers: a WebSocket per head stream and algorithm. A snapshot first (what to
//! download, how to decode), then one binary frame per deformed frame. Each viewer reads
//! the newest frame of its pipeline when it is ready for one, so a slow viewer skips
//! frames and never slows the producer or other viewers; memory per viewer is constant.

use std::time::Duration;

use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Path, Query, State};
use axum::http::HeaderMap;
use axum::response::Response;
use futures_util::stream::SplitSink;
use futures_util::{SinkExt, StreamExt};
use serde::Deserialize;

use super::error::ApiError;
use super::ingest::{close, text};
use super::pipeline::{Output, Pipeline};
use super::registry::HeadStatus;
use super::{check_token, AppState};
use crate::deform::AlgoSpec;
use crate::mask::LIP_VERTICES;
use facewire_proto::messages::{ServerMessage, Snapshot};

#[derive(Debug, Deserialize)]
pub struct ViewQuery {
    pub token: Option<String>,
    /// Algorithm spec or letter; the server's default when absent.
    pub algo: Option<String>,
    /// `1` or `true`: frames carry per-vertex face roughness.
    pub face: Option<String>,
}

/// How long a viewer waits for a head that is still registering.
const REGISTRATION_WAIT: Duration = Duration::from_secs(120);

pub async fn view(
    ws: WebSocketUpgrade,
    State(state): State<AppState>,
    Path((id, stream)): Path<(String, String)>,
    Query(query): Query<ViewQuery>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    check_token(
        state.config.auth.viewer_token.as_deref(),
        query.token.as_deref(),
        &headers,
        "viewer",
    )?;
    Ok(ws.on_upgrade(move |socket| viewer_session(socket, state, id, stream, query)))
}

type Sink = SplitSink<WebSocket, Message>;

async fn refuse(tx: &mut Sink, code: &str, close_code: u16, message: String) {
    let error = ServerMessage::Error {
        code: code.into(),
        message: message.clone(),
        seq: None,
        field: None,
    };
    let _ = tx.send(text(&error)).await;
    let mut reason = message;
    reason.truncate(120);
    let _ = tx.send(close(close_code, &reason)).await;
}

async fn viewer_session(socket: WebSocket, state: AppState, id: String, stream: String, query: ViewQuery) {
    let (mut tx, mut rx) = socket.split();
    let Some(head) = state.registry.get(&id) else {
        return refuse(&mut tx, "unknown_head", 4404, format!("no head {id:?}")).await;
    };
    let spec: AlgoSpec = match query.algo.as_deref().filter(|a| !a.is_empty()) {
        None => state.default_spec,
        Some(text) => match text.parse() {
            Ok(spec) => spec,
            Err(e) => return refuse(&mut tx, "bad_algorithm", 4400, e.to_string()).await,
        },
    };
    let face = matches!(query.face.as_deref(), Some("1" | "true"));
    let waited = tokio::time::Instant::now();
    let ready = loop {
        match head.status() {
            HeadStatus::Ready(r) => break r,
            HeadStatus::Failed(e) => {
                return refuse(
                    &mut tx,
                    "registration_failed",
                    4409,
                    format!("head {id:?} failed to register: {e}"),
                )
                .await
            }
            HeadStatus::Registering { .. } if waited.elapsed() < REGISTRATION_WAIT => {
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
            HeadStatus::Registering { .. } => {
                return refuse(
                    &mut tx,
                    "registering",
                    4503,
                    format!("head {id:?} is still registering"),
                )
                .await
            }
        }
    };
    if !state.admit_viewer() {
        return refuse(
            &mut tx,
            "server_full",
            4503,
            "too many viewers; try again later".into(),
        )
        .await;
    }
    state.telemetry.viewers.inc();
    let binding = ready.binding(&spec).await;
    let channel = head.channel(&stream);
    let key = (spec.to_string(), face);
    let mut frames = channel.watch_pipeline(key.clone(), |events| {
        Pipeline::start(
            channel.clone(),
            key,
            ready.clone(),
            binding,
            events,
            state.telemetry.clone(),
        )
    });
    let reg = &ready.registration;
    let snapshot = ServerMessage::Snapshot(Snapshot {
        protocol: facewire_proto::PROTOCOL_VERSION.into(),
        head: id.clone(),
        stream: stream.clone(),
        algorithm: spec.to_string(),
        vertices: reg.vertex_count() as u32,
        triangles: reg.head.triangles.len() as u32,
        rest_mesh: format!("/v1/heads/{id}/mesh.bin"),
        rest_obj: format!("/v1/heads/{id}/mesh.obj"),
        mm_per_unit: reg.mm_per_unit(),
        step: ready.step,
        lip_vertices: LIP_VERTICES.iter().map(|&v| v as u32).collect(),
        face_roughness: face,
    });
    let mut last_seq: Option<u64> = None;
    let mut pending = frames.borrow_and_update().clone();
    if tx.send(text(&snapshot)).await.is_ok() {
        loop {
            match std::mem::replace(&mut pending, Output::Waiting) {
                Output::Waiting => {}
                Output::Frame(encoded) => {
                    if let Some(previous) = last_seq.filter(|&p| encoded.seq > p + 1) {
                        state.telemetry.skipped("viewer", encoded.seq - previous - 1);
                    }
                    last_seq = Some(encoded.seq);
                    let size = encoded.bytes.len() as u64;
                    if tx.send(Message::Binary(encoded.bytes.clone())).await.is_err() {
                        break;
                    }
                    state.telemetry.frames_out.inc();
                    state.telemetry.bytes_out.inc_by(size);
                    state
                        .telemetry
                        .latency("publish_to_send", encoded.published.elapsed().as_secs_f64());
                }
                Output::Ended(reason) => {
                    last_seq = None;
                    if tx.send(text(&ServerMessage::End { reason })).await.is_err() {
                        break;
                    }
                }
            }
            tokio::select! {
                _ = state.shutdown.cancelled() => {
                    let _ = tx.send(text(&ServerMessage::End { reason: "server shutting down".into() })).await;
                    let _ = tx.send(close(1001, "server shutting down")).await;
                    break;
                }
                changed = frames.changed() => {
                    if changed.is_err() {
                        break;
                    }
                    pending = frames.borrow_and_update().clone();
                }
                incoming = rx.next() => match incoming {
                    None | Some(Err(_)) | Some(Ok(Message::Close(_))) => break,
                    Some(Ok(_)) => {}
                },
            }
        }
    }
    drop(frames);
    state.release_viewer();
    state.telemetry.viewers.dec();
}
