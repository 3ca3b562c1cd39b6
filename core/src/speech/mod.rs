//! Speech to animation: the mouth derived from a voice alone. 16 kHz samples become
//! log-mel frames ([`log_mel`]), a small learned model ([`model`]) and a causal decoder
//! ([`tracker`]) turn them into one of the 15 MPEG-4 (Oculus) visemes every 10 ms with a
//! bounded look-ahead, and [`frames`] holds each viseme as FAP 1 in the stream's frames,
//! so a voice drives a head exactly as a parameter producer would; [`live`] does it all
//! for a voice that arrives in chunks on a stream's clock. docs/SPEECH.md is the
//! model card: the features, the training data, the figures on held-out voices.
//!
//! Plain synchronous Rust, as the rest of the core.

pub mod frames;
pub mod live;
pub mod log_mel;
pub mod model;
pub mod resample;
pub mod tracker;

pub use frames::VisemeFrames;
pub use live::{speech_frames, SpeechError, SpeechEvent, SpeechStream};
pub use model::{ModelError, VisemeModel};
pub use tracker::{Decision, VisemeTracker};
