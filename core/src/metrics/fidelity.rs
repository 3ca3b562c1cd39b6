//! Fidelity: whether a deformation does what the mask asked, not just whether it is smooth
//! (the thesis's smoothest algorithm "squashed" the mouth). Three measures, all in mm:
//!
//! - **Control error**: at each anchor, how far the head's displacement is from the mask
//!   vertex's displacement, `|d(anchor_j) - delta_j|`, over the anchors that move.
//! - **Mouth opening**: the distance between the inner-lip midpoint anchors (87 above, 40
//!   below) on the deformed head, against the same distance on the deformed mask.
//! - **Ground-truth error**: RMS and max distance between the deformed head and a target
//!   head (the same mesh posed by an artist) over the face vertices.
//!
//! Each is a loop over slices that allocates nothing, so they can run every frame.

use glam::Vec3;

use super::face_region::FaceVertices;
use crate::fit::Anchors;
use crate::mask::{INNER_LIP_MID_LOWER, INNER_LIP_MID_UPPER};

/// A mask vertex moves when its control displacement exceeds this (mm).
pub const MOVING_CONTROL_MM: f64 = 1e-3;

/// Below this mask opening (mm) the opening ratio is not reported: the neutral mask's inner
/// lips coincide while the head's are about a millimetre apart.
pub const MIN_MASK_OPENING_MM: f64 = 1.0;

/// Inputs that do not fit together.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FidelityError {
    #[error("mm_per_unit must be a positive number, found {0}")]
    Scale(f32),
    #[error("{what}: expected {expected} values, found {found}")]
    Length {
        what: &'static str,
        expected: usize,
        found: usize,
    },
    #[error("{what} refers to head vertex {vertex}, but the head has {count} vertices")]
    VertexOutOfRange {
        what: &'static str,
        vertex: u32,
        count: usize,
    },
}

/// Control error at the moving anchors, mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlError {
    /// Mask vertices whose displacement exceeds [`MOVING_CONTROL_MM`]; mean and max are 0
    /// when none does.
    pub moving: usize,
    pub mean_mm: f64,
    pub max_mm: f64,
}

/// Mouth opening on the head and on the mask, mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MouthOpening {
    /// Between the anchors of 87 and 40 on the deformed head.
    pub head_mm: f64,
    /// Between mask vertices 87 and 40 of the deformed mask.
    pub mask_mm: f64,
    /// `head_mm / mask_mm`; `None` while the mask opening is under [`MIN_MASK_OPENING_MM`].
    pub ratio: Option<f64>,
}

/// Distance from a target head over the face vertices, mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundTruthError {
    pub vertices: usize,
    pub rms_mm: f64,
    pub max_mm: f64,
}

/// `|d(anchor_j) - delta_j|` over moving mask vertices: `deformed` and `rest` are the head
/// (one position per head vertex, head units), `controls` one displacement per mask vertex
/// (head units, as from [`crate::fit::FittedMask::controls_into`]).
pub fn control_error(
    deformed: &[Vec3],
    rest: &[Vec3],
    anchors: &Anchors,
    controls: &[Vec3],
    mm_per_unit: f32,
) -> Result<ControlError, FidelityError> {
    let mm = scale(mm_per_unit)?;
    same_length("rest positions", deformed.len(), rest.len())?;
    same_length("control displacements", anchors.vertex.len(), controls.len())?;
    let (mut moving, mut sum, mut max) = (0usize, 0.0f64, 0.0f64);
    for (&vertex, &delta) in anchors.vertex.iter().zip(controls) {
        let delta = delta.as_dvec3();
        if delta.length() * mm <= MOVING_CONTROL_MM {
            continue;
        }
        let v = checked(vertex, deformed.len(), "an anchor")?;
        let moved = deformed[v].as_dvec3() - rest[v].as_dvec3();
        let error = moved.distance(delta) * mm;
        moving += 1;
        sum += error;
        max = max.max(error);
    }
    Ok(ControlError {
        moving,
        mean_mm: if moving > 0 { sum / moving as f64 } else { 0.0 },
        max_mm: max,
    })
}

/// The inner-lip midpoint distance on the deformed head (`deformed`, head units) against
/// the deformed mask (`posed_mask`, one position per mask vertex, head units).
pub fn mouth_opening(
    deformed: &[Vec3],
    anchors: &Anchors,
    posed_mask: &[Vec3],
    mm_per_unit: f32,
) -> Result<MouthOpening, FidelityError> {
    let mm = scale(mm_per_unit)?;
    same_length("posed mask vertices", anchors.vertex.len(), posed_mask.len())?;
    let anchor = |j: usize| -> Result<usize, FidelityError> {
        let vertex = *anchors.vertex.get(j).ok_or(FidelityError::Length {
            what: "anchors",
            expected: INNER_LIP_MID_UPPER.max(INNER_LIP_MID_LOWER) + 1,
            found: anchors.vertex.len(),
        })?;
        checked(vertex, deformed.len(), "an inner-lip anchor")
    };
    let (upper, lower) = (anchor(INNER_LIP_MID_UPPER)?, anchor(INNER_LIP_MID_LOWER)?);
    let head_mm = deformed[upper].as_dvec3().distance(deformed[lower].as_dvec3()) * mm;
    let mask_mm = posed_mask[INNER_LIP_MID_UPPER]
        .as_dvec3()
        .distance(posed_mask[INNER_LIP_MID_LOWER].as_dvec3())
        * mm;
    Ok(MouthOpening {
        head_mm,
        mask_mm,
        ratio: (mask_mm >= MIN_MASK_OPENING_MM).then(|| head_mm / mask_mm),
    })
}

/// RMS and max distance between `deformed` and `target` (the same head's vertices in the
/// same order, head units) over the face vertices.
pub fn ground_truth_error(
    deformed: &[Vec3],
    target: &[Vec3],
    face: &FaceVertices,
    mm_per_unit: f32,
) -> Result<GroundTruthError, FidelityError> {
    let mm = scale(mm_per_unit)?;
    same_length("target positions", deformed.len(), target.len())?;
    let (mut squares, mut max) = (0.0f64, 0.0f64);
    for &vertex in face.vertices() {
        let v = checked(vertex, deformed.len(), "a face vertex")?;
        let error = deformed[v].as_dvec3().distance(target[v].as_dvec3()) * mm;
        squares += error * error;
        max = max.max(error);
    }
    let count = face.vertices().len();
    Ok(GroundTruthError {
        vertices: count,
        rms_mm: if count > 0 {
            (squares / count as f64).sqrt()
        } else {
            0.0
        },
        max_mm: max,
    })
}

fn scale(mm_per_unit: f32) -> Result<f64, FidelityError> {
    if mm_per_unit.is_finite() && mm_per_unit > 0.0 {
        Ok(f64::from(mm_per_unit))
    } else {
        Err(FidelityError::Scale(mm_per_unit))
    }
}

fn same_length(what: &'static str, expected: usize, found: usize) -> Result<(), FidelityError> {
    if expected == found {
        Ok(())
    } else {
        Err(FidelityError::Length {
            what,
            expected,
            found,
        })
    }
}

fn checked(vertex: u32, count: usize, what: &'static str) -> Result<usize, FidelityError> {
    if (vertex as usize) < count {
        Ok(vertex as usize)
    } else {
        Err(FidelityError::VertexOutOfRange { what, vertex, count })
    }
}
