//! One load producer: the syllable stream, looped, on one stream's producer WebSocket at a
//! steady frame rate, each send time recorded for the viewers, then `end`.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use futures_util::{SinkExt, StreamExt};
use tokio::time::Instant;
use tokio_tungstenite::tungstenite::Message;

use super::send_times::SendTimes;
use facewire_proto::messages::ServerMessage;

pub struct ProducerPlan {
    pub url: String,
    /// The stream's frames as JSON objects, replayed in a loop with new `seq` and `t`.
    pub frames: Arc<Vec<serde_json::Value>>,
    pub fps: f64,
    /// Frames to send.
    pub count: u64,
    /// When to send frame 0.
    pub start: Instant,
    pub times: Arc<SendTimes>,
    /// Frames sent by every producer, for the progress line.
    pub sent: Arc<AtomicU64>,
}

/// Frames sent, or why the producer stopped.
pub async fn produce(plan: ProducerPlan) -> Result<u64, String> {
    let (socket, _) = tokio_tungstenite::connect_async(plan.url.as_str())
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
    let mut sent = 0;
    for seq in 0..plan.count {
        tokio::time::sleep_until(plan.start + Duration::from_secs_f64(seq as f64 / plan.fps)).await;
        if refusals.is_finished() {
            break;
        }
        let mut frame = plan.frames[seq as usize % plan.frames.len()].clone();
        frame["seq"] = seq.into();
        frame["t"] = (seq as f64 / plan.fps).into();
        plan.times.sent(seq);
        tx.send(Message::Text(frame.to_string().into()))
            .await
            .map_err(|e| format!("sending frame {seq}: {e}"))?;
        plan.sent.fetch_add(1, Ordering::Relaxed);
        sent += 1;
    }
    let _ = tx.send(Message::Text(r#"{"type":"end"}"#.into())).await;
    match tokio::time::timeout(Duration::from_secs(5), refusals).await {
        Ok(Ok(Some(refusal))) => Err(format!("refused: {refusal}")),
        _ => Ok(sent),
    }
}
