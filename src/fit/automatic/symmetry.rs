//! How far a head is from mirror-symmetric about a plane: the median distance from its
//! vertices, reflected across the plane, to its surface. A face is close to symmetric
//! about the plane through its nose that holds the up and forward directions, and far
//! from it about any plane through an ear or a cheekbone.

use glam::Vec3;

use crate::head::Head;

/// At most this many vertices are reflected (evenly spread over the file order).
const SAMPLES: usize = 1500;

/// Median distance (head units) from `head`'s vertices, reflected across the plane through
/// `point` with unit normal `normal`, to the surface.
pub fn asymmetry(head: &Head, point: Vec3, normal: Vec3) -> f32 {
    let step = head.positions.len().div_ceil(SAMPLES).max(1);
    let mut distances: Vec<f32> = head
        .positions
        .iter()
        .step_by(step)
        .filter_map(|&p| {
            let mirrored = p - 2.0 * (p - point).dot(normal) * normal;
            head.surface.closest_point(mirrored).map(|s| s.distance)
        })
        .collect();
    if distances.is_empty() {
        return f32::INFINITY;
    }
    let middle = distances.len() / 2;
    *distances.select_nth_unstable_by(middle, f32::total_cmp).1
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two parallel squares from x = 0 to x = 2: symmetric about x = 1, not about x = 0.2.
    fn slab() -> Head {
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        // A grid on the top face (y = 1) and the bottom face (y = 0), 11 x 11 each.
        for y in [0.0f32, 1.0] {
            let base = positions.len() as u32;
            for i in 0..11 {
                for k in 0..11 {
                    positions.push(Vec3::new(i as f32 * 0.2, y, k as f32 * 0.2));
                }
            }
            for i in 0..10u32 {
                for k in 0..10u32 {
                    let a = base + i * 11 + k;
                    triangles.push([a, a + 11, a + 1]);
                    triangles.push([a + 1, a + 11, a + 12]);
                }
            }
        }
        Head::new("slab", positions, triangles)
    }

    #[test]
    fn a_slab_is_symmetric_about_its_middle_only() {
        let head = slab();
        assert!(asymmetry(&head, Vec3::new(1.0, 0.0, 0.0), Vec3::X) < 1e-5);
        // Reflected about x = 0.2, the slab lands on x in [-1.6, 0.4]: most of it off itself.
        let off = asymmetry(&head, Vec3::new(0.2, 0.0, 0.0), Vec3::X);
        assert!((off - 0.6).abs() < 0.05, "{off}");
    }
}
