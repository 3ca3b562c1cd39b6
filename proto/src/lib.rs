//! facewire's wire protocol: the message types that the server, the CLI clients and the
//! tests share, so that all of them agree on every field and byte. `PROTOCOL.md` beside
//! this crate describes the same messages for clients written in other languages.
//!
//! - [`codes`]: error codes, WebSocket close codes and end-of-stream reasons.
//! - [`messages`]: JSON control messages (snapshots, acks, errors, end of stream).
//! - [`viewer_frame`]: the binary per-frame message a viewer receives (quantized vertex
//!   deltas, motions, roughness), in the sectioned `FWF2` layout or the frozen `FWF1`.
//! - [`param_frame`]: the binary per-frame message a producer may send instead of JSON,
//!   `FWP2` or the frozen `FWP1`.
//! - [`mesh`]: the binary rest mesh a viewer downloads once.
//! - [`vertex_weights`]: a weight per vertex of a mesh (`FWL1`): where the rest mesh's lips
//!   are, which of a tongue part's vertices are the tongue itself, for drawing each in its
//!   own colour.
//! - [`texture_coords`]: where the rest mesh sits on its texture (`FWU1`), for drawing it.
//! - [`audio_chunk`]: a piece of a stream's voice on its timeline (`FWA1`), from producers
//!   and to viewers.
//!
//! Inside: [`Reader`] and `Writer` (little-endian fields), `sections` (the kind-length-body
//! framing both sectioned layouts share), `delta_block` (the quantized delta codec) and
//! `varint`.

pub mod audio_chunk;
pub mod codes;
mod delta_block;
pub mod mesh;
pub mod messages;
pub mod param_frame;
mod reader;
mod sections;
pub mod texture_coords;
mod varint;
pub mod vertex_weights;
pub mod viewer_frame;
mod writer;

pub(crate) use reader::Reader;
pub(crate) use writer::Writer;

/// The protocol version, the first segment of every HTTP and WebSocket path (`/v1/...`).
pub const PROTOCOL_VERSION: &str = "v1";

/// Errors decoding a binary message: what is wrong and at which byte.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum DecodeError {
    #[error("message too short: {field} needs bytes {at}..{end}, the message has {len}")]
    Truncated {
        field: &'static str,
        at: usize,
        end: usize,
        len: usize,
    },
    #[error("bad magic {}: expected {expected}", String::from_utf8_lossy(found))]
    Magic { found: [u8; 4], expected: &'static str },
    #[error("byte {at}: {field}: {problem}")]
    Invalid {
        field: &'static str,
        at: usize,
        problem: String,
    },
    #[error("{extra} unexpected byte(s) after the message")]
    Trailing { extra: usize },
}

impl DecodeError {
    /// The field of the layout that is wrong (`flags`, `au weight`, `delta block`), as
    /// PROTOCOL.md names it; `None` for a bad magic or bytes after the message.
    pub fn field(&self) -> Option<&'static str> {
        match self {
            DecodeError::Truncated { field, .. } | DecodeError::Invalid { field, .. } => Some(field),
            DecodeError::Magic { .. } | DecodeError::Trailing { .. } => None,
        }
    }
}
