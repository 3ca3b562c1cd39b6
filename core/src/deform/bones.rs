//! The bones of `planar_bones` (see that file for the method): one bone per mask
//! triangle, the Voronoi region of a point relative to it, the point's coordinates in the
//! region's basis, and every bone's region bases in the current pose, evaluated per frame
//! by [`super::Binding::deform`].

use glam::{Vec3, Vec3A};

use super::normalize::Weighted;
use super::triangle_basis::TriangleBasis;

/// The region of a point relative to one bone.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Region {
    /// Foot point inside the triangle.
    Inside,
    /// Nearest to the interior of edge i (from corner i to corner i+1).
    Edge(u8),
    /// Nearest to corner i.
    Corner(u8),
}

/// One bone's influence on a head vertex.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoneTerm {
    pub triangle: u16,
    pub region: Region,
    /// Index of the region basis in [`BoneBases`]: `triangle * 7 + region.slot()`.
    pub basis: u32,
    /// Inside: (a, b, c) in the affine basis. Edge: (t, s, h) with
    /// `P - V_i = t e_i + s u_i + h n`. Corner: (x, y, h) with the in-plane offset
    /// `x u_i + y u_i-1` and height h.
    pub coords: Vec3,
    /// Corner regions: the rest length of the in-plane offset (head units).
    pub offset_length: f32,
    pub weight: f32,
}

impl Weighted for BoneTerm {
    fn weight_mut(&mut self) -> &mut f32 {
        &mut self.weight
    }
}

/// A bone's geometry in one pose: corners, edges, outward edge normals, unit normal.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Bone {
    pub corners: [Vec3A; 3],
    pub edges: [Vec3A; 3],
    pub outward: [Vec3A; 3],
    pub normal: Vec3A,
}

impl Bone {
    pub fn of(a: Vec3, b: Vec3, c: Vec3) -> Bone {
        let corners = [Vec3A::from(a), Vec3A::from(b), Vec3A::from(c)];
        let edges = [
            corners[1] - corners[0],
            corners[2] - corners[1],
            corners[0] - corners[2],
        ];
        let normal = edges[0].cross(corners[2] - corners[0]).normalize_or_zero();
        let outward = edges.map(|e| e.cross(normal).normalize_or_zero());
        Bone {
            corners,
            edges,
            outward,
            normal,
        }
    }

    fn basis(&self) -> TriangleBasis {
        TriangleBasis {
            origin: self.corners[0],
            e1: self.edges[0],
            e2: self.corners[2] - self.corners[0],
            normal: self.normal,
        }
    }

    /// Classifies `p` and computes its coordinates; `None` for a degenerate bone.
    pub fn bind(&self, p: Vec3) -> Option<(Region, Vec3, f32)> {
        if self.normal == Vec3A::ZERO {
            return None;
        }
        let p = Vec3A::from(p);
        let height = (p - self.corners[0]).dot(self.normal);
        let foot = p - height * self.normal;
        // Outside edge i when the foot is beyond its outward normal.
        let beyond = |i: usize| (foot - self.corners[i]).dot(self.outward[i]) > 0.0;
        if !(0..3).any(beyond) {
            return Some((Region::Inside, self.basis().coords(p.into())?, 0.0));
        }
        let mut best_edge: Option<(usize, f32)> = None;
        for i in 0..3 {
            let length = self.edges[i].length();
            let along = (foot - self.corners[i]).dot(self.edges[i]) / length;
            if beyond(i) && (0.0..=length).contains(&along) {
                let gap = (foot - self.corners[i]).dot(self.outward[i]);
                if best_edge.is_none_or(|(_, g)| gap < g) {
                    best_edge = Some((i, gap));
                }
            }
        }
        if let Some((i, gap)) = best_edge {
            let t = (foot - self.corners[i]).dot(self.edges[i]) / self.edges[i].length_squared();
            return Some((Region::Edge(i as u8), Vec3::new(t, gap, height), 0.0));
        }
        let i = (0..3)
            .min_by(|&a, &b| {
                foot.distance(self.corners[a])
                    .total_cmp(&foot.distance(self.corners[b]))
            })
            .expect("three corners");
        let offset = foot - self.corners[i];
        let (x, y) = self.corner_coords(i, offset)?;
        Some((Region::Corner(i as u8), Vec3::new(x, y, height), offset.length()))
    }

    /// Coordinates of an in-plane offset in the corner basis (u_i, u_i-1).
    fn corner_coords(&self, i: usize, offset: Vec3A) -> Option<(f32, f32)> {
        let (u, w) = (self.outward[i], self.outward[(i + 2) % 3]);
        let (uu, uw, ww) = (u.dot(u), u.dot(w), w.dot(w));
        let det = uu * ww - uw * uw;
        if det.abs() <= 1e-12 {
            return None;
        }
        let (ou, ow) = (offset.dot(u), offset.dot(w));
        Some(((ou * ww - ow * uw) / det, (ow * uu - ou * uw) / det))
    }

    /// The bound point in this pose.
    /// The seven region bases of this bone, in [`Region::slot`] order: origin and three
    /// axes each. Inside: (A, B - A, C - A, n); edge i: (V_i, e_i, u_i, n); corner i:
    /// (V_i, u_i, u_i-1, n).
    pub fn bases(&self) -> [RegionBasis; 7] {
        let basis = self.basis();
        let edge = |i: usize| [self.corners[i], self.edges[i], self.outward[i], self.normal];
        let corner = |i: usize| {
            [
                self.corners[i],
                self.outward[i],
                self.outward[(i + 2) % 3],
                self.normal,
            ]
        };
        [
            [basis.origin, basis.e1, basis.e2, basis.normal],
            edge(0),
            edge(1),
            edge(2),
            corner(0),
            corner(1),
            corner(2),
        ]
    }

    /// The bound point in this pose, one bone at a time: the reference the tests check
    /// [`BoneBases`]' evaluation and the region rules against.
    #[cfg(test)]
    pub fn point(&self, region: Region, coords: Vec3, offset_length: f32) -> Vec3A {
        evaluate(&self.bases()[region.slot()], coords, offset_length)
    }
}

/// Origin and three axes of one region basis.
pub type RegionBasis = [Vec3A; 4];

impl Region {
    /// Index of this region's basis among a bone's seven.
    pub fn slot(self) -> usize {
        match self {
            Region::Inside => 0,
            Region::Edge(i) => 1 + i as usize,
            Region::Corner(i) => 4 + i as usize,
        }
    }
}

/// `origin + s (x a1 + y a2) + z a3`, where `s` rescales a corner region's in-plane offset
/// to its rest length (`offset_length > 0`) and is 1 otherwise. Branch-free: terms of all
/// regions mix within a vertex, and a mispredicted branch per term costs more than the
/// arithmetic.
#[inline]
fn evaluate(basis: &RegionBasis, coords: Vec3, offset_length: f32) -> Vec3A {
    let in_plane = coords.x * basis[1] + coords.y * basis[2];
    let length = in_plane.length();
    let keep = f32::from(u8::from(offset_length <= 0.0 || length <= 0.0));
    let scale = (offset_length * (1.0 - keep) + length * keep) / length.max(f32::MIN_POSITIVE);
    basis[0] + in_plane * scale + coords.z * basis[3]
}

/// Every bone's region bases in the current pose; rebuilt once per frame.
#[derive(Debug, Clone, Default)]
pub struct BoneBases {
    bases: Vec<RegionBasis>,
}

impl BoneBases {
    pub fn with_capacity(triangles: usize) -> BoneBases {
        BoneBases {
            bases: Vec::with_capacity(triangles * 7),
        }
    }

    /// Rebuilds the bases from the moved mask. Allocates nothing once sized.
    pub fn update(&mut self, mask_now: &[Vec3], triangles: &[[u32; 3]]) {
        self.bases.clear();
        for t in triangles {
            let bone = Bone::of(
                mask_now[t[0] as usize],
                mask_now[t[1] as usize],
                mask_now[t[2] as usize],
            );
            self.bases.extend(bone.bases());
        }
    }

    /// A bound point of any region.
    pub fn point(&self, term: &BoneTerm) -> Vec3A {
        evaluate(&self.bases[term.basis as usize], term.coords, term.offset_length)
    }

    /// A bound point of an inside or edge region: affine in its basis, no rescale.
    #[inline]
    pub fn affine_point(&self, term: &BoneTerm) -> Vec3A {
        let f = &self.bases[term.basis as usize];
        f[0] + term.coords.x * f[1] + term.coords.y * f[2] + term.coords.z * f[3]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bone() -> Bone {
        Bone::of(Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0))
    }

    #[test]
    fn regions_are_the_voronoi_regions_of_the_triangle() {
        let b = bone();
        assert_eq!(b.bind(Vec3::new(0.5, 0.5, 1.0)).unwrap().0, Region::Inside);
        assert_eq!(b.bind(Vec3::new(1.0, -1.0, 0.0)).unwrap().0, Region::Edge(0));
        assert_eq!(b.bind(Vec3::new(2.0, 2.0, 0.0)).unwrap().0, Region::Edge(1));
        assert_eq!(b.bind(Vec3::new(-1.0, 1.0, 0.0)).unwrap().0, Region::Edge(2));
        assert_eq!(b.bind(Vec3::new(-1.0, -1.0, 0.0)).unwrap().0, Region::Corner(0));
        assert_eq!(b.bind(Vec3::new(3.0, -0.5, 0.0)).unwrap().0, Region::Corner(1));
        assert_eq!(b.bind(Vec3::new(-0.5, 3.0, 0.0)).unwrap().0, Region::Corner(2));
    }

    #[test]
    fn rest_pose_reproduces_every_point() {
        let b = bone();
        for p in [
            Vec3::new(0.5, 0.5, 1.0),
            Vec3::new(1.0, -1.0, 0.3),
            Vec3::new(-1.0, -1.0, -0.2),
            Vec3::new(3.0, -0.5, 0.0),
            Vec3::new(2.0, 2.0, 0.5),
        ] {
            let (region, coords, len) = b.bind(p).unwrap();
            assert!(
                Vec3::from(b.point(region, coords, len)).abs_diff_eq(p, 1e-5),
                "{p} {region:?}"
            );
        }
    }

    #[test]
    fn hand_computed_stretch() {
        // Stretch edge 0 to length 4: a point below its middle slides along and keeps its
        // distance; a point beyond corner 0 keeps its distance from the corner.
        let rest = bone();
        let moved = Bone::of(Vec3::ZERO, Vec3::new(4.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0));
        let (r, c, l) = rest.bind(Vec3::new(1.0, -1.0, 0.5)).unwrap();
        assert_eq!(r, Region::Edge(0));
        assert!(Vec3::from(moved.point(r, c, l)).abs_diff_eq(Vec3::new(2.0, -1.0, 0.5), 1e-5));
        let (r, c, l) = rest.bind(Vec3::new(-1.0, -1.0, 0.0)).unwrap();
        assert_eq!(r, Region::Corner(0));
        let q = Vec3::from(moved.point(r, c, l));
        assert!((q.length() - 2f32.sqrt()).abs() < 1e-5, "{q}");
    }

    #[test]
    fn continuous_across_region_borders() {
        // Deform the bone non-rigidly and walk a point across every border: no jumps larger
        // than the step times the largest stretch (here 3) plus rounding.
        let rest = bone();
        let moved = Bone::of(
            Vec3::new(0.1, 0.0, 0.2),
            Vec3::new(3.0, 0.5, -0.3),
            Vec3::new(-0.4, 2.5, 0.4),
        );
        let step = 1e-3;
        for (start, dir) in [
            (Vec3::new(-1.5, -1.0, 0.3), Vec3::X),
            (Vec3::new(3.0, -2.0, 0.0), Vec3::Y),
            (Vec3::new(-2.0, 3.0, -0.4), Vec3::new(1.0, -1.0, 0.0).normalize()),
        ] {
            let mut previous: Option<Vec3A> = None;
            for k in 0..5000 {
                let p = start + dir * (k as f32 * step);
                let (r, c, l) = rest.bind(p).unwrap();
                let q = moved.point(r, c, l);
                if let Some(prev) = previous {
                    assert!(
                        q.distance(prev) < 3.0 * step + 1e-4,
                        "jump at {p}: {}",
                        q.distance(prev)
                    );
                }
                previous = Some(q);
            }
        }
    }
}
