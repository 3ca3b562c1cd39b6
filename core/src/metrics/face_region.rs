//! The "face vertices" ground-truth error is measured over: head vertices within a surface
//! distance of [`FACE_RADIUS_MM`] of the anchor of some mask vertex that a mask triangle
//! uses (the 9 loose CANDIDE-3 vertices are left out). This is the part of the head the
//! deformation algorithms can reach, measured the way they measure reach (along the
//! surface); it leaves out the scalp, ears and neck, whose zero error would dilute the RMS,
//! and does not depend on the expression being scored, so every target and algorithm is
//! measured over the same vertices.

use super::region::{anchor_of, radius_in_head_units, RegionError};
use crate::fit::Anchors;
use crate::head::{Head, SurfaceDistance};
use crate::mask::Mask;

/// Surface radius around the used mask anchors, millimetres. Large enough that no vertex
/// inside the fitted mask's outline is left out between anchors (docs/METRICS.md).
pub const FACE_RADIUS_MM: f32 = 30.0;

/// The head vertices ground-truth error is measured over, ascending.
#[derive(Debug, Clone, PartialEq)]
pub struct FaceVertices {
    radius_mm: f32,
    vertices: Vec<u32>,
}

impl FaceVertices {
    /// The face at the standard radius, [`FACE_RADIUS_MM`].
    pub fn new(
        head: &Head,
        mask: &Mask,
        anchors: &Anchors,
        mm_per_unit: f32,
    ) -> Result<FaceVertices, RegionError> {
        FaceVertices::with_radius(head, mask, anchors, mm_per_unit, FACE_RADIUS_MM)
    }

    /// The face at another surface radius (millimetres).
    pub fn with_radius(
        head: &Head,
        mask: &Mask,
        anchors: &Anchors,
        mm_per_unit: f32,
        radius_mm: f32,
    ) -> Result<FaceVertices, RegionError> {
        let radius = radius_in_head_units(radius_mm, mm_per_unit)?;
        let vertex_count = head.positions.len();
        let sources = mask
            .used_vertices()
            .iter()
            .enumerate()
            .filter(|(_, &used)| used)
            .map(|(j, _)| anchor_of(anchors, j, vertex_count).map(|v| (v, 0.0)))
            .collect::<Result<Vec<_>, _>>()?;
        let mut search = SurfaceDistance::new(vertex_count);
        let mut vertices = search.run(&head.topology, &sources, radius).to_vec();
        vertices.sort_unstable();
        Ok(FaceVertices { radius_mm, vertices })
    }

    /// The surface radius, millimetres.
    pub fn radius_mm(&self) -> f32 {
        self.radius_mm
    }

    /// The face vertices (head vertex indexes), ascending.
    pub fn vertices(&self) -> &[u32] {
        &self.vertices
    }

    /// The face triangles: the head triangles whose three corners are face vertices,
    /// ascending.
    pub fn triangles(&self, head: &Head) -> Vec<u32> {
        triangles_within(head, &self.vertices)
    }
}

/// The head triangles whose three corners are among `vertices`, ascending.
pub(super) fn triangles_within(head: &Head, vertices: &[u32]) -> Vec<u32> {
    let mut inside = vec![false; head.positions.len()];
    for &v in vertices {
        inside[v as usize] = true;
    }
    (0..head.triangles.len() as u32)
        .filter(|&t| head.triangles[t as usize].iter().all(|&v| inside[v as usize]))
        .collect()
}
