//! Registration of the CANDIDE-3 mask on a head: the similarity pose and shape-unit values
//! that lay the mask on the head's face, optional per-vertex nudges, the physical scale,
//! and the head vertex each mask vertex is anchored to.
//!
//! Frames: a fit maps **mask units** (CANDIDE model frame) to **head units**;
//! `mm_per_unit` maps head units to millimetres.

mod anchors;
pub(crate) mod automatic;
mod face_lengths;
mod file;
mod from_landmarks;
mod landmarks;
pub mod limits;
mod lip_seeds;
mod mouth_opening;
pub mod report;
pub mod residuals;
mod solve;
pub mod umeyama;

use glam::Vec3;

use crate::mask::{fap, FapuValues, Mask, MaskPose};

pub use anchors::{anchor_mask, Anchors};
pub use automatic::{
    fit_automatically, fit_automatically_unless, AutomaticFit, AutomaticFitError, AutomaticFitWarning,
    EyeKind, FoundFeatures, MouthCorners, PUPILS_RELATIVE_SD, UNIT_SNAP,
};
pub use face_lengths::{FaceLengths, FACE_LENGTHS};
pub use file::{FitFile, FitFileError, Nudge};
pub use from_landmarks::{fit_from_landmarks, FitError, LandmarkFit};
pub use landmarks::{Landmark, LandmarkError, Landmarks};
pub use limits::RangeError;
pub use mouth_opening::{mouth_opening, MouthCalibration, MouthOpening};
pub use report::{report, FitReport, FitWarning, LIPS_APART_MM};
pub use residuals::{DistanceStats, Residuals};
pub use solve::{solve_fit, FitSolution, SolveError, SolveOptions};

/// Pupil separation assumed when a fit gives no physical scale (adult mean, mm).
pub const ASSUMED_PUPIL_SEPARATION_MM: f32 = 63.0;

/// A resolved fit: everything needed to place the mask on a head.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    pub pose: MaskPose,
    /// One weight per shape unit of the mask.
    pub shape: Vec<f32>,
    /// (mask vertex, offset in mask units) added before the pose.
    pub nudges: Vec<(u32, Vec3)>,
    /// Millimetres per head unit.
    pub mm_per_unit: f32,
}

impl Fit {
    /// `g0 + SU sigma + nudges`: this person's neutral mask, mask units.
    pub fn neutral_mask_units(&self, mask: &Mask) -> Vec<Vec3> {
        let mut base = mask.shaped(&self.shape);
        for &(v, offset) in &self.nudges {
            base[v as usize] += offset;
        }
        base
    }

    /// Millimetres per head unit from the fitted pupil separation, assuming it is 63 mm.
    pub fn mm_per_unit_from_pupils(mask: &Mask, shape: &[f32], pose: &MaskPose) -> f32 {
        let mut posed = mask.shaped(shape);
        pose.apply_all(&mut posed);
        let left = fap::centroid(&posed, &fap::LEFT_PUPIL);
        let right = fap::centroid(&posed, &fap::RIGHT_PUPIL);
        ASSUMED_PUPIL_SEPARATION_MM / left.distance(right)
    }
}

/// A mask laid on one head, ready to be moved frame by frame. Per-frame methods
/// allocate nothing.
#[derive(Debug, Clone)]
pub struct FittedMask {
    pub mask: Mask,
    pub fit: Fit,
    /// This person's neutral mask (shape units and nudges applied), mask units.
    pub base: Vec<Vec3>,
    /// The neutral mask in head units: `pose(base)`.
    pub neutral: Vec<Vec3>,
    /// FAP units measured on `base`, mask units.
    pub fapu: FapuValues,
}

impl FittedMask {
    pub fn new(mask: Mask, fit: Fit) -> FittedMask {
        let base = fit.neutral_mask_units(&mask);
        let mut neutral = base.clone();
        fit.pose.apply_all(&mut neutral);
        let fapu = FapuValues::measure(&base);
        FittedMask {
            mask,
            fit,
            base,
            neutral,
            fapu,
        }
    }

    /// Mask vertices in head units for animation weights `animation` (one per animation
    /// unit; missing ones are zero). `out` must have one slot per mask vertex.
    pub fn pose_into(&self, animation: &[f32], out: &mut [Vec3]) {
        out.copy_from_slice(&self.base);
        crate::mask::add_units(&self.mask.animation_units, animation, out);
        self.fit.pose.apply_all(out);
    }

    /// Like [`FittedMask::pose_into`], with per-vertex offsets (mask units, one per mask
    /// vertex: raw control displacements, ARKit retargeting) added before the pose.
    pub fn pose_with_offsets_into(&self, animation: &[f32], offsets: &[Vec3], out: &mut [Vec3]) {
        out.copy_from_slice(&self.base);
        crate::mask::add_units(&self.mask.animation_units, animation, out);
        for (p, o) in out.iter_mut().zip(offsets) {
            *p += *o;
        }
        self.fit.pose.apply_all(out);
    }

    /// Control displacements `c' - c` in head units for animation weights.
    pub fn controls_into(&self, animation: &[f32], out: &mut [Vec3]) {
        self.pose_into(animation, out);
        for (d, n) in out.iter_mut().zip(&self.neutral) {
            *d -= *n;
        }
    }

    /// Mask units to millimetres (uniform part of the pose scale times `mm_per_unit`).
    pub fn mm_per_mask_unit(&self) -> f32 {
        self.fit.pose.scale.x * self.fit.mm_per_unit
    }
}
