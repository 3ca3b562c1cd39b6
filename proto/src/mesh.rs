//! The rest mesh a viewer downloads once (`GET /v1/heads/{id}/mesh.bin`, `FWM1`):
//! positions in head units, triangles, and the millimetres per head unit. Viewer frames
//! carry deltas against these positions.
//!
//! ```text
//! offset  size  field
//!      0     4  magic "FWM1"
//!      4     4  vertex count V (u32)
//!      8     4  triangle count T (u32)
//!     12     4  mm per head unit (f32)
//!     16  12 V  positions, x y z f32 each (head units)
//! 16+12V  12 T  triangles, 3 u32 vertex indices each (0-based)
//! ```
//! Little-endian throughout.

use crate::{DecodeError, Reader};

pub const MESH_MAGIC: [u8; 4] = *b"FWM1";

/// A rest mesh as `mesh.bin` carries it.
#[derive(Debug, Clone, PartialEq)]
pub struct RestMesh {
    pub mm_per_unit: f32,
    /// x y z per vertex, head units.
    pub positions: Vec<[f32; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

impl RestMesh {
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(16 + 12 * (self.positions.len() + self.triangles.len()));
        out.extend_from_slice(&MESH_MAGIC);
        out.extend_from_slice(&(self.positions.len() as u32).to_le_bytes());
        out.extend_from_slice(&(self.triangles.len() as u32).to_le_bytes());
        out.extend_from_slice(&self.mm_per_unit.to_le_bytes());
        for p in &self.positions {
            for x in p {
                out.extend_from_slice(&x.to_le_bytes());
            }
        }
        for t in &self.triangles {
            for v in t {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        out
    }

    /// Decodes `mesh.bin`, checking the counts against the length and every triangle's
    /// indices against the vertex count.
    pub fn decode(bytes: &[u8]) -> Result<RestMesh, DecodeError> {
        let mut r = Reader::new(bytes);
        let magic = r.array::<4>("magic")?;
        if magic != MESH_MAGIC {
            return Err(DecodeError::Magic {
                found: magic,
                expected: "FWM1",
            });
        }
        let vertices = r.u32("vertex count")? as usize;
        let triangles = r.u32("triangle count")? as usize;
        let mm_per_unit = r.f32("mm per unit")?;
        let needed = 12u64 * (vertices as u64 + triangles as u64);
        if needed != r.remaining() as u64 {
            return Err(DecodeError::Invalid {
                field: "counts",
                at: 4,
                problem: format!(
                    "{vertices} vertices and {triangles} triangles need {needed} bytes after the header; the message has {}",
                    r.remaining()
                ),
            });
        }
        let mut mesh = RestMesh {
            mm_per_unit,
            positions: Vec::with_capacity(vertices),
            triangles: Vec::with_capacity(triangles),
        };
        for _ in 0..vertices {
            mesh.positions
                .push([r.f32("position")?, r.f32("position")?, r.f32("position")?]);
        }
        for _ in 0..triangles {
            let at = r.position();
            let t = [r.u32("triangle")?, r.u32("triangle")?, r.u32("triangle")?];
            if let Some(&v) = t.iter().find(|&&v| v as usize >= vertices) {
                return Err(DecodeError::Invalid {
                    field: "triangle",
                    at,
                    problem: format!("vertex index {v} is out of range (0..{vertices})"),
                });
            }
            mesh.triangles.push(t);
        }
        r.finish()?;
        Ok(mesh)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_hand_checked_layout() {
        let mesh = RestMesh {
            mm_per_unit: 2.5,
            positions: vec![[0.0, 1.0, 2.0], [3.0, 4.0, 5.0], [-1.0, 0.5, 0.25]],
            triangles: vec![[0, 1, 2]],
        };
        let bytes = mesh.encode();
        assert_eq!(bytes.len(), 16 + 36 + 12);
        assert_eq!(&bytes[0..4], b"FWM1");
        assert_eq!(bytes[4..8], 3u32.to_le_bytes());
        assert_eq!(bytes[8..12], 1u32.to_le_bytes());
        assert_eq!(bytes[12..16], 2.5f32.to_le_bytes());
        assert_eq!(bytes[16 + 12..16 + 16], 3.0f32.to_le_bytes());
        assert_eq!(bytes[52..56], 0u32.to_le_bytes());
        assert_eq!(bytes[60..64], 2u32.to_le_bytes());
        assert_eq!(RestMesh::decode(&bytes).unwrap(), mesh);
    }

    #[test]
    fn refuses_wrong_counts_and_indices() {
        let mesh = RestMesh {
            mm_per_unit: 1.0,
            positions: vec![[0.0; 3]; 3],
            triangles: vec![[0, 1, 3]],
        };
        let bytes = mesh.encode();
        let err = RestMesh::decode(&bytes).unwrap_err();
        assert!(
            err.to_string().contains("vertex index 3 is out of range"),
            "{err}"
        );
        let err = RestMesh::decode(&bytes[..bytes.len() - 1]).unwrap_err();
        assert!(err.to_string().contains("need 48 bytes"), "{err}");
        let mut huge = bytes.clone();
        huge[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(RestMesh::decode(&huge).is_err());
    }
}
