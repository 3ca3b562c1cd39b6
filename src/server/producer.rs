//! The producer WebSocket: one per stream at a time. Each frame is acked by sequence
//! number or refused with a reason, and the stream keeps running. The session ends, and
//! the stream with it (viewers get `end` with the reason), when the producer sends
//! `{"type":"end"}` (answered with `end`, then close 1000), disconnects, goes idle (4408),
//! is cancelled (4499), when its head is deleted (4410), or on shutdown (1001).
//!
//! With `derive=visemes` the producer sends audio only and the server derives the face
//! from it ([`SpeechProducer`]); parameter frames are then refused.

use std::sync::Arc;
use std::time::Duration;

use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Path, Query, State};
use axum::response::Response;
use futures_util::{Sink, SinkExt, StreamExt};
use serde::Deserialize;
use tokio_util::sync::CancellationToken;

use super::audio_gate::AudioGate;
use super::error::ApiError;
use super::head::HeadEntry;
use super::ingest::{parse_audio, parse_binary, parse_text, Incoming, Refusal};
use super::rate::ProducerGate;
use super::recordings::{RecordQuery, Recorder};
use super::socket::{close, close_for, error, refuse, text};
use super::speech_producer::SpeechProducer;
use super::stream::{ProducerPermit, Stream};
use super::transcode::Transcoder;
use super::{now_us, AppState};
use facewire_proto::audio_chunk::AUDIO_MAGIC;
use facewire_proto::codes::{CloseCode, EndReason, ErrorCode};
use facewire_proto::messages::ServerMessage;

/// Frames a second of a derived face when `fps` is not given.
pub const DERIVED_FPS: f64 = 30.0;

#[derive(Debug, Deserialize)]
pub struct ProduceQuery {
    /// `visemes`: the face is derived from the stream's audio; `none` or absent, the
    /// producer sends parameter frames.
    pub derive: Option<String>,
    /// Frames a second of the derived face ([`DERIVED_FPS`] when absent; at most `max_fps`).
    pub fps: Option<f64>,
    /// `1` or `true`: the producer is sent each derived frame (`{"type":"derived",...}`).
    pub derived: Option<String>,
    /// Keep the frames as a recording of the head ([`RecordQuery`]).
    pub record: Option<String>,
}

/// How a derived face is made: frames a second, and whether the producer hears of them.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Derive {
    fps: f64,
    report: bool,
}

impl ProduceQuery {
    fn derive(&self, max_fps: f64) -> Result<Option<Derive>, ApiError> {
        let bad = |what: String| Err(ApiError::BadRequest(what));
        match self.derive.as_deref() {
            None | Some("" | "none") => {
                if self.fps.is_some() || self.derived.is_some() {
                    return bad("fps= and derived= go with derive=visemes".into());
                }
                Ok(None)
            }
            Some("visemes") => {
                let fps = self.fps.unwrap_or(DERIVED_FPS.min(max_fps));
                if !(fps.is_finite() && fps > 0.0 && fps <= max_fps) {
                    return bad(format!(
                        "fps={fps}: expected above 0 and at most max_fps ({max_fps})"
                    ));
                }
                let report = match self.derived.as_deref() {
                    None | Some("" | "0" | "false") => false,
                    Some("1" | "true") => true,
                    Some(other) => {
                        return bad(format!("derived={}: expected 1 or 0", crate::quote::clip(other)))
                    }
                };
                Ok(Some(Derive { fps, report }))
            }
            Some(other) => bad(format!(
                "derive={}: expected visemes or none",
                crate::quote::clip(other)
            )),
        }
    }
}

/// `GET /v1/heads/{id}/streams/{stream}/produce` (the token is checked by the route layer).
pub async fn produce(
    ws: WebSocketUpgrade,
    State(state): State<AppState>,
    Path((id, name)): Path<(String, String)>,
    Query(query): Query<ProduceQuery>,
) -> Result<Response, ApiError> {
    let derive = query.derive(state.config.limits.max_fps)?;
    let head = state.registry.head(&id)?;
    head.ready()?;
    let stream = head.stream(&name)?;
    let recorder = RecordQuery {
        record: query.record.clone(),
    }
    .recorder(&head.recordings, &head.id, &name)?;
    let limit = state.config.limits.max_message_bytes;
    let session = state.sessions.token();
    Ok(ws
        .max_message_size(limit)
        .max_frame_size(limit)
        .on_upgrade(move |socket| async move {
            let speech = derive.map(|d| SpeechProducer::new(state.speech_model.clone(), d.fps, d.report));
            producer_session(socket, state, head, stream, speech, recorder).await;
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

async fn producer_session(
    mut socket: WebSocket,
    state: AppState,
    head: Arc<HeadEntry>,
    stream: Arc<Stream>,
    speech: Option<SpeechProducer>,
    recorder: Option<Recorder>,
) {
    let mut permit = match state.claim_producer(&head.id, &stream).await {
        Ok(permit) => permit,
        Err(refused) => {
            let code = refused.code();
            state.telemetry.reject(code.as_str());
            return refuse(&mut socket, code, refused.close_code(), refused.to_string()).await;
        }
    };
    if let Some(recorder) = recorder {
        permit.record(recorder);
    }
    state.telemetry.producers.inc();
    tracing::info!(head = %head.id, stream = %stream.name, "producer connected");
    // The stream's voice in the other codec, once for every viewer that asks for it.
    let mut transcoder = Transcoder::default();
    let ending = receive_frames(
        &mut socket,
        &state,
        &head.deleted,
        &permit,
        &mut transcoder,
        speech,
    )
    .await;
    if matches!(ending, Ending::Gone(_) | Ending::Ended | Ending::Idle) {
        // The voice has ended: its last samples are heard in the other codec too.
        transcoder.finish(&permit, &state.telemetry);
    }
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
            error(ErrorCode::Idle, format!("nothing received for {idle_s} s"))
        }
        _ => ServerMessage::end(reason),
    };
    let _ = socket.send(text(&told)).await;
    close(&mut socket, close_code, close_reason).await;
    state.telemetry.producers.dec();
    tracing::info!(head = %head.id, stream = %stream.name, %reason, "producer disconnected");
}

/// Acks or refuses every message until the session ends. `socket` is the producer's
/// WebSocket (any stream of messages and sink of replies, so that tests can script it);
/// `head_deleted` is the head's deletion token; `transcoder` puts the voice in the other
/// codec; `speech`, for a derived face, what derives it.
async fn receive_frames<S>(
    socket: &mut S,
    state: &AppState,
    head_deleted: &CancellationToken,
    permit: &ProducerPermit,
    transcoder: &mut Transcoder,
    mut speech: Option<SpeechProducer>,
) -> Ending
where
    S: futures_util::Stream<Item = Result<Message, axum::Error>> + Sink<Message> + Unpin,
{
    let idle = Duration::from_secs_f64(state.config.limits.producer_idle_s);
    let mask = &state.mask;
    let mut gate = ProducerGate::new(state.config.limits.max_fps);
    let mut audio = AudioGate::new();
    // The newest accepted frame's `t`, which audio must stay near.
    let mut last_t = None;
    let mut messages = 0u64;
    loop {
        let next = tokio::select! {
            _ = state.shutdown.cancelled() => return Ending::Shutdown,
            _ = head_deleted.cancelled() => return Ending::HeadDeleted,
            _ = permit.cancelled() => return Ending::Cancelled,
            next = tokio::time::timeout(idle, socket.next()) => next,
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
            Message::Binary(b) if b.starts_with(&AUDIO_MAGIC) => {
                match parse_audio(&b, received_us).and_then(|(chunk, relayed)| {
                    audio.admit(&chunk, last_t)?;
                    Ok((chunk, relayed))
                }) {
                    Ok((chunk, relayed)) => {
                        permit.publish_audio(relayed);
                        permit.record_audio(&chunk);
                        state.telemetry.audio_in.inc();
                        transcoder.publish(&chunk, permit, &state.telemetry);
                        let Some(speech) = &mut speech else {
                            continue;
                        };
                        let derived = speech.publish(&chunk, permit, &state.telemetry);
                        for report in speech.reports() {
                            if socket.send(text(&report)).await.is_err() {
                                return Ending::Gone(None);
                            }
                        }
                        match derived {
                            Ok(()) => continue,
                            Err(refusal) => Err(refusal),
                        }
                    }
                    Err(refusal) => Err(refusal),
                }
            }
            Message::Binary(b) => parse_binary(&b, mask),
        };
        let reply = match incoming.and_then(|incoming| match incoming {
            Incoming::End => Ok(None),
            Incoming::Frame { frame, .. } if speech.is_some() => Err(Refusal::new(
                ErrorCode::BadFrame,
                Some("derive"),
                "this stream's face is derived from its audio (derive=visemes): it takes audio only",
            )
            .with_seq(frame.seq)),
            Incoming::Frame { frame, ignored } => match gate.admit(&frame) {
                Ok(()) => Ok(Some((*frame, ignored))),
                Err(refusal) => Err(refusal.with_seq(frame.seq)),
            },
        }) {
            Ok(None) => {
                if let Some(speech) = &mut speech {
                    speech.finish(permit, &state.telemetry);
                    for report in speech.reports() {
                        if socket.send(text(&report)).await.is_err() {
                            return Ending::Gone(None);
                        }
                    }
                }
                return Ending::Ended;
            }
            Ok(Some((frame, ignored))) => {
                let seq = frame.seq;
                last_t = Some(frame.time_s);
                permit.publish(frame, received_us);
                state.telemetry.frames_in.inc();
                ServerMessage::Ack {
                    seq,
                    received_us,
                    ignored,
                }
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

#[cfg(test)]
mod tests {
    use std::pin::Pin;
    use std::task::{Context, Poll};

    use tokio::sync::mpsc;
    use tokio::time::Instant;

    use super::*;
    use crate::server::config::Limits;
    use crate::server::Config;

    /// A producer's socket played from a script: what the test sends into `incoming`
    /// arrives as messages; the server's replies are kept in `replies`.
    struct ScriptedSocket {
        incoming: mpsc::UnboundedReceiver<Message>,
        replies: Vec<ServerMessage>,
    }

    impl futures_util::Stream for ScriptedSocket {
        type Item = Result<Message, axum::Error>;

        fn poll_next(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Self::Item>> {
            self.incoming.poll_recv(cx).map(|message| message.map(Ok))
        }
    }

    impl Sink<Message> for ScriptedSocket {
        type Error = std::convert::Infallible;

        fn poll_ready(self: Pin<&mut Self>, _: &mut Context<'_>) -> Poll<Result<(), Self::Error>> {
            Poll::Ready(Ok(()))
        }

        fn start_send(mut self: Pin<&mut Self>, message: Message) -> Result<(), Self::Error> {
            let Message::Text(text) = message else {
                panic!("the server replied with {message:?}");
            };
            self.replies.push(serde_json::from_str(text.as_str()).unwrap());
            Ok(())
        }

        fn poll_flush(self: Pin<&mut Self>, _: &mut Context<'_>) -> Poll<Result<(), Self::Error>> {
            Poll::Ready(Ok(()))
        }

        fn poll_close(self: Pin<&mut Self>, _: &mut Context<'_>) -> Poll<Result<(), Self::Error>> {
            Poll::Ready(Ok(()))
        }
    }

    /// A service in memory with `producer_idle_s`, a stream's producer permit, and the
    /// producer's scripted socket with the sender that plays its script.
    fn scripted_producer(
        producer_idle_s: f64,
    ) -> (
        AppState,
        ProducerPermit,
        mpsc::UnboundedSender<Message>,
        ScriptedSocket,
    ) {
        let state = AppState::new(Config {
            data_dir: None,
            limits: Limits {
                producer_idle_s,
                ..Limits::default()
            },
            ..Config::default()
        })
        .unwrap();
        let permit = Arc::new(Stream::new("s")).claim_producer().unwrap();
        let (script, incoming) = mpsc::unbounded_channel();
        let socket = ScriptedSocket {
            incoming,
            replies: Vec::new(),
        };
        (state, permit, script, socket)
    }

    #[tokio::test(start_paused = true)]
    async fn a_producer_is_idle_after_producer_idle_s_of_silence_and_not_before() {
        let (state, permit, script, mut socket) = scripted_producer(5.0);
        // Every message restarts the idle clock: a frame, a ping, a refused message and a
        // frame, 4 s apart; then silence.
        let started = Instant::now();
        tokio::spawn(async move {
            let messages = [
                Message::Text(r#"{"seq":0,"t":0.0}"#.into()),
                Message::Ping(Default::default()),
                Message::Text("not json".into()),
                Message::Text(r#"{"seq":1,"t":0.1}"#.into()),
            ];
            for (i, message) in messages.into_iter().enumerate() {
                tokio::time::sleep_until(started + Duration::from_secs(4 * i as u64)).await;
                script.send(message).unwrap();
            }
            std::future::pending::<()>().await;
        });
        let ending = receive_frames(
            &mut socket,
            &state,
            &CancellationToken::new(),
            &permit,
            &mut Transcoder::default(),
            None,
        )
        .await;
        let elapsed = started.elapsed().as_secs_f64();
        assert!(matches!(ending, Ending::Idle));
        assert!(
            (17.0..17.01).contains(&elapsed),
            "idle after {elapsed} s, not 12 s + 5 s"
        );
        let replies: Vec<&str> = socket
            .replies
            .iter()
            .map(|reply| match reply {
                ServerMessage::Ack { .. } => "ack",
                ServerMessage::Error { .. } => "error",
                _ => "other",
            })
            .collect();
        assert_eq!(replies, ["ack", "error", "ack"]);
    }

    #[tokio::test(start_paused = true)]
    async fn a_producer_that_keeps_sending_is_never_idle() {
        let (state, permit, script, mut socket) = scripted_producer(1.0);
        // A frame every 0.9 s for a minute, then `end`.
        tokio::spawn(async move {
            for seq in 0..67u64 {
                let t = 0.9 * seq as f64;
                script
                    .send(Message::Text(format!(r#"{{"seq":{seq},"t":{t}}}"#).into()))
                    .unwrap();
                tokio::time::sleep(Duration::from_millis(900)).await;
            }
            script.send(Message::Text(r#"{"type":"end"}"#.into())).unwrap();
        });
        let ending = receive_frames(
            &mut socket,
            &state,
            &CancellationToken::new(),
            &permit,
            &mut Transcoder::default(),
            None,
        )
        .await;
        assert!(matches!(ending, Ending::Ended));
        assert_eq!(socket.replies.len(), 67);
    }
}
