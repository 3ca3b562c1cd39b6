//! Mesh checks with counts and examples. Only what stops the maths is fatal (that is
//! decided by the OBJ reader: bad numbers, bad indices, no triangles); everything here is
//! reported so a user can judge a scan before registering it.

use std::collections::HashMap;

use glam::Vec3;
use serde::Serialize;

use super::Topology;

/// How many examples a problem keeps.
const EXAMPLES: usize = 5;

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Problem {
    /// Machine-readable kind (`degenerate_triangles`, `non_manifold_edges`, ...).
    pub kind: &'static str,
    pub count: usize,
    /// What the examples are, e.g. "triangle index" or "edge (vertex, vertex)".
    pub what: &'static str,
    pub examples: Vec<String>,
}

impl std::fmt::Display for Problem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {} (e.g. {}: {})",
            self.kind,
            self.count,
            self.what,
            self.examples.join(", ")
        )
    }
}

struct Collector {
    kind: &'static str,
    what: &'static str,
    count: usize,
    examples: Vec<String>,
}

impl Collector {
    fn new(kind: &'static str, what: &'static str) -> Collector {
        Collector {
            kind,
            what,
            count: 0,
            examples: Vec::new(),
        }
    }

    fn add(&mut self, example: impl FnOnce() -> String) {
        self.count += 1;
        if self.examples.len() < EXAMPLES {
            self.examples.push(example());
        }
    }

    fn finish(self, problems: &mut Vec<Problem>) {
        if self.count > 0 {
            problems.push(Problem {
                kind: self.kind,
                count: self.count,
                what: self.what,
                examples: self.examples,
            });
        }
    }
}

/// Finds degenerate, duplicate and non-manifold elements, unused vertices and
/// inconsistent winding. `area_epsilon` is the triangle area (head units squared) below
/// which a triangle counts as degenerate.
pub fn check(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    topology: &Topology,
    area_epsilon: f32,
) -> Vec<Problem> {
    let mut problems = Vec::new();

    let mut repeated = Collector::new("repeated_corner_triangles", "triangle");
    let mut zero_area = Collector::new("zero_area_triangles", "triangle");
    let mut duplicates = Collector::new("duplicate_triangles", "triangle (duplicate of)");
    let mut seen: HashMap<[u32; 3], usize> = HashMap::with_capacity(triangles.len());
    for (i, t) in triangles.iter().enumerate() {
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            repeated.add(|| format!("{i} {t:?}"));
            continue;
        }
        let [a, b, c] = t.map(|v| positions[v as usize]);
        if 0.5 * (b - a).cross(c - a).length() <= area_epsilon {
            zero_area.add(|| format!("{i}"));
        }
        let mut key = *t;
        key.sort_unstable();
        if let Some(&first) = seen.get(&key) {
            duplicates.add(|| format!("{i} ({first})"));
        } else {
            seen.insert(key, i);
        }
    }
    repeated.finish(&mut problems);
    zero_area.finish(&mut problems);
    duplicates.finish(&mut problems);

    let mut non_manifold = Collector::new("non_manifold_edges", "edge (vertex-vertex: triangles)");
    for e in topology.non_manifold_edges() {
        non_manifold.add(|| format!("{}-{}: {}", e.a, e.b, e.triangles));
    }
    non_manifold.finish(&mut problems);

    let mut used = vec![false; positions.len()];
    for t in triangles {
        for &v in t {
            used[v as usize] = true;
        }
    }
    let mut unused = Collector::new("unreferenced_vertices", "vertex");
    for (v, _) in used.iter().enumerate().filter(|(_, u)| !**u) {
        unused.add(|| v.to_string());
    }
    unused.finish(&mut problems);

    // Winding: on a consistently oriented manifold edge the two triangles traverse it in
    // opposite directions.
    let mut direction: HashMap<(u32, u32), (usize, bool)> = HashMap::with_capacity(triangles.len() * 3 / 2);
    let mut flipped = Collector::new("inconsistent_winding_edges", "edge (vertex-vertex)");
    for t in triangles
        .iter()
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
    {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let key = (a.min(b), a.max(b));
            let forward = a < b;
            let entry = direction.entry(key).or_insert((0, forward));
            entry.0 += 1;
            if entry.0 == 2 && entry.1 == forward {
                flipped.add(|| format!("{}-{}", key.0, key.1));
            }
        }
    }
    flipped.finish(&mut problems);
    problems
}
