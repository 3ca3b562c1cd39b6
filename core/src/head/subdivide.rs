//! Midpoint subdivision: each triangle splits into four through its edge midpoints. The
//! shape is unchanged (the new vertices lie on the old edges); vertex count grows by the
//! edge count. Used to make large heads for benchmarks from the shipped scan.

use std::collections::HashMap;

use glam::Vec3;

/// One round of midpoint subdivision. The original vertices keep their indices.
pub fn midpoint(positions: &[Vec3], triangles: &[[u32; 3]]) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut out_positions = positions.to_vec();
    let mut midpoints: HashMap<(u32, u32), u32> = HashMap::with_capacity(triangles.len() * 3 / 2);
    let mut out_triangles = Vec::with_capacity(triangles.len() * 4);
    for t in triangles {
        let mut mid = |a: u32, b: u32| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                out_positions.push(0.5 * (positions[a as usize] + positions[b as usize]));
                (out_positions.len() - 1) as u32
            })
        };
        let (ab, bc, ca) = (mid(t[0], t[1]), mid(t[1], t[2]), mid(t[2], t[0]));
        out_triangles.extend([[t[0], ab, ca], [ab, t[1], bc], [ca, bc, t[2]], [ab, bc, ca]]);
    }
    (out_positions, out_triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_triangle_becomes_four_sharing_midpoints() {
        let (p, t) = midpoint(&[Vec3::ZERO, Vec3::X, Vec3::Y], &[[0, 1, 2]]);
        assert_eq!(p.len(), 6);
        assert_eq!(t.len(), 4);
        assert_eq!(p[3], Vec3::new(0.5, 0.0, 0.0));
        // two triangles sharing an edge share its midpoint
        let (p, t) = midpoint(
            &[Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE],
            &[[0, 1, 2], [1, 3, 2]],
        );
        assert_eq!(p.len(), 4 + 5);
        assert_eq!(t.len(), 8);
    }
}
