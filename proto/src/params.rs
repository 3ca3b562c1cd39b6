//! The binary parameter frame a producer may send instead of a JSON line: the same content
//! as facewire's JSONL format, in fixed-width little-endian fields (see PROTOCOL.md).
//!
//! ```text
//! offset  size  field
//!      0     4  magic "FWP1"
//!      4     8  seq (u64)
//!     12     8  time_s (f64)
//!     20     1  flags: bit 0 head rotation present, bit 1 label present
//!     21     2  au_count (u16), then au_count x { u16 unit index, f32 weight }
//!      .     2  fap_count (u16), then fap_count x { u8 FAP number, f32 value in FAP counts }
//!      .     2  arkit_count (u16), then arkit_count x { u8 blendshape index, f32 weight }
//!      .    12  if head rotation: rx, ry, rz (3 x f32, radians)
//!      .     .  if label: u8 length, then that many UTF-8 bytes
//! ```
//!
//! [`ParamFrame::decode`] checks the layout: magic, lengths, no flag bit other than 0 and
//! 1, a UTF-8 label, no byte after the frame. What the values mean (unit, FAP and
//! blendshape indices, each at most once, and their ranges) is checked where the frame is
//! used, by the same check as a JSONL frame's (`facewire::stream::Frame::from_param_frame`).

use crate::{DecodeError, Reader};

pub const PARAMS_MAGIC: [u8; 4] = *b"FWP1";
const FLAG_ROTATION: u8 = 1;
const FLAG_LABEL: u8 = 2;

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
        } | if self.label.is_some() { FLAG_LABEL } else { 0 };
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
        let undefined = flags & !(FLAG_ROTATION | FLAG_LABEL);
        if undefined != 0 {
            return Err(DecodeError::Invalid {
                field: "flags",
                at: 20,
                problem: format!("undefined bits {undefined:#04x} are set (bit 0 rotation, bit 1 label)"),
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
        r.finish()?;
        Ok(ParamFrame {
            seq,
            time_s,
            animation,
            faps,
            arkit,
            head_rotation_rad,
            label,
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
        };
        let bytes = frame.encode();
        assert_eq!(bytes.len(), 4 + 8 + 8 + 1 + 2 + 12 + 2 + 5 + 2 + 5 + 12 + 3);
        assert_eq!(ParamFrame::decode(&bytes), Ok(frame));
        assert!(matches!(
            ParamFrame::decode(&bytes[..25]),
            Err(DecodeError::Truncated {
                field: "au weight",
                ..
            })
        ));
        for undefined in [4u8, 8, 0x80] {
            let mut flagged = bytes.clone();
            flagged[20] |= undefined;
            assert_eq!(
                ParamFrame::decode(&flagged),
                Err(DecodeError::Invalid {
                    field: "flags",
                    at: 20,
                    problem: format!("undefined bits {undefined:#04x} are set (bit 0 rotation, bit 1 label)"),
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
