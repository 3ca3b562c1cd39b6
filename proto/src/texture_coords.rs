//! Where a head's rest mesh sits on its texture, for a viewer that draws the texture
//! (`GET /v1/heads/{id}/uv.bin`, `FWU1`): the texture coordinates, and for each triangle
//! of the rest mesh (in `mesh.bin`'s order) the coordinate of each corner, so that a
//! vertex on a seam takes one coordinate on each side. The snapshot names the path
//! (`texture.uv`).
//!
//! ```text
//! offset  size  field
//!      0     4  magic "FWU1"
//!      4     4  coordinate count C (u32)
//!      8     4  triangle count T (u32), as the rest mesh's
//!     12    8C  coordinates, u v f32 each (v up, as OBJ writes them)
//! 12 + 8C   12T  corners, 3 u32 coordinate indices per triangle
//! ```
//! Little-endian throughout.

use crate::{DecodeError, Reader, Writer};

pub const TEXTURE_COORDS_MAGIC: [u8; 4] = *b"FWU1";

/// The texture coordinates as `uv.bin` carries them.
#[derive(Debug, Clone, PartialEq)]
pub struct TextureCoords {
    pub coords: Vec<[f32; 2]>,
    /// Per rest-mesh triangle, its corners' indices into `coords`.
    pub corners: Vec<[u32; 3]>,
}

impl TextureCoords {
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(12 + 8 * self.coords.len() + 12 * self.corners.len());
        out.extend_from_slice(&TEXTURE_COORDS_MAGIC);
        out.put_u32(self.coords.len() as u32);
        out.put_u32(self.corners.len() as u32);
        for &[u, v] in &self.coords {
            out.put_f32(u);
            out.put_f32(v);
        }
        for corner in self.corners.iter().flatten() {
            out.put_u32(*corner);
        }
        out
    }

    /// Decodes `uv.bin`, checking its counts against its length and every corner against
    /// the coordinates.
    pub fn decode(bytes: &[u8]) -> Result<TextureCoords, DecodeError> {
        let mut r = Reader::new(bytes);
        let magic = r.array::<4>("magic")?;
        if magic != TEXTURE_COORDS_MAGIC {
            return Err(DecodeError::Magic {
                found: magic,
                expected: "FWU1",
            });
        }
        let count = r.u32("coordinate count")? as usize;
        let triangles = r.u32("triangle count")? as usize;
        let needed = count as u64 * 8 + triangles as u64 * 12;
        if needed != r.remaining() as u64 {
            return Err(DecodeError::Invalid {
                field: "coordinate count",
                at: 4,
                problem: format!(
                    "{count} coordinates and {triangles} triangles need {needed} bytes after the header; the message has {}",
                    r.remaining()
                ),
            });
        }
        let mut coords = Vec::with_capacity(count);
        for _ in 0..count {
            coords.push([r.f32("coordinates")?, r.f32("coordinates")?]);
        }
        let mut corners = Vec::with_capacity(triangles);
        for t in 0..triangles {
            let at = 12 + 8 * count + 12 * t;
            let mut corner = [0u32; 3];
            for slot in &mut corner {
                *slot = r.u32("corners")?;
                if *slot as usize >= count {
                    return Err(DecodeError::Invalid {
                        field: "corners",
                        at,
                        problem: format!("triangle {t} names coordinate {slot}; there are {count}"),
                    });
                }
            }
            corners.push(corner);
        }
        r.finish()?;
        Ok(TextureCoords { coords, corners })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_hand_checked_layout() {
        let uv = TextureCoords {
            coords: vec![[0.0, 1.0], [0.5, 0.25]],
            corners: vec![[0, 1, 1]],
        };
        let bytes = uv.encode();
        let mut expected = b"FWU1".to_vec();
        expected.extend_from_slice(&[2, 0, 0, 0, 1, 0, 0, 0]);
        for x in [0.0f32, 1.0, 0.5, 0.25] {
            expected.extend_from_slice(&x.to_le_bytes());
        }
        expected.extend_from_slice(&[0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0]);
        assert_eq!(bytes, expected);
        assert_eq!(TextureCoords::decode(&bytes).unwrap(), uv);
    }

    #[test]
    fn counts_the_bytes_do_not_hold_and_corners_out_of_range_are_refused() {
        let uv = TextureCoords {
            coords: vec![[0.0, 1.0]],
            corners: vec![[0, 0, 0]],
        };
        let mut short = uv.encode();
        short.pop();
        assert_eq!(
            TextureCoords::decode(&short).unwrap_err().field(),
            Some("coordinate count")
        );
        let bad = TextureCoords {
            corners: vec![[0, 1, 0]],
            ..uv
        };
        let error = TextureCoords::decode(&bad.encode()).unwrap_err();
        assert_eq!(error.field(), Some("corners"));
        assert!(error.to_string().contains("names coordinate 1"), "{error}");
    }
}
