//! `FWP1`, the frozen parameter frame layout, accepted for as long as `/v1` is served
//! (PROTOCOL.md, "Versions and growth").
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

use super::{ParamFrame, ParamViseme, Unrepresentable};
use crate::{DecodeError, Reader, Writer};

pub(super) const MAGIC: [u8; 4] = *b"FWP1";
const FLAG_ROTATION: u8 = 1;
const FLAG_LABEL: u8 = 2;
const FLAG_VISEME: u8 = 4;

pub(super) fn write(p: &ParamFrame) -> Result<Vec<u8>, Unrepresentable> {
    if p.head_translation.is_some() {
        return Err(Unrepresentable("head_translation"));
    }
    let mut out = Vec::with_capacity(32 + 6 * (p.animation.len() + p.faps.len() + p.arkit.len()));
    out.extend_from_slice(&MAGIC);
    out.put_u64(p.seq);
    out.put_f64(p.time_s);
    let flags = [
        (p.head_rotation_rad.is_some(), FLAG_ROTATION),
        (p.label.is_some(), FLAG_LABEL),
        (p.viseme.is_some(), FLAG_VISEME),
    ]
    .into_iter()
    .filter(|(present, _)| *present)
    .fold(0, |flags, (_, bit)| flags | bit);
    out.put_u8(flags);
    out.put_u16(p.animation.len() as u16);
    for &(unit, w) in &p.animation {
        out.put_u16(unit);
        out.put_f32(w);
    }
    for list in [&p.faps, &p.arkit] {
        out.put_u16(list.len() as u16);
        for &(index, value) in list {
            out.put_u8(index);
            out.put_f32(value);
        }
    }
    if let Some(r) = p.head_rotation_rad {
        out.put_f32s(&r);
    }
    if let Some(label) = &p.label {
        out.put_label(label);
    }
    if let Some(viseme) = p.viseme {
        out.extend_from_slice(&viseme.bytes());
    }
    Ok(out)
}

pub(super) fn read(bytes: &[u8]) -> Result<ParamFrame, DecodeError> {
    let mut r = Reader::new(bytes);
    r.take(4, "magic")?;
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
    let faps = read_indexed(&mut r, ("fap_count", "fap number", "fap value"))?;
    let arkit = read_indexed(&mut r, ("arkit_count", "arkit index", "arkit weight"))?;
    let head_rotation_rad = match flags & FLAG_ROTATION {
        0 => None,
        _ => Some([r.f32("rx")?, r.f32("ry")?, r.f32("rz")?]),
    };
    let label = (flags & FLAG_LABEL != 0).then(|| r.label()).transpose()?;
    let viseme = (flags & FLAG_VISEME != 0)
        .then(|| ParamViseme::read(&mut r))
        .transpose()?;
    r.finish()?;
    Ok(ParamFrame {
        seq,
        time_s,
        animation,
        faps,
        arkit,
        head_rotation_rad,
        head_translation: None,
        label,
        viseme,
        ignored: Vec::new(),
    })
}

/// A u16 count, then count x { u8 index, f32 value }, with the fields' names.
pub(super) fn read_indexed(
    r: &mut Reader<'_>,
    (count_field, index_field, value_field): (&'static str, &'static str, &'static str),
) -> Result<Vec<(u8, f32)>, DecodeError> {
    let count = r.u16(count_field)?;
    let mut list = Vec::with_capacity(usize::from(count).min(r.remaining() / 5));
    for _ in 0..count {
        list.push((r.u8(index_field)?, r.f32(value_field)?));
    }
    Ok(list)
}
