//! Producers: a WebSocket per head stream taking JSON (facewire's JSONL line format) and
//! binary (`FWP1`) frames, acking each by sequence number and naming the frame and field of
//! every refusal; and an HTTP batch endpoint (JSONL or `.fap` body) played at its
//! timestamps. One producer per stream at a time; idle producers are closed.

use std::io::Cursor;
use std::sync::Arc;
use std::time::{Duration, Instant};

use axum::body::Bytes;
use axum::extract::ws::{CloseFrame, Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Path, Query, State};
use axum::http::{HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use futures_util::{SinkExt, StreamExt};
use glam::Vec3;
use serde_json::json;

use super::channel::{Channel, Params};
use super::error::ApiError;
use super::registry::{HeadEntry, ReadyHead};
use super::routes::{ready_head, TokenQuery};
use super::{check_token, now_us, AppState};
use crate::stream::{FapReader, Frame, JsonlReader, StreamError};
use facewire_proto::messages::{ProducerMessage, ServerMessage};
use facewire_proto::params::ParamFrame;

/// Hard cap on one WebSocket message; the configured (smaller) limit is checked per
/// message so that an oversized one is refused with a message, not a dropped socket.
const SOCKET_MESSAGE_CAP: usize = 16 << 20;

/// A refusal: machine code, field (when known) and a message for people.
#[derive(Debug)]
struct Refusal {
    code: &'static str,
    field: Option<String>,
    message: String,
    /// The refused frame's sequence number, once it was parsed far enough to have one.
    seq: Option<u64>,
}

impl Refusal {
    fn new(code: &'static str, field: Option<&str>, message: impl Into<String>) -> Refusal {
        Refusal {
            code,
            field: field.map(str::to_string),
            message: message.into(),
            seq: None,
        }
    }
}

/// The head a producer addresses, once its token is checked and the head is ready.
fn producer_head(
    state: &AppState,
    id: &str,
    query: &TokenQuery,
    headers: &HeaderMap,
) -> Result<(Arc<HeadEntry>, Arc<ReadyHead>), ApiError> {
    let head = state.registry.get(id).ok_or_else(|| ApiError::unknown_head(id))?;
    producer_auth(state, &head, query, headers)?;
    let ready = ready_head(state, id)?;
    Ok((head, ready))
}

fn producer_auth(
    state: &AppState,
    head: &HeadEntry,
    query: &TokenQuery,
    headers: &HeaderMap,
) -> Result<(), ApiError> {
    let expected = head
        .record
        .meta
        .producer_token
        .as_deref()
        .or(state.config.auth.producer_token.as_deref());
    check_token(expected, query.token.as_deref(), headers, "producer")
}

pub async fn produce(
    ws: WebSocketUpgrade,
    State(state): State<AppState>,
    Path((id, stream)): Path<(String, String)>,
    Query(query): Query<TokenQuery>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let (head, ready) = producer_head(&state, &id, &query, &headers)?;
    let channel = head.channel(&stream);
    Ok(ws
        .max_message_size(SOCKET_MESSAGE_CAP)
        .on_upgrade(move |socket| producer_session(socket, state, ready, channel)))
}

/// Per-producer ordering and rate state.
struct Gate {
    last: Option<(u64, f64)>,
    /// Token bucket: frames may come in bursts of `burst`, at `max_fps` on average.
    tokens: f64,
    burst: f64,
    max_fps: f64,
    refilled: Instant,
}

impl Gate {
    fn new(max_fps: f64) -> Gate {
        let burst = (max_fps / 4.0).max(2.0);
        Gate {
            last: None,
            tokens: burst,
            burst,
            max_fps,
            refilled: Instant::now(),
        }
    }

    fn admit(&mut self, frame: &Frame) -> Result<(), Refusal> {
        if let Some((seq, time)) = self.last {
            if frame.seq <= seq {
                return Err(Refusal::new(
                    "out_of_order",
                    Some("seq"),
                    format!("seq {} does not follow {seq}", frame.seq),
                ));
            }
            if frame.time_s < time {
                return Err(Refusal::new(
                    "out_of_order",
                    Some("t"),
                    format!("t {} s is before the previous frame's {time} s", frame.time_s),
                ));
            }
        }
        let now = Instant::now();
        self.tokens = (self.tokens + (now - self.refilled).as_secs_f64() * self.max_fps).min(self.burst);
        self.refilled = now;
        if self.tokens < 1.0 {
            return Err(Refusal::new(
                "rate_limited",
                None,
                format!("more than {} frames per second", self.max_fps),
            ));
        }
        self.tokens -= 1.0;
        self.last = Some((frame.seq, frame.time_s));
        Ok(())
    }
}

/// Resolves a frame against the head and publishes it on the channel.
pub(super) fn publish_frame(
    state: &AppState,
    head: &ReadyHead,
    channel: &Channel,
    frame: Frame,
    received_us: u64,
) {
    let fitted = &head.registration.fitted;
    let mut animation = vec![0.0f32; fitted.mask.animation_units.len()];
    frame.animation_weights(&fitted.mask, &fitted.fapu, &mut animation);
    let mut offsets = vec![Vec3::ZERO; fitted.mask.vertices.len()];
    frame.mask_offsets(&state.arkit, &mut offsets);
    channel.publish(Params {
        seq: frame.seq,
        time_s: frame.time_s,
        label: frame.label,
        received_us,
        animation,
        offsets,
    });
    state.telemetry.frames_in.inc();
}

fn stream_refusal(e: &StreamError) -> Refusal {
    Refusal::new("bad_frame", None, e.to_string())
}

/// Turns a binary `FWP1` message into a frame, checking indices and values.
fn frame_from_binary(bytes: &[u8], units: usize) -> Result<Frame, Refusal> {
    let p = ParamFrame::decode(bytes).map_err(|e| Refusal::new("bad_frame", None, e.to_string()))?;
    let finite = |field: &str, values: &[f32]| {
        if values.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(Refusal::new(
                "bad_frame",
                Some(field),
                format!("{field}: values must be finite numbers"),
            ))
        }
    };
    finite("au", &p.animation.iter().map(|a| a.1).collect::<Vec<_>>())?;
    finite("fap", &p.faps.iter().map(|a| a.1).collect::<Vec<_>>())?;
    finite("arkit", &p.arkit.iter().map(|a| a.1).collect::<Vec<_>>())?;
    finite(
        "head_rotation_rad",
        p.head_rotation_rad.as_ref().map_or(&[][..], |r| &r[..]),
    )?;
    if !p.time_s.is_finite() {
        return Err(Refusal::new("bad_frame", Some("t"), "t must be a finite number"));
    }
    if let Some((u, _)) = p.animation.iter().find(|(u, _)| usize::from(*u) >= units) {
        return Err(Refusal::new(
            "bad_frame",
            Some("au"),
            format!("animation unit {u} is out of range (0..{units})"),
        ));
    }
    if let Some((f, _)) = p.faps.iter().find(|(f, _)| !(1..=68).contains(f)) {
        return Err(Refusal::new(
            "bad_frame",
            Some("fap"),
            format!("FAP {f} is out of range (1..=68)"),
        ));
    }
    if let Some((a, _)) = p
        .arkit
        .iter()
        .find(|(a, _)| usize::from(*a) >= crate::stream::ARKIT_BLENDSHAPES.len())
    {
        return Err(Refusal::new(
            "bad_frame",
            Some("arkit"),
            format!("ARKit index {a} is out of range (0..52)"),
        ));
    }
    let mut frame = Frame::at(p.seq, p.time_s);
    frame.label = p.label;
    frame.animation = p.animation;
    frame.faps = p.faps;
    frame.arkit = p.arkit;
    frame.head_rotation_rad = p.head_rotation_rad;
    Ok(frame)
}

async fn producer_session(socket: WebSocket, state: AppState, head: Arc<ReadyHead>, channel: Arc<Channel>) {
    let producer = state.next_id();
    let (mut tx, mut rx) = socket.split();
    if !channel.claim_producer(producer) {
        state.telemetry.reject("producer_busy");
        let refusal = ServerMessage::Error {
            code: "producer_busy".into(),
            message: format!("stream {:?} already has a producer; one at a time", channel.name),
            seq: None,
            field: None,
        };
        let _ = tx.send(text(&refusal)).await;
        let _ = tx.send(close(4409, "another producer is streaming")).await;
        return;
    }
    state.telemetry.producers.inc();
    tracing::info!(stream = %channel.name, producer, "producer connected");
    let limits = &state.config.limits;
    let idle = Duration::from_secs_f64(limits.producer_idle_s.max(0.001));
    let mask = crate::mask::Mask::candide3();
    let mut gate = Gate::new(limits.max_fps);
    let mut messages = 0u64;
    let reason = loop {
        let next = tokio::select! {
            _ = state.shutdown.cancelled() => break (1001, "server shutting down".to_string()),
            next = tokio::time::timeout(idle, rx.next()) => next,
        };
        let message = match next {
            Err(_) => {
                state.telemetry.reject("idle");
                let idle_error = ServerMessage::Error {
                    code: "idle".into(),
                    message: format!("no frame for {} s", limits.producer_idle_s),
                    seq: None,
                    field: None,
                };
                let _ = tx.send(text(&idle_error)).await;
                break (4408, "idle producer".to_string());
            }
            Ok(None) | Ok(Some(Err(_))) => break (1000, String::new()),
            Ok(Some(Ok(message))) => message,
        };
        messages += 1;
        let received_us = now_us();
        let parsed: Result<Option<Frame>, Refusal> = match message {
            Message::Close(_) => break (1000, String::new()),
            Message::Ping(_) | Message::Pong(_) => continue,
            Message::Text(t) if t.len() > limits.max_message_bytes => {
                Err(too_large(t.len(), limits.max_message_bytes))
            }
            Message::Binary(b) if b.len() > limits.max_message_bytes => {
                Err(too_large(b.len(), limits.max_message_bytes))
            }
            Message::Text(t) => {
                if let Ok(ProducerMessage::End) = serde_json::from_str::<ProducerMessage>(&t) {
                    channel.end("producer ended the stream");
                    tracing::info!(stream = %channel.name, producer, "producer ended the stream");
                    Ok(None)
                } else {
                    crate::stream::jsonl::parse_message(&format!("message {messages}"), &t, &mask)
                        .map(Some)
                        .map_err(|e| stream_refusal(&e))
                }
            }
            Message::Binary(b) => frame_from_binary(&b, mask.animation_units.len()).map(Some),
        };
        let reply = match parsed.and_then(|f| match f {
            Some(frame) => match gate.admit(&frame) {
                Ok(()) => Ok(Some(frame)),
                Err(refusal) => Err(Refusal {
                    seq: Some(frame.seq),
                    ..refusal
                }),
            },
            None => Ok(None),
        }) {
            Ok(Some(frame)) => {
                let seq = frame.seq;
                publish_frame(&state, &head, &channel, frame, received_us);
                ServerMessage::Ack { seq, received_us }
            }
            Ok(None) => continue,
            Err(refusal) => {
                state.telemetry.reject(refusal.code);
                ServerMessage::Error {
                    code: refusal.code.into(),
                    message: refusal.message,
                    seq: refusal.seq,
                    field: refusal.field,
                }
            }
        };
        if tx.send(text(&reply)).await.is_err() {
            break (1000, String::new());
        }
    };
    if reason.0 != 1000 {
        let _ = tx.send(close(reason.0, &reason.1)).await;
    }
    channel.release_producer(producer);
    state.telemetry.producers.dec();
    tracing::info!(stream = %channel.name, producer, "producer disconnected");
}

fn too_large(size: usize, limit: usize) -> Refusal {
    Refusal::new(
        "message_too_large",
        None,
        format!("message of {size} bytes; the limit is {limit}"),
    )
}

pub(super) fn text(message: &ServerMessage) -> Message {
    Message::Text(serde_json::to_string(message).expect("messages serialize").into())
}

pub(super) fn close(code: u16, reason: &str) -> Message {
    Message::Close(Some(CloseFrame {
        code,
        reason: reason.into(),
    }))
}

/// `POST .../batch`: a whole JSONL or `.fap` stream, validated up front, then played at
/// its timestamps as the stream's producer.
pub async fn batch(
    State(state): State<AppState>,
    Path((id, stream)): Path<(String, String)>,
    Query(query): Query<TokenQuery>,
    headers: HeaderMap,
    body: Bytes,
) -> Result<Response, ApiError> {
    let (head, ready) = producer_head(&state, &id, &query, &headers)?;
    let is_fap = headers
        .get(axum::http::header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.contains("fap"));
    let max_frames = state.config.limits.max_batch_frames;
    let frames = tokio::task::spawn_blocking(move || -> Result<Vec<Frame>, ApiError> {
        let mask = crate::mask::Mask::candide3();
        let reader: Box<dyn Iterator<Item = Result<Frame, StreamError>>> = if is_fap {
            Box::new(FapReader::new(Cursor::new(body)).with_source_name("batch"))
        } else {
            Box::new(JsonlReader::new(Cursor::new(body), &mask).with_source_name("batch"))
        };
        let mut frames = Vec::new();
        for frame in reader {
            let frame = frame.map_err(|e| ApiError::bad_request("bad_frame", e.to_string()))?;
            if frames.len() >= max_frames {
                return Err(ApiError::new(
                    StatusCode::PAYLOAD_TOO_LARGE,
                    "too_many_frames",
                    format!("more than {max_frames} frames in one batch"),
                ));
            }
            frames.push(frame);
        }
        Ok(frames)
    })
    .await
    .map_err(|e| ApiError::new(StatusCode::INTERNAL_SERVER_ERROR, "internal", e.to_string()))??;
    let channel = head.channel(&stream);
    let producer = state.next_id();
    if !channel.claim_producer(producer) {
        return Err(ApiError::new(
            StatusCode::CONFLICT,
            "producer_busy",
            format!("stream {stream:?} already has a producer; one at a time"),
        ));
    }
    let count = frames.len();
    let duration = frames.last().map_or(0.0, |f| f.time_s) - frames.first().map_or(0.0, |f| f.time_s);
    tokio::spawn(play_batch(state, ready, channel, producer, frames));
    Ok((
        StatusCode::ACCEPTED,
        Json(json!({ "frames": count, "duration_s": duration })),
    )
        .into_response())
}

async fn play_batch(
    state: AppState,
    head: Arc<ReadyHead>,
    channel: Arc<Channel>,
    producer: u64,
    frames: Vec<Frame>,
) {
    state.telemetry.producers.inc();
    let start = tokio::time::Instant::now();
    let first = frames.first().map_or(0.0, |f| f.time_s);
    for frame in frames {
        let at = start + Duration::from_secs_f64((frame.time_s - first).max(0.0));
        tokio::select! {
            _ = state.shutdown.cancelled() => break,
            _ = tokio::time::sleep_until(at) => {}
        }
        publish_frame(&state, &head, &channel, frame, now_us());
    }
    channel.end("batch finished");
    channel.release_producer(producer);
    state.telemetry.producers.dec();
}
