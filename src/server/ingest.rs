//! Producer messages turned into frames: JSON text (one line of facewire's JSONL) or binary
//! `FWP1`, both validated by the core's frame checks, and every refusal named by code,
//! field and sequence number, the same whichever format the frame came in.

use crate::mask::Mask;
use crate::stream::{Frame, StreamError};
use facewire_proto::codes::ErrorCode;
use facewire_proto::messages::{ProducerMessage, ServerMessage};
use facewire_proto::params::ParamFrame;

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
    Frame(Box<Frame>),
    End,
}

fn bad_frame(e: &StreamError) -> Refusal {
    Refusal::new(ErrorCode::BadFrame, None, e.to_string())
}

/// A text message: `{"type":"end"}` or one JSONL frame. `number` counts the producer's
/// messages, for error messages.
pub fn parse_text(text: &str, number: u64, mask: &Mask) -> Result<Incoming, Refusal> {
    if let Ok(ProducerMessage::End) = serde_json::from_str::<ProducerMessage>(text) {
        return Ok(Incoming::End);
    }
    crate::stream::jsonl::parse_message(&format!("message {number}"), text, mask)
        .map(|f| Incoming::Frame(Box::new(f)))
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

/// A binary `FWP1` message.
pub fn parse_binary(bytes: &[u8], mask: &Mask) -> Result<Incoming, Refusal> {
    frame_from_binary(bytes, mask.animation_units.len()).map(|f| Incoming::Frame(Box::new(f)))
}

fn frame_from_binary(bytes: &[u8], units: usize) -> Result<Frame, Refusal> {
    let p = ParamFrame::decode(bytes).map_err(|e| Refusal::new(ErrorCode::BadFrame, None, e.to_string()))?;
    let finite = |field: &str, values: &[f32]| {
        if values.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(Refusal::new(
                ErrorCode::BadFrame,
                Some(field),
                format!("{field}: values must be finite numbers"),
            ))
        }
    };
    finite("au", &p.animation.iter().map(|a| a.1).collect::<Vec<_>>())?;
    finite("fap", &p.faps.iter().map(|a| a.1).collect::<Vec<_>>())?;
    finite("arkit", &p.arkit.iter().map(|a| a.1).collect::<Vec<_>>())?;
    finite(
        "head_rotation_rad",
        p.head_rotation_rad.as_ref().map_or(&[][..], |r| &r[..]),
    )?;
    if !p.time_s.is_finite() {
        return Err(Refusal::new(
            ErrorCode::BadFrame,
            Some("t"),
            "t must be a finite number",
        ));
    }
    if let Some((u, _)) = p.animation.iter().find(|(u, _)| usize::from(*u) >= units) {
        return Err(Refusal::new(
            ErrorCode::BadFrame,
            Some("au"),
            format!("animation unit {u} is out of range (0..{units})"),
        ));
    }
    if let Some((f, _)) = p.faps.iter().find(|(f, _)| !(1..=68).contains(f)) {
        return Err(Refusal::new(
            ErrorCode::BadFrame,
            Some("fap"),
            format!("FAP {f} is out of range (1..=68)"),
        ));
    }
    if let Some((a, _)) = p
        .arkit
        .iter()
        .find(|(a, _)| usize::from(*a) >= crate::stream::ARKIT_BLENDSHAPES.len())
    {
        return Err(Refusal::new(
            ErrorCode::BadFrame,
            Some("arkit"),
            format!("ARKit index {a} is out of range (0..52)"),
        ));
    }
    let mut frame = Frame::at(p.seq, p.time_s);
    frame.label = p.label;
    frame.animation = p.animation;
    frame.faps = p.faps;
    frame.arkit = p.arkit;
    frame.head_rotation_rad = p.head_rotation_rad;
    Ok(frame)
}
