//! `FWP2`, the parameter frame as a fixed header and typed sections: the server skips the
//! kinds it does not know (and names them in its `ack`), so producers can send new kinds
//! of parameters to servers that may not use them yet (PROTOCOL.md, "Versions and growth").
//!
//! ```text
//! offset  size  field
//!      0     4  magic "FWP2"
//!      4     8  seq (u64)
//!     12     8  time_s (f64)
//!     20     1  section count, then each section: kind (u8), length (u32), body
//!
//! kind  name              body
//!    1  au                count u16, count x { u16 unit index, f32 weight }
//!    2  fap               count u16, count x { u8 FAP number, f32 value in FAP counts }
//!    3  arkit             count u16, count x { u8 blendshape index, f32 weight }
//!    4  head_rotation     rx, ry, rz (3 x f32, radians)
//!    5  head_translation  x, y, z (3 x f32, mask units)
//!    6  label             u8 length, UTF-8 bytes
//!    7  viseme            u8 scheme, 4 x u8 (as FWP1)
//! ```

use super::fwp1::read_indexed;
use super::{ParamFrame, ParamViseme};
use crate::sections::{read_sections, KindsSeen, SectionsOut};
use crate::{DecodeError, Reader, Writer};

pub(super) const MAGIC: [u8; 4] = *b"FWP2";
const AU: u8 = 1;
const FAP: u8 = 2;
const ARKIT: u8 = 3;
const HEAD_ROTATION: u8 = 4;
const HEAD_TRANSLATION: u8 = 5;
const LABEL: u8 = 6;
const VISEME: u8 = 7;

/// Every section kind this server reads in a parameter frame, by number and name.
pub const SECTIONS: [(u8, &str); 7] = [
    (AU, "au"),
    (FAP, "fap"),
    (ARKIT, "arkit"),
    (HEAD_ROTATION, "head_rotation"),
    (HEAD_TRANSLATION, "head_translation"),
    (LABEL, "label"),
    (VISEME, "viseme"),
];

pub(super) fn write(p: &ParamFrame) -> Vec<u8> {
    let mut out = Vec::with_capacity(64 + 6 * (p.animation.len() + p.faps.len() + p.arkit.len()));
    out.extend_from_slice(&MAGIC);
    out.put_u64(p.seq);
    out.put_f64(p.time_s);
    let mut sections = SectionsOut::start(&mut out);
    if !p.animation.is_empty() {
        let slot = sections.open(&mut out, AU);
        out.put_u16(p.animation.len() as u16);
        for &(unit, w) in &p.animation {
            out.put_u16(unit);
            out.put_f32(w);
        }
        SectionsOut::close(&mut out, slot);
    }
    for (kind, list) in [(FAP, &p.faps), (ARKIT, &p.arkit)] {
        if !list.is_empty() {
            let slot = sections.open(&mut out, kind);
            out.put_u16(list.len() as u16);
            for &(index, value) in list {
                out.put_u8(index);
                out.put_f32(value);
            }
            SectionsOut::close(&mut out, slot);
        }
    }
    for (kind, xyz) in [
        (HEAD_ROTATION, p.head_rotation_rad),
        (HEAD_TRANSLATION, p.head_translation),
    ] {
        if let Some(xyz) = xyz {
            let slot = sections.open(&mut out, kind);
            out.put_f32s(&xyz);
            SectionsOut::close(&mut out, slot);
        }
    }
    if let Some(label) = &p.label {
        let slot = sections.open(&mut out, LABEL);
        out.put_label(label);
        SectionsOut::close(&mut out, slot);
    }
    if let Some(viseme) = p.viseme {
        let slot = sections.open(&mut out, VISEME);
        out.extend_from_slice(&viseme.bytes());
        SectionsOut::close(&mut out, slot);
    }
    sections.finish(&mut out);
    out
}

fn xyz(r: &mut Reader<'_>, field: &'static str) -> Result<[f32; 3], DecodeError> {
    Ok([r.f32(field)?, r.f32(field)?, r.f32(field)?])
}

pub(super) fn read(bytes: &[u8]) -> Result<ParamFrame, DecodeError> {
    let mut r = Reader::new(bytes);
    r.take(4, "magic")?;
    let mut frame = ParamFrame {
        seq: r.u64("seq")?,
        time_s: r.f64("time_s")?,
        ..ParamFrame::default()
    };
    let mut seen = KindsSeen::new();
    for mut section in read_sections(&mut r)? {
        let (kind, at) = (section.kind, section.at);
        let body = &mut section.body;
        if let Some((_, name)) = SECTIONS.iter().find(|(k, _)| *k == kind) {
            seen.mark(kind, at, name)?;
        }
        match kind {
            AU => {
                let count = body.u16("au_count")?;
                frame
                    .animation
                    .reserve(usize::from(count).min(body.remaining() / 6));
                for _ in 0..count {
                    frame
                        .animation
                        .push((body.u16("au unit")?, body.f32("au weight")?));
                }
            }
            FAP => frame.faps = read_indexed(body, ("fap_count", "fap number", "fap value"))?,
            ARKIT => frame.arkit = read_indexed(body, ("arkit_count", "arkit index", "arkit weight"))?,
            HEAD_ROTATION => frame.head_rotation_rad = Some(xyz(body, "head_rotation")?),
            HEAD_TRANSLATION => frame.head_translation = Some(xyz(body, "head_translation")?),
            LABEL => frame.label = Some(body.label()?),
            VISEME => frame.viseme = Some(ParamViseme::read(body)?),
            // A kind from a later producer: skipped, and named in the ack.
            _ => frame.ignored.push(kind),
        }
    }
    Ok(frame)
}
