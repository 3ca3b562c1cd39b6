//! The binary frame a viewer receives for every deformed frame: vertex deltas against the
//! rest mesh, quantized and sent only for vertices that moved, plus the lip roughness and,
//! on request, per-vertex face roughness, and the head's own rigid motion, which is never
//! baked into the deltas. All numbers little-endian; see PROTOCOL.md.
//!
//! ```text
//! offset  size  field
//!      0     4  magic "FWF1"
//!      4     1  flags: bit 0 face roughness present, bit 1 label present, bit 2 deltas deflated,
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
//!      .     4  delta block length in bytes (u32), then the block:
//!               moved x { varint index gap, 3 x zigzag varint count differences },
//!               raw-deflated (RFC 1951) when flag bit 2 is set
//!      .     .  if tongue: u8 part (index in the snapshot's parts), u32 its vertex_count,
//!               u32 moved, u32 block length, then a delta block as above
//!      .     .  if face roughness: f32 max, then vertex_count x u8 (value = byte / 255 * max)
//! ```
//! The index gap is `index - previous index - 1` (previous = -1 before the first), so
//! consecutive moved vertices cost one byte of index. Counts are sent as the difference
//! from the previous moved vertex's counts (starting from 0, 0, 0): neighbouring vertices
//! move alike, and the many small differences deflate well (the syllable stream on the
//! scan: 29 kB -> 8.4 kB per frame for RBF).

use crate::varint::{encode, unzigzag, zigzag};
use crate::{DecodeError, Reader};

pub const FRAME_MAGIC: [u8; 4] = *b"FWF1";
const FLAG_FACE: u8 = 1;
const FLAG_LABEL: u8 = 2;
const FLAG_DEFLATE: u8 = 4;
const FLAG_HEAD: u8 = 8;
const FLAG_JAW: u8 = 16;
const FLAG_TONGUE: u8 = 32;
const FLAG_FOLDS: u8 = 64;
/// How far from 1 a head rotation quaternion's length may be (f32 rounding is 1e-7).
const UNIT_QUATERNION_TOLERANCE: f32 = 1e-4;

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

/// A decoded viewer frame.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewerFrame {
    pub header: FrameHeader,
    pub step: f32,
    pub vertex_count: u32,
    /// (vertex, quantized delta counts); delta = counts * step.
    pub moved: Vec<(u32, [i32; 3])>,
    pub lip: LipRoughness,
    pub label: Option<String>,
    /// Per-vertex face roughness, when the viewer asked for it.
    pub face: Option<Vec<f32>>,
    /// The head's own motion; [`RigidMotion::IDENTITY`] when the frame has none.
    pub head: RigidMotion,
    /// The jaw's motion (before the head's), for the parts that move with it;
    /// [`RigidMotion::IDENTITY`] when the frame has none.
    pub jaw: RigidMotion,
    /// The tongue's deltas (before the jaw's and the head's motions), when it is shaped.
    pub tongue: Option<PartDeltas>,
    /// The lip region's folds, when the server measured them.
    pub folds: Option<LipFolds>,
}

/// Decoded deltas of one part (the tongue): vertices of the part, same step as the head.
#[derive(Debug, Clone, PartialEq)]
pub struct PartDeltas {
    /// Index of the part in the snapshot's `parts`.
    pub part: u8,
    pub vertex_count: u32,
    /// (part vertex, quantized delta counts); delta = counts * step.
    pub moved: Vec<(u32, [i32; 3])>,
}

impl ViewerFrame {
    /// Rest positions plus the decoded deltas (flat xyz arrays, head units), before the
    /// head's motion: [`ViewerFrame::place`] applies that.
    pub fn apply(&self, rest: &[f32], out: &mut Vec<f32>) {
        out.clear();
        out.extend_from_slice(rest);
        for &(v, q) in &self.moved {
            for (k, &count) in q.iter().enumerate() {
                out[v as usize * 3 + k] += count as f32 * self.step;
            }
        }
    }

    /// Rest positions plus deltas, moved by the head's motion (flat xyz, head units): where
    /// the head is in the viewer's world.
    pub fn place(&self, rest: &[f32], out: &mut Vec<f32>) {
        self.apply(rest, out);
        for p in out.chunks_exact_mut(3) {
            p.copy_from_slice(&self.head.apply([p[0], p[1], p[2]]));
        }
    }
}

/// What to encode besides the header.
pub struct FrameContent<'a> {
    pub step: f32,
    /// Per-vertex deltas against the rest mesh, head units.
    pub deltas: &'a [[f32; 3]],
    pub lip: &'a LipRoughness,
    pub label: Option<&'a str>,
    /// Per-vertex roughness, if the viewer wants it.
    pub face: Option<&'a [f32]>,
    /// Deflate the delta block (about a third of the size, a little slower to encode).
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
}

/// Encodes frames into reused buffers.
#[derive(Default)]
pub struct FrameEncoder {
    buffer: Vec<u8>,
    block: Vec<u8>,
    compressor: Option<flate2::Compress>,
}

impl FrameEncoder {
    /// An encoder whose buffers already hold the largest frame of a head with `vertices`
    /// vertices and `lip_values` lip roughness values (every vertex moved by the largest
    /// counts, a 255-byte label, face roughness), so encoding allocates nothing after the
    /// first frame (which makes the deflate state).
    pub fn for_head(vertices: usize, lip_values: usize) -> FrameEncoder {
        // Gap and three counts, each a LEB128 varint of at most 5 bytes (u32 and zigzag i32).
        let block = vertices * 20;
        let header = 64 + 1 + 4 * lip_values + 256 + 2 * 28 + 8 + 4;
        // Deflate's worst case stays under the stored size plus its 5-byte block headers;
        // the loop reserves half a block and 64 bytes more before each call.
        let deflated = block + block / 2 + 64 + 5 * (block / 16_384 + 1);
        FrameEncoder {
            buffer: Vec::with_capacity(header + deflated + 4 + vertices),
            block: Vec::with_capacity(block),
            compressor: None,
        }
    }

    /// Encodes one frame; the returned slice lives until the next call.
    pub fn encode(&mut self, header: &FrameHeader, content: &FrameContent<'_>) -> &[u8] {
        let out = &mut self.buffer;
        out.clear();
        out.extend_from_slice(&FRAME_MAGIC);
        let label = content.label.filter(|l| !l.is_empty());
        let mut flags = 0;
        if content.face.is_some() {
            flags |= FLAG_FACE;
        }
        if label.is_some() {
            flags |= FLAG_LABEL;
        }
        if content.deflate {
            flags |= FLAG_DEFLATE;
        }
        if content.head.is_some() {
            flags |= FLAG_HEAD;
        }
        if content.jaw.is_some() {
            flags |= FLAG_JAW;
        }
        if content.tongue.is_some() {
            flags |= FLAG_TONGUE;
        }
        if content.folds.is_some() {
            flags |= FLAG_FOLDS;
        }
        out.extend_from_slice(&[flags, 0, 0, 0]);
        out.extend_from_slice(&header.seq.to_le_bytes());
        out.extend_from_slice(&header.producer_time_s.to_le_bytes());
        out.extend_from_slice(&header.server_receive_us.to_le_bytes());
        out.extend_from_slice(&header.server_send_us.to_le_bytes());
        out.extend_from_slice(&content.step.to_le_bytes());
        out.extend_from_slice(&(content.deltas.len() as u32).to_le_bytes());
        let moved_at = out.len();
        out.extend_from_slice(&0u32.to_le_bytes());
        for x in [content.lip.min, content.lip.max, content.lip.mean] {
            out.extend_from_slice(&x.to_le_bytes());
        }
        let lip_count = content.lip.per_vertex.len().min(255);
        out.push(lip_count as u8);
        for x in &content.lip.per_vertex[..lip_count] {
            out.extend_from_slice(&x.to_le_bytes());
        }
        if let Some(label) = label {
            write_label(label, out);
        }
        for motion in [content.head, content.jaw].into_iter().flatten() {
            for x in motion.rotation.iter().chain(&motion.translation) {
                out.extend_from_slice(&x.to_le_bytes());
            }
        }
        if let Some(folds) = content.folds {
            out.extend_from_slice(&folds.turned_over_60.to_le_bytes());
            out.extend_from_slice(&folds.turned_over_90.to_le_bytes());
            out.extend_from_slice(&folds.max_dihedral_increase_deg.to_le_bytes());
        }

        let moved = self.write_deltas(content.deltas, content.step, content.deflate);
        self.buffer[moved_at..moved_at + 4].copy_from_slice(&moved.to_le_bytes());
        if let Some((part, deltas)) = content.tongue {
            let out = &mut self.buffer;
            out.push(part);
            out.extend_from_slice(&(deltas.len() as u32).to_le_bytes());
            let moved_at = out.len();
            out.extend_from_slice(&0u32.to_le_bytes());
            let moved = self.write_deltas(deltas, content.step, content.deflate);
            self.buffer[moved_at..moved_at + 4].copy_from_slice(&moved.to_le_bytes());
        }

        let out = &mut self.buffer;
        if let Some(face) = content.face {
            let max = face
                .iter()
                .copied()
                .filter(|x| x.is_finite())
                .fold(0.0f32, f32::max);
            out.extend_from_slice(&max.to_le_bytes());
            out.extend(face.iter().map(|&x| {
                if max > 0.0 && x.is_finite() {
                    (x / max * 255.0).round().clamp(0.0, 255.0) as u8
                } else {
                    0
                }
            }));
        }
        &self.buffer
    }
}

impl FrameEncoder {
    /// Appends a delta block's length and the block (deflated if asked) for `deltas`
    /// quantized by `step`; returns how many entries (moved vertices) it holds.
    fn write_deltas(&mut self, deltas: &[[f32; 3]], step: f32, deflate: bool) -> u32 {
        let (out, block) = (&mut self.buffer, &mut self.block);
        block.clear();
        let inverse = 1.0 / step;
        let mut moved = 0u32;
        let mut previous: i64 = -1;
        let mut previous_q = [0i64; 3];
        for (v, d) in deltas.iter().enumerate() {
            // Counts saturate at the i32 range the decoder accepts (NaN counts as 0).
            let q = d.map(|x| round_half_away(x * inverse).clamp(i32::MIN.into(), i32::MAX.into()));
            if q == [0, 0, 0] {
                continue;
            }
            encode((v as i64 - previous - 1) as u64, block);
            for k in 0..3 {
                encode(zigzag(q[k] - previous_q[k]), block);
            }
            previous = v as i64;
            previous_q = q;
            moved += 1;
        }
        let length_at = out.len();
        out.extend_from_slice(&0u32.to_le_bytes());
        let start = out.len();
        if deflate {
            // Level 2: zlib-rs's level 1 codes with fixed Huffman tables, 29 % more bytes a
            // frame on the scan's syllable stream; level 2 is 9 % fewer than miniz_oxide's 1.
            let compressor = self
                .compressor
                .get_or_insert_with(|| flate2::Compress::new(flate2::Compression::new(2), false));
            compressor.reset();
            loop {
                out.reserve(block.len() / 2 + 64);
                let consumed = compressor.total_in() as usize;
                let status = compressor
                    .compress_vec(&block[consumed..], out, flate2::FlushCompress::Finish)
                    .expect("deflating into a vector cannot fail");
                if status == flate2::Status::StreamEnd {
                    break;
                }
            }
        } else {
            out.extend_from_slice(block);
        }
        let length = (out.len() - start) as u32;
        out[length_at..length_at + 4].copy_from_slice(&length.to_le_bytes());
        moved
    }
}

/// `x.round() as i64`, without the call to the C library's `roundf` that `f32::round`
/// compiles to on x86-64 (a tenth of the frame encoder's time). In f64 the half added is
/// exact for every f32, so the result is the same for every input, NaN (0) and
/// infinities (saturated) included.
fn round_half_away(x: f32) -> i64 {
    let x = f64::from(x);
    (x + 0.5f64.copysign(x)) as i64
}

/// A label of at most 255 bytes, cut at a character boundary: u8 length, UTF-8 bytes.
pub(crate) fn write_label(label: &str, out: &mut Vec<u8>) {
    let mut end = label.len().min(255);
    while !label.is_char_boundary(end) {
        end -= 1;
    }
    out.push(end as u8);
    out.extend_from_slice(&label.as_bytes()[..end]);
}

/// Inflates a raw deflate stream, refusing to produce more than `limit` bytes.
fn inflate(stored: &[u8], limit: usize, at: usize) -> Result<Vec<u8>, DecodeError> {
    let invalid = |problem: String| DecodeError::Invalid {
        field: "delta block",
        at,
        problem,
    };
    let mut out = Vec::with_capacity(stored.len().saturating_mul(4).min(limit).min(1 << 20));
    let mut inflater = flate2::Decompress::new(false);
    loop {
        if out.len() == out.capacity() {
            if out.len() > limit {
                return Err(invalid(format!("inflates past {limit} bytes")));
            }
            out.reserve((limit + 1 - out.len()).min(1 << 16));
        }
        let consumed = inflater.total_in() as usize;
        let produced = out.len();
        let status = inflater
            .decompress_vec(&stored[consumed..], &mut out, flate2::FlushDecompress::None)
            .map_err(|e| invalid(format!("bad deflate data: {e}")))?;
        if out.len() > limit {
            return Err(invalid(format!("inflates past {limit} bytes")));
        }
        match status {
            flate2::Status::StreamEnd => return Ok(out),
            _ if inflater.total_in() as usize == consumed
                && out.len() == produced
                && out.len() < out.capacity() =>
            {
                return Err(invalid("truncated deflate data".into()))
            }
            _ => {}
        }
    }
}

/// Decodes only a frame's header (its first 40 bytes), for clients that count frames
/// rather than draw them, such as a load generator.
pub fn decode_header(bytes: &[u8]) -> Result<FrameHeader, DecodeError> {
    read_header(&mut Reader::new(bytes)).map(|(_, header)| header)
}

/// The magic, the flags and the header.
fn read_header(r: &mut Reader<'_>) -> Result<(u8, FrameHeader), DecodeError> {
    let magic = r.array::<4>("magic")?;
    if magic != FRAME_MAGIC {
        return Err(DecodeError::Magic {
            found: magic,
            expected: FRAME_MAGIC,
        });
    }
    let flags = r.u8("flags")?;
    r.take(3, "reserved")?;
    let header = FrameHeader {
        seq: r.u64("seq")?,
        producer_time_s: r.f64("producer_time_s")?,
        server_receive_us: r.u64("server_receive_us")?,
        server_send_us: r.u64("server_send_us")?,
    };
    Ok((flags, header))
}

/// Decodes a viewer frame, checking every length.
pub fn decode(bytes: &[u8]) -> Result<ViewerFrame, DecodeError> {
    let mut r = Reader::new(bytes);
    let (flags, header) = read_header(&mut r)?;
    let step = r.f32("step")?;
    let vertex_count = r.u32("vertex_count")?;
    let moved_count = r.u32("moved")?;
    let (min, max, mean) = (r.f32("lip min")?, r.f32("lip max")?, r.f32("lip mean")?);
    let lip_count = r.u8("lip_count")?;
    let per_vertex = (0..lip_count)
        .map(|_| r.f32("lip roughness"))
        .collect::<Result<Vec<_>, _>>()?;
    let label = if flags & FLAG_LABEL != 0 {
        Some(r.label()?)
    } else {
        None
    };
    let head = if flags & FLAG_HEAD != 0 {
        read_rigid_motion(&mut r, "head motion")?
    } else {
        RigidMotion::IDENTITY
    };
    let jaw = if flags & FLAG_JAW != 0 {
        read_rigid_motion(&mut r, "jaw motion")?
    } else {
        RigidMotion::IDENTITY
    };
    let folds = if flags & FLAG_FOLDS != 0 {
        let turned_over_60 = r.u16("lip folds")?;
        let turned_over_90 = r.u16("lip folds")?;
        let at = r.position();
        let max_dihedral_increase_deg = r.f32("lip folds")?;
        if !(max_dihedral_increase_deg.is_finite() && max_dihedral_increase_deg >= 0.0) {
            return Err(DecodeError::Invalid {
                field: "lip folds",
                at,
                problem: format!("largest dihedral increase {max_dihedral_increase_deg}"),
            });
        }
        Some(LipFolds {
            turned_over_60,
            turned_over_90,
            max_dihedral_increase_deg,
        })
    } else {
        None
    };
    if moved_count > vertex_count {
        return Err(DecodeError::Invalid {
            field: "moved",
            at: 48,
            problem: format!("{moved_count} moved of {vertex_count} vertices"),
        });
    }
    let moved = read_deltas(&mut r, flags & FLAG_DEFLATE != 0, moved_count, vertex_count)?;
    let tongue = if flags & FLAG_TONGUE != 0 {
        let part = r.u8("tongue part")?;
        let vertex_count = r.u32("tongue vertex_count")?;
        let moved_at = r.position();
        let moved_count = r.u32("tongue moved")?;
        if moved_count > vertex_count {
            return Err(DecodeError::Invalid {
                field: "tongue moved",
                at: moved_at,
                problem: format!("{moved_count} moved of {vertex_count} vertices"),
            });
        }
        let moved = read_deltas(&mut r, flags & FLAG_DEFLATE != 0, moved_count, vertex_count)?;
        Some(PartDeltas {
            part,
            vertex_count,
            moved,
        })
    } else {
        None
    };
    let face = if flags & FLAG_FACE != 0 {
        let max = r.f32("face roughness max")?;
        let bytes = r.take(vertex_count as usize, "face roughness")?;
        Some(bytes.iter().map(|&b| f32::from(b) / 255.0 * max).collect())
    } else {
        None
    };
    r.finish()?;
    Ok(ViewerFrame {
        header,
        step,
        vertex_count,
        moved,
        lip: LipRoughness {
            min,
            max,
            mean,
            per_vertex,
        },
        label,
        face,
        head,
        jaw,
        tongue,
        folds,
    })
}

/// A delta block's length and the block: `moved_count` entries of vertices below
/// `vertex_count`, inflated first if `deflated`.
fn read_deltas(
    r: &mut Reader<'_>,
    deflated: bool,
    moved_count: u32,
    vertex_count: u32,
) -> Result<Vec<(u32, [i32; 3])>, DecodeError> {
    let block_length = r.u32("delta block length")? as usize;
    let block_at = r.position();
    let stored = r.take(block_length, "delta block")?;
    // An entry takes 4 to 40 bytes: never inflate past what the count allows.
    let inflated;
    let block: &[u8] = if deflated {
        inflated = inflate(stored, moved_count as usize * 40, block_at)?;
        &inflated
    } else {
        stored
    };
    if moved_count as usize > block.len() / 4 {
        return Err(DecodeError::Invalid {
            field: "moved",
            at: 48,
            problem: format!("{moved_count} entries cannot fit in {} bytes", block.len()),
        });
    }
    let mut entries = Reader::new(block);
    let mut moved = Vec::with_capacity(moved_count as usize);
    // The lowest index the next entry may have: one past the previous entry's.
    let mut next: u32 = 0;
    let mut previous_q = [0i64; 3];
    for _ in 0..moved_count {
        let at = block_at + entries.position();
        let gap = entries.varint("index gap")?;
        let index = u64::from(next)
            .checked_add(gap)
            .and_then(|index| u32::try_from(index).ok())
            .filter(|&index| index < vertex_count)
            .ok_or_else(|| DecodeError::Invalid {
                field: "index gap",
                at,
                problem: format!("gap {gap} after vertex {next} passes the {vertex_count} vertices"),
            })?;
        let mut q = [0i32; 3];
        for k in 0..3 {
            let at = block_at + entries.position();
            let value = previous_q[k].saturating_add(unzigzag(entries.varint("delta")?));
            q[k] = i32::try_from(value).map_err(|_| DecodeError::Invalid {
                field: "delta",
                at,
                problem: "count out of range".into(),
            })?;
            previous_q[k] = value;
        }
        moved.push((index, q));
        next = index + 1;
    }
    if entries.remaining() != 0 {
        return Err(DecodeError::Invalid {
            field: "delta block",
            at: block_at,
            problem: format!("{} byte(s) left after {moved_count} entries", entries.remaining()),
        });
    }
    Ok(moved)
}

/// A rigid motion: finite numbers, a unit rotation quaternion.
fn read_rigid_motion(r: &mut Reader<'_>, field: &'static str) -> Result<RigidMotion, DecodeError> {
    let at = r.position();
    let mut values = [0.0f32; 7];
    for x in &mut values {
        *x = r.f32(field)?;
    }
    let invalid = |problem: String| DecodeError::Invalid { field, at, problem };
    if values.iter().any(|x| !x.is_finite()) {
        return Err(invalid(format!("not finite: {values:?}")));
    }
    let rotation = [values[0], values[1], values[2], values[3]];
    let length = rotation.iter().map(|x| x * x).sum::<f32>().sqrt();
    if (length - 1.0).abs() > UNIT_QUATERNION_TOLERANCE {
        return Err(invalid(format!("rotation quaternion of length {length}, not 1")));
    }
    Ok(RigidMotion {
        rotation,
        translation: [values[4], values[5], values[6]],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding_matches_the_standard_library_for_every_kind_of_f32() {
        let mut cases = vec![
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            1.5,
            -1.5,
            2.5,
            0.49999997,
            -0.49999997,
            8_388_607.5,
            16_777_217.0,
            1e20,
            -1e20,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MIN_POSITIVE,
            f32::EPSILON,
        ];
        // Every 997th f32 bit pattern: all exponents, both signs.
        cases.extend((0..u32::MAX / 997).map(|i| f32::from_bits(i * 997)));
        for x in cases {
            assert_eq!(round_half_away(x), x.round() as i64, "{x:e} ({:#x})", x.to_bits());
        }
    }

    fn header() -> FrameHeader {
        FrameHeader {
            seq: 42,
            producer_time_s: 1.5,
            server_receive_us: 1_000_000,
            server_send_us: 1_000_250,
        }
    }

    fn content<'a>(deltas: &'a [[f32; 3]], lip: &'a LipRoughness, deflate: bool) -> FrameContent<'a> {
        FrameContent {
            step: 0.5,
            deltas,
            lip,
            label: None,
            face: None,
            deflate,
            head: None,
            jaw: None,
            tongue: None,
            folds: None,
        }
    }

    #[test]
    fn lip_folds_travel_and_bad_ones_are_refused() {
        let lip = LipRoughness::default();
        let folds = LipFolds {
            turned_over_60: 12,
            turned_over_90: 3,
            max_dihedral_increase_deg: 97.5,
        };
        let mut encoder = FrameEncoder::default();
        let with = |folds| FrameContent {
            folds,
            ..content(&[[0.0; 3]], &lip, true)
        };
        let bytes = encoder.encode(&header(), &with(Some(folds))).to_vec();
        assert_eq!(decode(&bytes).unwrap().folds, Some(folds));
        let plain = encoder.encode(&header(), &with(None)).to_vec();
        assert_eq!(bytes.len(), plain.len() + 8);
        assert_eq!(decode(&plain).unwrap().folds, None);
        let nan = LipFolds {
            max_dihedral_increase_deg: f32::NAN,
            ..folds
        };
        let bytes = encoder.encode(&header(), &with(Some(nan))).to_vec();
        match decode(&bytes) {
            Err(DecodeError::Invalid { field, .. }) => assert_eq!(field, "lip folds"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn tongue_deltas_travel_after_the_head_with_the_same_step() {
        let lip = LipRoughness::default();
        let head = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
        let tongue = [[0.0; 3], [0.0, 0.26, -0.1], [0.0; 3], [0.1, 0.0, 0.0]];
        for deflate in [false, true] {
            let mut encoder = FrameEncoder::default();
            let bytes = encoder
                .encode(
                    &header(),
                    &FrameContent {
                        tongue: Some((3, &tongue)),
                        ..content(&head, &lip, deflate)
                    },
                )
                .to_vec();
            let frame = decode(&bytes).unwrap();
            assert_eq!(frame.moved, [(1, [2, 0, 0])]);
            let decoded = frame.tongue.unwrap();
            assert_eq!((decoded.part, decoded.vertex_count), (3, 4));
            // step 0.5: 0.26 -> 1 count, -0.1 -> 0, 0.1 -> 0.
            assert_eq!(decoded.moved, [(1, [0, 1, 0])]);
            // Without the flag nothing follows the head's block.
            let plain = encoder.encode(&header(), &content(&head, &lip, deflate)).to_vec();
            assert_eq!(decode(&plain).unwrap().tongue, None);
            assert!(plain.len() < bytes.len());
        }
    }

    #[test]
    fn round_trip_with_quantization_bounded_by_half_a_step() {
        let deltas = [
            [0.0, 0.0, 0.0],
            [0.011, -0.2, 0.0],
            [0.0, 0.0, 0.0],
            [0.0004, 0.0, 0.0],
            [-1.0, 2.5, 0.3],
        ];
        let lip = LipRoughness {
            min: 0.1,
            max: 0.4,
            mean: 0.2,
            per_vertex: vec![0.1, 0.3],
        };
        let face = [0.0, 0.5, 1.0, 0.25, 0.0];
        let step = 0.001;
        for deflate in [false, true] {
            let mut encoder = FrameEncoder::default();
            let bytes = encoder
                .encode(
                    &header(),
                    &FrameContent {
                        step,
                        deltas: &deltas,
                        lip: &lip,
                        label: Some("pa"),
                        face: Some(&face),
                        deflate,
                        head: None,
                        jaw: None,
                        tongue: None,
                        folds: None,
                    },
                )
                .to_vec();
            let frame = decode(&bytes).unwrap();
            assert_eq!(frame.header, header());
            assert_eq!(decode_header(&bytes).unwrap(), header());
            assert_eq!(decode_header(&bytes[..40]).unwrap(), header());
            assert!(decode_header(&bytes[..39]).is_err());
            assert!(matches!(
                decode_header(b"FWP1xxxx"),
                Err(DecodeError::Magic { .. })
            ));
            assert_eq!(frame.label.as_deref(), Some("pa"));
            assert_eq!(frame.lip, lip);
            // vertex 3 moves less than half a step: not sent
            assert_eq!(frame.moved.iter().map(|m| m.0).collect::<Vec<_>>(), vec![1, 4]);
            let rest = vec![0.0f32; 15];
            let mut out = Vec::new();
            frame.apply(&rest, &mut out);
            for (v, d) in deltas.iter().enumerate() {
                for k in 0..3 {
                    assert!((out[v * 3 + k] - d[k]).abs() <= 0.5 * step + 1e-7, "{v} {k}");
                }
            }
            let face_back = frame.face.unwrap();
            assert!((face_back[1] - 0.5).abs() < 1.0 / 255.0);
            assert_eq!(face_back[2], 1.0);
        }
    }

    /// A quarter turn about +y (yaw) and a shift.
    const QUARTER_YAW: RigidMotion = RigidMotion {
        rotation: [
            0.0,
            std::f32::consts::FRAC_1_SQRT_2,
            0.0,
            std::f32::consts::FRAC_1_SQRT_2,
        ],
        translation: [1.0, 2.0, 3.0],
    };

    #[test]
    fn head_motion_rotates_then_translates() {
        let p = QUARTER_YAW.apply([1.0, 0.0, 0.0]);
        // +x turns onto -z about +y, then shifts.
        for (got, want) in p.iter().zip([1.0, 2.0, 2.0]) {
            assert!((got - want).abs() < 1e-6, "{p:?}");
        }
        assert_eq!(RigidMotion::IDENTITY.apply([4.0, 5.0, 6.0]), [4.0, 5.0, 6.0]);
    }

    #[test]
    fn head_motion_travels_beside_the_deltas() {
        let deltas = [[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]];
        let lip = LipRoughness::default();
        let still = FrameEncoder::default()
            .encode(&header(), &content(&deltas, &lip, true))
            .to_vec();
        let mut moving = content(&deltas, &lip, true);
        moving.head = Some(QUARTER_YAW);
        let moving = FrameEncoder::default().encode(&header(), &moving).to_vec();
        let open = RigidMotion {
            rotation: [0.2f32.sin(), 0.0, 0.0, 0.2f32.cos()],
            translation: [0.0, -0.5, 0.25],
        };
        let mut with_jaw = content(&deltas, &lip, true);
        with_jaw.head = Some(QUARTER_YAW);
        with_jaw.jaw = Some(open);
        let with_jaw = FrameEncoder::default().encode(&header(), &with_jaw).to_vec();
        assert_eq!(with_jaw.len(), moving.len() + 28);
        let both = decode(&with_jaw).unwrap();
        assert_eq!((both.head, both.jaw), (QUARTER_YAW, open));
        assert_eq!(decode(&moving).unwrap().jaw, RigidMotion::IDENTITY);
        // 28 bytes of motion; the deltas are the same bytes.
        assert_eq!(moving.len(), still.len() + 28);
        assert_eq!(moving[4], still[4] | FLAG_HEAD);
        let frame = decode(&moving).unwrap();
        assert_eq!(frame.head, QUARTER_YAW);
        assert_eq!(decode(&still).unwrap().head, RigidMotion::IDENTITY);
        let (mut local, mut placed) = (Vec::new(), Vec::new());
        let rest = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0];
        frame.apply(&rest, &mut local);
        frame.place(&rest, &mut placed);
        assert_eq!(local, [0.0, 0.0, 0.0, 1.5, 0.0, 0.0]);
        let expected = [1.0, 2.0, 3.0, 1.0, 2.0, 1.5];
        for (got, want) in placed.iter().zip(expected) {
            assert!((got - want).abs() < 1e-6, "{placed:?}");
        }

        // The motion starts after the 65 fixed bytes (no lip values, no label).
        for (bad, problem) in [(f32::NAN, "not finite"), (2.0, "length")] {
            let mut broken = moving.clone();
            broken[65..69].copy_from_slice(&bad.to_le_bytes());
            match decode(&broken) {
                Err(DecodeError::Invalid {
                    field: "head motion",
                    at: 65,
                    problem: text,
                }) => assert!(text.contains(problem), "{text}"),
                other => panic!("{other:?}"),
            }
        }
        assert!(matches!(
            decode(&moving[..80]),
            Err(DecodeError::Truncated {
                field: "head motion",
                ..
            })
        ));
    }

    #[test]
    fn hand_encoded_bytes() {
        let mut encoder = FrameEncoder::default();
        let lip = LipRoughness::default();
        let deltas = [[0.0, 0.0, 0.0], [1.0, -0.5, 0.0], [1.0, 0.0, 0.5]];
        let bytes = encoder.encode(&header(), &content(&deltas, &lip, false));
        // header 52 + lip 12 + lip_count 1 + block length 4, then
        // vertex 1: gap 1, counts +2 -1 0 -> zigzag 4 1 0
        // vertex 2: gap 0, differences 0 +1 +1 -> zigzag 0 2 2
        assert_eq!(&bytes[44..52], &[3, 0, 0, 0, 2, 0, 0, 0]);
        assert_eq!(&bytes[65..69], &[8, 0, 0, 0]);
        assert_eq!(&bytes[69..], &[1, 4, 1, 0, 0, 0, 2, 2]);
    }

    #[test]
    fn deflate_shrinks_smooth_fields() {
        let deltas: Vec<[f32; 3]> = (0..5000).map(|v| [0.5 + v as f32 * 1e-4, -1.0, 0.25]).collect();
        let lip = LipRoughness::default();
        let plain = FrameEncoder::default()
            .encode(&header(), &content(&deltas, &lip, false))
            .len();
        let mut encoder = FrameEncoder::default();
        let packed = encoder.encode(&header(), &content(&deltas, &lip, true)).to_vec();
        assert!(packed.len() * 20 < plain, "{} vs {plain}", packed.len());
        assert_eq!(decode(&packed).unwrap().moved.len(), 5000);
    }

    /// A frame with `gaps` as its delta block (counts all zero), for `vertex_count` vertices.
    fn frame_with_gaps(gaps: &[u64], vertex_count: u32) -> Vec<u8> {
        let lip = LipRoughness::default();
        let mut bytes = FrameEncoder::default()
            .encode(&header(), &content(&[], &lip, false))
            .to_vec();
        bytes[44..48].copy_from_slice(&vertex_count.to_le_bytes());
        bytes[48..52].copy_from_slice(&(gaps.len() as u32).to_le_bytes());
        let mut block = Vec::new();
        for &gap in gaps {
            encode(gap, &mut block);
            block.extend_from_slice(&[0, 0, 0]);
        }
        bytes.truncate(65);
        bytes.extend_from_slice(&(block.len() as u32).to_le_bytes());
        bytes.extend_from_slice(&block);
        bytes
    }

    #[test]
    fn index_gaps_past_the_vertex_count_are_refused_not_wrapped() {
        assert_eq!(decode(&frame_with_gaps(&[0, 2], 4)).unwrap().moved.len(), 2);
        for gaps in [
            vec![5, i64::MAX as u64],
            vec![1 << 63],
            vec![u64::MAX],
            vec![3, u64::MAX],
            vec![u64::from(u32::MAX)],
        ] {
            assert!(
                matches!(
                    decode(&frame_with_gaps(&gaps, 10)),
                    Err(DecodeError::Invalid {
                        field: "index gap",
                        ..
                    })
                ),
                "{gaps:?}"
            );
        }
    }

    #[test]
    fn deltas_beyond_the_count_range_saturate_and_decode() {
        let lip = LipRoughness::default();
        let deltas = [[1e30, -1e30, 0.0], [-1e30, 1e30, f32::NAN], [0.5, 0.0, 0.0]];
        let mut encoder = FrameEncoder::default();
        let bytes = encoder.encode(&header(), &content(&deltas, &lip, false)).to_vec();
        let frame = decode(&bytes).unwrap();
        assert_eq!(
            frame.moved,
            [
                (0, [i32::MAX, i32::MIN, 0]),
                (1, [i32::MIN, i32::MAX, 0]),
                (2, [1, 0, 0])
            ]
        );
    }

    #[test]
    fn malformed_frames_name_the_field() {
        let lip = LipRoughness::default();
        for deflate in [false, true] {
            let mut encoder = FrameEncoder::default();
            let good = encoder
                .encode(&header(), &content(&[[1.0, 0.0, 0.0]], &lip, deflate))
                .to_vec();
            assert!(matches!(
                decode(&good[..10]),
                Err(DecodeError::Truncated { field: "seq", .. })
            ));
            let mut bad = good.clone();
            bad[0] = b'X';
            assert!(matches!(decode(&bad), Err(DecodeError::Magic { .. })));
            let mut long = good.clone();
            long.push(0);
            assert_eq!(decode(&long), Err(DecodeError::Trailing { extra: 1 }));
            let mut huge = good.clone();
            huge[48..52].copy_from_slice(&u32::MAX.to_le_bytes());
            assert!(matches!(
                decode(&huge),
                Err(DecodeError::Invalid { field: "moved", .. })
            ));
        }
        // A deflate bomb: a small block claiming one entry but inflating to megabytes.
        let mut encoder = FrameEncoder::default();
        let mut bomb = encoder
            .encode(&header(), &content(&[[1.0, 0.0, 0.0]], &lip, false))
            .to_vec();
        bomb[4] |= FLAG_DEFLATE;
        let zeros = vec![0u8; 1 << 20];
        let mut compressor = flate2::Compress::new(flate2::Compression::best(), false);
        let mut packed = Vec::with_capacity(1 << 20);
        compressor
            .compress_vec(&zeros, &mut packed, flate2::FlushCompress::Finish)
            .unwrap();
        bomb.truncate(65);
        bomb.extend_from_slice(&(packed.len() as u32).to_le_bytes());
        bomb.extend_from_slice(&packed);
        assert!(matches!(
            decode(&bomb),
            Err(DecodeError::Invalid {
                field: "delta block",
                ..
            })
        ));
    }
}
