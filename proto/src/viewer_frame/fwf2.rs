//! `FWF2`, the viewer frame as a fixed header and typed sections: a decoder skips the
//! kinds it does not know and the end of a section past the fields it knows, so frames can
//! gain content (audio's timing, eyes, textures) without breaking the clients that read
//! them today (PROTOCOL.md, "Versions and growth").
//!
//! ```text
//! offset  size  field
//!      0     4  magic "FWF2"
//!      4     8  seq (u64)
//!     12     8  producer_time_s (f64)
//!     20     8  server_receive_us (u64)
//!     28     8  server_send_us (u64)
//!     36     1  section count, then each section: kind (u8), length (u32), body
//!
//! kind  name           body
//!    1  deltas         step f32, vertex_count u32, moved u32, encoding u8, u32 length + block
//!    2  lip_roughness  min, max, mean f32, n u8, n x f32
//!    3  label          u8 length, UTF-8 bytes
//!    4  head_motion    quaternion x y z w, translation x y z (7 x f32)
//!    5  jaw_motion     the same
//!    6  lip_folds      u16 turned over 60, u16 over 90, f32 largest dihedral increase
//!    7  part_deltas    part u8, step f32, vertex_count u32, moved u32, encoding u8, u32 length + block
//!    8  heat           max f32, count u32, count x u8
//!    9  eye_motion     eye u8, quaternion x y z w, translation x y z (7 x f32)
//!   10  viseme         select1 u8, select2 u8, blend u8 (MPEG-4 FAP 1)
//! ```

use super::fields::{
    read_folds, read_heat, read_lip, read_motion, read_timing, write_folds, write_heat, write_lip,
    write_motion, write_timing,
};
use super::{
    EyeMotion, FrameContent, FrameHeader, FrameLayout, FrameViseme, PartDeltas, RigidMotion, ViewerFrame,
};
use crate::delta_block::{self, DeltaBlockEncoder, MovedField, MovedVertex};
use crate::sections::{read_sections, KindsSeen, Section, SectionsOut};
use crate::{DecodeError, Reader, Writer};

pub(super) const MAGIC: [u8; 4] = *b"FWF2";
const DELTAS: u8 = 1;
const LIP_ROUGHNESS: u8 = 2;
const LABEL: u8 = 3;
const HEAD_MOTION: u8 = 4;
const JAW_MOTION: u8 = 5;
const LIP_FOLDS: u8 = 6;
const PART_DELTAS: u8 = 7;
const HEAT: u8 = 8;
const EYE_MOTION: u8 = 9;
const VISEME: u8 = 10;

/// Every section kind this server may put in a frame, by number and name: what the
/// snapshot's `sections` lists.
pub const SECTIONS: [(u8, &str); 10] = [
    (DELTAS, "deltas"),
    (LIP_ROUGHNESS, "lip_roughness"),
    (LABEL, "label"),
    (HEAD_MOTION, "head_motion"),
    (JAW_MOTION, "jaw_motion"),
    (LIP_FOLDS, "lip_folds"),
    (PART_DELTAS, "part_deltas"),
    (HEAT, "heat"),
    (EYE_MOTION, "eye_motion"),
    (VISEME, "viseme"),
];

/// A delta block's encoding byte.
const PLAIN: u8 = 0;
const DEFLATE: u8 = 1;

pub(super) fn write(
    out: &mut Vec<u8>,
    deltas: &mut DeltaBlockEncoder,
    header: &FrameHeader,
    content: &FrameContent<'_>,
) {
    out.extend_from_slice(&MAGIC);
    write_timing(out, header);
    let mut sections = SectionsOut::start(out);
    let encoding = if content.deflate { DEFLATE } else { PLAIN };

    let slot = sections.open(out, DELTAS);
    out.put_f32(content.step);
    out.put_u32(content.deltas.len() as u32);
    let moved_slot = out.slot_u32();
    out.put_u8(encoding);
    let moved = deltas.write(out, content.deltas, content.step, content.deflate);
    out.fill_u32(moved_slot, moved);
    SectionsOut::close(out, slot);

    let slot = sections.open(out, LIP_ROUGHNESS);
    write_lip(out, content.lip);
    SectionsOut::close(out, slot);

    if let Some(label) = content.label.filter(|l| !l.is_empty()) {
        let slot = sections.open(out, LABEL);
        out.put_label(label);
        SectionsOut::close(out, slot);
    }
    for (kind, motion) in [(HEAD_MOTION, &content.head), (JAW_MOTION, &content.jaw)] {
        if let Some(motion) = motion {
            let slot = sections.open(out, kind);
            write_motion(out, motion);
            SectionsOut::close(out, slot);
        }
    }
    if let Some(folds) = &content.folds {
        let slot = sections.open(out, LIP_FOLDS);
        write_folds(out, folds);
        SectionsOut::close(out, slot);
    }
    if let Some((part, part_deltas)) = content.tongue {
        let slot = sections.open(out, PART_DELTAS);
        out.put_u8(part);
        out.put_f32(content.step);
        out.put_u32(part_deltas.len() as u32);
        let moved_slot = out.slot_u32();
        out.put_u8(encoding);
        let moved = deltas.write(out, part_deltas, content.step, content.deflate);
        out.fill_u32(moved_slot, moved);
        SectionsOut::close(out, slot);
    }
    if let Some(values) = content.heat {
        let slot = sections.open(out, HEAT);
        write_heat(out, values, |out| out.put_u32(values.len() as u32));
        SectionsOut::close(out, slot);
    }
    for eye in content.eyes {
        let slot = sections.open(out, EYE_MOTION);
        out.put_u8(eye.eye);
        write_motion(out, &eye.motion);
        SectionsOut::close(out, slot);
    }
    if let Some(viseme) = content.viseme {
        let slot = sections.open(out, VISEME);
        out.put_u8(viseme.select1);
        out.put_u8(viseme.select2);
        out.put_u8(viseme.blend);
        SectionsOut::close(out, slot);
    }
    sections.finish(out);
}

pub(super) fn read_header(r: &mut Reader<'_>) -> Result<FrameHeader, DecodeError> {
    r.take(4, "magic")?;
    read_timing(r)
}

/// A `deltas` or `part_deltas` body from its vertex count on: the step comes first.
struct Block {
    step: f32,
    vertex_count: u32,
    moved: Vec<MovedVertex>,
}

fn read_block(body: &mut Reader<'_>, moved_name: &'static str) -> Result<Block, DecodeError> {
    let step = body.f32("step")?;
    let vertex_count = body.u32("vertex_count")?;
    let at = body.position();
    let moved_count = body.u32(moved_name)?;
    let encoding_at = body.position();
    let deflated = match body.u8("encoding")? {
        PLAIN => false,
        DEFLATE => true,
        other => {
            return Err(DecodeError::Invalid {
                field: "encoding",
                at: encoding_at,
                problem: format!("{other}: expected 0 (plain) or 1 (raw deflate)"),
            })
        }
    };
    let field = MovedField {
        field: moved_name,
        at,
    };
    let moved = delta_block::read(body, deflated, moved_count, vertex_count, field)?;
    Ok(Block {
        step,
        vertex_count,
        moved,
    })
}

pub(super) fn read(bytes: &[u8]) -> Result<ViewerFrame, DecodeError> {
    let mut r = Reader::new(bytes);
    let header = read_header(&mut r)?;
    let mut seen = KindsSeen::new();
    let (mut block, mut lip, mut label, mut folds, mut viseme) = (None, None, None, None, None);
    let (mut head, mut jaw) = (RigidMotion::IDENTITY, RigidMotion::IDENTITY);
    let mut parts: Vec<PartDeltas> = Vec::new();
    let mut eyes: Vec<EyeMotion> = Vec::new();
    // Heat values need the head's vertex count, which may come in a later section.
    let mut heat_section: Option<Section<'_>> = None;
    for mut section in read_sections(&mut r)? {
        let (kind, at) = (section.kind, section.at);
        let body = &mut section.body;
        match kind {
            DELTAS => {
                seen.mark(kind, at, "deltas")?;
                block = Some(read_block(body, "moved")?);
            }
            LIP_ROUGHNESS => {
                seen.mark(kind, at, "lip_roughness")?;
                lip = Some(read_lip(body)?);
            }
            LABEL => {
                seen.mark(kind, at, "label")?;
                label = Some(body.label()?);
            }
            HEAD_MOTION => {
                seen.mark(kind, at, "head_motion")?;
                head = read_motion(body, "head motion")?;
            }
            JAW_MOTION => {
                seen.mark(kind, at, "jaw_motion")?;
                jaw = read_motion(body, "jaw motion")?;
            }
            LIP_FOLDS => {
                seen.mark(kind, at, "lip_folds")?;
                folds = Some(read_folds(body)?);
            }
            PART_DELTAS => {
                let part = body.u8("part")?;
                if parts.iter().any(|p| p.part == part) {
                    return Err(DecodeError::Invalid {
                        field: "part_deltas",
                        at,
                        problem: format!("part {part} given twice"),
                    });
                }
                let Block {
                    step,
                    vertex_count,
                    moved,
                } = read_block(body, "part moved")?;
                parts.push(PartDeltas {
                    part,
                    step,
                    vertex_count,
                    moved,
                });
            }
            EYE_MOTION => {
                let eye = body.u8("eye")?;
                if eyes.iter().any(|e| e.eye == eye) {
                    return Err(DecodeError::Invalid {
                        field: "eye_motion",
                        at,
                        problem: format!("eye {eye} given twice"),
                    });
                }
                let motion = read_motion(body, "eye motion")?;
                eyes.push(EyeMotion { eye, motion });
            }
            VISEME => {
                seen.mark(kind, at, "viseme")?;
                viseme = Some(read_viseme(body)?);
            }
            HEAT => {
                seen.mark(kind, at, "heat")?;
                heat_section = Some(section);
            }
            // A kind from a later server: skipped.
            _ => {}
        }
    }
    let missing = |name: &'static str| DecodeError::Invalid {
        field: name,
        at: 36,
        problem: format!("the frame has no {name} section"),
    };
    let block = block.ok_or_else(|| missing("deltas"))?;
    let lip = lip.ok_or_else(|| missing("lip_roughness"))?;
    let mut heat = None;
    if let Some(mut section) = heat_section {
        let body = &mut section.body;
        let max = body.f32("heat max")?;
        let count_at = body.position();
        let count = body.u32("heat count")?;
        if count != block.vertex_count {
            return Err(DecodeError::Invalid {
                field: "heat count",
                at: count_at,
                problem: format!("{count} values for {} vertices", block.vertex_count),
            });
        }
        heat = Some(read_heat(body, max, count as usize)?);
    }
    parts.sort_by_key(|p| p.part);
    eyes.sort_by_key(|e| e.eye);
    Ok(ViewerFrame {
        layout: FrameLayout::Fwf2,
        header,
        step: block.step,
        vertex_count: block.vertex_count,
        moved: block.moved,
        lip,
        label,
        heat,
        head,
        jaw,
        parts,
        folds,
        eyes,
        viseme,
    })
}

fn read_viseme(body: &mut Reader<'_>) -> Result<FrameViseme, DecodeError> {
    let at = body.position();
    let viseme = FrameViseme {
        select1: body.u8("viseme")?,
        select2: body.u8("viseme")?,
        blend: body.u8("viseme")?,
    };
    if viseme.select1 > 14 || viseme.select2 > 14 || viseme.blend > 63 {
        return Err(DecodeError::Invalid {
            field: "viseme",
            at,
            problem: format!(
                "selects {} and {}, blend {}: expected visemes 0-14 and a blend of 0-63",
                viseme.select1, viseme.select2, viseme.blend
            ),
        });
    }
    Ok(viseme)
}
