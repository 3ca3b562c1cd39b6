//! What the lip and face regions share: checking the scale, the radius and the anchors
//! they grow from, with errors that name the mask vertex at fault.

use crate::fit::Anchors;

/// Why a lip or face region cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RegionError {
    #[error("mm_per_unit must be a positive number, found {0}")]
    Scale(f32),
    #[error("the region radius must be a non-negative number of millimetres, found {0}")]
    Radius(f32),
    #[error("mask vertex {mask_vertex} has no anchor: the anchors cover {count} mask vertices")]
    MissingAnchor { mask_vertex: usize, count: usize },
    #[error(
        "mask vertex {mask_vertex} is anchored to head vertex {vertex}, but the head has {count} vertices"
    )]
    AnchorOutOfRange {
        mask_vertex: usize,
        vertex: u32,
        count: usize,
    },
    #[error("no head triangle has a corner within {radius_mm} mm of lip vertex {mask_vertex}'s anchor (head vertex {vertex})")]
    EmptyLipPatch {
        mask_vertex: usize,
        vertex: u32,
        radius_mm: f32,
    },
    #[error("region triangle {triangle} is not a head triangle: the head has {triangles}")]
    TriangleOutOfRange { triangle: u32, triangles: usize },
    #[error("a pose of {found} vertices for a head of {expected}")]
    PoseLength { found: usize, expected: usize },
}

/// The surface radius in head units, after checking both numbers.
pub(crate) fn radius_in_head_units(radius_mm: f32, mm_per_unit: f32) -> Result<f32, RegionError> {
    if !(mm_per_unit.is_finite() && mm_per_unit > 0.0) {
        return Err(RegionError::Scale(mm_per_unit));
    }
    if !(radius_mm.is_finite() && radius_mm >= 0.0) {
        return Err(RegionError::Radius(radius_mm));
    }
    Ok(radius_mm / mm_per_unit)
}

/// The head vertex anchoring `mask_vertex`, checked against the head's vertex count.
pub(crate) fn anchor_of(
    anchors: &Anchors,
    mask_vertex: usize,
    vertex_count: usize,
) -> Result<u32, RegionError> {
    let &vertex = anchors
        .vertex
        .get(mask_vertex)
        .ok_or(RegionError::MissingAnchor {
            mask_vertex,
            count: anchors.vertex.len(),
        })?;
    if vertex as usize >= vertex_count {
        return Err(RegionError::AnchorOutOfRange {
            mask_vertex,
            vertex,
            count: vertex_count,
        });
    }
    Ok(vertex)
}
