//! What a stream carries between its producer and its pipelines, viewers and relays: a
//! parameter frame as the server received it, the timeline of them, and an audio chunk as
//! every viewer of its codec receives it. Types only, so that the stream, its pipelines
//! and the cluster's relay share them without importing one another.

use axum::body::Bytes;
use facewire_proto::audio_chunk::AudioChunk;

use super::timeline::Timeline;
use crate::stream::Frame;

/// A producer's frame as the server received it.
#[derive(Debug)]
pub struct ReceivedFrame {
    pub frame: Frame,
    /// µs since the Unix epoch.
    pub received_us: u64,
}

pub type ParamTimeline = Timeline<ReceivedFrame>;

/// A producer's audio chunk as viewers receive it, encoded once for all of them.
#[derive(Debug, Clone)]
pub struct RelayedAudio {
    /// `pcm` or `opus`, as a viewer's `audio=` names it.
    pub codec: &'static str,
    /// The `FWA1` message, stamped with the server's receipt: cloning it shares the bytes.
    pub bytes: Bytes,
}

impl RelayedAudio {
    /// `chunk` as every viewer of its codec gets it, encoded once.
    pub fn of(chunk: &AudioChunk) -> RelayedAudio {
        RelayedAudio {
            codec: chunk.body.codec(),
            bytes: chunk.encode().into(),
        }
    }
}
