//! The demo's built-in producer: loops the recorded syllable stream on a stream of the
//! given heads, as a producer would, so `facewire demo` shows talking heads at once.

use std::time::Duration;

use super::error::ApiError;
use super::store::{HeadMeta, HeadRecord};
use super::AppState;
use crate::stream::{syllables, Frame};

/// Shipped heads the demo registers: (id, OBJ, fit).
pub const DEMO_HEADS: [(&str, &[u8], &str); 3] = [
    (
        "scan",
        include_bytes!("../../data/heads/lee_perry_smith_head.obj"),
        include_str!("../../data/heads/lee_perry_smith_head.fit.toml"),
    ),
    (
        "makehuman",
        include_bytes!("../../data/heads/makehuman_head.obj"),
        include_str!("../../data/heads/makehuman_head.fit.toml"),
    ),
    (
        "ict",
        include_bytes!("../../data/heads/ict_head.obj"),
        include_str!("../../data/heads/ict_head.fit.toml"),
    ),
];

/// Registers the demo heads (in memory) from the embedded files.
pub async fn register_heads(state: &AppState) -> Result<(), ApiError> {
    for (id, obj, fit) in DEMO_HEADS {
        let slot = state.registry.registration_slot(Duration::MAX).await?;
        let record = HeadRecord {
            id: id.to_string(),
            obj: obj.to_vec(),
            fit_toml: fit.to_string(),
            meta: HeadMeta::default(),
        };
        state.registry.register(record, false, slot).await?;
    }
    Ok(())
}

/// Plays the syllable stream on `stream` of every head in `heads`, forever (until
/// shutdown), with sequence numbers and timestamps that keep increasing across loops.
pub async fn loop_syllables(state: AppState, heads: Vec<String>, stream: String) {
    let frames: Vec<Frame> = syllables::generate(syllables::SHIPPED_FPS).expect("the shipped fps is valid");
    let period = frames.last().map_or(1.0, |f| f.time_s) + 1.0 / syllables::SHIPPED_FPS;
    // Wait for registration, then hold the producer slot of each stream.
    let mut producers = Vec::new();
    for id in &heads {
        let Some(entry) = state.registry.get(id) else {
            continue;
        };
        tokio::select! {
            _ = state.shutdown.cancelled() => return,
            ready = entry.wait_ready(Duration::MAX) => if ready.is_err() { continue },
        }
        if let Some(permit) = entry.stream(&stream).ok().and_then(|s| s.claim_producer()) {
            producers.push(permit);
        }
    }
    let start = tokio::time::Instant::now();
    let mut seq = 0u64;
    for round in 0u64.. {
        for frame in &frames {
            let t = round as f64 * period + frame.time_s;
            tokio::select! {
                _ = state.shutdown.cancelled() => return,
                _ = tokio::time::sleep_until(start + Duration::from_secs_f64(t)) => {}
            }
            let mut looped = frame.clone();
            looped.seq = seq;
            looped.time_s = t;
            seq += 1;
            for permit in &producers {
                permit.publish(looped.clone(), super::now_us());
            }
        }
    }
}
