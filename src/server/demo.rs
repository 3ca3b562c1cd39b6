//! The demo's built-in producer: loops the recorded syllable stream and its voice on a
//! stream of the given heads, as a producer would, so `facewire demo` shows talking heads
//! at once and viewers who ask for audio hear them.

use std::time::Duration;

use super::error::ApiError;
use super::recorded_voice::RecordedVoice;
use super::schedule::{self, Scheduled, ScheduledProducer};
use super::store::{HeadMeta, HeadRecord, PartRecord};
use super::AppState;
use crate::head::PartRole;
use crate::stream::{syllables, Frame, IdleEyes};
use crate::voice::syllable_voice;

/// A shipped head the demo registers.
pub struct DemoHead {
    pub id: &'static str,
    pub obj: &'static [u8],
    pub fit: &'static str,
    /// (name, role or `None` to infer it, OBJ).
    pub parts: &'static [(&'static str, Option<PartRole>, &'static [u8])],
}

pub const DEMO_HEADS: [DemoHead; 3] = [
    DemoHead {
        id: "scan",
        obj: include_bytes!("../../data/heads/lee_perry_smith_head.obj"),
        fit: include_str!("../../data/heads/lee_perry_smith_head.fit.toml"),
        parts: &[],
    },
    DemoHead {
        id: "makehuman",
        obj: include_bytes!("../../data/heads/makehuman_head.obj"),
        fit: include_str!("../../data/heads/makehuman_head.fit.toml"),
        parts: &[],
    },
    DemoHead {
        id: "ict",
        obj: include_bytes!("../../data/heads/ict_head.obj"),
        fit: include_str!("../../data/heads/ict_head.fit.toml"),
        // Teeth and gums find their roles (skull or jaw) themselves; a tongue and eyes are named.
        parts: &[
            (
                "teeth_upper",
                None,
                include_bytes!("../../data/heads/ict_head_teeth_upper.obj"),
            ),
            (
                "teeth_lower",
                None,
                include_bytes!("../../data/heads/ict_head_teeth_lower.obj"),
            ),
            (
                "gums_upper",
                None,
                include_bytes!("../../data/heads/ict_head_gums_upper.obj"),
            ),
            (
                "gums_lower_tongue",
                Some(PartRole::Tongue),
                include_bytes!("../../data/heads/ict_head_gums_lower_tongue.obj"),
            ),
            (
                "eyes",
                Some(PartRole::Eyes),
                include_bytes!("../../data/heads/ict_head_eyes.obj"),
            ),
        ],
    },
];

/// Registers the demo heads (in memory) from the embedded files.
pub async fn register_heads(state: &AppState) -> Result<(), ApiError> {
    for head in DEMO_HEADS {
        let slot = state.registry.registration_slot(Duration::MAX).await?;
        let record = HeadRecord {
            id: head.id.to_string(),
            obj: head.obj.to_vec(),
            fit_toml: head.fit.to_string(),
            parts: head
                .parts
                .iter()
                .map(|&(name, role, obj)| PartRecord {
                    name: name.to_string(),
                    role,
                    obj: obj.to_vec(),
                })
                .collect(),
            texture: None,
            arkit_basis: None,
            meta: HeadMeta::default(),
        };
        state.registry.register(record, false, slot).await?;
    }
    Ok(())
}

/// The name of the recording of one round of the syllables each demo head holds.
pub const SYLLABLES_RECORDING: &str = "syllables";

/// The demo face's blinks and glances, over the syllables.
const DEMO_EYES: IdleEyes = IdleEyes { seed: 1 };

/// Plays the syllable stream and its voice on `stream` of every head in `heads`, forever
/// (until shutdown), with sequence numbers and timestamps that keep increasing across
/// loops, the eyes blinking and glancing ([`IdleEyes`]) as they do not in the file. Each
/// round lasts the 27 syllables' slots; the last frame (at rest, as the first) is the next
/// round's first. Each head also keeps one round, with its voice, as its recording
/// [`SYLLABLES_RECORDING`], for replay.
pub async fn loop_syllables(state: AppState, heads: Vec<String>, stream: String) {
    let frames: Vec<Frame> = syllables::generate(syllables::SHIPPED_FPS).expect("the shipped fps is valid");
    let voice = syllable_voice().expect("the shipped voice reads");
    let period = syllables::SYLLABLE_S * syllables::SYLLABLES.len() as f64;
    let frames: Vec<Frame> = frames.into_iter().filter(|f| f.time_s < period - 1e-9).collect();
    // One round, as each head's recording `syllables`, for replay.
    let recorded: Vec<Frame> = frames
        .iter()
        .cloned()
        .map(|mut frame| {
            DEMO_EYES.add_to(frame.time_s, &mut frame.arkit);
            frame
        })
        .collect();
    let recorded_voice = RecordedVoice {
        start_t_s: 0.0,
        voice: voice.between(0.0, period),
    };
    let round = schedule::merge(frames, voice.audio_chunks(0.0).collect());
    // Wait for registration, then hold the producer slot of each stream.
    let mut producers: Vec<ScheduledProducer> = Vec::new();
    for id in &heads {
        let Some(entry) = state.registry.get(id) else {
            continue;
        };
        tokio::select! {
            _ = state.shutdown.cancelled() => return,
            ready = entry.wait_ready(Duration::MAX) => if ready.is_err() { continue },
        }
        entry.recordings.keep(
            SYLLABLES_RECORDING,
            &stream,
            recorded.clone(),
            Some(recorded_voice.clone()),
        );
        if let Some(permit) = entry.stream(&stream).ok().and_then(|s| s.claim_producer()) {
            producers.push(ScheduledProducer::new(permit));
        }
    }
    let start = tokio::time::Instant::now();
    let mut seq = 0u64;
    for number in 0u64.. {
        let offset = number as f64 * period;
        // Frames and chunks in time order, each sent when its `t` comes.
        for item in &round {
            let mut item = item.clone();
            item.shift(offset);
            tokio::select! {
                _ = state.shutdown.cancelled() => return,
                _ = tokio::time::sleep_until(start + Duration::from_secs_f64(item.t_s())) => {}
            }
            if let Scheduled::Frame(frame) = &mut item {
                frame.seq = seq;
                seq += 1;
                DEMO_EYES.add_to(frame.time_s, &mut frame.arkit);
            }
            for producer in &mut producers {
                producer.publish(item.clone(), &state.telemetry);
            }
        }
    }
}
