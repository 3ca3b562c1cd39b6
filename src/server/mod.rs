//! The facewire service: a thin tokio/axum layer over the geometry core. Heads are
//! registered over HTTP, producers push parameter frames over WebSocket (or HTTP batches),
//! every (stream, algorithm) with viewers runs the core's per-frame job once per frame, and
//! viewers get encoded frames over WebSocket, latest-frame-wins. `proto/PROTOCOL.md`
//! documents every endpoint, code and byte; `docs/ARCHITECTURE.md` draws the data path
//! and who owns what.
//!
//! - Connections and shutdown: [`listen`]; routes: [`app`]; who may do what: [`auth`].
//! - Heads: [`registry`], [`head`], [`registration`], [`bindings`], [`store`],
//!   [`head_store`], [`heads`] (their HTTP resources).
//! - Several nodes: [`cluster`] (NATS: frames between nodes, shared heads, leases).
//! - Streams: [`stream`] (producer slot, pipelines), [`timeline`] (latest-frame-wins with
//!   ends), [`pipeline`] (the per-frame job per algorithm).
//! - Sockets: [`producer`], [`ingest`] (messages to frames), [`rate`], [`batch`],
//!   [`view`], [`socket`]; [`speech_producer`] (a face derived from a producer's voice).

mod app;
mod audio_gate;
mod auth;
mod batch;
mod bindings;
mod bus_url;
mod cluster;
pub mod config;
pub mod demo;
mod error;
mod follow;
mod frames;
mod glb_upload;
mod head;
mod head_store;
mod heads;
mod ids;
mod ingest;
mod listen;
mod ogg_voice;
mod ops;
mod opus_decode;
mod opus_encode;
mod pipeline;
pub mod process;
mod producer;
mod rate;
mod recorded_voice;
mod recording_shelf;
mod recordings;
mod registration;
mod registry;
mod replay;
mod replay_voice;
mod schedule;
mod socket;
mod speech_producer;
mod state;
mod store;
mod stream;
mod telemetry;
mod texture_image;
mod timeline;
mod transcode;
mod trim;
mod view;
mod web;

pub use app::app;
pub use config::{Config, ConfigError};
pub use error::ApiError;
pub use ids::valid_id;
pub use listen::serve;
pub use state::{AppState, StateError};
pub use telemetry::Telemetry;

/// Microseconds since the Unix epoch: the clock every timestamp on the wire uses.
pub fn now_us() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_micros() as u64)
}
