//! Where each eye looks in a frame, and the eyeball's motion that follows. Gaze comes from
//! MPEG-4 FAPs 23-26 (`yaw_l_eyeball`, `yaw_r_eyeball`, `pitch_l_eyeball`,
//! `pitch_r_eyeball`: 1e-5 rad a count, yaw positive towards the face's left, pitch
//! positive down) and ARKit's `eyeLook{Down,In,Out,Up}{Left,Right}` weights, which add.
//!
//! Angles are in the mask's frame: yaw about +y, pitch about +x, applied as
//! `R = Ry(yaw) Rx(pitch)` (Fick's gimbal: the eye turns sideways, then up or down about
//! its turned horizontal axis, and never rolls). The eyeball turns about its own centre:
//! `p -> R_h (p - c) + c` in head units, `R_h` being `R` seen through the fit's rotation.

use glam::Mat3;

use super::{Eyeball, RigidMotion, Side};
use crate::mask::MaskPose;
use crate::stream::{Frame, ARKIT_LOOK_RAD, RADIANS_PER_ANGLE_COUNT};

/// The eye turns at most this far each way, radians (45 degrees: the eye's mechanical
/// range is about 45-50 degrees in every direction). Larger requests are held at it.
pub const GAZE_LIMIT_RAD: f32 = std::f32::consts::FRAC_PI_4;

/// FAPs (yaw, pitch) of each eye.
const LEFT_FAPS: (u8, u8) = (23, 25);
const RIGHT_FAPS: (u8, u8) = (24, 26);

/// ARKit blendshape indices (`ARKIT_BLENDSHAPES`) of each eye's look: down, in, out, up.
const LEFT_LOOKS: [u8; 4] = [1, 2, 3, 4];
const RIGHT_LOOKS: [u8; 4] = [8, 9, 10, 11];

/// One eye's gaze, radians, in the mask's frame.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Gaze {
    /// Positive turns the eye towards the face's left (+x).
    pub yaw_rad: f32,
    /// Positive turns it down.
    pub pitch_rad: f32,
}

impl Gaze {
    /// What `frame` asks of the `side` eye, each angle held within [`GAZE_LIMIT_RAD`].
    pub fn of(frame: &Frame, side: Side) -> Gaze {
        let ((yaw_fap, pitch_fap), looks) = match side {
            Side::Left => (LEFT_FAPS, LEFT_LOOKS),
            Side::Right => (RIGHT_FAPS, RIGHT_LOOKS),
        };
        let mut gaze = Gaze::default();
        for &(fap, count) in &frame.faps {
            if fap == yaw_fap {
                gaze.yaw_rad += count * RADIANS_PER_ANGLE_COUNT;
            } else if fap == pitch_fap {
                gaze.pitch_rad += count * RADIANS_PER_ANGLE_COUNT;
            }
        }
        // Out is towards the face's left for the left eye and its right for the right.
        let outwards = match side {
            Side::Left => 1.0,
            Side::Right => -1.0,
        };
        for &(shape, weight) in &frame.arkit {
            let weight = weight * ARKIT_LOOK_RAD;
            match looks.iter().position(|&l| l == shape) {
                Some(0) => gaze.pitch_rad += weight,
                Some(1) => gaze.yaw_rad -= outwards * weight,
                Some(2) => gaze.yaw_rad += outwards * weight,
                Some(3) => gaze.pitch_rad -= weight,
                _ => {}
            }
        }
        Gaze {
            yaw_rad: gaze.yaw_rad.clamp(-GAZE_LIMIT_RAD, GAZE_LIMIT_RAD),
            pitch_rad: gaze.pitch_rad.clamp(-GAZE_LIMIT_RAD, GAZE_LIMIT_RAD),
        }
    }

    pub fn is_rest(&self) -> bool {
        self.yaw_rad == 0.0 && self.pitch_rad == 0.0
    }

    /// The eye's rotation in the mask's frame.
    pub fn rotation(&self) -> Mat3 {
        Mat3::from_rotation_y(self.yaw_rad) * Mat3::from_rotation_x(self.pitch_rad)
    }

    /// The motion of `eye` (head units, before the head's own motion) on a mask fitted with
    /// `pose`; exactly the identity at rest.
    pub fn motion_of(&self, eye: &Eyeball, pose: &MaskPose) -> RigidMotion {
        match self.is_rest() {
            true => RigidMotion::IDENTITY,
            false => RigidMotion::in_mask_frame(self.rotation(), eye.centre_mask, glam::Vec3::ZERO, pose),
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::head::Head;
    use crate::stream::ARKIT_BLENDSHAPES;

    #[test]
    fn the_look_indices_name_the_eye_s_looks() {
        for (looks, side) in [(LEFT_LOOKS, "Left"), (RIGHT_LOOKS, "Right")] {
            let names = looks.map(|i| ARKIT_BLENDSHAPES[usize::from(i)]);
            assert_eq!(
                names,
                ["Down", "In", "Out", "Up"].map(|d| format!("eyeLook{d}{side}"))
            );
        }
    }

    #[test]
    fn faps_and_arkit_looks_add_up_and_are_held_in_range() {
        // FAP 23 of 10,000 counts is 0.1 rad to the face's left; eyeLookOutLeft 0.5 adds 15
        // degrees the same way; eyeLookUpLeft 0.2 is 6 degrees up.
        let frame = Frame {
            faps: vec![(23, 10_000.0), (26, -5_000.0)],
            arkit: vec![(3, 0.5), (4, 0.2), (10, 0.5)],
            ..Frame::default()
        };
        let left = Gaze::of(&frame, Side::Left);
        assert!(
            (left.yaw_rad - (0.1 + 0.5 * ARKIT_LOOK_RAD)).abs() < 1e-6,
            "{left:?}"
        );
        assert!((left.pitch_rad + 0.2 * ARKIT_LOOK_RAD).abs() < 1e-6);
        // The right eye looking out looks to the face's right: negative yaw.
        let right = Gaze::of(&frame, Side::Right);
        assert!((right.yaw_rad + 0.5 * ARKIT_LOOK_RAD).abs() < 1e-6, "{right:?}");
        assert!((right.pitch_rad + 0.05).abs() < 1e-6);
        let far = Frame {
            faps: vec![(24, 300_000.0)],
            ..Frame::default()
        };
        assert_eq!(Gaze::of(&far, Side::Right).yaw_rad, GAZE_LIMIT_RAD);
        assert!(Gaze::of(&Frame::default(), Side::Left).is_rest());
    }

    #[test]
    fn the_eye_turns_about_its_centre_towards_the_gaze() {
        // A fit rotated 90 degrees about +y and scaled by 10: mask +z is head +x.
        let mut fitted = super::super::eyeball::tests::identity_fit();
        fitted.fit.pose = MaskPose::similarity(
            Vec3::new(0.0, std::f32::consts::FRAC_PI_2, 0.0),
            10.0,
            Vec3::new(1.0, 2.0, 3.0),
        );
        let centre_mask = Vec3::new(0.3, 0.2, -0.1);
        let centre = fitted.fit.pose.affine().transform_point3(centre_mask);
        let (p, t) = super::super::eyeball::tests::eyeball(centre, 1.2, 0.0, 0);
        let eyes = Eyeball::of_part(&Head::new("eye", p, t), "eye", &fitted).unwrap();
        let eye = &eyes[0];
        assert_eq!(eye.side, Side::Left);
        assert!(eye.forward.abs_diff_eq(Vec3::X, 1e-6), "{}", eye.forward);
        let pupil_at_rest = eye.centre + eye.forward * eye.radius;
        // 30 degrees down: the pupil drops by r sin 30 and moves in by r (1 - cos 30).
        let gaze = Gaze {
            yaw_rad: 0.0,
            pitch_rad: std::f32::consts::PI / 6.0,
        };
        let motion = gaze.motion_of(eye, &fitted.fit.pose);
        assert!(motion.apply(eye.centre).abs_diff_eq(eye.centre, 1e-4));
        let pupil = motion.apply(pupil_at_rest);
        let expected = eye.centre + Vec3::new(1.2 * 0.866_025_4, -0.6, 0.0);
        assert!(pupil.abs_diff_eq(expected, 1e-3), "{pupil} vs {expected}");
        // 90 degrees to the face's left: the mask's +x, which this fit puts at head -z.
        let left = Gaze {
            yaw_rad: std::f32::consts::FRAC_PI_2,
            pitch_rad: 0.0,
        };
        let turned = left.motion_of(eye, &fitted.fit.pose).apply(pupil_at_rest);
        assert!(turned.abs_diff_eq(eye.centre - Vec3::Z * 1.2, 1e-3), "{turned}");
        assert!(Gaze::default().motion_of(eye, &fitted.fit.pose).is_identity());
    }
}
