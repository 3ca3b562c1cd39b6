//! The jaw's rigid motion in a frame, derived from the mask's motion so that every input
//! moves it the same way (animation units, FAPs 3/14/15, ARKit weights through the basis,
//! raw controls). Parts that move with the jaw (lower teeth, lower gums, the tongue) are
//! placed by it.
//!
//! The mask lies on the skin, and the skin of the chin does not follow the mandible one to
//! one: on the ICT Face Model's jaw targets it turns about 82 % of the bone's angle when
//! the mouth opens and slides further than the bone when the jaw is pushed forward or to
//! the side. So the jaw is a hinge, worked out in mask units from the mean of the chin
//! vertices 10, 32 and 65 (the ones FAPs 3, 14 and 15 move), at rest `c` and now `c'`:
//!
//! 1. the skin's opening angle `a`: the turn about the x axis through [`JAW_PIVOT_MASK`]
//!    that brings `c` to the height of `c'`;
//! 2. what that turn leaves unexplained, `r = c' - turn_a(c)`: the jaw's slide;
//! 3. the bone turns `a / `[`SKIN_TURN`], slides [`SLIDE_GAIN`]` r` up/down and
//!    forward/back, and shifts [`SHIFT_GAIN`]` r_x` sideways, [`SHIFT_AS_YAW`] of it as a
//!    yaw about the pivot (a jaw moved sideways pivots on one joint).
//!
//! The constants are calibrated on the ICT jaw targets (`tests/core/jaw.rs` holds the lower
//! teeth within 1 mm RMS of them); docs/ALGORITHMS.md, "The jaw", gives the figures.

use glam::{Mat3, Vec3};

use super::RigidMotion;
use crate::mask::MaskPose;

/// The chin vertices the jaw is read from.
pub const CHIN_VERTICES: [usize; 3] = [10, 32, 65];

/// Where the jaw hinges, mask units: on the mid-line, at about the height of the nose's
/// base and 0.8 units (about 85 mm on the ICT head) behind the face plane, near the
/// temporomandibular joints.
pub const JAW_PIVOT_MASK: Vec3 = Vec3::new(0.0, -0.1, -0.8);

/// The chin's skin turns this fraction of the jaw's opening angle.
pub const SKIN_TURN: f32 = 0.825;
/// The jaw slides (up/down, forward/back) this fraction of what the chin's skin slides.
pub const SLIDE_GAIN: f32 = 0.8;
/// The jaw shifts sideways this fraction of what the chin's skin shifts.
pub const SHIFT_GAIN: f32 = 0.85;
/// This share of the sideways shift is a yaw about the pivot, the rest a translation.
pub const SHIFT_AS_YAW: f32 = 0.4;

/// The jaw's motion (head units, before the head's own motion) for the mask moved from
/// `mask_rest` to `mask_now` (head units, one entry per mask vertex), the mask fitted
/// with `pose`. Exactly the identity when the chin vertices do not move. Allocates
/// nothing.
pub fn jaw_motion(mask_rest: &[Vec3], mask_now: &[Vec3], pose: &MaskPose) -> RigidMotion {
    if CHIN_VERTICES.iter().all(|&j| mask_now[j] == mask_rest[j]) {
        return RigidMotion::IDENTITY;
    }
    let to_mask = pose.affine().inverse();
    let mean = |points: &[Vec3]| {
        CHIN_VERTICES
            .iter()
            .map(|&j| to_mask.transform_point3(points[j]))
            .sum::<Vec3>()
            / CHIN_VERTICES.len() as f32
    };
    let (chin, chin_now) = (mean(mask_rest), mean(mask_now));
    let arm = chin - JAW_PIVOT_MASK;
    // Turning about x: y' = y cos a - z sin a = rho cos(a + phi).
    let rho = arm.y.hypot(arm.z);
    let phi = arm.z.atan2(arm.y);
    let skin_turn = ((arm.y + chin_now.y - chin.y) / rho).clamp(-1.0, 1.0).acos() - phi;
    let slide = chin_now - (Mat3::from_rotation_x(skin_turn) * arm + JAW_PIVOT_MASK);
    let shift = SHIFT_GAIN * slide.x;
    let yaw = SHIFT_AS_YAW * shift / arm.z;
    let rotation = Mat3::from_rotation_y(yaw) * Mat3::from_rotation_x(skin_turn / SKIN_TURN);
    let translation = Vec3::new(
        (1.0 - SHIFT_AS_YAW) * shift,
        SLIDE_GAIN * slide.y,
        SLIDE_GAIN * slide.z,
    );
    RigidMotion::in_mask_frame(rotation, JAW_PIVOT_MASK, translation, pose)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mask of 66 points (enough for the chin's indices) with the chin where CANDIDE-3
    /// has it, mask units = head units.
    fn mask_at_rest() -> Vec<Vec3> {
        let mut mask = vec![Vec3::ZERO; 66];
        mask[10] = Vec3::new(0.0, -0.852, 0.063);
        mask[32] = Vec3::new(0.174, -0.809, 0.0);
        mask[65] = Vec3::new(-0.174, -0.809, 0.0);
        mask
    }

    fn moved(rest: &[Vec3], motion: impl Fn(Vec3) -> Vec3) -> Vec<Vec3> {
        rest.iter()
            .enumerate()
            .map(|(j, &p)| if CHIN_VERTICES.contains(&j) { motion(p) } else { p })
            .collect()
    }

    #[test]
    fn a_still_chin_is_exactly_the_identity() {
        let rest = mask_at_rest();
        let pose = MaskPose::similarity(Vec3::new(0.1, 0.2, 0.0), 12.0, Vec3::ONE);
        assert!(jaw_motion(&rest, &rest, &pose).is_identity());
    }

    #[test]
    fn a_chin_turning_about_the_pivot_opens_the_jaw_further() {
        let rest = mask_at_rest();
        let skin = Mat3::from_rotation_x(0.2);
        let now = moved(&rest, |p| skin * (p - JAW_PIVOT_MASK) + JAW_PIVOT_MASK);
        let jaw = jaw_motion(&rest, &now, &MaskPose::IDENTITY);
        let expected = glam::Quat::from_rotation_x(0.2 / SKIN_TURN);
        assert!(jaw.rotation.abs_diff_eq(expected, 1e-5), "{jaw:?}");
        // Nothing slid: the pivot stays.
        assert!(
            jaw.apply(JAW_PIVOT_MASK).abs_diff_eq(JAW_PIVOT_MASK, 1e-5),
            "{jaw:?}"
        );
    }

    #[test]
    fn a_chin_shifted_sideways_shifts_and_yaws_the_jaw() {
        let rest = mask_at_rest();
        let shift = 0.05;
        let now = moved(&rest, |p| p + Vec3::new(shift, 0.0, 0.0));
        let jaw = jaw_motion(&rest, &now, &MaskPose::IDENTITY);
        let chin = CHIN_VERTICES.iter().map(|&j| rest[j]).sum::<Vec3>() / 3.0;
        let yaw = SHIFT_AS_YAW * SHIFT_GAIN * shift / (chin.z - JAW_PIVOT_MASK.z);
        assert!(
            jaw.rotation.abs_diff_eq(glam::Quat::from_rotation_y(yaw), 1e-6),
            "{jaw:?}"
        );
        let pivot_moves = jaw.apply(JAW_PIVOT_MASK) - JAW_PIVOT_MASK;
        let expected = Vec3::new((1.0 - SHIFT_AS_YAW) * SHIFT_GAIN * shift, 0.0, 0.0);
        assert!(pivot_moves.abs_diff_eq(expected, 1e-6), "{pivot_moves}");
        // The chin itself moves SHIFT_GAIN of the skin's shift (the yaw's lever is the
        // chin's depth in front of the pivot).
        let chin_moves = jaw.apply(chin) - chin;
        assert!((chin_moves.x - SHIFT_GAIN * shift).abs() < 1e-4, "{chin_moves}");
    }
}
