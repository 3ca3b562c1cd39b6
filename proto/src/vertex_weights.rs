//! A weight per vertex of a mesh (`FWL1`), for a viewer that draws part of the mesh in its
//! own colour: where a head's lips are (`GET /v1/heads/{id}/lips.bin`, one weight per
//! rest-mesh vertex, 0 for skin and 255 for lip with a soft edge between; the snapshot's
//! `lip_tint` names it) and which vertices of a tongue part are the tongue itself rather
//! than the gums or the floor of the mouth the same mesh holds
//! (`GET /v1/heads/{id}/parts/{part}/tongue.bin`, one weight per part vertex, 255 tongue,
//! 0 not; the part's `tongue_proper` in the snapshot names it).
//!
//! ```text
//! offset  size  field
//!      0     4  magic "FWL1"
//!      4     4  vertex count V (u32), as the mesh's
//!      8     V  weights, u8 each, in the mesh's vertex order
//! ```
//! Little-endian throughout.

use crate::{DecodeError, Reader, Writer};

pub const VERTEX_WEIGHTS_MAGIC: [u8; 4] = *b"FWL1";

/// The weights as `lips.bin` and `tongue.bin` carry them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct VertexWeights {
    /// Per mesh vertex: 0 (skin, gums) .. 255 (lip, tongue).
    pub weights: Vec<u8>,
}

impl VertexWeights {
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(8 + self.weights.len());
        out.extend_from_slice(&VERTEX_WEIGHTS_MAGIC);
        out.put_u32(self.weights.len() as u32);
        out.extend_from_slice(&self.weights);
        out
    }

    /// Decodes `lips.bin` or `tongue.bin`, checking its count against its length.
    pub fn decode(bytes: &[u8]) -> Result<VertexWeights, DecodeError> {
        let mut r = Reader::new(bytes);
        let magic = r.array::<4>("magic")?;
        if magic != VERTEX_WEIGHTS_MAGIC {
            return Err(DecodeError::Magic {
                found: magic,
                expected: "FWL1",
            });
        }
        let vertices = r.u32("vertex count")? as usize;
        if vertices != r.remaining() {
            return Err(DecodeError::Invalid {
                field: "vertex count",
                at: 4,
                problem: format!(
                    "{vertices} vertices need {vertices} bytes after the header; the message has {}",
                    r.remaining()
                ),
            });
        }
        let weights = r.take(vertices, "weights")?.to_vec();
        r.finish()?;
        Ok(VertexWeights { weights })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_hand_checked_layout() {
        let tint = VertexWeights {
            weights: vec![0, 128, 255],
        };
        let bytes = tint.encode();
        assert_eq!(bytes, [b'F', b'W', b'L', b'1', 3, 0, 0, 0, 0, 128, 255]);
        assert_eq!(VertexWeights::decode(&bytes).unwrap(), tint);
    }

    #[test]
    fn a_count_the_bytes_do_not_hold_is_refused() {
        let mut bytes = VertexWeights { weights: vec![1, 2] }.encode();
        bytes.pop();
        let error = VertexWeights::decode(&bytes).unwrap_err();
        assert_eq!(error.field(), Some("vertex count"));
        assert!(error.to_string().contains("2 vertices need 2 bytes"), "{error}");
        assert!(matches!(
            VertexWeights::decode(b"FWM1\0\0\0\0"),
            Err(DecodeError::Magic { expected: "FWL1", .. })
        ));
        assert_eq!(
            VertexWeights::decode(b"FWL1\0\0").unwrap_err().field(),
            Some("vertex count")
        );
    }
}
