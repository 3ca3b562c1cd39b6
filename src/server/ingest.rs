//! Producer messages turned into frames: JSON text (one line of facewire's JSONL) or binary
//! `FWP2` or `FWP1`, all validated by the core's frame checks, and every refusal named by code,
//! field and sequence number, the same whichever format the frame came in.

use crate::mask::Mask;
use crate::stream::{Frame, StreamError};
use facewire_proto::audio_chunk::AudioChunk;
use facewire_proto::codes::ErrorCode;
use facewire_proto::messages::{ProducerMessage, ServerMessage};
use facewire_proto::param_frame::ParamFrame;

use super::frames::RelayedAudio;

/// A refused producer message: machine code, field (when known), message for people,
/// and the refused frame's sequence number once it was parsed far enough to have one.
#[derive(Debug)]
pub struct Refusal {
    pub code: ErrorCode,
    pub field: Option<String>,
    pub message: String,
    pub seq: Option<u64>,
}

impl Refusal {
    pub fn new(code: ErrorCode, field: Option<&str>, message: impl Into<String>) -> Refusal {
        Refusal {
            code,
            field: field.map(str::to_string),
            message: message.into(),
            seq: None,
        }
    }

    pub fn with_seq(self, seq: u64) -> Refusal {
        Refusal {
            seq: Some(seq),
            ..self
        }
    }

    pub fn message(self) -> ServerMessage {
        ServerMessage::Error {
            code: self.code,
            message: self.message,
            seq: self.seq,
            field: self.field,
        }
    }
}

/// What a producer message asks for.
pub enum Incoming {
    /// A frame, with the section kinds of an `FWP2` frame the server skipped (for its ack).
    Frame {
        frame: Box<Frame>,
        ignored: Vec<u8>,
    },
    End,
}

fn bad_frame(e: &StreamError) -> Refusal {
    Refusal::new(ErrorCode::BadFrame, e.field(), e.to_string())
}

/// A text message: `{"type":"end"}` or one JSONL frame. `number` counts the producer's
/// messages, for error messages.
pub fn parse_text(text: &str, number: u64, mask: &Mask) -> Result<Incoming, Refusal> {
    if let Ok(ProducerMessage::End) = serde_json::from_str::<ProducerMessage>(text) {
        return Ok(Incoming::End);
    }
    crate::stream::jsonl::parse_message(&format!("message {number}"), text, mask)
        .map(|f| Incoming::Frame {
            frame: Box::new(f),
            ignored: Vec::new(),
        })
        .map_err(|e| {
            let refusal = bad_frame(&e);
            match seq_of(text) {
                Some(seq) => refusal.with_seq(seq),
                None => refusal,
            }
        })
}

/// The `seq` of a refused JSON frame, when it has a readable one.
fn seq_of(text: &str) -> Option<u64> {
    #[derive(serde::Deserialize)]
    struct Seq {
        seq: Option<u64>,
    }
    serde_json::from_str::<Seq>(text).ok()?.seq
}

/// A binary audio message (`FWA1`): the chunk, and the message viewers get (stamped with
/// `received_us`, the server's receipt).
pub fn parse_audio(bytes: &[u8], received_us: u64) -> Result<(AudioChunk, RelayedAudio), Refusal> {
    let mut chunk =
        AudioChunk::decode(bytes).map_err(|e| Refusal::new(ErrorCode::BadFrame, e.field(), e.to_string()))?;
    chunk.server_receive_us = received_us;
    let relayed = RelayedAudio::of(&chunk);
    Ok((chunk, relayed))
}

/// A binary `FWP2` or `FWP1` message, checked as a JSON frame is.
pub fn parse_binary(bytes: &[u8], mask: &Mask) -> Result<Incoming, Refusal> {
    let mut params =
        ParamFrame::decode(bytes).map_err(|e| Refusal::new(ErrorCode::BadFrame, e.field(), e.to_string()))?;
    let seq = params.seq;
    let ignored = std::mem::take(&mut params.ignored);
    Frame::from_param_frame(params, mask)
        .map(|f| Incoming::Frame {
            frame: Box::new(f),
            ignored,
        })
        .map_err(|e| bad_frame(&e).with_seq(seq))
}
