//! The binary frame a viewer receives for every deformed frame: vertex deltas against the
//! rest mesh, quantized and sent only for vertices that moved, the lip roughness and folds,
//! the head's and the jaw's rigid motions (never baked into the deltas), the tongue's
//! deltas and, on request, per-vertex heat values. Two layouts carry the same content:
//! `FWF2` (a header and typed sections a decoder skips when it does not know them,
//! [`fwf2`]) and the frozen `FWF1` ([`fwf1`]); PROTOCOL.md describes both.

mod fields;
mod fwf1;
mod fwf2;
#[cfg(test)]
mod tests;

use crate::delta_block::DeltaBlockEncoder;
pub use crate::delta_block::MovedVertex;
use crate::DecodeError;
pub use fwf2::SECTIONS;

/// A viewer frame layout: what `format=` names and what the frames' magic says.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FrameLayout {
    /// The frozen flag-bit layout, for clients built before `FWF2`.
    Fwf1,
    /// Header and typed sections.
    Fwf2,
}

impl FrameLayout {
    /// Its name in a viewer's `format=` and the snapshot's `format`.
    pub fn name(self) -> &'static str {
        match self {
            FrameLayout::Fwf1 => "fwf1",
            FrameLayout::Fwf2 => "fwf2",
        }
    }

    pub fn magic(self) -> [u8; 4] {
        match self {
            FrameLayout::Fwf1 => fwf1::MAGIC,
            FrameLayout::Fwf2 => fwf2::MAGIC,
        }
    }

    /// The layout whose magic starts `bytes`.
    fn of(bytes: &[u8]) -> Result<FrameLayout, DecodeError> {
        let found = crate::Reader::magic(bytes)?;
        [FrameLayout::Fwf2, FrameLayout::Fwf1]
            .into_iter()
            .find(|layout| layout.magic() == found)
            .ok_or(DecodeError::Magic {
                found,
                expected: "FWF2 or FWF1",
            })
    }
}

/// Timing and identity of one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameHeader {
    pub seq: u64,
    pub producer_time_s: f64,
    pub server_receive_us: u64,
    pub server_send_us: u64,
}

/// Lip roughness of one frame: the summary over the lip region and the mean around each
/// lip vertex (CANDIDE order of the snapshot's `lip_vertices`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LipRoughness {
    pub min: f32,
    pub max: f32,
    pub mean: f32,
    pub per_vertex: Vec<f32>,
}

/// Folds of the lip region in one frame (docs/METRICS.md, "Folds"): how much of the skin
/// around the mouth turned over, after the region's own rigid motion.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LipFolds {
    /// Lip triangles whose normal turned more than 60 degrees from rest (saturates at
    /// 65,535).
    pub turned_over_60: u16,
    /// ... more than 90 degrees: facing away.
    pub turned_over_90: u16,
    /// The largest increase of a dihedral angle between two lip triangles over its rest
    /// value, degrees.
    pub max_dihedral_increase_deg: f32,
}

/// A rigid motion of head units, `world = rotate(rotation, local) + translation`: the
/// head's own motion in a frame (local = rest + delta).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidMotion {
    /// Unit quaternion x, y, z, w.
    pub rotation: [f32; 4],
    /// Head units.
    pub translation: [f32; 3],
}

impl RigidMotion {
    pub const IDENTITY: RigidMotion = RigidMotion {
        rotation: [0.0, 0.0, 0.0, 1.0],
        translation: [0.0; 3],
    };

    /// `rotation` applied to `p`, then `translation` added.
    pub fn apply(&self, p: [f32; 3]) -> [f32; 3] {
        let [x, y, z, w] = self.rotation;
        // v' = v + 2 w (q x v) + 2 q x (q x v), q = (x, y, z)
        let cross = |a: [f32; 3], b: [f32; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let q = [x, y, z];
        let c = cross(q, p);
        let cc = cross(q, c);
        [0, 1, 2].map(|k| p[k] + 2.0 * (w * c[k] + cc[k]) + self.translation[k])
    }
}

/// A decoded viewer frame, whichever layout carried it.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewerFrame {
    pub layout: FrameLayout,
    pub header: FrameHeader,
    /// Head units per count of the head's deltas.
    pub step: f32,
    pub vertex_count: u32,
    /// The head's moved vertices; delta = counts x step.
    pub moved: Vec<MovedVertex>,
    pub lip: LipRoughness,
    pub label: Option<String>,
    /// Per-vertex values (the snapshot's `heat`: face roughness or folds, degrees), when
    /// the viewer asked for them.
    pub heat: Option<Vec<f32>>,
    /// The head's own motion; [`RigidMotion::IDENTITY`] when the frame has none.
    pub head: RigidMotion,
    /// The jaw's motion (before the head's), for the parts that move with it;
    /// [`RigidMotion::IDENTITY`] when the frame has none.
    pub jaw: RigidMotion,
    /// The shaped parts' deltas (the tongue), in increasing part; parts not listed are at
    /// their rest shape.
    pub parts: Vec<PartDeltas>,
    /// The lip region's folds, when the server measured them.
    pub folds: Option<LipFolds>,
    /// The turned eyeballs' motions, in increasing eye (`FWF2` only); eyes not listed look
    /// ahead.
    pub eyes: Vec<EyeMotion>,
    /// The mouth shape that drove the frame, when its parameters named one (`FWF2` only).
    pub viseme: Option<FrameViseme>,
}

/// The viseme of a frame: MPEG-4 FAP 1 as the producer gave it, or as the server derived
/// it from the stream's voice (`derive=visemes`): `blend / 63` of `select1`, the rest of
/// `select2`, each an MPEG-4 viseme number (0-14, the Oculus order `sil`, `PP`, ... `ou`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameViseme {
    pub select1: u8,
    pub select2: u8,
    pub blend: u8,
}

/// An eyeball's motion in one frame: the turn about its centre (head units, before the
/// head's motion: an eyeball's world position is `head(motion(rest))`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EyeMotion {
    /// Index of the eyeball in the snapshot's `eyes`.
    pub eye: u8,
    pub motion: RigidMotion,
}

/// Decoded deltas of one part (the tongue), against its rest mesh, before the jaw's and
/// the head's motions.
#[derive(Debug, Clone, PartialEq)]
pub struct PartDeltas {
    /// Index of the part in the snapshot's `parts`.
    pub part: u8,
    /// Head units per count.
    pub step: f32,
    pub vertex_count: u32,
    /// The part's moved vertices; delta = counts x step.
    pub moved: Vec<MovedVertex>,
}

impl ViewerFrame {
    /// Rest positions plus the decoded deltas (flat xyz arrays, head units), before the
    /// head's motion: [`ViewerFrame::place`] applies that.
    pub fn apply(&self, rest: &[f32], out: &mut Vec<f32>) {
        apply_moved(rest, &self.moved, self.step, out);
    }

    /// Rest positions plus deltas, moved by the head's motion (flat xyz, head units): where
    /// the head is in the viewer's world.
    pub fn place(&self, rest: &[f32], out: &mut Vec<f32>) {
        self.apply(rest, out);
        for p in out.chunks_exact_mut(3) {
            p.copy_from_slice(&self.head.apply([p[0], p[1], p[2]]));
        }
    }

    /// The deltas of part `part` (its index in the snapshot's `parts`), if it is shaped.
    pub fn part(&self, part: u8) -> Option<&PartDeltas> {
        self.parts.iter().find(|p| p.part == part)
    }
}

impl PartDeltas {
    /// The part's rest positions plus its deltas (flat xyz, head units), before any motion.
    pub fn apply(&self, rest: &[f32], out: &mut Vec<f32>) {
        apply_moved(rest, &self.moved, self.step, out);
    }
}

fn apply_moved(rest: &[f32], moved: &[MovedVertex], step: f32, out: &mut Vec<f32>) {
    out.clear();
    out.extend_from_slice(rest);
    for &(v, q) in moved {
        for (k, &count) in q.iter().enumerate() {
            out[v as usize * 3 + k] += count as f32 * step;
        }
    }
}

/// What to encode besides the header.
pub struct FrameContent<'a> {
    /// Head units per count, for the head and the tongue.
    pub step: f32,
    /// Per-vertex deltas against the rest mesh, head units.
    pub deltas: &'a [[f32; 3]],
    pub lip: &'a LipRoughness,
    pub label: Option<&'a str>,
    /// Per-vertex heat values, if the viewer wants them.
    pub heat: Option<&'a [f32]>,
    /// Deflate the delta blocks (about a third of the size, a little slower to encode).
    pub deflate: bool,
    /// The head's own motion, sent beside the deltas; `None` for a head at rest.
    pub head: Option<RigidMotion>,
    /// The jaw's motion, for heads with parts that move with it; `None` at rest.
    pub jaw: Option<RigidMotion>,
    /// The tongue's deltas against its rest mesh (head units, before the jaw's motion)
    /// and its index among the head's parts; `None` for a tongue at rest.
    pub tongue: Option<(u8, &'a [[f32; 3]])>,
    /// The lip region's folds in this frame.
    pub folds: Option<LipFolds>,
    /// The eyeballs turned in this frame (`FWF2` only: `FWF1` is frozen and has no place
    /// for them).
    pub eyes: &'a [EyeMotion],
    /// The frame's viseme (`FWF2` only).
    pub viseme: Option<FrameViseme>,
}

/// Encodes frames into reused buffers.
#[derive(Default)]
pub struct FrameEncoder {
    buffer: Vec<u8>,
    deltas: DeltaBlockEncoder,
}

impl FrameEncoder {
    /// An encoder whose buffers already hold the largest frame of a head with `vertices`
    /// vertices (head and tongue) and `lip_values` lip roughness values (every vertex moved
    /// by the largest counts, a 255-byte label, heat values) in either layout, so encoding
    /// allocates nothing after the first frame (which makes the deflate state).
    pub fn for_head(vertices: usize, lip_values: usize) -> FrameEncoder {
        // Header, lip values, label, two motions, folds, the tongue's fields, the heat's
        // max and count, two eyes' motions, and every section's kind and length.
        let fixed = 64 + 1 + 4 * lip_values + 256 + 2 * 28 + 8 + 32 + 8 + 2 * 34 + 16 * 5;
        FrameEncoder {
            buffer: Vec::with_capacity(fixed + DeltaBlockEncoder::worst_case(vertices) + vertices),
            deltas: DeltaBlockEncoder::for_vertices(vertices),
        }
    }

    /// Encodes one frame in `layout`; the returned slice lives until the next call.
    pub fn encode(&mut self, layout: FrameLayout, header: &FrameHeader, content: &FrameContent<'_>) -> &[u8] {
        let out = &mut self.buffer;
        out.clear();
        match layout {
            FrameLayout::Fwf1 => fwf1::write(out, &mut self.deltas, header, content),
            FrameLayout::Fwf2 => fwf2::write(out, &mut self.deltas, header, content),
        }
        &self.buffer
    }
}

/// Decodes a viewer frame of either layout, checking every length.
pub fn decode(bytes: &[u8]) -> Result<ViewerFrame, DecodeError> {
    match FrameLayout::of(bytes)? {
        FrameLayout::Fwf1 => fwf1::read(bytes),
        FrameLayout::Fwf2 => fwf2::read(bytes),
    }
}

/// Decodes only a frame's header, for clients that count frames rather than draw them,
/// such as a load generator.
pub fn decode_header(bytes: &[u8]) -> Result<FrameHeader, DecodeError> {
    match FrameLayout::of(bytes)? {
        FrameLayout::Fwf1 => fwf1::read_header(&mut crate::Reader::new(bytes)).map(|(_, h)| h),
        FrameLayout::Fwf2 => fwf2::read_header(&mut crate::Reader::new(bytes)),
    }
}
