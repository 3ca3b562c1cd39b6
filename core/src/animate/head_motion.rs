//! The head's own motion: a frame's head rotation and translation (`head_rotation_rad`,
//! `head_translation`, FAPs 48-50, FWP1's rotation) as one rigid transform of head units.
//! It is kept apart from the deformation: the deformers see the mask without it, the
//! deltas stay small, and viewers (and `facewire deform`'s OBJ files) apply it on top.
//!
//! The motion is defined in mask units, about [`NECK_PIVOT_MASK`]:
//! `m(p) = R (p - c) + c + t`, with `R` in [`MaskPose`]'s angle convention. Carried into
//! head units through the fit's pose `g(p) = L p + t_fit` (`L = R_fit s`, uniform `s`):
//! `H = g m g^-1`, so `H(x) = R_h (x - g(c)) + g(c) + L t` with `R_h = R_fit R R_fit^T`.
//! `H` is rigid: the head turns, nothing in it bends.

use glam::Vec3;

use super::RigidMotion;
use crate::mask::MaskPose;
use crate::stream::Frame;

/// Where the head turns about, mask units: on the mid-line, level with the mouth corners
/// (CANDIDE-3 vertices 31 and 64 have y = -0.461) and 0.75 units (about 75 mm) behind the
/// face plane z = 0, near where the skull sits on the spine.
pub const NECK_PIVOT_MASK: Vec3 = Vec3::new(0.0, -0.461, -0.75);

/// The head's motion `frame` asks for, in the head units of a mask fitted with `pose`.
/// Exactly [`RigidMotion::IDENTITY`] for a frame without head rotation or translation.
pub fn head_motion(frame: &Frame, pose: &MaskPose) -> RigidMotion {
    let rotation_rad = Vec3::from_array(frame.head_rotation());
    let translation = Vec3::from_array(frame.head_translation.unwrap_or([0.0; 3]));
    if rotation_rad == Vec3::ZERO && translation == Vec3::ZERO {
        return RigidMotion::IDENTITY;
    }
    let in_mask = MaskPose::similarity(rotation_rad, 1.0, Vec3::ZERO).rotation();
    RigidMotion::in_mask_frame(in_mask, NECK_PIVOT_MASK, translation, pose)
}

#[cfg(test)]
mod tests {
    use std::f32::consts::FRAC_PI_2;

    use super::*;

    fn frame(rotation: [f32; 3], translation: Option<[f32; 3]>) -> Frame {
        Frame {
            head_rotation_rad: Some(rotation),
            head_translation: translation,
            ..Frame::default()
        }
    }

    #[test]
    fn no_rotation_no_translation_is_exactly_the_identity() {
        let pose = MaskPose::similarity(Vec3::new(0.1, 0.2, 0.3), 80.0, Vec3::ONE);
        assert!(head_motion(&Frame::default(), &pose).is_identity());
        assert!(head_motion(&frame([0.0; 3], Some([0.0; 3])), &pose).is_identity());
        assert_eq!(RigidMotion::IDENTITY.to_wire(), None);
    }

    #[test]
    fn a_quarter_yaw_turns_about_the_neck_pivot() {
        // Mask units are head units here: the pivot stays, a point 1 unit in front of it
        // (+z) turns onto +x (yaw is a rotation about +y).
        let motion = head_motion(&frame([0.0, FRAC_PI_2, 0.0], None), &MaskPose::IDENTITY);
        assert!(motion.apply(NECK_PIVOT_MASK).abs_diff_eq(NECK_PIVOT_MASK, 1e-6));
        let front = NECK_PIVOT_MASK + Vec3::Z;
        let turned = motion.apply(front);
        assert!(turned.abs_diff_eq(NECK_PIVOT_MASK + Vec3::X, 1e-6), "{turned}");
    }

    #[test]
    fn fap_rotation_and_translation_add_up() {
        // FAP 49 (yaw) 10,000 counts = 0.1 rad, plus 0.1 rad in radians; 0.5 units up.
        let frame = Frame {
            head_rotation_rad: Some([0.0, 0.1, 0.0]),
            head_translation: Some([0.0, 0.5, 0.0]),
            faps: vec![(49, 10_000.0)],
            ..Frame::default()
        };
        let motion = head_motion(&frame, &MaskPose::IDENTITY);
        let expected = glam::Quat::from_rotation_y(0.2);
        assert!(motion.rotation.abs_diff_eq(expected, 1e-6), "{}", motion.rotation);
        assert!(motion
            .apply(NECK_PIVOT_MASK)
            .abs_diff_eq(NECK_PIVOT_MASK + 0.5 * Vec3::Y, 1e-6));
    }

    #[test]
    fn in_head_units_the_motion_is_the_mask_motion_seen_through_the_fit() {
        // H(g(p)) = g(m(p)) for points all over the mask's frame.
        let pose = MaskPose::similarity(Vec3::new(0.2, -0.4, 0.1), 85.0, Vec3::new(3.0, 160.0, -20.0));
        let (rotation, translation) = (Vec3::new(0.3, -0.5, 0.25), Vec3::new(0.1, -0.2, 0.05));
        let motion = head_motion(&frame(rotation.to_array(), Some(translation.to_array())), &pose);
        let in_mask = MaskPose::similarity(rotation, 1.0, Vec3::ZERO).rotation();
        for p in [
            Vec3::ZERO,
            Vec3::X,
            Vec3::new(0.3, -0.8, 0.2),
            Vec3::new(-0.6, 1.0, -0.3),
        ] {
            let moved_in_mask = in_mask * (p - NECK_PIVOT_MASK) + NECK_PIVOT_MASK + translation;
            let mut expected = [moved_in_mask];
            pose.apply_all(&mut expected);
            let mut at_rest = [p];
            pose.apply_all(&mut at_rest);
            let got = motion.apply(at_rest[0]);
            assert!(
                got.abs_diff_eq(expected[0], 1e-3),
                "{p}: {got} vs {}",
                expected[0]
            );
        }
        // Rigid: lengths are kept.
        let (a, b) = (Vec3::new(1.0, 2.0, 3.0), Vec3::new(-4.0, 0.5, 2.0));
        let moved = motion.apply(a) - motion.apply(b);
        assert!((moved.length() - (a - b).length()).abs() < 1e-4);
    }
}
