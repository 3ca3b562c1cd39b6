//! Nearest-vertex and nearest-surface-point queries on a head, backed by R*-trees.
//! Used at registration (anchors, fit residuals), never per frame.

use glam::{DVec3, Vec3};
use rstar::primitives::GeomWithData;
use rstar::{PointDistance, RTree, RTreeObject, AABB};

type IndexedPoint = GeomWithData<[f32; 3], u32>;

/// Nearest head vertex to a point.
#[derive(Debug, Clone)]
pub struct VertexIndex {
    tree: RTree<IndexedPoint>,
}

impl VertexIndex {
    pub fn new(positions: &[Vec3]) -> VertexIndex {
        let points = positions
            .iter()
            .enumerate()
            .map(|(i, p)| IndexedPoint::new(p.to_array(), i as u32))
            .collect();
        VertexIndex {
            tree: RTree::bulk_load(points),
        }
    }

    /// The nearest vertex and its distance (head units).
    pub fn nearest(&self, p: Vec3) -> Option<(u32, f32)> {
        self.nearest_where(p, |_| true)
    }

    /// The nearest vertex accepted by `keep`, searching outwards.
    pub fn nearest_where(&self, p: Vec3, mut keep: impl FnMut(u32) -> bool) -> Option<(u32, f32)> {
        self.tree
            .nearest_neighbor_iter_with_distance_2(&p.to_array())
            .find(|(item, _)| keep(item.data))
            .map(|(item, d2)| (item.data, d2.sqrt()))
    }
}

/// A triangle with its index, stored in the surface tree.
#[derive(Debug, Clone)]
struct IndexedTriangle {
    corners: [Vec3; 3],
    index: u32,
}

impl RTreeObject for IndexedTriangle {
    type Envelope = AABB<[f32; 3]>;

    fn envelope(&self) -> Self::Envelope {
        let [a, b, c] = self.corners;
        AABB::from_corners(a.min(b).min(c).to_array(), a.max(b).max(c).to_array())
    }
}

impl PointDistance for IndexedTriangle {
    fn distance_2(&self, point: &[f32; 3]) -> f32 {
        let p = Vec3::from_array(*point).as_dvec3();
        let [a, b, c] = self.corners.map(|c| c.as_dvec3());
        // Squared in f64, then held to f32's range: infinite, never NaN.
        (closest_point_f64(p, a, b, c).distance_squared(p) as f32).min(f32::MAX)
    }
}

/// The closest point of a surface to a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    pub triangle: u32,
    pub point: Vec3,
    /// Head units.
    pub distance: f32,
}

/// Nearest point on a triangle mesh.
#[derive(Debug, Clone)]
pub struct SurfaceIndex {
    tree: RTree<IndexedTriangle>,
}

impl SurfaceIndex {
    pub fn new(positions: &[Vec3], triangles: &[[u32; 3]]) -> SurfaceIndex {
        let items = triangles
            .iter()
            .enumerate()
            .map(|(i, t)| IndexedTriangle {
                corners: t.map(|v| positions[v as usize]),
                index: i as u32,
            })
            .collect();
        SurfaceIndex {
            tree: RTree::bulk_load(items),
        }
    }

    pub fn closest_point(&self, p: Vec3) -> Option<SurfacePoint> {
        let tri = self.tree.nearest_neighbor(&p.to_array())?;
        let [a, b, c] = tri.corners.map(|c| c.as_dvec3());
        let point = closest_point_f64(p.as_dvec3(), a, b, c).as_vec3();
        Some(SurfacePoint {
            triangle: tri.index,
            point,
            distance: point.distance(p),
        })
    }
}

/// Defines a closest-point-on-triangle function for one precision: the Voronoi-region
/// test (corners, edges, face; degenerate triangles too), written once for both.
macro_rules! closest_point_in {
    ($(#[$doc:meta])* $name:ident, $vec:ty, $float:ty) => {
        $(#[$doc])*
        pub fn $name(p: $vec, a: $vec, b: $vec, c: $vec) -> $vec {
            let ab = b - a;
            let ac = c - a;
            let ap = p - a;
            let d1 = ab.dot(ap);
            let d2 = ac.dot(ap);
            if d1 <= 0.0 && d2 <= 0.0 {
                return a;
            }
            let bp = p - b;
            let d3 = ab.dot(bp);
            let d4 = ac.dot(bp);
            if d3 >= 0.0 && d4 <= d3 {
                return b;
            }
            let vc = d1 * d4 - d3 * d2;
            if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
                return a + ab * (d1 / (d1 - d3));
            }
            let cp = p - c;
            let d5 = ab.dot(cp);
            let d6 = ac.dot(cp);
            if d6 >= 0.0 && d5 <= d6 {
                return c;
            }
            let vb = d5 * d2 - d1 * d6;
            if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
                return a + ac * (d2 / (d2 - d6));
            }
            let va = d3 * d6 - d5 * d4;
            if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
                return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
            }
            let denom = va + vb + vc;
            if denom.abs() < <$float>::MIN_POSITIVE {
                return a; // all three corners coincide
            }
            let v = vb / denom;
            let w = vc / denom;
            a + ab * v + ac * w
        }
    };
}

closest_point_in!(
    /// Closest point to `p` on triangle `abc`. f32, for per-frame use on heads of sane
    /// size: the region tests multiply four coordinates, which overflows f32 past about
    /// 1e9 head units; the nearest-point indexes use [`closest_point_f64`] instead.
    closest_point_on_triangle,
    Vec3,
    f32
);

closest_point_in!(
    /// [`closest_point_on_triangle`] in f64, for the nearest-point indexes (registration
    /// and fitting, never per frame): for any finite f32 input it cannot overflow, so an
    /// R*-tree over a head a billion units across still orders its distances (a NaN there
    /// panics).
    closest_point_f64,
    DVec3,
    f64
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_point_regions() {
        let (a, b, c) = (Vec3::ZERO, Vec3::X, Vec3::Y);
        let inside = closest_point_on_triangle(Vec3::new(0.2, 0.2, 5.0), a, b, c);
        assert!(inside.abs_diff_eq(Vec3::new(0.2, 0.2, 0.0), 1e-6), "{inside}");
        assert_eq!(closest_point_on_triangle(Vec3::new(-1.0, -1.0, 0.0), a, b, c), a);
        assert_eq!(
            closest_point_on_triangle(Vec3::new(0.5, -2.0, 1.0), a, b, c),
            Vec3::new(0.5, 0.0, 0.0)
        );
        let on_hypotenuse = closest_point_on_triangle(Vec3::new(1.0, 1.0, 0.0), a, b, c);
        assert!(on_hypotenuse.abs_diff_eq(Vec3::new(0.5, 0.5, 0.0), 1e-6));
    }

    #[test]
    fn nearest_vertex_and_surface() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(5.0, 5.0, 0.0)];
        let t = vec![[0, 1, 2], [1, 3, 2]];
        let vi = VertexIndex::new(&p);
        assert_eq!(vi.nearest(Vec3::new(0.9, 0.1, 0.0)).unwrap().0, 1);
        assert_eq!(
            vi.nearest_where(Vec3::new(0.9, 0.1, 0.0), |v| v != 1).unwrap().0,
            0
        );
        let si = SurfaceIndex::new(&p, &t);
        let hit = si.closest_point(Vec3::new(0.25, 0.25, 2.0)).unwrap();
        assert_eq!(hit.triangle, 0);
        assert!((hit.distance - 2.0).abs() < 1e-6);
    }

    #[test]
    fn a_surface_a_trillion_units_across_still_has_nearest_points() {
        let s = 1e12;
        let p = vec![Vec3::ZERO, Vec3::X * s, Vec3::Y * s, Vec3::new(5.0, 5.0, 0.0) * s];
        let si = SurfaceIndex::new(&p, &[[0, 1, 2], [1, 3, 2]]);
        for q in [Vec3::new(0.25, 0.25, 2.0), Vec3::new(3.0, 4.0, -1.0)] {
            let hit = si.closest_point(q * s).unwrap();
            assert!(hit.distance.is_finite(), "{hit:?}");
        }
        let hit = si.closest_point(Vec3::new(0.25, 0.25, 2.0) * s).unwrap();
        assert_eq!(hit.triangle, 0);
        assert!((hit.distance / s - 2.0).abs() < 1e-5, "{hit:?}");
    }
}
