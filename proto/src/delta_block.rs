//! The delta block: the quantized deltas of the vertices that moved, as varint index gaps
//! and zigzag count differences, raw-deflated (RFC 1951) when asked. Both viewer frame
//! layouts carry it, for the head and for each shaped part.
//!
//! ```text
//! moved x { varint index - previous index - 1 (previous starts at -1),
//!           3 x zigzag varint count - previous entry's count (starting from 0, 0, 0) }
//! ```
//! Consecutive moved vertices cost one byte of index; neighbouring vertices move alike, so
//! the many small differences deflate well (the syllable stream on the scan: 29 kB -> 8.4 kB
//! per frame for RBF).

use crate::varint::{unzigzag, zigzag};
use crate::{DecodeError, Reader, Writer};

/// One moved vertex: its index and its quantized delta counts (delta = counts x step).
pub type MovedVertex = (u32, [i32; 3]);

/// Encodes delta blocks into reused buffers.
#[derive(Default)]
pub(crate) struct DeltaBlockEncoder {
    block: Vec<u8>,
    compressor: Option<flate2::Compress>,
}

impl DeltaBlockEncoder {
    /// An encoder whose buffer holds the block of `vertices` moved vertices.
    pub(crate) fn for_vertices(vertices: usize) -> DeltaBlockEncoder {
        DeltaBlockEncoder {
            block: Vec::with_capacity(vertices * MAX_ENTRY_BYTES),
            compressor: None,
        }
    }

    /// The most bytes `out` needs for the length and block of `vertices` vertices, deflated
    /// or not.
    pub(crate) fn worst_case(vertices: usize) -> usize {
        let block = vertices * MAX_ENTRY_BYTES;
        // Deflate's worst case stays under the stored size plus its 5-byte block headers;
        // the loop reserves half a block and 64 bytes more before each call.
        4 + block + block / 2 + 64 + 5 * (block / 16_384 + 1)
    }

    /// Appends the block's length (u32) and the block (deflated if asked) for `deltas`
    /// quantized by `step` (head units per count); returns how many entries (moved
    /// vertices) it holds.
    pub(crate) fn write(&mut self, out: &mut Vec<u8>, deltas: &[[f32; 3]], step: f32, deflate: bool) -> u32 {
        let block = &mut self.block;
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
            block.put_varint((v as i64 - previous - 1) as u64);
            for k in 0..3 {
                block.put_varint(zigzag(q[k] - previous_q[k]));
            }
            previous = v as i64;
            previous_q = q;
            moved += 1;
        }
        let length_slot = out.slot_u32();
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
        out.fill_u32(length_slot, length);
        moved
    }
}

/// Gap and three counts, each a LEB128 varint of at most 5 bytes (u32 and zigzag i32).
const MAX_ENTRY_BYTES: usize = 20;

/// `x.round() as i64`, without the call to the C library's `roundf` that `f32::round`
/// compiles to on x86-64 (a tenth of the frame encoder's time). In f64 the half added is
/// exact for every f32, so the result is the same for every input, NaN (0) and
/// infinities (saturated) included.
fn round_half_away(x: f32) -> i64 {
    let x = f64::from(x);
    (x + 0.5f64.copysign(x)) as i64
}

/// Where a block's `moved` count was read, to name it in errors.
pub(crate) struct MovedField {
    pub(crate) field: &'static str,
    pub(crate) at: usize,
}

/// Reads a block's length and the block: `moved_count` entries of vertices below
/// `vertex_count`, inflated first if `deflated`.
pub(crate) fn read(
    r: &mut Reader<'_>,
    deflated: bool,
    moved_count: u32,
    vertex_count: u32,
    moved_field: MovedField,
) -> Result<Vec<MovedVertex>, DecodeError> {
    if moved_count > vertex_count {
        return Err(DecodeError::Invalid {
            field: moved_field.field,
            at: moved_field.at,
            problem: format!("{moved_count} moved of {vertex_count} vertices"),
        });
    }
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
            field: moved_field.field,
            at: moved_field.at,
            problem: format!("{moved_count} entries cannot fit in {} bytes", block.len()),
        });
    }
    let mut entries = Reader::within(block, block_at);
    let mut moved = Vec::with_capacity(moved_count as usize);
    // The lowest index the next entry may have: one past the previous entry's.
    let mut next: u32 = 0;
    let mut previous_q = [0i64; 3];
    for _ in 0..moved_count {
        let at = entries.position();
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
            let at = entries.position();
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

    fn block_of(gaps: &[u64]) -> Vec<u8> {
        let mut block = Vec::new();
        for &gap in gaps {
            block.put_varint(gap);
            block.extend_from_slice(&[0, 0, 0]);
        }
        let mut out = Vec::new();
        out.put_u32(block.len() as u32);
        out.extend_from_slice(&block);
        out
    }

    fn read_gaps(gaps: &[u64], vertex_count: u32) -> Result<Vec<MovedVertex>, DecodeError> {
        let bytes = block_of(gaps);
        let moved = MovedField {
            field: "moved",
            at: 0,
        };
        read(
            &mut Reader::new(&bytes),
            false,
            gaps.len() as u32,
            vertex_count,
            moved,
        )
    }

    #[test]
    fn hand_encoded_block() {
        let mut out = Vec::new();
        let deltas = [[0.0, 0.0, 0.0], [1.0, -0.5, 0.0], [1.0, 0.0, 0.5]];
        let moved = DeltaBlockEncoder::default().write(&mut out, &deltas, 0.5, false);
        // vertex 1: gap 1, counts +2 -1 0 -> zigzag 4 1 0
        // vertex 2: gap 0, differences 0 +1 +1 -> zigzag 0 2 2
        assert_eq!(moved, 2);
        assert_eq!(out, [8, 0, 0, 0, 1, 4, 1, 0, 0, 0, 2, 2]);
        let field = MovedField {
            field: "moved",
            at: 0,
        };
        let back = read(&mut Reader::new(&out), false, 2, 3, field).unwrap();
        assert_eq!(back, [(1, [2, -1, 0]), (2, [2, 0, 1])]);
    }

    #[test]
    fn index_gaps_past_the_vertex_count_are_refused_not_wrapped() {
        assert_eq!(read_gaps(&[0, 2], 4).unwrap().len(), 2);
        for gaps in [
            vec![5, i64::MAX as u64],
            vec![1 << 63],
            vec![u64::MAX],
            vec![3, u64::MAX],
            vec![u64::from(u32::MAX)],
        ] {
            assert!(
                matches!(
                    read_gaps(&gaps, 10),
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
        let deltas = [[1e30, -1e30, 0.0], [-1e30, 1e30, f32::NAN], [0.5, 0.0, 0.0]];
        let mut out = Vec::new();
        let moved = DeltaBlockEncoder::default().write(&mut out, &deltas, 0.5, false);
        let field = MovedField {
            field: "moved",
            at: 0,
        };
        assert_eq!(
            read(&mut Reader::new(&out), false, moved, 3, field).unwrap(),
            [
                (0, [i32::MAX, i32::MIN, 0]),
                (1, [i32::MIN, i32::MAX, 0]),
                (2, [1, 0, 0])
            ]
        );
    }

    #[test]
    fn a_deflate_bomb_is_refused() {
        // A small block claiming one entry but inflating to a megabyte.
        let zeros = vec![0u8; 1 << 20];
        let mut compressor = flate2::Compress::new(flate2::Compression::best(), false);
        let mut packed = Vec::with_capacity(1 << 20);
        compressor
            .compress_vec(&zeros, &mut packed, flate2::FlushCompress::Finish)
            .unwrap();
        let mut bytes = Vec::new();
        bytes.put_u32(packed.len() as u32);
        bytes.extend_from_slice(&packed);
        let field = MovedField {
            field: "moved",
            at: 0,
        };
        assert!(matches!(
            read(&mut Reader::new(&bytes), true, 1, 10, field),
            Err(DecodeError::Invalid {
                field: "delta block",
                ..
            })
        ));
    }

    #[test]
    fn deflate_shrinks_smooth_fields() {
        let deltas: Vec<[f32; 3]> = (0..5000).map(|v| [0.5 + v as f32 * 1e-4, -1.0, 0.25]).collect();
        let (mut plain, mut packed) = (Vec::new(), Vec::new());
        let mut encoder = DeltaBlockEncoder::default();
        encoder.write(&mut plain, &deltas, 0.5, false);
        let moved = encoder.write(&mut packed, &deltas, 0.5, true);
        assert!(
            packed.len() * 20 < plain.len(),
            "{} vs {}",
            packed.len(),
            plain.len()
        );
        let field = MovedField {
            field: "moved",
            at: 0,
        };
        assert_eq!(
            read(&mut Reader::new(&packed), true, moved, 5000, field)
                .unwrap()
                .len(),
            5000
        );
    }
}
