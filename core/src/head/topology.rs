//! Mesh connectivity built once per head: undirected edges with the triangles on them,
//! vertex adjacency with edge lengths (the graph surface distances run on), and each
//! vertex's triangles ordered around it (the fans roughness walks).
//!
//! Built without assuming consistent winding: fans are chained through shared spokes
//! `(v, x)`, so a flipped triangle does not break them. Triangles that repeat a vertex are
//! left out (they have no edges to share).

use glam::Vec3;

/// One undirected edge `a < b` and how many triangles use it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Edge {
    pub a: u32,
    pub b: u32,
    pub triangles: u32,
}

/// A maximal chain of a vertex's triangles, consecutive ones sharing a manifold spoke edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Fan {
    /// Start in [`Topology::fan_triangles`].
    pub start: u32,
    pub len: u32,
    /// The last triangle shares an edge with the first (interior vertex).
    pub closed: bool,
}

#[derive(Debug, Clone)]
pub struct Topology {
    pub vertex_count: usize,
    pub edges: Vec<Edge>,
    /// CSR adjacency: neighbours of `v` are `neighbors[neighbor_offsets[v]..neighbor_offsets[v+1]]`.
    pub neighbor_offsets: Vec<u32>,
    pub neighbors: Vec<u32>,
    /// Euclidean length of each adjacency entry, head units.
    pub neighbor_lengths: Vec<f32>,
    /// CSR fans: the fans of `v` are `fans[fan_offsets[v]..fan_offsets[v+1]]`.
    pub fan_offsets: Vec<u32>,
    pub fans: Vec<Fan>,
    pub fan_triangles: Vec<u32>,
    /// Closed loops of boundary edges (edges with one triangle), as vertex sequences.
    pub boundary_loops: Vec<Vec<u32>>,
}

impl Topology {
    pub fn new(positions: &[Vec3], triangles: &[[u32; 3]]) -> Topology {
        let n = positions.len();
        let usable = |t: &[u32; 3]| t[0] != t[1] && t[1] != t[2] && t[0] != t[2];

        // Edges: sort the three half-edges of each triangle by their undirected key.
        let mut half: Vec<(u32, u32)> = Vec::with_capacity(triangles.len() * 3);
        for t in triangles.iter().filter(|t| usable(t)) {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                half.push((a.min(b), a.max(b)));
            }
        }
        half.sort_unstable();
        let mut edges: Vec<Edge> = Vec::new();
        for (a, b) in half {
            match edges.last_mut() {
                Some(e) if e.a == a && e.b == b => e.triangles += 1,
                _ => edges.push(Edge { a, b, triangles: 1 }),
            }
        }

        let (neighbor_offsets, neighbors) = csr(n, edges.iter().flat_map(|e| [(e.a, e.b), (e.b, e.a)]));
        let neighbor_lengths = (0..n)
            .flat_map(|v| {
                let range = neighbor_offsets[v] as usize..neighbor_offsets[v + 1] as usize;
                neighbors[range].iter().map(move |&w| (v, w))
            })
            .map(|(v, w)| positions[v].distance(positions[w as usize]))
            .collect();

        let (tri_offsets, vertex_triangles) = csr(
            n,
            triangles
                .iter()
                .enumerate()
                .filter(|(_, t)| usable(t))
                .flat_map(|(i, t)| t.map(|v| (v, i as u32))),
        );
        let (fan_offsets, fans, fan_triangles) = build_fans(n, triangles, &tri_offsets, &vertex_triangles);
        let boundary_loops = boundary_loops(n, &edges);

        Topology {
            vertex_count: n,
            edges,
            neighbor_offsets,
            neighbors,
            neighbor_lengths,
            fan_offsets,
            fans,
            fan_triangles,
            boundary_loops,
        }
    }

    /// Neighbours of `v` and the edge lengths to them.
    pub fn neighbors_of(&self, v: u32) -> impl Iterator<Item = (u32, f32)> + '_ {
        let range =
            self.neighbor_offsets[v as usize] as usize..self.neighbor_offsets[v as usize + 1] as usize;
        self.neighbors[range.clone()]
            .iter()
            .copied()
            .zip(self.neighbor_lengths[range].iter().copied())
    }

    /// The fans of `v`: one closed fan for an interior vertex, one open fan on a
    /// boundary, several (or none) where the mesh is not a manifold.
    pub fn fans_of(&self, v: u32) -> &[Fan] {
        &self.fans[self.fan_offsets[v as usize] as usize..self.fan_offsets[v as usize + 1] as usize]
    }

    /// The triangles of one fan, in order around its vertex.
    pub fn fan(&self, fan: &Fan) -> &[u32] {
        &self.fan_triangles[fan.start as usize..(fan.start + fan.len) as usize]
    }

    /// Edges used by more than two triangles.
    pub fn non_manifold_edges(&self) -> impl Iterator<Item = &Edge> {
        self.edges.iter().filter(|e| e.triangles > 2)
    }

    /// Edges used by exactly one triangle.
    pub fn boundary_edge_count(&self) -> usize {
        self.edges.iter().filter(|e| e.triangles == 1).count()
    }
}

/// Builds a compressed sparse row table from (row, value) pairs; rows keep pair order.
fn csr(rows: usize, pairs: impl Iterator<Item = (u32, u32)> + Clone) -> (Vec<u32>, Vec<u32>) {
    let mut offsets = vec![0u32; rows + 1];
    for (r, _) in pairs.clone() {
        offsets[r as usize + 1] += 1;
    }
    for i in 0..rows {
        offsets[i + 1] += offsets[i];
    }
    let mut fill = offsets.clone();
    let mut values = vec![0u32; offsets[rows] as usize];
    for (r, v) in pairs {
        values[fill[r as usize] as usize] = v;
        fill[r as usize] += 1;
    }
    (offsets, values)
}

/// The two corners of `t` other than `v`.
fn spokes(t: &[u32; 3], v: u32) -> [u32; 2] {
    if t[0] == v {
        [t[1], t[2]]
    } else if t[1] == v {
        [t[2], t[0]]
    } else {
        [t[0], t[1]]
    }
}

/// Chains each vertex's triangles into fans. Linear-logarithmic in the vertex's valence:
/// a table of (spoke, triangle) sorted once per vertex answers "which triangles share
/// this spoke", so a vertex with 32,000 duplicate triangles costs milliseconds.
fn build_fans(
    n: usize,
    triangles: &[[u32; 3]],
    tri_offsets: &[u32],
    vertex_triangles: &[u32],
) -> (Vec<u32>, Vec<Fan>, Vec<u32>) {
    let mut fan_offsets = Vec::with_capacity(n + 1);
    let mut fans = Vec::new();
    let mut fan_triangles = Vec::with_capacity(vertex_triangles.len());
    let mut used: Vec<bool> = Vec::new();
    let mut free: Vec<bool> = Vec::new();
    // (spoke vertex, index into `around`), sorted: the triangles on each spoke in order.
    let mut spoke_table: Vec<(u32, u32)> = Vec::new();
    fan_offsets.push(0);
    for v in 0..n as u32 {
        let around =
            &vertex_triangles[tri_offsets[v as usize] as usize..tri_offsets[v as usize + 1] as usize];
        let spokes_of = |k: usize| spokes(&triangles[around[k] as usize], v);
        spoke_table.clear();
        for k in 0..around.len() {
            for x in spokes_of(k) {
                spoke_table.push((x, k as u32));
            }
        }
        spoke_table.sort_unstable();
        let on_spoke = |x: u32| {
            let start = spoke_table.partition_point(|&(s, _)| s < x);
            let end = spoke_table.partition_point(|&(s, _)| s <= x);
            &spoke_table[start..end]
        };
        // Manifold spokes are shared by exactly two of v's triangles.
        let manifold = |x: u32| on_spoke(x).len() == 2;
        // A triangle with a boundary or non-manifold spoke starts an open chain.
        free.clear();
        free.extend((0..around.len()).map(|k| spokes_of(k).iter().any(|&x| !manifold(x))));
        used.clear();
        used.resize(around.len(), false);
        // The first unused triangle with a free spoke, and the first unused one: both
        // only move forward, since triangles never become unused again.
        let (mut next_free, mut next_any) = (0, 0);
        loop {
            while next_free < around.len() && (used[next_free] || !free[next_free]) {
                next_free += 1;
            }
            while next_any < around.len() && used[next_any] {
                next_any += 1;
            }
            let start = if next_free < around.len() {
                next_free
            } else if next_any < around.len() {
                next_any
            } else {
                break;
            };
            let fan_start = fan_triangles.len() as u32;
            used[start] = true;
            fan_triangles.push(around[start]);
            // Walk in the direction whose spoke is free at the start, if any.
            let [s0, s1] = spokes_of(start);
            let mut exit = if manifold(s0) { s0 } else { s1 };
            let mut current = start;
            while manifold(exit) {
                let Some(&(_, next)) = on_spoke(exit).iter().find(|&&(_, k)| !used[k as usize]) else {
                    break;
                };
                let next = next as usize;
                used[next] = true;
                fan_triangles.push(around[next]);
                let [a, b] = spokes_of(next);
                exit = if a == exit { b } else { a };
                current = next;
            }
            let len = fan_triangles.len() as u32 - fan_start;
            let closed = len > 2 && current != start && spokes_of(start).contains(&exit) && manifold(exit);
            fans.push(Fan {
                start: fan_start,
                len,
                closed,
            });
        }
        fan_offsets.push(fans.len() as u32);
    }
    (fan_offsets, fans, fan_triangles)
}

/// Chains boundary edges into loops (vertex sequences). A vertex where several boundary
/// loops touch is visited once per loop.
fn boundary_loops(n: usize, edges: &[Edge]) -> Vec<Vec<u32>> {
    let boundary: Vec<&Edge> = edges.iter().filter(|e| e.triangles == 1).collect();
    let (offsets, incident) = csr(
        n,
        boundary
            .iter()
            .enumerate()
            .flat_map(|(i, e)| [(e.a, i as u32), (e.b, i as u32)]),
    );
    let mut used = vec![false; boundary.len()];
    let mut loops = Vec::new();
    for first in 0..boundary.len() {
        if used[first] {
            continue;
        }
        used[first] = true;
        let start = boundary[first].a;
        let mut current = boundary[first].b;
        let mut chain = vec![start];
        while current != start {
            chain.push(current);
            let range = offsets[current as usize] as usize..offsets[current as usize + 1] as usize;
            let Some(&next) = incident[range].iter().find(|&&e| !used[e as usize]) else {
                break; // an open chain: the boundary does not close (non-manifold corner)
            };
            used[next as usize] = true;
            let e = boundary[next as usize];
            current = if e.a == current { e.b } else { e.a };
        }
        loops.push(chain);
    }
    loops
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square pyramid: apex 4 over the square 0-1-2-3, open at the bottom.
    fn pyramid() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let p = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.5, 0.5, 1.0),
        ];
        let t = vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]];
        (p, t)
    }

    #[test]
    fn apex_has_one_closed_fan_and_base_corners_open_fans() {
        let (p, t) = pyramid();
        let topo = Topology::new(&p, &t);
        assert_eq!(topo.edges.len(), 8);
        assert_eq!(topo.boundary_edge_count(), 4);
        let apex = topo.fans_of(4);
        assert_eq!(apex.len(), 1);
        assert!(apex[0].closed);
        let ring = topo.fan(&apex[0]);
        assert_eq!(ring.len(), 4);
        // consecutive triangles share a spoke
        for k in 0..4 {
            let (a, b) = (t[ring[k] as usize], t[ring[(k + 1) % 4] as usize]);
            assert_eq!(a.iter().filter(|v| b.contains(v)).count(), 2);
        }
        let corner = topo.fans_of(0);
        assert_eq!(corner.len(), 1);
        assert!(!corner[0].closed);
        assert_eq!(corner[0].len, 2);
        assert_eq!(topo.boundary_loops.len(), 1);
        assert_eq!(topo.boundary_loops[0].len(), 4);
    }

    #[test]
    fn neighbours_carry_edge_lengths() {
        let (p, t) = pyramid();
        let topo = Topology::new(&p, &t);
        let mut around: Vec<(u32, f32)> = topo.neighbors_of(0).collect();
        around.sort_by_key(|&(v, _)| v);
        assert_eq!(around.iter().map(|x| x.0).collect::<Vec<_>>(), vec![1, 3, 4]);
        assert!((around[0].1 - 1.0).abs() < 1e-6);
        assert!((around[2].1 - 1.5f32.sqrt()).abs() < 1e-6);
    }

    #[test]
    fn flipped_winding_still_chains() {
        let (p, mut t) = pyramid();
        t[1] = [4, 2, 1];
        let topo = Topology::new(&p, &t);
        let apex = topo.fans_of(4);
        assert_eq!(apex.len(), 1);
        assert!(apex[0].closed);
    }

    #[test]
    fn a_vertex_of_high_valence_chains_in_one_pass() {
        // A disc of 80,000 triangles around vertex 0: one closed fan. Quadratic in the
        // valence before the spoke table (minutes); milliseconds now.
        let ring = 80_000u32;
        let mut p = vec![Vec3::ZERO];
        p.extend((0..ring).map(|i| {
            let a = i as f32 / ring as f32 * std::f32::consts::TAU;
            Vec3::new(a.cos(), a.sin(), 0.0)
        }));
        let t: Vec<[u32; 3]> = (0..ring).map(|i| [0, 1 + i, 1 + (i + 1) % ring]).collect();
        let topo = Topology::new(&p, &t);
        let centre = topo.fans_of(0);
        assert_eq!(centre.len(), 1);
        assert!(centre[0].closed);
        assert_eq!(centre[0].len, ring);
        assert_eq!(topo.boundary_loops.len(), 1);
        assert_eq!(topo.boundary_loops[0].len(), ring as usize);
    }

    #[test]
    fn duplicate_triangles_make_one_fan_each() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        let t = vec![[0, 1, 2]; 32_000];
        let topo = Topology::new(&p, &t);
        assert_eq!(topo.edges.len(), 3);
        assert_eq!(topo.non_manifold_edges().count(), 3);
        assert_eq!(topo.fans_of(0).len(), 32_000);
        assert!(topo.fans_of(0).iter().all(|f| !f.closed && f.len == 1));
    }

    #[test]
    fn non_manifold_edge_splits_fans() {
        // three triangles on edge 0-1
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::NEG_Y, Vec3::Z];
        let t = vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]];
        let topo = Topology::new(&p, &t);
        assert_eq!(topo.non_manifold_edges().count(), 1);
        // vertex 0: the spoke 0-1 is non-manifold, so each triangle is its own fan
        assert_eq!(topo.fans_of(0).len(), 3);
        assert!(topo.fans_of(0).iter().all(|f| !f.closed && f.len == 1));
    }
}
