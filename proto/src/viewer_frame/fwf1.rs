//! `FWF1`, the frozen viewer frame layout: a flag byte says which optional fields follow,
//! in a fixed order. Served to viewers that ask for `format=fwf1` or name no format, for
//! as long as `/v1` is; it never gains another bit or field (PROTOCOL.md, "Versions and
//! growth").
//!
//! ```text
//! offset  size  field
//!      0     4  magic "FWF1"
//!      4     1  flags: bit 0 heat values present, bit 1 label present, bit 2 deltas deflated,
//!                bit 3 head motion present, bit 4 jaw motion present, bit 5 tongue deltas present,
//!                bit 6 lip folds present
//!      5     3  reserved, 0
//!      8     8  seq (u64): the producer's sequence number
//!     16     8  producer_time_s (f64): the producer's timestamp
//!     24     8  server_receive_us (u64): when the server received the parameters (µs, Unix epoch)
//!     32     8  server_send_us (u64): when the server published this frame to viewers
//!     40     4  step (f32): head units per quantization count
//!     44     4  vertex_count (u32): vertices of the head
//!     48     4  moved (u32): vertices in the delta list
//!     52    12  lip roughness min, max, mean (3 x f32)
//!     64     1  lip_count n (u8), then n x f32: mean roughness around each lip vertex
//!      .     .  if label: u8 length, then that many UTF-8 bytes
//!      .    28  if head motion: rotation quaternion x, y, z, w, translation x, y, z (7 x f32)
//!      .    28  if jaw motion: the same, for the parts that move with the jaw
//!      .     8  if lip folds: u16 lip triangles turned over 60 degrees, u16 over 90, f32 the
//!               largest increase of a dihedral angle over rest (degrees)
//!      .     4  delta block length in bytes (u32), then the delta block
//!      .     .  if tongue: u8 part (index in the snapshot's parts), u32 its vertex_count,
//!               u32 moved, u32 block length, then a delta block as above
//!      .     .  if heat values: f32 max, then vertex_count x u8 (value = byte / 255 * max)
//! ```

use super::fields::{
    read_folds, read_heat, read_lip, read_motion, read_timing, write_folds, write_heat, write_lip,
    write_motion, write_timing,
};
use super::{FrameContent, FrameHeader, FrameLayout, PartDeltas, RigidMotion, ViewerFrame};
use crate::delta_block::{self, DeltaBlockEncoder, MovedField};
use crate::{DecodeError, Reader, Writer};

pub(super) const MAGIC: [u8; 4] = *b"FWF1";
const FLAG_HEAT: u8 = 1;
const FLAG_LABEL: u8 = 2;
const FLAG_DEFLATE: u8 = 4;
const FLAG_HEAD: u8 = 8;
const FLAG_JAW: u8 = 16;
const FLAG_TONGUE: u8 = 32;
const FLAG_FOLDS: u8 = 64;
/// Where the head's `moved` count is.
const MOVED_AT: usize = 48;

pub(super) fn write(
    out: &mut Vec<u8>,
    deltas: &mut DeltaBlockEncoder,
    header: &FrameHeader,
    content: &FrameContent<'_>,
) {
    out.extend_from_slice(&MAGIC);
    let label = content.label.filter(|l| !l.is_empty());
    let flags = [
        (content.heat.is_some(), FLAG_HEAT),
        (label.is_some(), FLAG_LABEL),
        (content.deflate, FLAG_DEFLATE),
        (content.head.is_some(), FLAG_HEAD),
        (content.jaw.is_some(), FLAG_JAW),
        (content.tongue.is_some(), FLAG_TONGUE),
        (content.folds.is_some(), FLAG_FOLDS),
    ]
    .into_iter()
    .filter(|(present, _)| *present)
    .fold(0, |flags, (_, bit)| flags | bit);
    out.extend_from_slice(&[flags, 0, 0, 0]);
    write_timing(out, header);
    out.put_f32(content.step);
    out.put_u32(content.deltas.len() as u32);
    let moved_slot = out.slot_u32();
    write_lip(out, content.lip);
    if let Some(label) = label {
        out.put_label(label);
    }
    for motion in [content.head, content.jaw].iter().flatten() {
        write_motion(out, motion);
    }
    if let Some(folds) = &content.folds {
        write_folds(out, folds);
    }
    let moved = deltas.write(out, content.deltas, content.step, content.deflate);
    out.fill_u32(moved_slot, moved);
    if let Some((part, part_deltas)) = content.tongue {
        out.put_u8(part);
        out.put_u32(part_deltas.len() as u32);
        let moved_slot = out.slot_u32();
        let moved = deltas.write(out, part_deltas, content.step, content.deflate);
        out.fill_u32(moved_slot, moved);
    }
    if let Some(values) = content.heat {
        write_heat(out, values, |_| {});
    }
}

/// The magic, the flags and the header.
pub(super) fn read_header(r: &mut Reader<'_>) -> Result<(u8, FrameHeader), DecodeError> {
    r.take(4, "magic")?;
    let flags = r.u8("flags")?;
    r.take(3, "reserved")?;
    Ok((flags, read_timing(r)?))
}

pub(super) fn read(bytes: &[u8]) -> Result<ViewerFrame, DecodeError> {
    let mut r = Reader::new(bytes);
    let (flags, header) = read_header(&mut r)?;
    let step = r.f32("step")?;
    let vertex_count = r.u32("vertex_count")?;
    let moved_count = r.u32("moved")?;
    let lip = read_lip(&mut r)?;
    let label = (flags & FLAG_LABEL != 0).then(|| r.label()).transpose()?;
    let motion = |r: &mut Reader<'_>, flag: u8, field| match flags & flag {
        0 => Ok(RigidMotion::IDENTITY),
        _ => read_motion(r, field),
    };
    let head = motion(&mut r, FLAG_HEAD, "head motion")?;
    let jaw = motion(&mut r, FLAG_JAW, "jaw motion")?;
    let folds = (flags & FLAG_FOLDS != 0)
        .then(|| read_folds(&mut r))
        .transpose()?;
    let deflated = flags & FLAG_DEFLATE != 0;
    let field = MovedField {
        field: "moved",
        at: MOVED_AT,
    };
    let moved = delta_block::read(&mut r, deflated, moved_count, vertex_count, field)?;
    let mut parts = Vec::new();
    if flags & FLAG_TONGUE != 0 {
        let part = r.u8("tongue part")?;
        let part_vertices = r.u32("tongue vertex_count")?;
        let at = r.position();
        let part_moved = r.u32("tongue moved")?;
        let field = MovedField {
            field: "tongue moved",
            at,
        };
        parts.push(PartDeltas {
            part,
            step,
            vertex_count: part_vertices,
            moved: delta_block::read(&mut r, deflated, part_moved, part_vertices, field)?,
        });
    }
    let heat = match flags & FLAG_HEAT {
        0 => None,
        _ => {
            let max = r.f32("heat max")?;
            Some(read_heat(&mut r, max, vertex_count as usize)?)
        }
    };
    r.finish()?;
    Ok(ViewerFrame {
        layout: FrameLayout::Fwf1,
        header,
        step,
        vertex_count,
        moved,
        lip,
        label,
        heat,
        head,
        jaw,
        parts,
        folds,
        eyes: Vec::new(),
        viseme: None,
    })
}
