//! Global motion of the mask: `g = R (S p) + t`, carrying mask units into head units.
//!
//! Rotation convention: `R = Rz(rz) * Ry(ry) * Rx(rx)` (x applied first), angles in
//! radians: rx pitches the face, ry yaws it, rz rolls it. Scale is per axis as in the
//! `.wfm` GLOBAL MOTION section; fits use a uniform scale (head units per mask unit).

use glam::{Affine3A, EulerRot, Mat3, Vec3, Vec3A};

#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MaskPose {
    pub rotation_rad: Vec3,
    pub scale: Vec3,
    pub translation: Vec3,
}

impl Default for MaskPose {
    fn default() -> Self {
        MaskPose::IDENTITY
    }
}

impl MaskPose {
    pub const IDENTITY: MaskPose = MaskPose {
        rotation_rad: Vec3::ZERO,
        scale: Vec3::ONE,
        translation: Vec3::ZERO,
    };

    /// A similarity: rotation (radians), uniform scale, translation.
    pub fn similarity(rotation_rad: Vec3, scale: f32, translation: Vec3) -> MaskPose {
        MaskPose {
            rotation_rad,
            scale: Vec3::splat(scale),
            translation,
        }
    }

    pub fn rotation(&self) -> Mat3 {
        let r = self.rotation_rad;
        Mat3::from_euler(EulerRot::ZYX, r.z, r.y, r.x)
    }

    /// The affine map `p -> R S p + t`.
    pub fn affine(&self) -> Affine3A {
        Affine3A::from_mat3_translation(
            self.rotation() * Mat3::from_diagonal(self.scale),
            self.translation,
        )
    }

    /// Applies the pose to every point in place. Allocates nothing.
    pub fn apply_all(&self, points: &mut [Vec3]) {
        let affine = self.affine();
        for p in points {
            *p = Vec3::from(affine.transform_point3a(Vec3A::from(*p)));
        }
    }

    /// Rotation angles (radians, the convention above) of a rotation matrix.
    pub fn angles_of(rotation: Mat3) -> Vec3 {
        let (rz, ry, rx) = rotation.to_euler(EulerRot::ZYX);
        Vec3::new(rx, ry, rz)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_order_is_z_y_x() {
        let pose = MaskPose::similarity(Vec3::new(0.3, -0.2, 0.5), 1.0, Vec3::ZERO);
        let expected = Mat3::from_rotation_z(0.5) * Mat3::from_rotation_y(-0.2) * Mat3::from_rotation_x(0.3);
        assert!(pose.rotation().abs_diff_eq(expected, 1e-6));
        let back = MaskPose::angles_of(pose.rotation());
        assert!(back.abs_diff_eq(pose.rotation_rad, 1e-5), "{back}");
    }

    #[test]
    fn pose_scales_rotates_then_translates() {
        let pose = MaskPose::similarity(
            Vec3::new(0.0, 0.0, std::f32::consts::FRAC_PI_2),
            2.0,
            Vec3::new(1.0, 2.0, 3.0),
        );
        let mut p = [Vec3::X];
        pose.apply_all(&mut p);
        // x scaled to 2, rolled 90 degrees onto +y, then translated.
        assert!(p[0].abs_diff_eq(Vec3::new(1.0, 4.0, 3.0), 1e-6), "{}", p[0]);
    }
}
