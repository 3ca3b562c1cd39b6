//! A mask triangle's local frame (origin, two edges, unit normal): the coordinates in which
//! the frame-based deformers (the barycentric variants, bones) store a point bound to a
//! triangle, and from which they place it on the moved mask. Its own module because both
//! the binding and the bones use it.

use glam::{Vec3, Vec3A};

/// A mask triangle's basis on the moved mask: origin, edges and unit normal.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TriangleBasis {
    pub origin: Vec3A,
    pub e1: Vec3A,
    pub e2: Vec3A,
    pub normal: Vec3A,
}

impl TriangleBasis {
    pub fn of(a: Vec3, b: Vec3, c: Vec3) -> TriangleBasis {
        let (a, b, c) = (Vec3A::from(a), Vec3A::from(b), Vec3A::from(c));
        let e1 = b - a;
        let e2 = c - a;
        TriangleBasis {
            origin: a,
            e1,
            e2,
            normal: e1.cross(e2).normalize_or_zero(),
        }
    }

    /// Local coordinates (a, b, c) of `p`, or `None` for a degenerate triangle.
    pub fn coords(&self, p: Vec3) -> Option<Vec3> {
        let m = glam::Mat3A::from_cols(self.e1, self.e2, self.normal);
        let det = m.determinant();
        if det.abs() <= f32::MIN_POSITIVE || !det.is_finite() {
            return None;
        }
        Some(Vec3::from(m.inverse() * (Vec3A::from(p) - self.origin)))
    }

    pub fn point(&self, coords: Vec3) -> Vec3A {
        self.origin + coords.x * self.e1 + coords.y * self.e2 + coords.z * self.normal
    }
}
