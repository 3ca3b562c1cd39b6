//! Replay: a recording of a head (`super::recordings`) played to one viewer at the
//! viewer's pace, for people who learn from it: paused, stepped a frame at a time, slowed,
//! looped over a syllable, sought to any frame. Each replay viewer has its own frame job,
//! and the server deforms only the frames it shows, each exactly once per showing, so
//! every frame sent is the one asked for (its `seq` is its index in the recording). A live
//! stream is unchanged by any of it: replays never touch a stream.
//!
//! `GET /v1/heads/{id}/recordings/{name}/view?algo=&format=&heat=`: a snapshot (the
//! recording in `replay`), the first frame, then frames at the recording's own times
//! (scaled by the speed) until the last, where it pauses. The viewer steers it with JSON
//! text ([`ReplayControl`]); each control is answered with a `replay` message saying
//! where it stands. A control that cannot be followed gets an `error` naming the field,
//! and the replay goes on. With `audio=`, a recording with a voice is heard with its
//! frames (`super::replay_voice`).

use std::sync::Arc;
use std::time::Duration;

use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Path, Query, State};
use axum::response::Response;
use futures_util::StreamExt;
use tokio::time::Instant;

use super::error::ApiError;
use super::frames::ReceivedFrame;
use super::head::HeadEntry;
use super::pipeline::{process, FrameFormat};
use super::recordings::Recording;
use super::replay_voice::ReplayVoice;
use super::socket::{close, close_for, error, refuse, text};
use super::view::{snapshot, ViewQuery, REGISTRATION_WAIT, VIEWER_MESSAGE_LIMIT};
use super::{now_us, AppState};
use crate::animate::FrameJob;
use facewire_proto::codes::{CloseCode, EndReason, ErrorCode};
use facewire_proto::messages::{ReplayControl, ServerMessage, Snapshot};

/// The slowest and fastest a replay plays, times the recording's own pace.
pub const SPEEDS: [f64; 2] = [0.1, 2.0];

/// The time from one frame to the next when the recording cannot say (a frame alone),
/// seconds.
const LONE_FRAME_S: f64 = 1.0 / 30.0;

/// `GET /v1/heads/{id}/recordings/{name}/view` (the token is checked by the route layer).
pub async fn view(
    ws: WebSocketUpgrade,
    State(state): State<AppState>,
    Path((id, name)): Path<(String, String)>,
    Query(query): Query<ViewQuery>,
) -> Response {
    let session = state.sessions.token();
    ws.max_message_size(VIEWER_MESSAGE_LIMIT)
        .max_frame_size(VIEWER_MESSAGE_LIMIT)
        .on_upgrade(move |mut socket| async move {
            match open_replay(&state, &id, &name, &query).await {
                Ok(replay) => replay.run(socket, &state).await,
                Err(error) => {
                    refuse(&mut socket, error.code(), error.close_code(), error.to_string()).await;
                }
            }
            drop(session);
        })
}

/// A replay viewer's place: its slot, its head, the recording and its own frame job.
struct Replay {
    _slot: tokio::sync::OwnedSemaphorePermit,
    head: Arc<HeadEntry>,
    recording: Arc<Recording>,
    job: Option<Box<FrameJob>>,
    format: FrameFormat,
    snapshot: Snapshot,
    /// The voice, when the viewer asked for it.
    voice: Option<ReplayVoice>,
}

async fn open_replay(state: &AppState, id: &str, name: &str, query: &ViewQuery) -> Result<Replay, ApiError> {
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
    let audio = query.audio()?;
    let recording = head.recordings.get(id, name)?;
    // Heard when it has a voice; a recording without one replays silent, as a live
    // stream whose producer sends no audio.
    let voice = audio.and_then(|codec| ReplayVoice::new(recording.clone(), codec));
    let audio = voice.as_ref().and(audio);
    let ready = tokio::select! {
        ready = head.wait_ready(REGISTRATION_WAIT) => ready?,
        _ = head.deleted.cancelled() => return Err(ApiError::UnknownHead(id.to_string())),
        _ = state.shutdown.cancelled() => return Err(ApiError::ShuttingDown),
    };
    let binding = ready.bindings.get(&ready.animated, &spec).await?;
    let (animated, arkit) = (ready.animated.clone(), ready.arkit.clone());
    // Its meters' tables take milliseconds on a large head: off the runtime.
    let job = tokio::task::spawn_blocking(move || FrameJob::new(animated, binding, arkit, heat))
        .await
        .map_err(ApiError::internal)?
        .map_err(ApiError::internal)?;
    let mut snapshot = snapshot(&ready, id, &recording.stream, &spec, heat, format, audio);
    snapshot.messages = ["frame", "replay", "end"].map(String::from).to_vec();
    if audio.is_some() {
        snapshot.messages.push("audio".into());
    }
    snapshot.replay = Some(recording.info());
    Ok(Replay {
        _slot: slot,
        head,
        recording,
        job: Some(Box::new(job)),
        format,
        snapshot,
        voice,
    })
}

/// Where a replay stands.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Position {
    frame: usize,
    playing: bool,
    speed: f64,
    /// First and last frame played over and over, inclusive.
    looped: Option<(usize, usize)>,
}

impl Position {
    fn message(&self) -> ServerMessage {
        ServerMessage::Replay {
            frame: self.frame as u64,
            playing: self.playing,
            speed: self.speed,
            r#loop: self.looped.map(|(a, b)| [a as u64, b as u64]),
        }
    }
}

/// Why a control was not followed: the field and what is wrong.
struct BadControl {
    field: &'static str,
    message: String,
}

impl Position {
    /// Follows `control` on a recording of `frames` frames.
    fn apply(&mut self, control: ReplayControl, frames: usize) -> Result<(), BadControl> {
        let last = frames - 1;
        let frame_in = |field: &'static str, f: u64| {
            usize::try_from(f)
                .ok()
                .filter(|&f| f <= last)
                .ok_or_else(|| BadControl {
                    field,
                    message: format!("frame {f} is past the recording's last, {last}"),
                })
        };
        match control {
            ReplayControl::Play { speed } => {
                if let Some(speed) = speed {
                    if !(SPEEDS[0]..=SPEEDS[1]).contains(&speed) {
                        return Err(BadControl {
                            field: "speed",
                            message: format!("speed {speed}: expected {} to {}", SPEEDS[0], SPEEDS[1]),
                        });
                    }
                    self.speed = speed;
                }
                // Played to its end, it starts again from the first frame.
                if self.frame == last && self.looped.is_none() {
                    self.frame = 0;
                }
                self.playing = true;
            }
            ReplayControl::Pause => self.playing = false,
            ReplayControl::Seek { frame } => self.frame = frame_in("frame", frame)?,
            ReplayControl::Step { frames: by } => {
                self.playing = false;
                self.frame = (self.frame as i64).saturating_add(by).clamp(0, last as i64) as usize;
            }
            ReplayControl::Loop { first, last: end } => match (first, end) {
                (None, None) => self.looped = None,
                (Some(first), Some(end)) => {
                    let (a, b) = (frame_in("first", first)?, frame_in("last", end)?);
                    if a > b {
                        return Err(BadControl {
                            field: "last",
                            message: format!("a loop from frame {a} to frame {b} goes backwards"),
                        });
                    }
                    self.looped = Some((a, b));
                    if !(a..=b).contains(&self.frame) {
                        self.frame = a;
                    }
                }
                _ => {
                    return Err(BadControl {
                        field: if first.is_none() { "first" } else { "last" },
                        message: "a loop needs both its first and last frame (neither clears it)".into(),
                    })
                }
            },
        }
        Ok(())
    }

    /// The frame after the shown one while playing, or `None` where the replay stops.
    fn next(&self, frames: usize) -> Option<usize> {
        match self.looped {
            Some((first, last)) if self.frame >= last => Some(first),
            _ if self.frame + 1 < frames => Some(self.frame + 1),
            _ => None,
        }
    }
}

impl Replay {
    async fn run(mut self, mut socket: WebSocket, state: &AppState) {
        state.telemetry.viewers.inc();
        let ending = self.play(&mut socket, state).await;
        if let Some((reason, code)) = ending {
            let _ = socket.send(text(&ServerMessage::end(reason))).await;
            close(&mut socket, code, reason.message()).await;
        }
        state.telemetry.viewers.dec();
    }

    /// Plays until the viewer leaves (`None`) or the server or the head ends it.
    async fn play(&mut self, socket: &mut WebSocket, state: &AppState) -> Option<(EndReason, CloseCode)> {
        let frames = self.recording.frames.len();
        let snapshot = text(&ServerMessage::Snapshot(Box::new(self.snapshot.clone())));
        socket.send(snapshot).await.ok()?;
        let mut position = Position {
            frame: 0,
            playing: true,
            speed: 1.0,
            looped: None,
        };
        let mut shown: Option<usize> = None;
        let mut shown_at = Instant::now();
        self.follow_with_voice(&position, shown_at);
        loop {
            if shown != Some(position.frame) {
                let message = self.frame_message(position.frame, state).await?;
                socket.send(message).await.ok()?;
                shown = Some(position.frame);
            }
            let next = position.playing.then(|| position.next(frames)).flatten();
            if position.playing && next.is_none() {
                // The last frame: the replay stops there, and says so.
                position.playing = false;
                socket.send(text(&position.message())).await.ok()?;
            }
            let due = next.map(|n| shown_at + self.gap(position.frame, n, position.speed));
            let voice_due = self.voice.as_ref().and_then(ReplayVoice::due);
            tokio::select! {
                _ = state.shutdown.cancelled() => return Some((EndReason::ServerShutdown, CloseCode::GoingAway)),
                _ = self.head.deleted.cancelled() => return Some((EndReason::HeadDeleted, CloseCode::HeadDeleted)),
                _ = sleep_until(voice_due) => {
                    if let Some(chunk) = self.voice.as_mut().and_then(ReplayVoice::next_message) {
                        socket.send(chunk).await.ok()?;
                    }
                }
                _ = sleep_until(due) => {
                    let next = next.expect("a due frame has a next");
                    let started_over = next < position.frame;
                    position.frame = next;
                    shown_at = due.expect("due");
                    if started_over {
                        // A loop starting over: said, and its voice from its start.
                        socket.send(text(&position.message())).await.ok()?;
                        self.follow_with_voice(&position, shown_at);
                    }
                }
                incoming = socket.next() => {
                    let body = match incoming {
                        None | Some(Ok(Message::Close(_))) => return None,
                        Some(Err(e)) => {
                            if let Some((code, why)) = close_for(e, VIEWER_MESSAGE_LIMIT) {
                                close(socket, code, &why).await;
                            }
                            return None;
                        }
                        Some(Ok(Message::Text(body))) => body,
                        Some(Ok(_)) => continue,
                    };
                    let reply = match serde_json::from_str::<ReplayControl>(body.as_str()) {
                        Err(e) => bad(None, format!("not a replay control: {e}")),
                        Ok(control) => match position.apply(control, frames) {
                            Ok(()) => {
                                shown_at = Instant::now();
                                self.follow_with_voice(&position, shown_at);
                                position.message()
                            }
                            Err(BadControl { field, message }) => bad(Some(field), message),
                        },
                    };
                    socket.send(text(&reply)).await.ok()?;
                }
            }
        }
    }

    /// Starts the voice where `position` plays, heard from `at` (when its frame is shown),
    /// to the end of what it plays (its loop's last frame, else the recording's), or stops
    /// it when paused.
    fn follow_with_voice(&mut self, position: &Position, at: Instant) {
        let Some(voice) = &mut self.voice else { return };
        if !position.playing {
            voice.stop();
            return;
        }
        let frames = &self.recording.frames;
        let last = position.looped.map_or(frames.len() - 1, |(_, last)| last);
        // The last frame lasts as long as the one before it.
        let last_lasts = if last > 0 {
            frames[last].time_s - frames[last - 1].time_s
        } else {
            LONE_FRAME_S
        };
        let until = frames[last].time_s + last_lasts.max(0.0);
        voice.play(frames[position.frame].time_s, until, position.speed, at);
    }

    /// How long after frame `from` is shown frame `to` is due at `speed`: the recording's
    /// own time between them; from the end of a loop back to its start, the time between
    /// the loop's last frame and the one before it.
    fn gap(&self, from: usize, to: usize, speed: f64) -> Duration {
        let t = |i: usize| self.recording.frames[i].time_s;
        let seconds = if to > from {
            t(to) - t(from)
        } else if from > 0 {
            t(from) - t(from - 1)
        } else {
            LONE_FRAME_S
        };
        Duration::from_secs_f64((seconds.max(0.0) / speed).min(3600.0))
    }

    /// Frame `index` of the recording deformed, measured and encoded, its `seq` the index.
    /// `None` (logged) when the job fails, which ends the replay.
    async fn frame_message(&mut self, index: usize, state: &AppState) -> Option<Message> {
        let mut frame = self.recording.frames[index].clone();
        frame.seq = index as u64;
        let received = ReceivedFrame {
            frame,
            received_us: now_us(),
        };
        let mut job = self.job.take()?;
        let (format, telemetry) = (self.format, state.telemetry.clone());
        let handed = tokio::task::spawn_blocking(move || {
            let encoded = process(&mut job, format, &received, &telemetry);
            (job, encoded)
        })
        .await;
        match handed {
            Ok((job, encoded)) => {
                self.job = Some(job);
                encoded.map(|e| e.message)
            }
            Err(e) => {
                tracing::error!(error = %e, "replay frame job failed");
                None
            }
        }
    }
}

fn bad(field: Option<&'static str>, message: String) -> ServerMessage {
    let mut refusal = error(ErrorCode::BadRequest, message);
    if let ServerMessage::Error { field: slot, .. } = &mut refusal {
        *slot = field.map(String::from);
    }
    refusal
}

/// Sleeps until `due`, or forever without one.
async fn sleep_until(due: Option<Instant>) {
    match due {
        Some(due) => tokio::time::sleep_until(due).await,
        None => std::future::pending().await,
    }
}
