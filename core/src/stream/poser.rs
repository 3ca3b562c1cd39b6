//! A stream frame turned into the moved fitted mask: the one place where a frame's
//! animation weights and per-vertex offsets become mask positions. Every consumer of a
//! stream takes this step before deforming (`facewire deform`, `facewire compare`, the
//! service's per-frame job in [`crate::animate`]).

use glam::Vec3;

use super::expressions::add_expression;
use super::visemes::add_viseme;
use super::{ArkitBasis, Frame};
use crate::fit::FittedMask;
use crate::mask::{FapuValues, Mask, UnitKind};

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
        animation_weights(frame, &fitted.mask, &fitted.fapu, &mut self.weights);
        mask_offsets(frame, basis, &mut self.offsets);
        fitted.pose_with_offsets_into(&self.weights, &self.offsets, &mut self.posed);
        &self.posed
    }

    /// The animation-unit weights of the last [`FramePoser::pose`] ([`animation_weights`]).
    pub fn weights(&self) -> &[f32] {
        &self.weights
    }

    /// The mask as the last [`FramePoser::pose`] left it (head units).
    pub fn posed(&self) -> &[Vec3] {
        &self.posed
    }
}

/// Fills `out` with the animation-unit weights of `frame` (`out` is zeroed first;
/// pass one slot per animation unit of `mask`, 65 for CANDIDE-3). The weights are the
/// sum of the `animation` entries and of the FAPs CANDIDE implements, each FAP count
/// converted with `fapu` (`FapuValues::weight`), FAP 1's viseme as its mouth shape
/// ([`super::visemes::add_viseme`]) and FAP 2's expressions as theirs
/// ([`super::expressions::add_expression`]). FAPs the mask has no unit for (the head
/// rotation 48-50, which [`Frame::head_rotation`] returns, the tongue 43-47,
/// which shape a head's tongue part in `crate::animate::TongueShaper`, and the ears
/// 65-68), ARKit weights ([`mask_offsets`] has them) and indices
/// beyond `out` are left out.
/// Allocates nothing.
pub fn animation_weights(frame: &Frame, mask: &Mask, fapu: &FapuValues, out: &mut [f32]) {
    out.fill(0.0);
    for &(unit, weight) in &frame.animation {
        if let Some(slot) = out.get_mut(usize::from(unit)) {
            *slot += weight;
        }
    }
    for &(fap, count) in &frame.faps {
        let Some(unit) = mask.fap_unit(fap) else {
            continue;
        };
        if let (UnitKind::Fap { fapu: kind, .. }, Some(slot)) =
            (&mask.animation_units[unit].kind, out.get_mut(unit))
        {
            *slot += fapu.weight(*kind, count);
        }
    }
    if let Some(viseme) = &frame.viseme {
        add_viseme(viseme, out);
    }
    if let Some(expression) = &frame.expression {
        add_expression(expression, out);
    }
}

/// Fills `out` with `frame`'s per-vertex offsets of the mask, mask units (`out` is
/// zeroed first; pass one slot per mask vertex, 113 for CANDIDE-3): the raw `controls`
/// plus the `arkit` weights retargeted through `basis` (`sum_k w_k B_k`). Entries
/// beyond `out` are left out. Allocates nothing.
///
/// With [`animation_weights`] this is the whole per-frame path:
/// `fitted.pose_with_offsets_into(&weights, &offsets, &mut posed)`.
pub fn mask_offsets(frame: &Frame, basis: &ArkitBasis, out: &mut [Vec3]) {
    out.fill(Vec3::ZERO);
    for (slot, control) in out.iter_mut().zip(frame.controls.iter().flatten()) {
        *slot += Vec3::from_array(*control);
    }
    basis.apply(&frame.arkit, out);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_add_animation_units_and_converted_faps() {
        let mask = Mask::candide3();
        let fapu = FapuValues::measure(&mask.vertices);
        let frame = Frame {
            animation: vec![(1, 0.25), (11, 0.01)],
            // open_jaw 512 counts = half an MNS; head pitch is not a unit; tongue neither.
            faps: vec![(3, 512.0), (44, 100.0), (48, 1000.0)],
            arkit: vec![(17, 1.0)],
            ..Frame::default()
        };
        let mut out = [7.0; 65];
        animation_weights(&frame, &mask, &fapu, &mut out);
        assert_eq!(out[1], 0.25);
        assert!((out[11] - (0.01 + 0.5 * 0.196)).abs() < 1e-6, "{}", out[11]);
        let moved: Vec<usize> = (0..65).filter(|&i| out[i] != 0.0).collect();
        assert_eq!(moved, [1, 11]);
    }

    #[test]
    fn angle_faps_use_the_eyeball_radius() {
        let mask = Mask::candide3();
        let fapu = FapuValues::measure(&mask.vertices);
        let frame = Frame {
            faps: vec![(23, 100_000.0)], // yaw_l_eyeball, 1 rad
            ..Frame::default()
        };
        let mut out = [0.0; 65];
        animation_weights(&frame, &mask, &fapu, &mut out);
        assert!((out[31] - 0.085).abs() < 1e-6, "{}", out[31]);
    }

    #[test]
    fn offsets_add_controls_and_retargeted_arkit_weights() {
        let basis = ArkitBasis::parse("b", "jawOpen 1 0 -0.5 0\nmouthClose 2 0 0.25 0\n").unwrap();
        let mut controls = vec![[0.0; 3]; 3];
        controls[1] = [0.1, 0.0, 0.0];
        let frame = Frame {
            controls: Some(controls),
            arkit: vec![(17, 0.5), (18, 1.0)],
            ..Frame::default()
        };
        let mut out = [Vec3::ONE; 3];
        mask_offsets(&frame, &basis, &mut out);
        assert_eq!(
            out,
            [Vec3::ZERO, Vec3::new(0.1, -0.25, 0.0), Vec3::new(0.0, 0.25, 0.0)]
        );
        mask_offsets(&Frame::default(), &basis, &mut out);
        assert_eq!(out, [Vec3::ZERO; 3]);
    }
}
