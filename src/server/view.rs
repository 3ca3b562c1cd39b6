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
use futures_util::stream::{SplitSink, SplitStream};
use futures_util::{SinkExt, StreamExt};
use serde::Deserialize;
use tokio::sync::{broadcast, watch};
use tokio::task::JoinHandle;
use tokio_util::sync::CancellationToken;

use super::error::ApiError;
use super::frames::RelayedAudio;
use super::head::{HeadEntry, ReadyHead};
use super::pipeline::{Encoded, FrameFormat, Pipeline, PipelineKey};
use super::socket::{close, close_for, refuse, text};
use super::timeline::{Step, Timeline};
use super::AppState;
use crate::animate::{FrameJob, Heat};
use crate::deform::AlgoSpec;
use crate::mask::LIP_VERTICES;
use facewire_proto::codes::{CloseCode, EndReason};
use facewire_proto::messages::{SectionInfo, ServerMessage, Snapshot, TextureInfo};
use facewire_proto::viewer_frame::{self, FrameLayout};

#[derive(Debug, Deserialize)]
pub struct ViewQuery {
    /// Algorithm spec or letter; the server's default when absent.
    pub algo: Option<String>,
    /// `1` or `true`: frames carry per-vertex face roughness (as `heat=roughness`).
    pub face: Option<String>,
    /// `roughness` or `folds`: what the frames' per-vertex values measure.
    pub heat: Option<String>,
    /// `fwf2`, `fwf1` (the default, for clients built before `FWF2`) or `json`: every
    /// position as JSON text, the naive baseline.
    pub format: Option<String>,
    /// `pcm` or `opus`: the stream's audio chunks in that codec come on the socket too;
    /// `none` or absent, no audio.
    pub audio: Option<String>,
}

impl ViewQuery {
    pub(super) fn format(&self) -> Result<FrameFormat, ApiError> {
        match self.format.as_deref() {
            None | Some("" | "fwf1") => Ok(FrameFormat::Binary(FrameLayout::Fwf1)),
            Some("fwf2") => Ok(FrameFormat::Binary(FrameLayout::Fwf2)),
            Some("json") => Ok(FrameFormat::Json),
            Some(other) => Err(ApiError::BadRequest(format!(
                "format={}: expected fwf2, fwf1 or json",
                crate::quote::clip(other)
            ))),
        }
    }

    /// The audio codec asked for, if any.
    pub(super) fn audio(&self) -> Result<Option<&'static str>, ApiError> {
        match self.audio.as_deref() {
            None | Some("" | "none") => Ok(None),
            Some("pcm") => Ok(Some("pcm")),
            Some("opus") => Ok(Some("opus")),
            Some(other) => Err(ApiError::BadRequest(format!(
                "audio={}: expected opus, pcm or none",
                crate::quote::clip(other)
            ))),
        }
    }

    /// The per-vertex values asked for: `heat` by name, else `face`.
    pub(super) fn heat(&self) -> Result<Heat, ApiError> {
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

/// The most a viewer may send in one message. Viewers only send control frames (pings and
/// the close); anything larger closes the socket with 1009.
pub(super) const VIEWER_MESSAGE_LIMIT: usize = 4096;

/// The read buffer of a viewer's socket. The WebSocket layer zeroes a whole buffer on each
/// read attempt, made for every frame sent; its 128 KiB default cost a fifth of the
/// server's CPU at 600 viewers (docs/PERFORMANCE.md, "What limited it, and what was fixed").
const VIEWER_READ_BUFFER: usize = VIEWER_MESSAGE_LIMIT;

/// How long a viewer waits for a head that is still registering.
pub(super) const REGISTRATION_WAIT: Duration = Duration::from_secs(120);

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
    ws.read_buffer_size(VIEWER_READ_BUFFER)
        .max_message_size(VIEWER_MESSAGE_LIMIT)
        .max_frame_size(VIEWER_MESSAGE_LIMIT)
        .on_upgrade(move |mut socket| async move {
            match open_view(&state, &id, &stream, &query).await {
                Ok(view) => view.run(socket, &state).await,
                Err(error) => {
                    refuse(&mut socket, error.code(), error.close_code(), error.to_string()).await;
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
    /// The stream's audio in the codec this viewer asked for, if it asked.
    audio: Option<broadcast::Receiver<Arc<RelayedAudio>>>,
}

async fn open_view(state: &AppState, id: &str, name: &str, query: &ViewQuery) -> Result<View, ApiError> {
    let slot = state.viewer_slots.clone().try_acquire_owned().map_err(|_| {
        ApiError::LimitReached(format!(
            "{} viewers are watching, the most this server takes; try again later",
            state.config.limits.max_viewers
        ))
    })?;
    let head = state.registry.head(id)?;
    let spec = state.viewer_algorithm(query.algo.as_deref())?;
    let heat = query.heat()?;
    let format = query.format()?;
    let audio_codec = query.audio()?;
    let ready = tokio::select! {
        ready = head.wait_ready(REGISTRATION_WAIT) => ready?,
        _ = head.deleted.cancelled() => return Err(ApiError::UnknownHead(id.to_string())),
        _ = state.shutdown.cancelled() => return Err(ApiError::ShuttingDown),
    };
    let stream = head.stream(name)?;
    let hold = stream.hold();
    let binding = ready.bindings.get(&ready.animated, &spec).await?;
    let key = PipelineKey {
        spec: spec.to_string(),
        heat,
        format,
    };
    let max_pipelines = state.config.limits.max_pipelines_per_stream;
    let full = || {
        ApiError::LimitReached(format!(
            "stream {} runs {max_pipelines} pipelines (one per algorithm, heat map and format \
             watched), the most per stream; watch with one of those",
            crate::quote::quote(name)
        ))
    };
    let (animated, arkit) = (ready.animated.clone(), ready.arkit.clone());
    let (trimmer, telemetry) = (state.trimmer.clone(), state.telemetry.clone());
    let frames = stream
        .pipeline(key, max_pipelines, full, move |params| async move {
            // Its meters' tables take milliseconds on a large head: off the runtime.
            let job = tokio::task::spawn_blocking(move || FrameJob::new(animated, binding, arkit, heat))
                .await
                .map_err(ApiError::internal)?
                .map_err(ApiError::internal)?;
            Ok(Pipeline::start(job, format, params, trimmer, telemetry))
        })
        .await?;
    let snapshot = snapshot(&ready, id, name, &spec, heat, format, audio_codec);
    Ok(View {
        _slot: slot,
        _hold: hold,
        audio: audio_codec.map(|codec| stream.subscribe_audio(codec)),
        head,
        snapshot,
        frames,
    })
}

/// What a viewer of `stream` of head `id` is told first: what to download, how the frames
/// come, what may follow. A replay adds its recording.
pub(super) fn snapshot(
    ready: &ReadyHead,
    id: &str,
    stream: &str,
    spec: &AlgoSpec,
    heat: Heat,
    format: FrameFormat,
    audio_codec: Option<&'static str>,
) -> Snapshot {
    let reg = &ready.animated.registration;
    Snapshot {
        protocol: facewire_proto::PROTOCOL_VERSION.into(),
        head: id.to_string(),
        stream: stream.to_string(),
        algorithm: spec.to_string(),
        vertices: reg.vertex_count() as u32,
        triangles: reg.head.triangles.len() as u32,
        rest_mesh: format!("/v1/heads/{id}/mesh.bin"),
        rest_obj: format!("/v1/heads/{id}/mesh.obj"),
        lip_tint: Some(format!("/v1/heads/{id}/lips.bin")),
        texture: ready.texture.as_ref().map(|_| TextureInfo {
            uv: format!("/v1/heads/{id}/uv.bin"),
            image: format!("/v1/heads/{id}/texture"),
        }),
        mm_per_unit: reg.mm_per_unit(),
        step: ready.animated.step,
        lip_vertices: LIP_VERTICES.iter().map(|&v| v as u32).collect(),
        face_roughness: heat == Heat::Roughness,
        heat: heat.name().map(str::to_string),
        mouth: ready.animated.mouth().to_array(),
        parts: ready.part_infos(id),
        eyes: ready.eye_infos(id),
        format: Some(format.name().to_string()),
        messages: ["frame", "end"]
            .into_iter()
            .chain(audio_codec.map(|_| "audio"))
            .map(String::from)
            .collect(),
        audio: audio_codec.map(String::from),
        sections: match format {
            FrameFormat::Binary(FrameLayout::Fwf2) => SectionInfo::list(&viewer_frame::SECTIONS),
            _ => Vec::new(),
        },
        replay: None,
    }
}

/// How a viewer's session ended.
enum ViewEnding {
    /// The viewer closed or the connection failed.
    Left,
    /// The stream or the server ended it: the end to send and the close code.
    Ended(EndReason, CloseCode),
    /// The viewer sent what a viewer may not: the close code and why.
    BadMessage(CloseCode, String),
}

type ViewerSink = SplitSink<WebSocket, Message>;
type ViewerStream = SplitStream<WebSocket>;

impl View {
    async fn run(mut self, socket: WebSocket, state: &AppState) {
        state.telemetry.viewers.inc();
        let (mut sink, stream) = socket.split();
        let snapshot = text(&ServerMessage::Snapshot(Box::new(self.snapshot.clone())));
        if sink.send(snapshot).await.is_ok() {
            let stop = CancellationToken::new();
            let listener = tokio::spawn(listen(
                stream,
                stop.clone(),
                state.shutdown.clone(),
                self.head.deleted.clone(),
            ));
            let (ending, stream) = self.send_frames(&mut sink, listener, &stop, state).await;
            if let Some(mut socket) = stream.and_then(|stream| sink.reunite(stream).ok()) {
                match ending {
                    ViewEnding::Left => {}
                    ViewEnding::Ended(reason, code) => {
                        let _ = socket.send(text(&ServerMessage::end(reason))).await;
                        close(&mut socket, code, reason.message()).await;
                    }
                    ViewEnding::BadMessage(code, why) => close(&mut socket, code, &why).await,
                }
            }
        }
        state.telemetry.viewers.dec();
    }

    /// Sends frames and ends until the listener reports an ending or a send fails; returns
    /// the ending and the socket's reading half, for the closing handshake.
    async fn send_frames(
        &mut self,
        sink: &mut ViewerSink,
        mut listener: JoinHandle<(ViewerStream, ViewEnding)>,
        stop: &CancellationToken,
        state: &AppState,
    ) -> (ViewEnding, Option<ViewerStream>) {
        let mut done = self.frames.borrow().join_point();
        let mut last_frame: Option<u64> = None;
        self.frames.mark_changed();
        let failed = loop {
            // Audio before frames: a producer publishes its last chunks before its end, and
            // a listener that keeps up hears them all before the end reaches it.
            tokio::select! {
                biased;
                heard = &mut listener => return match heard {
                    Ok((stream, ending)) => (ending, Some(stream)),
                    Err(_) => (ViewEnding::Left, None),
                },
                audio = next_audio(&mut self.audio, state) => {
                    if let Some(message) = audio {
                        if sink.send(message).await.is_err() {
                            break ViewEnding::Left;
                        }
                        state.telemetry.audio_out.inc();
                    }
                    continue;
                }
                changed = self.frames.changed() => if changed.is_err() {
                    break ViewEnding::Ended(EndReason::ServerShutdown, CloseCode::TryLater);
                },
            }
            // The steps own their frames: the channel's lock is released before any await.
            let steps = self.frames.borrow_and_update().steps_after(done);
            if self
                .send_steps(sink, steps, &mut done, &mut last_frame, state)
                .await
                .is_err()
            {
                break ViewEnding::Left;
            }
        };
        stop.cancel();
        match listener.await {
            Ok((stream, _)) => (failed, Some(stream)),
            Err(_) => (failed, None),
        }
    }

    async fn send_steps(
        &self,
        sink: &mut ViewerSink,
        steps: impl IntoIterator<Item = Step<Encoded>>,
        done: &mut u64,
        last_frame: &mut Option<u64>,
        state: &AppState,
    ) -> Result<(), axum::Error> {
        for step in steps {
            *done = step.serial();
            let message = match step {
                Step::Frame(encoded) => {
                    if let Some(skipped) = last_frame
                        .map(|l| encoded.serial.saturating_sub(l + 1))
                        .filter(|&s| s > 0)
                    {
                        state.telemetry.skipped("viewer", skipped);
                    }
                    *last_frame = Some(encoded.serial);
                    state.telemetry.frames_out.inc();
                    state.telemetry.bytes_out.inc_by(encoded.value.bytes as u64);
                    state
                        .telemetry
                        .latency("publish_to_send", encoded.value.published.elapsed().as_secs_f64());
                    encoded.value.message.clone()
                }
                Step::End { reason, .. } => {
                    *last_frame = None;
                    text(&ServerMessage::end(reason))
                }
            };
            sink.send(message).await?;
        }
        Ok(())
    }
}

/// The next audio chunk of the viewer's codec; never ready for a viewer without audio. A
/// viewer that fell more than the stream's backlog behind is moved to the newest chunk
/// (counted), rather than fed a backlog; `None` after such a resync.
async fn next_audio(
    audio: &mut Option<broadcast::Receiver<Arc<RelayedAudio>>>,
    state: &AppState,
) -> Option<Message> {
    let Some(receiver) = audio else {
        return std::future::pending().await;
    };
    match receiver.recv().await {
        Ok(chunk) => Some(Message::Binary(chunk.bytes.clone())),
        Err(broadcast::error::RecvError::Lagged(_)) => {
            *receiver = receiver.resubscribe();
            state.telemetry.audio_resyncs.inc();
            None
        }
        // The stream is gone: its viewers end with it.
        Err(broadcast::error::RecvError::Closed) => std::future::pending().await,
    }
}

/// Watches a viewer's socket, the server's shutdown and the head's deletion, in a task of
/// its own: the socket is read only when it has data, not once per frame sent (each read
/// attempt costs the WebSocket layer a buffer fill). Returns the reading half when the
/// viewer leaves or misbehaves, the server or the head ends the view, or `stop` is
/// cancelled (the ending is then [`ViewEnding::Left`] and ignored).
async fn listen(
    mut stream: ViewerStream,
    stop: CancellationToken,
    shutdown: CancellationToken,
    deleted: CancellationToken,
) -> (ViewerStream, ViewEnding) {
    let ending = loop {
        tokio::select! {
            _ = stop.cancelled() => break ViewEnding::Left,
            _ = shutdown.cancelled() => break ViewEnding::Ended(EndReason::ServerShutdown, CloseCode::GoingAway),
            _ = deleted.cancelled() => break ViewEnding::Ended(EndReason::HeadDeleted, CloseCode::HeadDeleted),
            incoming = stream.next() => match incoming {
                None | Some(Ok(Message::Close(_))) => break ViewEnding::Left,
                Some(Err(e)) => break match close_for(e, VIEWER_MESSAGE_LIMIT) {
                    Some((code, why)) => ViewEnding::BadMessage(code, why),
                    None => ViewEnding::Left,
                },
                Some(Ok(_)) => continue,
            },
        }
    };
    (stream, ending)
}

impl AppState {
    /// The algorithm a viewer asks for, checked against the allow-list.
    pub(super) fn viewer_algorithm(&self, asked: Option<&str>) -> Result<AlgoSpec, ApiError> {
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
