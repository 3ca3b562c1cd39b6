//! The producer WebSocket: one per stream at a time. Each frame is acked by sequence
//! number or refused with a reason, and the stream keeps running. The session ends, and
//! the stream with it (viewers get `end` with the reason), when the producer sends
//! `{"type":"end"}` (answered with `end`, then close 1000), disconnects, goes idle (4408),
//! is cancelled (4499), when its head is deleted (4410), or on shutdown (1001).

use std::sync::Arc;
use std::time::Duration;

use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Path, State};
use axum::response::Response;
use tokio_tungstenite::tungstenite;

use super::error::ApiError;
use super::head::HeadEntry;
use super::ingest::{parse_binary, parse_text, Incoming};
use super::rate::Gate;
use super::socket::{close, error, refuse, text};
use super::stream::{ProducerPermit, Stream};
use super::{now_us, AppState};
use facewire_proto::codes::{CloseCode, EndReason, ErrorCode};
use facewire_proto::messages::ServerMessage;

/// `GET /v1/heads/{id}/streams/{stream}/produce` (the token is checked by the route layer).
pub async fn produce(
    ws: WebSocketUpgrade,
    State(state): State<AppState>,
    Path((id, name)): Path<(String, String)>,
) -> Result<Response, ApiError> {
    let head = state.registry.head(&id)?;
    head.ready()?;
    let stream = head.stream(&name)?;
    let limit = state.config.limits.max_message_bytes;
    let session = state.sessions.token();
    Ok(ws
        .max_message_size(limit)
        .max_frame_size(limit)
        .on_upgrade(move |socket| async move {
            producer_session(socket, state, head, stream).await;
            drop(session);
        }))
}

/// How a producer session ended.
enum Ending {
    /// The producer sent `end`.
    Ended,
    /// The socket closed or failed; `close` is the code to answer with, if any.
    Gone(Option<(CloseCode, String)>),
    Idle,
    Cancelled,
    HeadDeleted,
    Shutdown,
}

async fn producer_session(mut socket: WebSocket, state: AppState, head: Arc<HeadEntry>, stream: Arc<Stream>) {
    let Some(permit) = stream.claim_producer() else {
        state.telemetry.reject(ErrorCode::ProducerBusy.as_str());
        let message = format!("stream {:?} already has a producer; one at a time", stream.name);
        return refuse(
            &mut socket,
            ErrorCode::ProducerBusy,
            CloseCode::ProducerBusy,
            message,
        )
        .await;
    };
    state.telemetry.producers.inc();
    tracing::info!(head = %head.id, stream = %stream.name, "producer connected");
    let ending = receive_frames(&mut socket, &state, &head, &permit).await;
    let idle_s = state.config.limits.producer_idle_s;
    let (reason, close_code, close_reason) = match ending {
        Ending::Gone(answer) => {
            drop(permit);
            if let Some((code, reason)) = answer {
                close(&mut socket, code, &reason).await;
            }
            state.telemetry.producers.dec();
            tracing::info!(head = %head.id, stream = %stream.name, "producer disconnected");
            return;
        }
        Ending::Ended => (EndReason::ProducerEnded, CloseCode::Normal, "stream ended"),
        Ending::Idle => (EndReason::ProducerIdle, CloseCode::Idle, "idle producer"),
        Ending::Cancelled => (
            EndReason::ProducerCancelled,
            CloseCode::Cancelled,
            "producer cancelled",
        ),
        Ending::HeadDeleted => (EndReason::HeadDeleted, CloseCode::HeadDeleted, "head deleted"),
        Ending::Shutdown => (
            EndReason::ServerShutdown,
            CloseCode::GoingAway,
            "server shutting down",
        ),
    };
    permit.end(reason);
    // An idle producer is told with an error (it sent nothing to be answered); the others
    // get the end of their stream.
    let told = match reason {
        EndReason::ProducerIdle => {
            state.telemetry.reject(ErrorCode::Idle.as_str());
            error(ErrorCode::Idle, format!("no frame for {idle_s} s"))
        }
        _ => ServerMessage::end(reason),
    };
    let _ = socket.send(text(&told)).await;
    close(&mut socket, close_code, close_reason).await;
    state.telemetry.producers.dec();
    tracing::info!(head = %head.id, stream = %stream.name, %reason, "producer disconnected");
}

/// Acks or refuses every message until the session ends.
async fn receive_frames(
    socket: &mut WebSocket,
    state: &AppState,
    head: &HeadEntry,
    permit: &ProducerPermit,
) -> Ending {
    let idle = Duration::from_secs_f64(state.config.limits.producer_idle_s);
    let mask = &state.mask;
    let mut gate = Gate::new(state.config.limits.max_fps);
    let mut messages = 0u64;
    loop {
        let next = tokio::select! {
            _ = state.shutdown.cancelled() => return Ending::Shutdown,
            _ = head.deleted.cancelled() => return Ending::HeadDeleted,
            _ = permit.cancelled() => return Ending::Cancelled,
            next = tokio::time::timeout(idle, socket.recv()) => next,
        };
        let message = match next {
            Err(_) => return Ending::Idle,
            Ok(None) => return Ending::Gone(None),
            Ok(Some(Err(e))) => return Ending::Gone(close_for(e, state.config.limits.max_message_bytes)),
            Ok(Some(Ok(message))) => message,
        };
        messages += 1;
        let received_us = now_us();
        let incoming = match message {
            Message::Close(_) => return Ending::Gone(None),
            Message::Ping(_) | Message::Pong(_) => continue,
            Message::Text(t) => parse_text(&t, messages, mask),
            Message::Binary(b) => parse_binary(&b, mask),
        };
        let reply = match incoming.and_then(|incoming| match incoming {
            Incoming::End => Ok(None),
            Incoming::Frame(frame) => match gate.admit(&frame) {
                Ok(()) => Ok(Some(*frame)),
                Err(refusal) => Err(refusal.with_seq(frame.seq)),
            },
        }) {
            Ok(None) => return Ending::Ended,
            Ok(Some(frame)) => {
                let seq = frame.seq;
                permit.publish(frame, received_us);
                state.telemetry.frames_in.inc();
                ServerMessage::Ack { seq, received_us }
            }
            Err(refusal) => {
                state.telemetry.reject(refusal.code.as_str());
                refusal.message()
            }
        };
        if socket.send(text(&reply)).await.is_err() {
            return Ending::Gone(None);
        }
    }
}

/// The close to answer a failed read with: 1009 for a message over the limit, 1007 for
/// text that is not UTF-8.
fn close_for(e: axum::Error, limit: usize) -> Option<(CloseCode, String)> {
    match e.into_inner().downcast::<tungstenite::Error>().map(|e| *e) {
        Ok(tungstenite::Error::Capacity(_)) => Some((
            CloseCode::MessageTooBig,
            format!("message_too_large: the limit is {limit} bytes"),
        )),
        Ok(tungstenite::Error::Utf8(_)) => {
            Some((CloseCode::InvalidPayload, "a text message is not UTF-8".into()))
        }
        Ok(tungstenite::Error::Protocol(p)) => Some((CloseCode::InvalidPayload, p.to_string())),
        _ => None,
    }
}
