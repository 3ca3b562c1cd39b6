//! The demo's built-in producer: loops the recorded syllable stream on a stream of the
//! given heads, as a producer would, so `facewire demo` shows talking heads at once.

use std::time::Duration;

use super::ingest::publish_frame;
use super::AppState;
use crate::stream::{syllables, Frame};

/// Shipped heads the demo registers: (id, OBJ, fit).
pub const DEMO_HEADS: [(&str, &[u8], &str); 2] = [
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
];

/// Plays the syllable stream on `stream` of every head in `heads`, forever (until
/// shutdown), with sequence numbers and timestamps that keep increasing across loops.
pub async fn loop_syllables(state: AppState, heads: Vec<String>, stream: String) {
    let frames: Vec<Frame> = syllables::generate(syllables::SHIPPED_FPS).expect("the shipped fps is valid");
    let period = frames.last().map_or(1.0, |f| f.time_s) + 1.0 / syllables::SHIPPED_FPS;
    let producer = state.next_id();
    // Wait for registration, then hold the producer slot of each stream.
    let mut targets = Vec::new();
    for id in &heads {
        let Some(entry) = state.registry.get(id) else {
            continue;
        };
        let ready = loop {
            if let Some(ready) = entry.ready() {
                break ready;
            }
            tokio::select! {
                _ = state.shutdown.cancelled() => return,
                _ = tokio::time::sleep(Duration::from_millis(50)) => {}
            }
        };
        let channel = entry.channel(&stream);
        if channel.claim_producer(producer) {
            targets.push((ready, channel));
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
            for (ready, channel) in &targets {
                publish_frame(&state, ready, channel, looped.clone(), super::now_us());
            }
        }
    }
}
