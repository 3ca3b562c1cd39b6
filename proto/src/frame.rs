//! The binary frame a viewer receives for every deformed frame: vertex deltas against the
//! rest mesh, quantized and sent only for vertices that moved, plus the lip roughness and,
//! on request, per-vertex face roughness. All numbers little-endian; see PROTOCOL.md.
//!
//! ```text
//! offset  size  field
//!      0     4  magic "FWF1"
//!      4     1  flags: bit 0 face roughness present, bit 1 label present
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
//!      .     .  moved x { varint index gap, 3 x zigzag varint dx dy dz counts }
//!      .     .  if face roughness: f32 max, then vertex_count x u8 (value = byte / 255 * max)
//! ```
//! The index gap is `index - previous index - 1` (previous = -1 before the first), so
//! consecutive moved vertices cost one byte of index.

use crate::varint::{encode, unzigzag, zigzag};
use crate::{DecodeError, Reader};

pub const FRAME_MAGIC: [u8; 4] = *b"FWF1";
const FLAG_FACE: u8 = 1;
const FLAG_LABEL: u8 = 2;

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
}

impl ViewerFrame {
    /// Rest positions plus the decoded deltas (flat xyz arrays, head units).
    pub fn apply(&self, rest: &[f32], out: &mut Vec<f32>) {
        out.clear();
        out.extend_from_slice(rest);
        for &(v, q) in &self.moved {
            for (k, &count) in q.iter().enumerate() {
                out[v as usize * 3 + k] += count as f32 * self.step;
            }
        }
    }
}

/// Encodes frames into a reused buffer.
#[derive(Debug, Default)]
pub struct FrameEncoder {
    buffer: Vec<u8>,
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
}

impl FrameEncoder {
    /// Encodes one frame; the returned slice lives until the next call.
    pub fn encode(&mut self, header: &FrameHeader, content: &FrameContent<'_>) -> &[u8] {
        let out = &mut self.buffer;
        out.clear();
        out.extend_from_slice(&FRAME_MAGIC);
        let label = content.label.filter(|l| !l.is_empty());
        let flags =
            if content.face.is_some() { FLAG_FACE } else { 0 } | if label.is_some() { FLAG_LABEL } else { 0 };
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
            let mut end = label.len().min(255);
            while !label.is_char_boundary(end) {
                end -= 1;
            }
            out.push(end as u8);
            out.extend_from_slice(&label.as_bytes()[..end]);
        }
        let inverse = 1.0 / content.step;
        let mut moved = 0u32;
        let mut previous: i64 = -1;
        for (v, d) in content.deltas.iter().enumerate() {
            let q = d.map(|x| (x * inverse).round() as i64);
            if q == [0, 0, 0] {
                continue;
            }
            encode((v as i64 - previous - 1) as u64, out);
            for c in q {
                encode(zigzag(c), out);
            }
            previous = v as i64;
            moved += 1;
        }
        out[moved_at..moved_at + 4].copy_from_slice(&moved.to_le_bytes());
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

/// Decodes a viewer frame, checking every length.
pub fn decode(bytes: &[u8]) -> Result<ViewerFrame, DecodeError> {
    let mut r = Reader::new(bytes);
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
    let step = r.f32("step")?;
    let vertex_count = r.u32("vertex_count")?;
    let moved_count = r.u32("moved")?;
    let (min, max, mean) = (r.f32("lip min")?, r.f32("lip max")?, r.f32("lip mean")?);
    let lip_count = r.u8("lip_count")?;
    let per_vertex = (0..lip_count)
        .map(|_| r.f32("lip roughness"))
        .collect::<Result<Vec<_>, _>>()?;
    let label = if flags & FLAG_LABEL != 0 {
        let len = r.u8("label length")? as usize;
        let at = r.position();
        let text = r.take(len, "label")?;
        Some(
            String::from_utf8(text.to_vec()).map_err(|_| DecodeError::Invalid {
                field: "label",
                at,
                problem: "not UTF-8".into(),
            })?,
        )
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
    // Each entry takes at least 4 bytes: refuse counts the message cannot hold before
    // allocating for them.
    if moved_count as usize > r.remaining() / 4 {
        return Err(DecodeError::Invalid {
            field: "moved",
            at: 48,
            problem: format!("{moved_count} entries cannot fit in {} bytes", r.remaining()),
        });
    }
    let mut moved = Vec::with_capacity(moved_count as usize);
    let mut previous: i64 = -1;
    for _ in 0..moved_count {
        let at = r.position();
        let index = previous + 1 + r.varint("index gap")? as i64;
        if index >= i64::from(vertex_count) {
            return Err(DecodeError::Invalid {
                field: "index gap",
                at,
                problem: format!("vertex {index} is out of range ({vertex_count} vertices)"),
            });
        }
        let mut q = [0i32; 3];
        for c in q.iter_mut() {
            let at = r.position();
            *c = i32::try_from(unzigzag(r.varint("delta")?)).map_err(|_| DecodeError::Invalid {
                field: "delta",
                at,
                problem: "count out of range".into(),
            })?;
        }
        moved.push((index as u32, q));
        previous = index;
    }
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
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header() -> FrameHeader {
        FrameHeader {
            seq: 42,
            producer_time_s: 1.5,
            server_receive_us: 1_000_000,
            server_send_us: 1_000_250,
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
        let mut encoder = FrameEncoder::default();
        let step = 0.001;
        let bytes = encoder
            .encode(
                &header(),
                &FrameContent {
                    step,
                    deltas: &deltas,
                    lip: &lip,
                    label: Some("pa"),
                    face: Some(&face),
                },
            )
            .to_vec();
        let frame = decode(&bytes).unwrap();
        assert_eq!(frame.header, header());
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

    #[test]
    fn hand_encoded_bytes() {
        let mut encoder = FrameEncoder::default();
        let lip = LipRoughness::default();
        let bytes = encoder.encode(
            &header(),
            &FrameContent {
                step: 0.5,
                deltas: &[[0.0, 0.0, 0.0], [1.0, -0.5, 0.0]],
                lip: &lip,
                label: None,
                face: None,
            },
        );
        // header 52 + lip 12 + lip_count 1, then gap 1, counts +2 -1 0 -> zigzag 4 1 0
        assert_eq!(bytes.len(), 65 + 4);
        assert_eq!(&bytes[65..], &[1, 4, 1, 0]);
        assert_eq!(&bytes[44..52], &[2, 0, 0, 0, 1, 0, 0, 0]);
    }

    #[test]
    fn malformed_frames_name_the_field() {
        let mut encoder = FrameEncoder::default();
        let lip = LipRoughness::default();
        let good = encoder
            .encode(
                &header(),
                &FrameContent {
                    step: 1.0,
                    deltas: &[[1.0, 0.0, 0.0]],
                    lip: &lip,
                    label: None,
                    face: None,
                },
            )
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
}
