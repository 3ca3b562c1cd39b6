//! The cotangent Laplacian and the lumped mass matrix of a triangle mesh at rest: the
//! discrete operators of smooth deformation (docs/ALGORITHMS.md, "Biharmonic").
//!
//! - `L` is symmetric with `L_ij = (cot a_ij + cot b_ij) / 2` for an edge ij, `a_ij` and
//!   `b_ij` the angles opposite it (one on a boundary edge), and `L_ii = -sum_j L_ij`, so
//!   its rows sum to zero and `L x = 0` for a constant `x`.
//! - `M` is diagonal: a third of the area of the triangles around each vertex (barycentric
//!   lumping), in squared position units.
//!
//! Both are in f64. Degenerate triangles would give infinite cotangents; they are clamped to
//! `±MAX_COTANGENT`, so that a sliver cannot dominate the operator.

use glam::DVec3;

/// Largest cotangent magnitude kept: an angle of about 0.006 degrees.
pub const MAX_COTANGENT: f64 = 1e4;

/// `L` and `M` of one mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct CotanLaplacian {
    /// `neighbors[i]`: the off-diagonal entries `(j, L_ij)` of row i, by increasing j.
    pub neighbors: Vec<Vec<(u32, f64)>>,
    /// `L_ii`.
    pub diagonal: Vec<f64>,
    /// `M_ii`: zero for a vertex in no triangle.
    pub mass: Vec<f64>,
}

impl CotanLaplacian {
    pub fn new(positions: &[glam::Vec3], triangles: &[[u32; 3]]) -> CotanLaplacian {
        let n = positions.len();
        let mut neighbors: Vec<Vec<(u32, f64)>> = vec![Vec::new(); n];
        let mut mass = vec![0.0; n];
        let position = |v: u32| positions[v as usize].as_dvec3();
        for &[a, b, c] in triangles {
            let corners = [a, b, c];
            let [pa, pb, pc] = corners.map(position);
            let area = 0.5 * (pb - pa).cross(pc - pa).length();
            for v in corners {
                mass[v as usize] += area / 3.0;
            }
            // The angle at each corner weighs the edge opposite it.
            for k in 0..3 {
                let (corner, i, j) = (corners[k], corners[(k + 1) % 3], corners[(k + 2) % 3]);
                let half_cot = 0.5 * cotangent(position(corner), position(i), position(j));
                neighbors[i as usize].push((j, half_cot));
                neighbors[j as usize].push((i, half_cot));
            }
        }
        let mut diagonal = vec![0.0; n];
        for (row, d) in neighbors.iter_mut().zip(&mut diagonal) {
            row.sort_by_key(|&(j, _)| j);
            row.dedup_by(|later, kept| {
                let same = later.0 == kept.0;
                if same {
                    kept.1 += later.1;
                }
                same
            });
            *d = -row.iter().map(|&(_, w)| w).sum::<f64>();
        }
        CotanLaplacian {
            neighbors,
            diagonal,
            mass,
        }
    }

    pub fn vertex_count(&self) -> usize {
        self.diagonal.len()
    }

    /// `(L x)_i` for a scalar field `x`.
    pub fn apply(&self, x: &[f64], i: usize) -> f64 {
        self.diagonal[i] * x[i]
            + self.neighbors[i]
                .iter()
                .map(|&(j, w)| w * x[j as usize])
                .sum::<f64>()
    }
}

/// Cotangent of the angle at `corner` between the edges to `i` and `j`, clamped to
/// `±MAX_COTANGENT`.
fn cotangent(corner: DVec3, i: DVec3, j: DVec3) -> f64 {
    let (u, v) = (i - corner, j - corner);
    let sine = u.cross(v).length();
    let cosine = u.dot(v);
    if sine <= f64::MIN_POSITIVE {
        return MAX_COTANGENT.copysign(cosine);
    }
    (cosine / sine).clamp(-MAX_COTANGENT, MAX_COTANGENT)
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-12
    }

    #[test]
    fn a_right_isoceles_triangle_by_hand() {
        // Right angle at 0, 45 degrees at 1 and 2: cot 90 = 0 weighs edge 1-2, cot 45 = 1
        // weighs edges 0-2 and 0-1; each edge has one triangle, so L_ij = cot / 2.
        let positions = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let l = CotanLaplacian::new(&positions, &[[0, 1, 2]]);
        assert_eq!(l.neighbors[0], vec![(1, 0.5), (2, 0.5)]);
        assert!(close(l.neighbors[1][1].1, 0.0), "{:?}", l.neighbors[1]);
        assert_eq!(l.diagonal[0], -1.0);
        assert!(close(l.diagonal[1], -0.5));
        // Area 1/2, a third to each corner.
        for m in &l.mass {
            assert!(close(*m, 1.0 / 6.0));
        }
    }

    #[test]
    fn two_triangles_sum_their_cotangents_on_the_shared_edge() {
        // A unit square split along 1-2: the shared edge sees two right angles (cot 0), the
        // outer edges one 45-degree angle each.
        let positions = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)];
        let l = CotanLaplacian::new(&positions, &[[0, 1, 2], [1, 3, 2]]);
        let entry = |i: usize, j: u32| l.neighbors[i].iter().find(|e| e.0 == j).map(|e| e.1);
        assert!(close(entry(1, 2).unwrap(), 0.0));
        assert!(close(entry(0, 1).unwrap(), 0.5));
        assert!(close(entry(3, 1).unwrap(), 0.5));
        assert_eq!(entry(0, 3), None);
        assert!(close(l.mass[1], 2.0 / 6.0));
    }

    #[test]
    fn constants_and_planar_linear_fields_at_interior_vertices_are_in_the_kernel() {
        // A flat fan of 6 triangles around vertex 0, irregular on purpose.
        let ring: Vec<Vec3> = [0.0f32, 50.0, 110.0, 170.0, 230.0, 300.0]
            .iter()
            .zip([1.0f32, 1.3, 0.8, 1.1, 0.9, 1.2])
            .map(|(deg, r)| Vec3::new(r * deg.to_radians().cos(), r * deg.to_radians().sin(), 0.0))
            .collect();
        let positions: Vec<Vec3> = std::iter::once(Vec3::new(0.05, -0.02, 0.0)).chain(ring).collect();
        let triangles: Vec<[u32; 3]> = (0..6).map(|k| [0, 1 + k, 1 + (k + 1) % 6]).collect();
        let l = CotanLaplacian::new(&positions, &triangles);
        let constant = vec![3.0; positions.len()];
        let linear: Vec<f64> = positions
            .iter()
            .map(|p| 2.0 * p.x as f64 - 0.7 * p.y as f64)
            .collect();
        assert!(l.apply(&constant, 0).abs() < 1e-12);
        // Linear precision of the cotangent Laplacian at an interior vertex of a flat mesh.
        assert!(l.apply(&linear, 0).abs() < 1e-6, "{}", l.apply(&linear, 0));
        // Every row sums to zero, boundary rows included.
        for i in 0..positions.len() {
            assert!(l.apply(&constant, i).abs() < 1e-12);
        }
    }

    #[test]
    fn a_degenerate_triangle_gives_clamped_weights_not_infinities() {
        let positions = [Vec3::ZERO, Vec3::X, Vec3::new(2.0, 0.0, 0.0)];
        let l = CotanLaplacian::new(&positions, &[[0, 1, 2]]);
        assert!(l.diagonal.iter().all(|d| d.is_finite()));
        assert!(l
            .neighbors
            .iter()
            .flatten()
            .all(|(_, w)| w.abs() <= MAX_COTANGENT / 2.0));
        assert_eq!(l.mass, vec![0.0; 3]);
    }
}
