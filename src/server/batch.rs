//! HTTP batches: a whole JSONL or `.fap` stream in one body, validated up front (errors
//! name the line and field), then played at its timestamps as the stream's producer. A
//! batch is bounded in frames and in duration, and `DELETE .../producer` cancels it (or a
//! socket producer) at once; viewers get `end` with the reason either way.

use std::io::Cursor;
use std::sync::Arc;
use std::time::Duration;

use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::{Path, State};
use axum::http::{HeaderMap, StatusCode};
use axum::Json;
use serde::Serialize;

use super::error::ApiError;
use super::stream::ProducerPermit;
use super::{now_us, AppState};
use crate::stream::{FapReader, Frame, JsonlReader, StreamError};
use facewire_proto::codes::EndReason;

#[derive(Debug, Serialize)]
pub struct BatchAccepted {
    pub frames: usize,
    pub duration_s: f64,
}

/// `POST /v1/heads/{id}/streams/{stream}/batch`.
pub async fn batch(
    State(state): State<AppState>,
    Path((id, name)): Path<(String, String)>,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> Result<(StatusCode, Json<BatchAccepted>), ApiError> {
    let body = body.map_err(|e| match e.status() {
        StatusCode::PAYLOAD_TOO_LARGE => ApiError::TooLarge {
            limit: state.config.limits.max_upload_bytes,
        },
        _ => ApiError::BadRequest(e.body_text()),
    })?;
    let head = state.registry.head(&id)?;
    head.ready()?;
    let stream = head.stream(&name)?;
    let is_fap = headers
        .get(axum::http::header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.contains("fap"));
    let limits = state.config.limits.clone();
    let mask = state.mask.clone();
    let frames =
        tokio::task::spawn_blocking(move || read_batch(body, is_fap, &mask, limits.max_batch_frames))
            .await
            .map_err(ApiError::internal)??;
    let first = frames.first().map_or(0.0, |f| f.time_s);
    let duration_s = frames.last().map_or(0.0, |f| f.time_s) - first;
    if duration_s.is_nan() || duration_s > limits.max_batch_duration_s {
        return Err(ApiError::TooLong {
            duration_s,
            limit_s: limits.max_batch_duration_s,
        });
    }
    let permit = state.claim_producer(&head.id, &stream).await?;
    let count = frames.len();
    let session = state.sessions.token();
    tokio::spawn(async move {
        play(state, head.deleted.clone(), permit, frames).await;
        drop(session);
    });
    Ok((
        StatusCode::ACCEPTED,
        Json(BatchAccepted {
            frames: count,
            duration_s,
        }),
    ))
}

fn read_batch(
    body: Bytes,
    is_fap: bool,
    mask: &crate::mask::Mask,
    max_frames: usize,
) -> Result<Vec<Frame>, ApiError> {
    let reader: Box<dyn Iterator<Item = Result<Frame, StreamError>>> = if is_fap {
        Box::new(FapReader::new(Cursor::new(body)).with_source_name("batch"))
    } else {
        Box::new(JsonlReader::new(Cursor::new(body), mask).with_source_name("batch"))
    };
    let mut frames = Vec::new();
    for frame in reader {
        let frame = frame.map_err(|e| ApiError::BadFrame(e.to_string()))?;
        if frames.len() >= max_frames {
            return Err(ApiError::TooManyFrames { limit: max_frames });
        }
        frames.push(frame);
    }
    Ok(frames)
}

/// Plays `frames` at their timestamps (relative to the first), then ends the stream.
async fn play(
    state: AppState,
    deleted: tokio_util::sync::CancellationToken,
    permit: ProducerPermit,
    frames: Vec<Frame>,
) {
    state.telemetry.producers.inc();
    let start = tokio::time::Instant::now();
    let first = frames.first().map_or(0.0, |f| f.time_s);
    let mut ending = EndReason::BatchFinished;
    for frame in frames {
        // Bounded by `max_batch_duration_s`, checked before playing.
        let offset = Duration::try_from_secs_f64((frame.time_s - first).max(0.0)).unwrap_or(Duration::ZERO);
        tokio::select! {
            _ = state.shutdown.cancelled() => { ending = EndReason::ServerShutdown; break }
            _ = deleted.cancelled() => { ending = EndReason::HeadDeleted; break }
            _ = permit.cancelled() => { ending = EndReason::ProducerCancelled; break }
            _ = tokio::time::sleep_until(start + offset) => {}
        }
        permit.publish(frame, now_us());
        state.telemetry.frames_in.inc();
    }
    permit.end(ending);
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
    use crate::server::stream::{ParamTimeline, Stream};
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
        let frames = vec![Frame::at(0, 10.0), Frame::at(1, 10.5), Frame::at(2, 12.0)];
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
        let frames = (0..100).map(|i| Frame::at(i, i as f64)).collect();
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
