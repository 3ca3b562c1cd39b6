//! Surface distance: shortest paths along mesh edges (Dijkstra), bounded and
//! multi-source. This is how facewire keeps the upper lip apart from the lower lip: they
//! touch in space but are centimetres apart along the surface.
//!
//! [`SurfaceDistance`] keeps its buffers between runs, so many bounded searches (one per
//! mask anchor at registration) cost only the vertices they reach.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use super::Topology;

/// A reusable bounded multi-source Dijkstra over a [`Topology`]'s edge graph.
#[derive(Debug, Clone)]
pub struct SurfaceDistance {
    distance: Vec<f32>,
    reached: Vec<u32>,
    heap: BinaryHeap<Item>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Item {
    distance: f32,
    vertex: u32,
}

impl Eq for Item {}

impl Ord for Item {
    // Reversed: BinaryHeap is a max-heap and we pop the nearest first.
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .distance
            .total_cmp(&self.distance)
            .then(other.vertex.cmp(&self.vertex))
    }
}

impl PartialOrd for Item {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl SurfaceDistance {
    pub fn new(vertex_count: usize) -> SurfaceDistance {
        SurfaceDistance {
            distance: vec![f32::INFINITY; vertex_count],
            reached: Vec::new(),
            heap: BinaryHeap::new(),
        }
    }

    /// Room for runs that reach `vertices` vertices without growing a buffer: a caller
    /// that must not allocate per run reserves once for the largest it makes.
    pub fn reserve(&mut self, vertices: usize) {
        self.reached.reserve(vertices);
        self.heap.reserve(vertices);
    }

    /// Runs from `sources` (vertex, starting distance), settling every vertex within
    /// `max_distance` (head units; `f32::INFINITY` for no bound). Returns the settled
    /// vertices in order of increasing distance.
    pub fn run(&mut self, topology: &Topology, sources: &[(u32, f32)], max_distance: f32) -> &[u32] {
        for &v in &self.reached {
            self.distance[v as usize] = f32::INFINITY;
        }
        self.reached.clear();
        self.heap.clear();
        for &(vertex, distance) in sources {
            if distance <= max_distance && distance < self.distance[vertex as usize] {
                self.distance[vertex as usize] = distance;
                self.heap.push(Item { distance, vertex });
            }
        }
        while let Some(Item { distance, vertex }) = self.heap.pop() {
            // A vertex is pushed again only with a strictly smaller distance, so exactly one
            // of its entries carries its final distance; the others are stale.
            if distance > self.distance[vertex as usize] {
                continue;
            }
            self.reached.push(vertex);
            for (next, length) in topology.neighbors_of(vertex) {
                let candidate = distance + length;
                if candidate <= max_distance && candidate < self.distance[next as usize] {
                    self.distance[next as usize] = candidate;
                    self.heap.push(Item {
                        distance: candidate,
                        vertex: next,
                    });
                }
            }
        }
        // Every relaxed vertex was pushed and so popped: `reached` lists exactly the
        // vertices with a finite distance.
        &self.reached
    }

    /// The vertices the last run reached, nearest first.
    pub fn reached(&self) -> &[u32] {
        &self.reached
    }

    /// Distance of `v` from the last run's sources; `f32::INFINITY` when not reached.
    pub fn distance(&self, v: u32) -> f32 {
        self.distance[v as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A 1-unit grid strip of `n` squares: vertices 0..=n on y=0, n+1..=2n+1 on y=1.
    fn strip(n: u32) -> Topology {
        let mut p = Vec::new();
        for y in 0..2 {
            for x in 0..=n {
                p.push(Vec3::new(x as f32, y as f32, 0.0));
            }
        }
        let mut t = Vec::new();
        for x in 0..n {
            let (a, b, c, d) = (x, x + 1, n + 1 + x, n + 2 + x);
            t.push([a, b, d]);
            t.push([a, d, c]);
        }
        Topology::new(&p, &t)
    }

    #[test]
    fn distances_along_edges() {
        let topo = strip(4);
        let mut sd = SurfaceDistance::new(topo.vertex_count);
        let reached = sd.run(&topo, &[(0, 0.0)], f32::INFINITY).to_vec();
        assert_eq!(reached.len(), 10);
        assert_eq!(reached[0], 0);
        assert!((sd.distance(4) - 4.0).abs() < 1e-6);
        // diagonal edges a-d exist: (0,0) -> (1,1) is sqrt 2, then along the top
        assert!((sd.distance(9) - (2f32.sqrt() + 3.0)).abs() < 1e-5);
    }

    #[test]
    fn bound_and_multiple_sources() {
        let topo = strip(4);
        let mut sd = SurfaceDistance::new(topo.vertex_count);
        let reached = sd.run(&topo, &[(0, 0.0), (4, 0.5)], 1.2).len();
        // from 0: 0, 1, 5; from 4 (starting at 0.5): 4, 3? (1.5 > 1.2, no), 9 (1.5, no)
        assert_eq!(reached, 3 + 1);
        assert!((sd.distance(4) - 0.5).abs() < 1e-6);
        assert_eq!(sd.distance(2), f32::INFINITY);
        // a second run forgets the first
        sd.run(&topo, &[(2, 0.0)], 0.5);
        assert_eq!(sd.distance(0), f32::INFINITY);
        assert_eq!(sd.distance(2), 0.0);
    }
}
