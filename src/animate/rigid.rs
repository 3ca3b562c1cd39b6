//! A rigid motion of head units (`x -> rotation x + translation`): how the whole head and
//! the jaw move in a frame. Kept apart from the deformation and sent as such, never baked
//! into vertex deltas.

use glam::{DVec3, Mat3, Quat, Vec3};

use crate::fit::umeyama::umeyama_pairs;
use crate::mask::MaskPose;
use facewire_proto::frame::RigidMotion as WireRigidMotion;

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

    /// The rigid motion that carries the first point of each pair onto the second with the
    /// least summed squared distance (Kabsch: Umeyama's rotation, no scale). Identity
    /// when the points are fewer than three or collinear. Allocates nothing.
    pub fn fit<I: Iterator<Item = (Vec3, Vec3)>>(pairs: impl Fn() -> I) -> RigidMotion {
        let wide = || pairs().map(|(a, b)| (DVec3::from(a), DVec3::from(b)));
        let Some(similarity) = umeyama_pairs(wide) else {
            return RigidMotion::IDENTITY;
        };
        let (mut n, mut from, mut to) = (0usize, DVec3::ZERO, DVec3::ZERO);
        for (a, b) in wide() {
            n += 1;
            from += a;
            to += b;
        }
        let (from, to) = (from / n as f64, to / n as f64);
        let rotation = glam::DQuat::from_mat3(&similarity.rotation).normalize();
        RigidMotion {
            rotation: rotation.as_quat(),
            translation: (to - rotation * from).as_vec3(),
        }
    }

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
    fn fit_recovers_a_rigid_motion_and_composes() {
        let truth = RigidMotion {
            rotation: Quat::from_euler(glam::EulerRot::ZYX, 0.3, -0.2, 0.45),
            translation: Vec3::new(1.0, -2.0, 0.5),
        };
        let points = [
            Vec3::ZERO,
            Vec3::X,
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(0.3, 0.1, 1.0),
        ];
        let found = RigidMotion::fit(|| points.iter().map(|&p| (p, truth.apply(p))));
        assert!(found.rotation.abs_diff_eq(truth.rotation, 1e-5), "{found:?}");
        assert!(
            found.translation.abs_diff_eq(truth.translation, 1e-5),
            "{found:?}"
        );
        // Too few points: identity.
        let two = RigidMotion::fit(|| points[..2].iter().map(|&p| (p, truth.apply(p))));
        assert!(two.is_identity());
        // Composition: x -> truth(truth(x)).
        let twice = truth.after(&truth);
        let p = Vec3::new(0.2, -0.7, 1.1);
        assert!(twice.apply(p).abs_diff_eq(truth.apply(truth.apply(p)), 1e-5));
    }
}
