//! A rigid motion of head units (`x -> rotation x + translation`): how the whole head and
//! the jaw move in a frame. Kept apart from the deformation and sent as such, never baked
//! into vertex deltas.

use glam::{Mat3, Quat, Vec3};

use crate::mask::MaskPose;
use facewire_proto::viewer_frame::RigidMotion as WireRigidMotion;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidMotion {
    pub rotation: Quat,
    pub translation: Vec3,
}

impl Default for RigidMotion {
    fn default() -> Self {
        RigidMotion::IDENTITY
    }
}

impl RigidMotion {
    pub const IDENTITY: RigidMotion = RigidMotion {
        rotation: Quat::IDENTITY,
        translation: Vec3::ZERO,
    };

    /// A motion defined in mask units, `q -> rotation (q - pivot) + pivot + translation`,
    /// carried into the head units of a mask fitted with `pose` (`g = L q + t_fit`,
    /// uniform scale): `g m g^-1`, which is rigid.
    pub fn in_mask_frame(rotation: Mat3, pivot: Vec3, translation: Vec3, pose: &MaskPose) -> RigidMotion {
        let fit_rotation = pose.rotation();
        let linear = fit_rotation * Mat3::from_diagonal(pose.scale);
        let pivot = linear * pivot + pose.translation;
        let rotation = Quat::from_mat3(&(fit_rotation * rotation * fit_rotation.transpose())).normalize();
        RigidMotion {
            rotation,
            translation: pivot + linear * translation - rotation * pivot,
        }
    }

    /// As an affine map of head units.
    pub fn affine(&self) -> glam::Affine3A {
        glam::Affine3A::from_rotation_translation(self.rotation, self.translation)
    }

    pub fn is_identity(&self) -> bool {
        *self == RigidMotion::IDENTITY
    }

    pub fn apply(&self, p: Vec3) -> Vec3 {
        self.rotation * p + self.translation
    }

    /// `out[i] = self.apply(points[i])`. Allocates nothing.
    pub fn apply_into(&self, points: &[Vec3], out: &mut [Vec3]) {
        for (o, p) in out.iter_mut().zip(points) {
            *o = self.apply(*p);
        }
    }

    /// `self` after `first`: `x -> self(first(x))`.
    pub fn after(&self, first: &RigidMotion) -> RigidMotion {
        RigidMotion {
            rotation: (self.rotation * first.rotation).normalize(),
            translation: self.rotation * first.translation + self.translation,
        }
    }

    /// The motion as a viewer frame carries it; `None` for the identity, which frames
    /// leave out.
    pub fn to_wire(&self) -> Option<WireRigidMotion> {
        (!self.is_identity()).then(|| WireRigidMotion {
            rotation: self.rotation.to_array(),
            translation: self.translation.to_array(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn after_applies_the_first_motion_then_its_own() {
        let turn = RigidMotion {
            rotation: Quat::from_euler(glam::EulerRot::ZYX, 0.3, -0.2, 0.45),
            translation: Vec3::new(1.0, -2.0, 0.5),
        };
        let shift = RigidMotion {
            rotation: Quat::IDENTITY,
            translation: Vec3::new(0.0, 3.0, 0.0),
        };
        let p = Vec3::new(0.2, -0.7, 1.1);
        assert!(turn
            .after(&turn)
            .apply(p)
            .abs_diff_eq(turn.apply(turn.apply(p)), 1e-5));
        assert!(turn
            .after(&shift)
            .apply(p)
            .abs_diff_eq(turn.apply(p + shift.translation), 1e-5));
        assert!(shift
            .after(&turn)
            .apply(p)
            .abs_diff_eq(turn.apply(p) + shift.translation, 1e-5));
    }
}
