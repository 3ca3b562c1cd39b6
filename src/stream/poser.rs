//! A stream frame turned into the moved fitted mask, the step every offline consumer of a
//! stream takes before deforming (`facewire deform`, `facewire compare`). The service does
//! the same in two halves: the weights and offsets at ingest, the pose in each pipeline.

use glam::Vec3;

use super::{ArkitBasis, Frame};
use crate::fit::FittedMask;

/// Moves the fitted mask frame by frame, with its buffers (no allocation per frame).
pub struct FramePoser<'a> {
    fitted: &'a FittedMask,
    basis: &'a ArkitBasis,
    weights: Vec<f32>,
    offsets: Vec<Vec3>,
    posed: Vec<Vec3>,
}

impl<'a> FramePoser<'a> {
    /// `basis` retargets the frames' ARKit weights.
    pub fn new(fitted: &'a FittedMask, basis: &'a ArkitBasis) -> FramePoser<'a> {
        FramePoser {
            fitted,
            basis,
            weights: vec![0.0; fitted.mask.animation_units.len()],
            offsets: vec![Vec3::ZERO; fitted.mask.vertices.len()],
            posed: vec![Vec3::ZERO; fitted.mask.vertices.len()],
        }
    }

    /// The fitted mask moved by a frame (head units): animation weights plus per-vertex
    /// offsets (raw controls, ARKit weights through the basis).
    pub fn pose(&mut self, frame: &Frame) -> &[Vec3] {
        frame.animation_weights(&self.fitted.mask, &self.fitted.fapu, &mut self.weights);
        frame.mask_offsets(self.basis, &mut self.offsets);
        self.fitted
            .pose_with_offsets_into(&self.weights, &self.offsets, &mut self.posed);
        &self.posed
    }
}
