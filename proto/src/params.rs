//! The binary parameter frame a producer may send instead of a JSON line: the same content
//! as facewire's JSONL format, in fixed-width little-endian fields (see PROTOCOL.md).
//!
//! ```text
//! offset  size  field
//!      0     4  magic "FWP1"
//!      4     8  seq (u64)
//!     12     8  time_s (f64)
//!     20     1  flags: bit 0 head rotation present, bit 1 label present, bit 2 viseme present
//!     21     2  au_count (u16), then au_count x { u16 unit index, f32 weight }
//!      .     2  fap_count (u16), then fap_count x { u8 FAP number, f32 value in FAP counts }
//!      .     2  arkit_count (u16), then arkit_count x { u8 blendshape index, f32 weight }
//!      .    12  if head rotation: rx, ry, rz (3 x f32, radians)
//!      .     .  if label: u8 length, then that many UTF-8 bytes
//!      .     5  if viseme: u8 scheme, then 4 x u8: scheme 0 (MPEG-4 FAP 1) select1, select2,
//!               blend, definition; scheme 1 (Oculus/Meta) or 2 (Microsoft) the ID, 0, 0, 0
//! ```
//!
//! [`ParamFrame::decode`] checks the layout: magic, lengths, no flag bit other than 0, 1
//! and 2, a UTF-8 label, a known viseme scheme with its unused bytes 0, no byte after the
//! frame. What the values mean (unit, FAP and
//! blendshape indices, each at most once, and their ranges) is checked where the frame is
//! used, by the same check as a JSONL frame's (`facewire::stream::Frame::from_param_frame`).

use crate::{DecodeError, Reader};

pub const PARAMS_MAGIC: [u8; 4] = *b"FWP1";
const FLAG_ROTATION: u8 = 1;
const FLAG_LABEL: u8 = 2;
const FLAG_VISEME: u8 = 4;

/// A viseme as FWP1 carries it: MPEG-4's FAP 1, or a text-to-speech engine's ID.
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
    fn bytes(self) -> [u8; 5] {
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

    fn read(r: &mut Reader<'_>) -> Result<ParamViseme, DecodeError> {
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
    pub animation: Vec<(u16, f32)>,
    pub faps: Vec<(u8, f32)>,
    pub arkit: Vec<(u8, f32)>,
    pub head_rotation_rad: Option<[f32; 3]>,
    pub label: Option<String>,
    pub viseme: Option<ParamViseme>,
}

impl ParamFrame {
    pub fn encode(&self) -> Vec<u8> {
        let mut out =
            Vec::with_capacity(32 + 6 * (self.animation.len() + self.faps.len() + self.arkit.len()));
        out.extend_from_slice(&PARAMS_MAGIC);
        out.extend_from_slice(&self.seq.to_le_bytes());
        out.extend_from_slice(&self.time_s.to_le_bytes());
        let flags = if self.head_rotation_rad.is_some() {
            FLAG_ROTATION
        } else {
            0
        } | if self.label.is_some() { FLAG_LABEL } else { 0 }
            | if self.viseme.is_some() { FLAG_VISEME } else { 0 };
        out.push(flags);
        out.extend_from_slice(&(self.animation.len() as u16).to_le_bytes());
        for (unit, w) in &self.animation {
            out.extend_from_slice(&unit.to_le_bytes());
            out.extend_from_slice(&w.to_le_bytes());
        }
        for list in [&self.faps, &self.arkit] {
            out.extend_from_slice(&(list.len() as u16).to_le_bytes());
            for (index, value) in list {
                out.push(*index);
                out.extend_from_slice(&value.to_le_bytes());
            }
        }
        if let Some(r) = self.head_rotation_rad {
            for x in r {
                out.extend_from_slice(&x.to_le_bytes());
            }
        }
        if let Some(label) = &self.label {
            crate::frame::write_label(label, &mut out);
        }
        if let Some(viseme) = self.viseme {
            out.extend_from_slice(&viseme.bytes());
        }
        out
    }

    pub fn decode(bytes: &[u8]) -> Result<ParamFrame, DecodeError> {
        let mut r = Reader::new(bytes);
        let magic = r.array::<4>("magic")?;
        if magic != PARAMS_MAGIC {
            return Err(DecodeError::Magic {
                found: magic,
                expected: PARAMS_MAGIC,
            });
        }
        let seq = r.u64("seq")?;
        let time_s = r.f64("time_s")?;
        let flags = r.u8("flags")?;
        let undefined = flags & !(FLAG_ROTATION | FLAG_LABEL | FLAG_VISEME);
        if undefined != 0 {
            return Err(DecodeError::Invalid {
                field: "flags",
                at: 20,
                problem: format!(
                    "undefined bits {undefined:#04x} are set (bit 0 rotation, bit 1 label, bit 2 viseme)"
                ),
            });
        }
        let au_count = r.u16("au_count")?;
        let mut animation = Vec::with_capacity(usize::from(au_count).min(r.remaining() / 6));
        for _ in 0..au_count {
            animation.push((r.u16("au unit")?, r.f32("au weight")?));
        }
        let mut lists = [Vec::new(), Vec::new()];
        for (list, (count_field, index_field, value_field)) in lists.iter_mut().zip([
            ("fap_count", "fap number", "fap value"),
            ("arkit_count", "arkit index", "arkit weight"),
        ]) {
            let count = r.u16(count_field)?;
            list.reserve(usize::from(count).min(r.remaining() / 5));
            for _ in 0..count {
                list.push((r.u8(index_field)?, r.f32(value_field)?));
            }
        }
        let [faps, arkit] = lists;
        let head_rotation_rad = if flags & FLAG_ROTATION != 0 {
            Some([r.f32("rx")?, r.f32("ry")?, r.f32("rz")?])
        } else {
            None
        };
        let label = if flags & FLAG_LABEL != 0 {
            Some(r.label()?)
        } else {
            None
        };
        let viseme = if flags & FLAG_VISEME != 0 {
            Some(ParamViseme::read(&mut r)?)
        } else {
            None
        };
        r.finish()?;
        Ok(ParamFrame {
            seq,
            time_s,
            animation,
            faps,
            arkit,
            head_rotation_rad,
            label,
            viseme,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_errors() {
        let frame = ParamFrame {
            seq: 7,
            time_s: 0.25,
            animation: vec![(1, 0.5), (2, -0.25)],
            faps: vec![(3, 120.0)],
            arkit: vec![(24, 1.0)],
            head_rotation_rad: Some([0.1, 0.0, -0.1]),
            label: Some("pa".into()),
            viseme: None,
        };
        let bytes = frame.encode();
        assert_eq!(bytes.len(), 4 + 8 + 8 + 1 + 2 + 12 + 2 + 5 + 2 + 5 + 12 + 3);
        for viseme in [
            ParamViseme::Fap1 {
                select1: 10,
                select2: 12,
                blend: 21,
                definition: 0,
            },
            ParamViseme::Oculus(1),
            ParamViseme::Microsoft(18),
        ] {
            let with = ParamFrame {
                viseme: Some(viseme),
                ..frame.clone()
            };
            let encoded = with.encode();
            assert_eq!(encoded.len(), bytes.len() + 5);
            assert_eq!(ParamFrame::decode(&encoded), Ok(with));
        }
        let mut unknown = ParamFrame {
            viseme: Some(ParamViseme::Oculus(1)),
            ..frame.clone()
        }
        .encode();
        let scheme_at = unknown.len() - 5;
        unknown[scheme_at] = 3;
        assert!(matches!(
            ParamFrame::decode(&unknown),
            Err(DecodeError::Invalid { field: "viseme", .. })
        ));
        unknown[scheme_at] = 1;
        unknown[scheme_at + 2] = 7;
        assert!(matches!(
            ParamFrame::decode(&unknown),
            Err(DecodeError::Invalid { field: "viseme", .. })
        ));
        assert_eq!(ParamFrame::decode(&bytes), Ok(frame));
        assert!(matches!(
            ParamFrame::decode(&bytes[..25]),
            Err(DecodeError::Truncated {
                field: "au weight",
                ..
            })
        ));
        for undefined in [8u8, 0x10, 0x80] {
            let mut flagged = bytes.clone();
            flagged[20] |= undefined;
            assert_eq!(
                ParamFrame::decode(&flagged),
                Err(DecodeError::Invalid {
                    field: "flags",
                    at: 20,
                    problem: format!(
                        "undefined bits {undefined:#04x} are set (bit 0 rotation, bit 1 label, bit 2 viseme)"
                    ),
                })
            );
            assert_eq!(ParamFrame::decode(&flagged).unwrap_err().field(), Some("flags"));
        }
        let mut extra = bytes.clone();
        extra.push(1);
        assert_eq!(
            ParamFrame::decode(&extra),
            Err(DecodeError::Trailing { extra: 1 })
        );
    }
}
