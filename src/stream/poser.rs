//! A stream frame turned into the moved fitted mask: the one place where a frame's
//! animation weights and per-vertex offsets become mask positions. Every consumer of a
//! stream takes this step before deforming (`facewire deform`, `facewire compare`, the
//! service's per-frame job in [`crate::animate`]).

use glam::Vec3;

use super::{ArkitBasis, Frame};
use crate::fit::FittedMask;

/// The buffers of the frame-to-mask step, sized for one mask (no allocation per frame).
pub struct FramePoser {
    weights: Vec<f32>,
    offsets: Vec<Vec3>,
    posed: Vec<Vec3>,
}

impl FramePoser {
    /// Buffers for `fitted`'s mask.
    pub fn new(fitted: &FittedMask) -> FramePoser {
        FramePoser {
            weights: vec![0.0; fitted.mask.animation_units.len()],
            offsets: vec![Vec3::ZERO; fitted.mask.vertices.len()],
            posed: vec![Vec3::ZERO; fitted.mask.vertices.len()],
        }
    }

    /// The fitted mask moved by a frame (head units): animation weights plus per-vertex
    /// offsets (raw controls, ARKit weights retargeted through `basis`). `fitted` is the
    /// mask these buffers were made for.
    pub fn pose(&mut self, fitted: &FittedMask, basis: &ArkitBasis, frame: &Frame) -> &[Vec3] {
        frame.animation_weights(&fitted.mask, &fitted.fapu, &mut self.weights);
        frame.mask_offsets(basis, &mut self.offsets);
        fitted.pose_with_offsets_into(&self.weights, &self.offsets, &mut self.posed);
        &self.posed
    }

    /// The mask as the last [`FramePoser::pose`] left it (head units).
    pub fn posed(&self) -> &[Vec3] {
        &self.posed
    }
}
