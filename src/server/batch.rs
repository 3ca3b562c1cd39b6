//! HTTP batches: a whole JSONL or `.fap` stream in one body, and with a multipart body its
//! voice as a WAV or Ogg Opus file beside it (or the voice alone), validated up front (errors name the
//! part, line and field), then played at its timestamps as the stream's producer. A batch
//! is bounded in bytes, frames and duration, and `DELETE .../producer` cancels it (or a
//! socket producer) at once; viewers get `end` with the reason either way.

use std::io::Cursor;
use std::sync::Arc;
use std::time::Duration;

use axum::body::Bytes;
use axum::extract::{FromRequest, Multipart, Path, Query, Request, State};
use axum::http::{header, StatusCode};
use axum::Json;
use serde::Serialize;

use super::error::ApiError;
use super::ogg_voice::decode_ogg_opus;
use super::recordings::RecordQuery;
use super::schedule::{self, Scheduled, ScheduledProducer};
use super::stream::ProducerPermit;
use super::AppState;
use crate::mask::Mask;
use crate::quote::quote;
use crate::stream::{FapReader, Frame, JsonlReader, StreamError};
use crate::voice::{read_ogg_opus, read_wav, Voice};
use facewire_proto::codes::EndReason;

#[derive(Debug, Serialize)]
pub struct BatchAccepted {
    pub frames: usize,
    /// From the first frame or audio sample to the last, s.
    pub duration_s: f64,
    /// The voice's length, s (0 without one).
    pub audio_s: f64,
    /// The recording the batch is kept as (`record=`), listed once it has played.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub recording: Option<String>,
}

/// The parts of a batch as they arrived, not yet read.
#[derive(Default)]
struct Upload {
    /// The parameter stream, and whether it is an MPEG-4 `.fap` file.
    stream: Option<(Bytes, bool)>,
    /// A WAV or Ogg Opus file.
    audio: Option<Bytes>,
    /// The stream time of the voice's first sample, s; by default the first frame's.
    audio_t_s: Option<f64>,
}

/// `POST /v1/heads/{id}/streams/{stream}/batch`.
pub async fn batch(
    State(state): State<AppState>,
    Path((id, name)): Path<(String, String)>,
    Query(record): Query<RecordQuery>,
    request: Request,
) -> Result<(StatusCode, Json<BatchAccepted>), ApiError> {
    let head = state.registry.head(&id)?;
    head.ready()?;
    let stream = head.stream(&name)?;
    let recorder = record.recorder(&head.recordings, &head.id, &name)?;
    let limit = state.config.limits.max_upload_bytes;
    let upload = read_upload(request, limit).await?;
    let limits = state.config.limits.clone();
    let mask = state.mask.clone();
    let (items, frames, audio_s) = tokio::task::spawn_blocking(move || {
        read_batch(
            upload,
            &mask,
            limits.max_batch_frames,
            limits.max_batch_duration_s,
        )
    })
    .await
    .map_err(ApiError::internal)??;
    let duration_s = match (items.first(), items.last()) {
        (Some(first), Some(last)) => last.t_s() - first.t_s(),
        _ => 0.0,
    };
    if duration_s.is_nan()
        || duration_s > limits.max_batch_duration_s
        || audio_s > limits.max_batch_duration_s
    {
        return Err(ApiError::TooLong {
            duration_s: duration_s.max(audio_s),
            limit_s: limits.max_batch_duration_s,
        });
    }
    let mut permit = state.claim_producer(&head.id, &stream).await?;
    let recording = recorder.map(|recorder| {
        let name = recorder.name().to_string();
        permit.record(recorder);
        name
    });
    let session = state.sessions.token();
    tokio::spawn(async move {
        play(state, head.deleted.clone(), permit, items).await;
        drop(session);
    });
    Ok((
        StatusCode::ACCEPTED,
        Json(BatchAccepted {
            frames,
            duration_s,
            audio_s,
            recording,
        }),
    ))
}

/// The body's parts: a multipart body's `stream`, `audio` and `audio_t_s`, or a plain body
/// as the stream (`.fap` when its `Content-Type` says so).
async fn read_upload(request: Request, limit: usize) -> Result<Upload, ApiError> {
    let content_type = |request: &Request| {
        request
            .headers()
            .get(header::CONTENT_TYPE)
            .and_then(|v| v.to_str().ok())
            .unwrap_or("")
            .to_ascii_lowercase()
    };
    let too_large_or = |status: StatusCode, text: String| match status {
        StatusCode::PAYLOAD_TOO_LARGE => ApiError::TooLarge { limit },
        _ => ApiError::BadRequest(text),
    };
    if !content_type(&request).starts_with("multipart/form-data") {
        let is_fap = content_type(&request).contains("fap");
        let body = Bytes::from_request(request, &())
            .await
            .map_err(|e| too_large_or(e.status(), e.body_text()))?;
        return Ok(Upload {
            stream: Some((body, is_fap)),
            ..Upload::default()
        });
    }
    let mut multipart = Multipart::from_request(request, &())
        .await
        .map_err(|e| too_large_or(e.status(), e.body_text()))?;
    let mut upload = Upload::default();
    while let Some(part) = multipart
        .next_field()
        .await
        .map_err(|e| too_large_or(e.status(), e.body_text()))?
    {
        let name = part.name().unwrap_or("").to_string();
        let is_fap = part.content_type().is_some_and(|t| t.contains("fap"))
            || part
                .file_name()
                .is_some_and(|f| f.to_ascii_lowercase().ends_with(".fap"));
        let bytes = part
            .bytes()
            .await
            .map_err(|e| too_large_or(e.status(), format!("part {}: {}", quote(&name), e.body_text())))?;
        let repeated = || ApiError::BadRequest(format!("part {} appears twice", quote(&name)));
        match name.as_str() {
            "stream" if upload.stream.is_none() => upload.stream = Some((bytes, is_fap)),
            "audio" if upload.audio.is_none() => upload.audio = Some(bytes),
            "audio_t_s" if upload.audio_t_s.is_none() => {
                let text = String::from_utf8_lossy(&bytes);
                // The range a producer's chunk is held to (`audio_gate`).
                let t_s = text
                    .trim()
                    .parse::<f64>()
                    .ok()
                    .filter(|t| (0.0..=crate::stream::MAX_TIME_S).contains(t));
                upload.audio_t_s = Some(t_s.ok_or_else(|| {
                    ApiError::BadRequest(format!(
                        "part \"audio_t_s\": {} is not a time in seconds from 0 to {}",
                        quote(text.trim()),
                        crate::stream::MAX_TIME_S
                    ))
                })?);
            }
            "stream" | "audio" | "audio_t_s" => return Err(repeated()),
            _ => {
                return Err(ApiError::BadRequest(format!(
                    "unknown part {}: a batch takes \"stream\", \"audio\" and \"audio_t_s\"",
                    quote(&name)
                )))
            }
        }
    }
    if upload.stream.is_none() && upload.audio.is_none() {
        return Err(ApiError::BadRequest(
            "a multipart batch needs a \"stream\" part, an \"audio\" part or both".into(),
        ));
    }
    if upload.audio.is_none() && upload.audio_t_s.is_some() {
        return Err(ApiError::BadRequest(
            "part \"audio_t_s\" without an \"audio\" part".into(),
        ));
    }
    Ok(upload)
}

/// The batch's schedule, its frame count and its voice's length (s), every frame and the
/// whole voice checked.
fn read_batch(
    upload: Upload,
    mask: &Mask,
    max_frames: usize,
    max_duration_s: f64,
) -> Result<(Vec<Scheduled>, usize, f64), ApiError> {
    let mut frames = Vec::new();
    if let Some((body, is_fap)) = upload.stream {
        let reader: Box<dyn Iterator<Item = Result<Frame, StreamError>>> = if is_fap {
            Box::new(FapReader::new(Cursor::new(body)).with_source_name("batch"))
        } else {
            Box::new(JsonlReader::new(Cursor::new(body), mask).with_source_name("batch"))
        };
        for frame in reader {
            let frame = frame.map_err(|e| ApiError::BadFrame(e.to_string()))?;
            if frames.len() >= max_frames {
                return Err(ApiError::TooManyFrames { limit: max_frames });
            }
            frames.push(frame);
        }
    }
    let (mut audio, mut audio_s) = (Vec::new(), 0.0);
    if let Some(file) = upload.audio {
        let voice = read_voice(&file, max_duration_s)?;
        let start = upload
            .audio_t_s
            .unwrap_or_else(|| frames.first().map_or(0.0, |f| f.time_s));
        audio_s = voice.duration_s();
        audio = voice.audio_chunks(start).collect();
    }
    let count = frames.len();
    Ok((schedule::merge(frames, audio), count, audio_s))
}

/// The voice in a batch's `audio` part: a WAV file, or an Ogg Opus file (by its first
/// bytes) no longer than `max_duration_s`, checked before it is decoded.
fn read_voice(file: &[u8], max_duration_s: f64) -> Result<Voice, ApiError> {
    const PART: &str = "part \"audio\"";
    if !file.starts_with(b"OggS") {
        return read_wav(Cursor::new(file), PART).map_err(|e| ApiError::BadFrame(e.to_string()));
    }
    let ogg = read_ogg_opus(file, PART).map_err(|e| ApiError::BadFrame(e.to_string()))?;
    if ogg.duration_s() > max_duration_s {
        return Err(ApiError::TooLong {
            duration_s: ogg.duration_s(),
            limit_s: max_duration_s,
        });
    }
    decode_ogg_opus(&ogg).map_err(|e| ApiError::BadFrame(format!("{PART}: {e}")))
}

/// Plays `items` at their timestamps (relative to the first), then ends the stream.
async fn play(
    state: AppState,
    deleted: tokio_util::sync::CancellationToken,
    permit: ProducerPermit,
    items: Vec<Scheduled>,
) {
    state.telemetry.producers.inc();
    let start = tokio::time::Instant::now();
    let first = items.first().map_or(0.0, Scheduled::t_s);
    let mut producer = ScheduledProducer::new(permit);
    let mut ending = EndReason::BatchFinished;
    for item in items {
        // Bounded by `max_batch_duration_s`, checked before playing.
        let offset = Duration::try_from_secs_f64((item.t_s() - first).max(0.0)).unwrap_or(Duration::ZERO);
        tokio::select! {
            _ = state.shutdown.cancelled() => { ending = EndReason::ServerShutdown; break }
            _ = deleted.cancelled() => { ending = EndReason::HeadDeleted; break }
            _ = producer.permit.cancelled() => { ending = EndReason::ProducerCancelled; break }
            _ = tokio::time::sleep_until(start + offset) => {}
        }
        producer.publish(item, &state.telemetry);
    }
    if ending == EndReason::BatchFinished {
        producer.finish(&state.telemetry);
    }
    producer.permit.end(ending);
    state.telemetry.producers.dec();
}

/// How long a cancel waits for the producer to give the stream back before answering.
const CANCEL_PATIENCE: Duration = Duration::from_secs(1);

/// `DELETE /v1/heads/{id}/streams/{stream}/producer`: cancels the stream's producer and
/// answers once it has given the stream back (or after [`CANCEL_PATIENCE`]), so that a
/// new producer or batch can start as soon as the answer arrives.
pub async fn cancel_producer(
    State(state): State<AppState>,
    Path((id, name)): Path<(String, String)>,
) -> Result<StatusCode, ApiError> {
    let head = state.registry.head(&id)?;
    let no_producer = || ApiError::NoProducer {
        head: id.clone(),
        stream: name.clone(),
    };
    let stream: Arc<_> = head.existing_stream(&name).ok_or_else(no_producer)?;
    if stream.cancel_producer(CANCEL_PATIENCE).await {
        Ok(StatusCode::NO_CONTENT)
    } else {
        Err(no_producer())
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::server::frames::ParamTimeline;
    use crate::server::stream::Stream;
    use crate::server::timeline::Step;
    use crate::server::Config;

    /// The newest producer seq the stream's viewers would see, and whether it has ended.
    fn seen(params: &tokio::sync::watch::Receiver<ParamTimeline>) -> (Option<u64>, Option<EndReason>) {
        let (mut seq, mut end) = (None, None);
        for step in params.borrow().steps_after(0) {
            match step {
                Step::Frame(f) => seq = Some(f.value.frame.seq),
                Step::End { reason, .. } => end = Some(reason),
            }
        }
        (seq, end)
    }

    fn memory_state() -> AppState {
        AppState::new(Config {
            data_dir: None,
            ..Config::default()
        })
        .unwrap()
    }

    #[tokio::test(start_paused = true)]
    async fn a_batch_plays_at_its_timestamps_then_ends() {
        let state = memory_state();
        let stream = Arc::new(Stream::new("s"));
        let params = stream.subscribe();
        let permit = stream.claim_producer().unwrap();
        // Timestamps count from the first frame: 0, 0.5 and 2 s into the batch.
        let frames = schedule::merge(
            vec![Frame::at(0, 10.0), Frame::at(1, 10.5), Frame::at(2, 12.0)],
            Vec::new(),
        );
        let deleted = tokio_util::sync::CancellationToken::new();
        let playing = tokio::spawn(play(state, deleted, permit, frames));
        let step = Duration::from_millis(10);
        tokio::time::sleep(step).await;
        assert_eq!(seen(&params), (Some(0), None));
        tokio::time::sleep(Duration::from_millis(480)).await;
        assert_eq!(seen(&params), (Some(0), None), "seq 1 is due at 0.5 s");
        tokio::time::sleep(step * 2).await;
        assert_eq!(seen(&params), (Some(1), None));
        tokio::time::sleep(Duration::from_millis(1480)).await;
        assert_eq!(seen(&params), (Some(1), None), "seq 2 is due at 2 s");
        tokio::time::sleep(step * 2).await;
        assert_eq!(seen(&params), (Some(2), Some(EndReason::BatchFinished)));
        playing.await.unwrap();
        assert!(!stream.has_producer(), "the slot is free again");
    }

    #[tokio::test(start_paused = true)]
    async fn a_cancelled_batch_ends_at_once() {
        let state = memory_state();
        let stream = Arc::new(Stream::new("s"));
        let params = stream.subscribe();
        let permit = stream.claim_producer().unwrap();
        let frames = schedule::merge((0..100).map(|i| Frame::at(i, i as f64)).collect(), Vec::new());
        let playing = tokio::spawn(play(
            state,
            tokio_util::sync::CancellationToken::new(),
            permit,
            frames,
        ));
        tokio::time::sleep(Duration::from_millis(2500)).await;
        assert!(stream.cancel_producer(Duration::from_secs(1)).await);
        playing.await.unwrap();
        assert_eq!(seen(&params), (Some(2), Some(EndReason::ProducerCancelled)));
    }
}
