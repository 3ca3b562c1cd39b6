//! Projecting a head vertex onto the fitted mask: which mask triangle it belongs to, where
//! its foot point lies in that triangle (barycentric coordinates) and how high above it.
//!
//! Rule (docs/ALGORITHMS.md): P is *inside* T when every barycentric coordinate of its foot
//! point is at least `-INSIDE_EPSILON`. Among the triangles P is inside, the one nearest
//! along the surface wins (ties by |h|): near the closed mouth a lower-lip vertex can
//! project inside an upper-lip triangle, and only surface distance tells them apart. When
//! P is inside none, the nearest reachable triangle is used (smallest surface distance,
//! ties by Euclidean distance).

use glam::Vec3;

use super::Registration;
use crate::head::spatial::closest_point_on_triangle;

/// Barycentric slack for "inside" (a point on an edge is inside both triangles).
pub const INSIDE_EPSILON: f32 = 1e-4;

/// Where a head vertex sits relative to the fitted neutral mask.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// The chosen mask triangle.
    pub triangle: u16,
    /// Whether the foot point lies inside it.
    pub inside: bool,
    /// Barycentric coordinates of the foot point (sum 1; negative outside).
    pub bary: [f32; 3],
    /// Signed height above the triangle's plane, head units.
    pub height: f32,
    /// Surface distance to the triangle (nearest corner's anchor), mm.
    pub distance_mm: f32,
}

/// Foot point barycentrics and height of `p` over triangle `abc`; `None` when the
/// triangle is degenerate.
pub fn barycentric(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Option<([f32; 3], f32)> {
    let n = (b - a).cross(c - a);
    let area2 = n.length_squared();
    if area2 <= f32::MIN_POSITIVE {
        return None;
    }
    let height = (p - a).dot(n) / area2.sqrt();
    // Signed sub-areas over the full area give the barycentrics of the foot point.
    let mu_a = (c - b).cross(p - b).dot(n) / area2;
    let mu_b = (a - c).cross(p - c).dot(n) / area2;
    Some(([mu_a, mu_b, 1.0 - mu_a - mu_b], height))
}

/// Projects head vertex `v` onto the registration's fitted mask.
pub fn project(reg: &Registration, v: u32) -> Projection {
    let p = reg.head.positions[v as usize];
    let mask = reg.mask_rest();
    let mut best_inside: Option<(f32, f32, Projection)> = None;
    let mut best_outside: Option<(f32, f32, Projection)> = None;
    for (t, tri) in reg.mask_triangles().iter().enumerate() {
        let [a, b, c] = tri.map(|j| mask[j as usize]);
        let Some((bary, height)) = barycentric(p, a, b, c) else {
            continue;
        };
        let (distance_mm, _) = reg.distance_to_triangle(t, v);
        let inside = bary.iter().all(|&m| m >= -INSIDE_EPSILON);
        let candidate = Projection {
            triangle: t as u16,
            inside,
            bary,
            height,
            distance_mm,
        };
        if inside {
            let key = (distance_mm, height.abs());
            if best_inside.as_ref().is_none_or(|(d, h, _)| key < (*d, *h)) {
                best_inside = Some((key.0, key.1, candidate));
            }
        } else {
            let euclid = closest_point_on_triangle(p, a, b, c).distance(p);
            let key = (distance_mm, euclid);
            if best_outside.as_ref().is_none_or(|(d, e, _)| key < (*d, *e)) {
                best_outside = Some((key.0, key.1, candidate));
            }
        }
    }
    best_inside
        .or(best_outside)
        .map(|(_, _, p)| p)
        .expect("the mask has non-degenerate triangles")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn barycentrics_and_height() {
        let (a, b, c) = (Vec3::ZERO, Vec3::X, Vec3::Y);
        let (bary, h) = barycentric(Vec3::new(0.25, 0.5, 2.0), a, b, c).unwrap();
        assert!(
            (bary[0] - 0.25).abs() < 1e-6 && (bary[1] - 0.25).abs() < 1e-6 && (bary[2] - 0.5).abs() < 1e-6
        );
        assert!((h - 2.0).abs() < 1e-6);
        let (bary, _) = barycentric(Vec3::new(2.0, 0.0, 0.0), a, b, c).unwrap();
        assert!((bary[0] + 1.0).abs() < 1e-6 && (bary[1] - 2.0).abs() < 1e-6 && bary[2].abs() < 1e-6);
        assert!(barycentric(Vec3::ZERO, a, a, b).is_none());
    }
}
