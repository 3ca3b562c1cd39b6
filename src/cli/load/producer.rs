//! One load producer: the syllable stream, looped, on one stream's producer WebSocket at a
//! steady frame rate, and with a voice its 20 ms PCM chunks (looped too) on the same clock,
//! each send time recorded for the viewers, then `end`. A deriving producer sends the
//! voice alone and the server makes the frames: each frame's send time is that of the
//! chunk holding its instant.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use futures_util::{SinkExt, StreamExt};
use tokio::time::Instant;
use tokio_tungstenite::tungstenite::Message;

use super::send_times::SendTimes;
use crate::voice::{Voice, CHUNK_S};
use facewire_proto::audio_chunk::{AudioBody, AudioChunk};
use facewire_proto::messages::ServerMessage;

/// The voice a producer sends with its frames, and when it sent each chunk (by index).
pub struct VoicePlan {
    pub voice: Arc<Voice>,
    pub times: Arc<SendTimes>,
    /// Chunks sent by every producer.
    pub sent: Arc<AtomicU64>,
}

pub struct ProducerPlan {
    pub url: String,
    /// The stream's frames as JSON objects, replayed in a loop with new `seq` and `t`.
    pub frames: Arc<Vec<serde_json::Value>>,
    pub fps: f64,
    /// Frames to send (or, deriving, to span with the voice).
    pub count: u64,
    /// Only the voice is sent (`derive=visemes`); the frames are the server's.
    pub derive: bool,
    /// When to send frame 0.
    pub start: Instant,
    pub times: Arc<SendTimes>,
    /// Frames sent by every producer, for the progress line.
    pub sent: Arc<AtomicU64>,
    pub voice: Option<VoicePlan>,
}

/// What a producer sent.
#[derive(Debug, Default, Clone, Copy)]
pub struct Sent {
    pub frames: u64,
    pub chunks: u64,
}

/// What was sent, or why the producer stopped.
pub async fn produce(plan: ProducerPlan) -> Result<Sent, String> {
    // Without Nagle: an audio chunk the server does not answer would otherwise hold the
    // next frame back until its ACK, delayed up to 40 ms by the server's kernel.
    let (socket, _) = tokio_tungstenite::connect_async_with_config(plan.url.as_str(), None, true)
        .await
        .map_err(|e| format!("cannot connect: {e}"))?;
    let (mut tx, mut rx) = socket.split();
    // Acks and refusals: the first refusal is the producer's failure.
    let refusals = tokio::spawn(async move {
        while let Some(Ok(message)) = rx.next().await {
            let Message::Text(text) = message else { continue };
            if let Ok(ServerMessage::Error { code, message, .. }) = serde_json::from_str(text.as_str()) {
                return Some(format!("{code}: {message}"));
            }
        }
        None
    });
    // The voice's chunks, looped, over the frames' span.
    let voice_chunks: Vec<&[i16]> = plan
        .voice
        .as_ref()
        .map_or(Vec::new(), |v| v.voice.chunks(CHUNK_S).map(|(_, c)| c).collect());
    let chunk_count = match voice_chunks.is_empty() {
        true => 0,
        false => (plan.count as f64 / plan.fps / CHUNK_S).floor() as u64,
    };
    let mut sent = Sent::default();
    // Deriving, no frame is sent: `seq` only counts the server's frames already covered.
    let frames_to_send = if plan.derive { 0 } else { plan.count };
    let (mut seq, mut k) = (0u64, 0u64);
    let mut derived = 0u64;
    while seq < frames_to_send || k < chunk_count {
        let frame_t = seq as f64 / plan.fps;
        let chunk_t = k as f64 * CHUNK_S;
        let is_frame = seq < frames_to_send && (k >= chunk_count || frame_t <= chunk_t);
        let t = if is_frame { frame_t } else { chunk_t };
        tokio::time::sleep_until(plan.start + Duration::from_secs_f64(t)).await;
        if refusals.is_finished() {
            break;
        }
        if is_frame {
            let mut frame = plan.frames[seq as usize % plan.frames.len()].clone();
            frame["seq"] = seq.into();
            frame["t"] = frame_t.into();
            plan.times.sent(seq);
            tx.send(Message::Text(frame.to_string().into()))
                .await
                .map_err(|e| format!("sending frame {seq}: {e}"))?;
            plan.sent.fetch_add(1, Ordering::Relaxed);
            sent.frames += 1;
            seq += 1;
        } else if let Some(voice) = &plan.voice {
            let chunk = AudioChunk {
                t_s: chunk_t,
                server_receive_us: 0,
                body: AudioBody::Pcm {
                    sample_rate: voice.voice.sample_rate,
                    samples: voice_chunks[k as usize % voice_chunks.len()].to_vec(),
                },
                ignored: Vec::new(),
            };
            voice.times.sent(k);
            if plan.derive {
                // The server's frames whose instants this chunk holds.
                while (derived as f64 / plan.fps) < chunk_t + CHUNK_S && derived < plan.count {
                    plan.times.sent(derived);
                    plan.sent.fetch_add(1, Ordering::Relaxed);
                    sent.frames += 1;
                    derived += 1;
                }
            }
            tx.send(Message::Binary(chunk.encode().into()))
                .await
                .map_err(|e| format!("sending audio chunk {k}: {e}"))?;
            voice.sent.fetch_add(1, Ordering::Relaxed);
            sent.chunks += 1;
            k += 1;
        }
    }
    let _ = tx.send(Message::Text(r#"{"type":"end"}"#.into())).await;
    match tokio::time::timeout(Duration::from_secs(5), refusals).await {
        Ok(Ok(Some(refusal))) => Err(format!("refused: {refusal}")),
        _ => Ok(sent),
    }
}
