//! A part mesh's connected pieces, and the closed ones as solids: a point is inside a
//! solid when a ray from it crosses the solid's surface an odd number of times. Teeth are
//! solids (each tooth of the ICT model is one closed piece); gums and tongues are open
//! surfaces. The contact measures (`metrics::contact`), the contact constraint
//! (`animate::teeth_contact`) and the split of a part holding both rows of teeth
//! (`animate::part_split`) all read meshes through this.

use glam::Vec3;

use super::{closest_point_on_triangle, Head, SurfaceIndex};

/// The ray the inside test casts: off every axis so that it does not run along the
/// edges of axis-aligned geometry.
const RAY: Vec3 = Vec3::new(0.8017, 0.3312, 0.4975);

/// A vertex no triangle uses.
pub const NO_PIECE: u32 = u32::MAX;

/// Each vertex's connected piece (vertices joined by triangles).
#[derive(Debug, Clone)]
pub struct Pieces {
    /// The piece of each vertex, [`NO_PIECE`] for a vertex no triangle uses.
    pub of_vertex: Vec<u32>,
    pub count: usize,
}

impl Pieces {
    pub fn of(mesh: &Head) -> Pieces {
        let n = mesh.positions.len();
        let mut parent: Vec<u32> = (0..n as u32).collect();
        fn root(parent: &mut [u32], mut v: u32) -> u32 {
            while parent[v as usize] != v {
                let up = parent[parent[v as usize] as usize];
                parent[v as usize] = up;
                v = up;
            }
            v
        }
        let mut used = vec![false; n];
        for t in &mesh.triangles {
            for &v in t {
                used[v as usize] = true;
            }
            for &v in &t[1..] {
                let (a, b) = (root(&mut parent, t[0]), root(&mut parent, v));
                if a != b {
                    parent[a.max(b) as usize] = a.min(b);
                }
            }
        }
        let mut label = vec![NO_PIECE; n];
        let mut of_vertex = vec![NO_PIECE; n];
        let mut count = 0u32;
        for v in 0..n {
            if !used[v] {
                continue;
            }
            let r = root(&mut parent, v as u32) as usize;
            if label[r] == NO_PIECE {
                label[r] = count;
                count += 1;
            }
            of_vertex[v] = label[r];
        }
        Pieces {
            of_vertex,
            count: count as usize,
        }
    }
}

/// One closed piece (a tooth): its triangles and bounding box, head units.
#[derive(Debug, Clone)]
pub struct Solid {
    pub min: Vec3,
    pub max: Vec3,
    pub triangles: Vec<[Vec3; 3]>,
    /// The triangles binned by where they lie across the inside test's ray.
    across: RayGrid,
    /// Each triangle's bounding sphere (centre, radius), for nearest-point queries.
    spheres: Vec<(Vec3, f32)>,
}

impl Solid {
    /// The solid bounded by `triangles` (a closed surface).
    pub fn new(triangles: Vec<[Vec3; 3]>) -> Solid {
        let (mut min, mut max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for &c in triangles.iter().flatten() {
            min = min.min(c);
            max = max.max(c);
        }
        Solid {
            min,
            max,
            across: RayGrid::new(&triangles),
            spheres: triangles
                .iter()
                .map(|t| {
                    let centre = (t[0] + t[1] + t[2]) / 3.0;
                    (centre, t.iter().map(|c| c.distance(centre)).fold(0.0, f32::max))
                })
                .collect(),
            triangles,
        }
    }

    /// Whether `p` is inside.
    pub fn contains(&self, p: Vec3) -> bool {
        if p.cmplt(self.min).any() || p.cmpgt(self.max).any() {
            return false;
        }
        let crossings = self
            .across
            .triangles_across(p)
            .iter()
            .filter(|&&t| ray_hits(p, RAY, &self.triangles[t as usize]))
            .count();
        crossings % 2 == 1
    }

    /// The point of the surface closest to `p` (head units).
    /// A triangle whose bounding sphere lies further than the best so far is skipped.
    pub fn closest_point(&self, p: Vec3) -> Vec3 {
        let (mut best, mut best_distance) = (p, f32::INFINITY);
        for ([a, b, c], &(centre, radius)) in self.triangles.iter().zip(&self.spheres) {
            if p.distance(centre) - radius >= best_distance {
                continue;
            }
            let q = closest_point_on_triangle(p, *a, *b, *c);
            let distance = q.distance(p);
            if distance < best_distance {
                (best, best_distance) = (q, distance);
            }
        }
        best
    }

    /// How far `p` is from the surface (head units).
    pub fn distance(&self, p: Vec3) -> f32 {
        self.closest_point(p).distance(p)
    }
}

/// Cells across [`RAY`] on each side of the grid.
const GRID_CELLS: usize = 8;

/// A solid's triangles binned on the plane across [`RAY`]: the ray from a point can only
/// cross triangles whose shadow on that plane covers the point's, so the inside test
/// reads one cell's list instead of every triangle.
#[derive(Debug, Clone)]
struct RayGrid {
    /// Two directions across the ray, and where the grid starts along them.
    u: Vec3,
    w: Vec3,
    origin: [f32; 2],
    /// Cell size along `u` and `w`.
    cell: [f32; 2],
    /// For cell `i`: `items[start[i]..start[i + 1]]`.
    start: Vec<u32>,
    items: Vec<u32>,
}

impl RayGrid {
    fn new(triangles: &[[Vec3; 3]]) -> RayGrid {
        let u = RAY.any_orthonormal_vector();
        let w = RAY.normalize().cross(u);
        let across = |c: Vec3| [c.dot(u), c.dot(w)];
        let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        for &c in triangles.iter().flatten() {
            let a = across(c);
            for k in 0..2 {
                lo[k] = lo[k].min(a[k]);
                hi[k] = hi[k].max(a[k]);
            }
        }
        let cell = [0, 1].map(|k| ((hi[k] - lo[k]) / GRID_CELLS as f32).max(f32::MIN_POSITIVE));
        let range = |t: &[Vec3; 3], k: usize| {
            let (mut a, mut b) = (f32::INFINITY, f32::NEG_INFINITY);
            for &c in t {
                a = a.min(across(c)[k]);
                b = b.max(across(c)[k]);
            }
            let index = |x: f32| (((x - lo[k]) / cell[k]).floor().max(0.0) as usize).min(GRID_CELLS - 1);
            index(a)..=index(b)
        };
        let mut cells: Vec<Vec<u32>> = vec![Vec::new(); GRID_CELLS * GRID_CELLS];
        for (i, t) in triangles.iter().enumerate() {
            for a in range(t, 0) {
                for b in range(t, 1) {
                    cells[a * GRID_CELLS + b].push(i as u32);
                }
            }
        }
        let mut start = vec![0u32];
        let mut items = Vec::new();
        for c in cells {
            items.extend(c);
            start.push(items.len() as u32);
        }
        RayGrid {
            u,
            w,
            origin: lo,
            cell,
            start,
            items,
        }
    }

    /// The triangles whose shadow may cover `p`'s.
    fn triangles_across(&self, p: Vec3) -> &[u32] {
        let index = |x: f32, k: usize| ((x - self.origin[k]) / self.cell[k]).floor();
        let (a, b) = (index(p.dot(self.u), 0), index(p.dot(self.w), 1));
        let cells = GRID_CELLS as f32;
        if !(0.0..cells).contains(&a) || !(0.0..cells).contains(&b) {
            return &[];
        }
        let i = a as usize * GRID_CELLS + b as usize;
        &self.items[self.start[i] as usize..self.start[i + 1] as usize]
    }
}

/// Möller-Trumbore: whether the ray `origin + s * direction`, `s > 0`, crosses `t`.
fn ray_hits(origin: Vec3, direction: Vec3, [a, b, c]: &[Vec3; 3]) -> bool {
    let (e1, e2) = (*b - *a, *c - *a);
    let h = direction.cross(e2);
    let det = e1.dot(h);
    if det.abs() < 1e-12 {
        return false;
    }
    let inv = 1.0 / det;
    let s = origin - *a;
    let u = s.dot(h) * inv;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let q = s.cross(e1);
    let v = direction.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    e2.dot(q) * inv > 0.0
}

/// The closed connected pieces of a mesh (pieces none of whose edges is open) as solids,
/// and the triangles of the open ones.
pub fn closed_pieces(mesh: &Head) -> (Vec<Solid>, Vec<[Vec3; 3]>) {
    let (pieces, open) = open_pieces(mesh);
    let mut solid_of = vec![usize::MAX; pieces.count];
    let mut closed: Vec<Vec<[Vec3; 3]>> = Vec::new();
    let mut open_triangles = Vec::new();
    for t in &mesh.triangles {
        let piece = pieces.of_vertex[t[0] as usize] as usize;
        let corners = t.map(|v| mesh.positions[v as usize]);
        if open[piece] {
            open_triangles.push(corners);
            continue;
        }
        if solid_of[piece] == usize::MAX {
            solid_of[piece] = closed.len();
            closed.push(Vec::new());
        }
        closed[solid_of[piece]].push(corners);
    }
    (closed.into_iter().map(Solid::new).collect(), open_triangles)
}

/// How many of the mesh's pieces are closed (teeth a contact can be kept out of).
pub fn closed_piece_count(mesh: &Head) -> usize {
    let (_, open) = open_pieces(mesh);
    open.iter().filter(|&&o| !o).count()
}

/// The mesh's pieces, and which of them have an open edge (one not shared by exactly two
/// triangles).
fn open_pieces(mesh: &Head) -> (Pieces, Vec<bool>) {
    let pieces = Pieces::of(mesh);
    let mut open = vec![false; pieces.count];
    for edge in mesh.topology.edges.iter().filter(|e| e.triangles != 2) {
        open[pieces.of_vertex[edge.a as usize] as usize] = true;
    }
    (pieces, open)
}

/// A surface index over loose triangles; `None` for none.
pub fn surface_of(triangles: &[[Vec3; 3]]) -> Option<SurfaceIndex> {
    let corners: Vec<Vec3> = triangles.iter().flatten().copied().collect();
    let indices: Vec<[u32; 3]> = (0..triangles.len() as u32)
        .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
        .collect();
    (!indices.is_empty()).then(|| SurfaceIndex::new(&corners, &indices))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed unit cube [0, 1]^3 moved by `offset`, as 12 triangles.
    fn cube(offset: Vec3) -> Head {
        crate::head::box_mesh(offset, offset + Vec3::ONE)
    }

    #[test]
    fn a_closed_piece_holds_its_inside_only() {
        let (pieces, open) = closed_pieces(&cube(Vec3::ZERO));
        assert!(open.is_empty());
        assert_eq!(pieces.len(), 1);
        assert_eq!(pieces[0].triangles.len(), 12);
        for (p, inside) in [
            (Vec3::splat(0.5), true),
            (Vec3::new(0.01, 0.99, 0.5), true),
            (Vec3::new(0.5, 0.5, 1.01), false),
            (Vec3::new(-0.5, 0.5, 0.5), false),
            (Vec3::new(2.0, 0.5, 0.5), false),
        ] {
            assert_eq!(pieces[0].contains(p), inside, "{p}");
        }
    }

    #[test]
    fn the_ray_grid_answers_as_every_triangle_would() {
        // A ball-ish closed mesh: a subdivided, normalized octahedron.
        let mut positions = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        let mut triangles = vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ];
        for _ in 0..3 {
            (positions, triangles) = crate::head::subdivide::midpoint(&positions, &triangles);
            for p in &mut positions {
                *p = p.normalize();
            }
        }
        let ball = Head::new("ball", positions, triangles);
        let (solids, _) = closed_pieces(&ball);
        assert_eq!(solids.len(), 1);
        let solid = &solids[0];
        for i in 0..2000 {
            let f = i as f32;
            let p = Vec3::new((f * 0.7311).sin(), (f * 1.3717).sin(), (f * 0.5123).cos()) * 1.1;
            let every = solid.triangles.iter().filter(|t| ray_hits(p, RAY, t)).count() % 2 == 1;
            assert_eq!(solid.contains(p), every, "{p}");
        }
        // Points well inside and outside.
        assert!(solid.contains(Vec3::splat(0.3)));
        assert!(!solid.contains(Vec3::splat(0.7)));
    }

    #[test]
    fn open_pieces_are_not_solids() {
        let open = Head::from_obj_bytes("open", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let (closed, triangles) = closed_pieces(&open);
        assert!(closed.is_empty());
        assert_eq!(triangles.len(), 1);
    }

    #[test]
    fn pieces_are_numbered_in_vertex_order_and_unused_vertices_belong_to_none() {
        let mut two = cube(Vec3::ZERO);
        let far = cube(Vec3::splat(3.0));
        let base = two.positions.len() as u32;
        let mut positions = two.positions.clone();
        positions.extend(&far.positions);
        positions.push(Vec3::splat(9.0));
        let mut triangles = two.triangles.clone();
        triangles.extend(far.triangles.iter().map(|t| t.map(|v| v + base)));
        two = Head::new("two", positions, triangles);
        let pieces = Pieces::of(&two);
        assert_eq!(pieces.count, 2);
        assert!(pieces.of_vertex[..8].iter().all(|&p| p == 0));
        assert!(pieces.of_vertex[8..16].iter().all(|&p| p == 1));
        assert_eq!(pieces.of_vertex[16], NO_PIECE);
        let (solids, _) = closed_pieces(&two);
        assert_eq!(solids.len(), 2);
        assert_eq!(closed_piece_count(&two), 2);
        let inside = Vec3::new(0.5, 0.5, 0.9);
        assert!((solids[0].closest_point(inside) - Vec3::new(0.5, 0.5, 1.0)).length() < 1e-6);
        assert!((solids[0].distance(inside) - 0.1).abs() < 1e-6);
    }

    #[test]
    fn ray_hits_only_forward() {
        let t = [
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(1.0, -1.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
        ];
        assert!(ray_hits(Vec3::ZERO, Vec3::Z, &t));
        assert!(!ray_hits(Vec3::ZERO, Vec3::NEG_Z, &t));
        assert!(!ray_hits(Vec3::new(5.0, 0.0, 0.0), Vec3::Z, &t));
    }
}
