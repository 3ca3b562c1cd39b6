//! The lip region roughness is measured on: for each of the 18 CANDIDE-3 lip vertices, the
//! head triangles with a corner within 5 mm *along the surface* of that vertex's anchor
//! (ALGORITHMS.md section 3). Surface distance keeps the upper lip's patches off the lower
//! lip even where the lips touch. Built once per head and fit.

use super::region::{anchor_of, radius_in_head_units, RegionError};
use crate::fit::Anchors;
use crate::head::{Head, SurfaceDistance};
use crate::mask::LIP_VERTICES;

/// Surface radius around each lip anchor, millimetres.
pub const LIP_RADIUS_MM: f32 = 5.0;

/// The head triangles near each lip vertex's anchor, and their union.
#[derive(Debug, Clone, PartialEq)]
pub struct LipRegion {
    radius_mm: f32,
    /// Triangles of `LIP_VERTICES[k]` are `members[offsets[k]..offsets[k + 1]]`, ascending.
    offsets: [u32; LIP_VERTICES.len() + 1],
    members: Vec<u32>,
    union: Vec<u32>,
}

impl LipRegion {
    /// The region at the standard radius, [`LIP_RADIUS_MM`].
    pub fn new(head: &Head, anchors: &Anchors, mm_per_unit: f32) -> Result<LipRegion, RegionError> {
        LipRegion::with_radius(head, anchors, mm_per_unit, LIP_RADIUS_MM)
    }

    /// The region at another surface radius (millimetres).
    pub fn with_radius(
        head: &Head,
        anchors: &Anchors,
        mm_per_unit: f32,
        radius_mm: f32,
    ) -> Result<LipRegion, RegionError> {
        let radius = radius_in_head_units(radius_mm, mm_per_unit)?;
        let vertex_count = head.positions.len();
        let mut search = SurfaceDistance::new(vertex_count);
        let mut offsets = [0u32; LIP_VERTICES.len() + 1];
        let mut members = Vec::new();
        for (k, &mask_vertex) in LIP_VERTICES.iter().enumerate() {
            let vertex = anchor_of(anchors, mask_vertex, vertex_count)?;
            search.run(&head.topology, &[(vertex, 0.0)], radius);
            let start = members.len();
            members.extend(
                head.triangles
                    .iter()
                    .enumerate()
                    .filter(|(_, corners)| {
                        corners
                            .iter()
                            .any(|&c| (c as usize) < vertex_count && search.distance(c) <= radius)
                    })
                    .map(|(t, _)| t as u32),
            );
            if members.len() == start {
                return Err(RegionError::EmptyLipPatch {
                    mask_vertex,
                    vertex,
                    radius_mm,
                });
            }
            offsets[k + 1] = members.len() as u32;
        }
        let mut union = members.clone();
        union.sort_unstable();
        union.dedup();
        Ok(LipRegion {
            radius_mm,
            offsets,
            members,
            union,
        })
    }

    /// The surface radius the region was built with, millimetres.
    pub fn radius_mm(&self) -> f32 {
        self.radius_mm
    }

    /// Each lip vertex (in [`LIP_VERTICES`] order) with its head triangles, ascending.
    pub fn per_lip_vertex(&self) -> impl Iterator<Item = (usize, &[u32])> + '_ {
        LIP_VERTICES
            .iter()
            .zip(self.offsets.windows(2))
            .map(|(&mask_vertex, range)| (mask_vertex, &self.members[range[0] as usize..range[1] as usize]))
    }

    /// Every lip triangle once, ascending.
    pub fn union(&self) -> &[u32] {
        &self.union
    }

    /// The vertices of `head` (the head the region was found on) of the triangles of the
    /// lip vertices that `keep` keeps (by mask vertex), each once, ascending.
    pub fn head_vertices(&self, head: &Head, keep: impl Fn(usize) -> bool) -> Vec<u32> {
        let mut vertices: Vec<u32> = self
            .per_lip_vertex()
            .filter(|&(mask_vertex, _)| keep(mask_vertex))
            .flat_map(|(_, triangles)| triangles.iter().flat_map(|&t| head.triangles[t as usize]))
            .collect();
        vertices.sort_unstable();
        vertices.dedup();
        vertices
    }
}
