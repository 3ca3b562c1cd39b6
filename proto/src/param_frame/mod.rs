//! The binary parameter frame a producer may send instead of a JSON line: the same content
//! as facewire's JSONL format in little-endian fields, as `FWP2` (a header and typed
//! sections, [`fwp2`]) or the frozen `FWP1` ([`fwp1`]); see PROTOCOL.md.
//!
//! [`ParamFrame::decode`] checks the layout: magic, lengths, a UTF-8 label, a known viseme
//! scheme with its unused bytes 0, no byte after the frame (and, for `FWP1`, no flag bit
//! but 0-2). What the values mean (unit, FAP and blendshape indices, each at most once,
//! and their ranges) is checked where the frame is used, by the same check as a JSONL
//! frame's (`facewire::stream::Frame::from_param_frame`).

mod fwp1;
mod fwp2;
#[cfg(test)]
mod tests;

use crate::{DecodeError, Reader};
pub use fwp2::SECTIONS;

/// A viseme as the binary frames carry it: MPEG-4's FAP 1, or a text-to-speech engine's ID.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamViseme {
    /// Scheme 0: FAP 1's four values.
    Fap1 {
        select1: u8,
        select2: u8,
        blend: u8,
        definition: u8,
    },
    /// Scheme 1: Oculus/Meta's 15 (MPEG-4's numbers).
    Oculus(u8),
    /// Scheme 2: Microsoft's 22.
    Microsoft(u8),
}

impl ParamViseme {
    pub(crate) fn bytes(self) -> [u8; 5] {
        match self {
            ParamViseme::Fap1 {
                select1,
                select2,
                blend,
                definition,
            } => [0, select1, select2, blend, definition],
            ParamViseme::Oculus(id) => [1, id, 0, 0, 0],
            ParamViseme::Microsoft(id) => [2, id, 0, 0, 0],
        }
    }

    pub(crate) fn read(r: &mut Reader<'_>) -> Result<ParamViseme, DecodeError> {
        let at = r.position();
        let [scheme, a, b, c, d] = r.array::<5>("viseme")?;
        let single = |viseme: ParamViseme| match [b, c, d] {
            [0, 0, 0] => Ok(viseme),
            _ => Err(DecodeError::Invalid {
                field: "viseme",
                at,
                problem: format!("scheme {scheme} carries one ID; bytes 2-4 must be 0, found {b} {c} {d}"),
            }),
        };
        match scheme {
            0 => Ok(ParamViseme::Fap1 {
                select1: a,
                select2: b,
                blend: c,
                definition: d,
            }),
            1 => single(ParamViseme::Oculus(a)),
            2 => single(ParamViseme::Microsoft(a)),
            _ => Err(DecodeError::Invalid {
                field: "viseme",
                at,
                problem: format!(
                    "scheme {scheme}: expected 0 (MPEG-4 FAP 1), 1 (Oculus/Meta) or 2 (Microsoft)"
                ),
            }),
        }
    }
}

/// One producer frame in its wire form.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ParamFrame {
    pub seq: u64,
    pub time_s: f64,
    /// (animation unit index, weight).
    pub animation: Vec<(u16, f32)>,
    /// (FAP number, value in FAP counts).
    pub faps: Vec<(u8, f32)>,
    /// (ARKit blendshape index, weight).
    pub arkit: Vec<(u8, f32)>,
    /// Radians.
    pub head_rotation_rad: Option<[f32; 3]>,
    /// Mask units (`FWP2` only).
    pub head_translation: Option<[f32; 3]>,
    pub label: Option<String>,
    pub viseme: Option<ParamViseme>,
    /// Section kinds the decoder did not know and skipped (`FWP2` from a later client):
    /// the server names them in its `ack`. Not encoded.
    pub ignored: Vec<u8>,
}

/// A frame that the frozen `FWP1` cannot carry.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error("FWP1 cannot carry {0}; send FWP2")]
pub struct Unrepresentable(pub &'static str);

impl ParamFrame {
    /// The frame as `FWP2`.
    pub fn encode(&self) -> Vec<u8> {
        fwp2::write(self)
    }

    /// The frame as the frozen `FWP1`, for servers older than `FWP2`.
    pub fn encode_fwp1(&self) -> Result<Vec<u8>, Unrepresentable> {
        fwp1::write(self)
    }

    /// Decodes an `FWP2` or `FWP1` frame, checking its layout.
    pub fn decode(bytes: &[u8]) -> Result<ParamFrame, DecodeError> {
        let found = Reader::magic(bytes)?;
        match found {
            fwp2::MAGIC => fwp2::read(bytes),
            fwp1::MAGIC => fwp1::read(bytes),
            _ => Err(DecodeError::Magic {
                found,
                expected: "FWP2 or FWP1",
            }),
        }
    }
}
