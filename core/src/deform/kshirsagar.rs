//! `kshirsagar` (thesis S): Kshirsagar, Garchery and Magnenat-Thalmann (2001), section 2,
//! "as published": feature-point regions grown over the surface, neighbouring feature
//! points, angle-selected reach `d` (eq. 2), sine weights (eq. 3-4) and the inverse-square
//! blend of eq. 5. Binds to linear terms over the control displacements.
//!
//! **Units.** Every distance is a surface distance (shortest path along head-mesh edges)
//! in millimetres, taken from the registration's per-anchor Dijkstra rows
//! ([`Registration::distance_to_control`]). Angles use Euclidean vectors between rest
//! positions in head units (only directions matter). Weights are dimensionless.
//!
//! **Feature points** are the anchors of the control mask vertices. Mask vertices sharing
//! one anchor head vertex form one feature point, which moves by the mean of their
//! displacements: its weight is split evenly among them.
//!
//! **Bind.**
//! 1. *Regions* (2.1.1): every head vertex is labelled with the feature point nearest
//!    along the surface, ties to the lower feature-point index (feature points are ordered
//!    by their first mask vertex). This is exactly the labelling a multi-source Dijkstra
//!    grown from all feature points at once produces; it is read off the registration's
//!    distance rows instead of running another search. Vertices no feature point reaches
//!    (a separate mesh component) have no region.
//! 2. *Neighbours*: two feature points are neighbours when an edge of the head joins
//!    their regions. `d_12` is the surface distance between their anchors (mm).
//! 3. *Weights* (2.1.2). The criteria for feature point FP_1 at head vertex P (rest
//!    position `p`):
//!    - angle criterion (1): among FP_1's neighbours FP_i, the angles `theta_i` between
//!      `FP_1 -> FP_i` and `FP_1 -> p` are computed; the two smallest below `pi/2` are
//!      kept (ties to the lower feature-point index). None below `pi/2` fails it;
//!    - reach: `d = (d_12 cos t2 + d_13 cos t3) / (cos t2 + cos t3)` with two, `d_12 /
//!      cos t2` with one (eq. 2); FP_1 is accepted while `d_1P < d` (`d_1P` the shortest
//!      surface distance), with `W_1P = sin(pi/2 (1 - d_1P / d))` (eq. 3-4).
//!
//!    Chosen reading of "P is approached from FP_1 during the traversal ... as long as
//!    the criteria hold": FP_1's traversal starts at its anchor and advances along mesh
//!    edges only into vertices that accept FP_1, so FP_1 influences P when P accepts it
//!    **and** a chain of accepting vertices joins P to FP_1's anchor. Every feature point
//!    traverses (P's own region's feature point is one candidate among them, with no
//!    privilege beyond the fallback below). The connectivity matters: testing the criteria
//!    at every vertex instead lets feature points with a huge reach (see weaknesses)
//!    influence disconnected patches: on the Lee Perry-Smith head a jaw drop then moved
//!    upper-lip vertices 15-27 mm from any feature point by up to 18 % of the lower lip's
//!    motion (the lower-lip and far rim feature points pulled them), 9 % with it. A feature
//!    point whose anchor coincides in space with `p` (but is not P) has no direction to
//!    P and is not accepted there.
//! 4. *Blend* (eq. 5): `D_P = sum(W_i D_i / d_iP^2) / sum(W_i / d_iP^2)`, stored as the
//!    normalized weights `(W_i / d_iP^2) / sum`. At a feature point's anchor (`d_iP = 0`,
//!    checked on P's own region first) the row is that feature point alone, so `D_P = D_i`
//!    exactly.
//!
//! **Fallbacks** (the paper is silent): a vertex that no feature point influences (no
//! neighbour under `pi/2`, or `d_iP >= d` for all) moves rigidly with its region's
//! feature point (weight 1). A vertex with no region (unreachable along the surface from
//! every anchor) moves rigidly with the feature point nearest in space.
//!
//! **Properties.** Rows are normalized, so a common translation of every control moves
//! every vertex by exactly that translation (up to f32 rounding); anchors reproduce their
//! feature point's displacement. Deforming is one sparse product. Binding is parallel:
//! one pass over the vertices testing every feature point against its neighbours (about
//! 100 x 6 dot products per vertex), then one breadth-first traversal per feature point.
//!
//! **Known weaknesses of the published method** (kept, not fixed, since this variant is
//! the paper as written):
//! - The deformation is not continuous. `d` jumps when the second-smallest angle crosses
//!   `pi/2` (`d_12 cos t2 / cos t2 = d_12` becomes `d_12 / cos t2`) or when two neighbours
//!   swap rank, and a feature point's whole term appears or vanishes when its last
//!   neighbour crosses `pi/2`. The rigid fallback is another seam.
//! - With a single neighbour near `pi/2`, `d = d_12 / cos t2` grows without bound, so a
//!   feature point on the rim of the mask (forehead, jaw line) can reach far beyond its
//!   neighbours; only the `1 / d_iP^2` factor of eq. 5 tames it.
//! - Angles are Euclidean on a curved surface; distances are along edges (Dijkstra), which
//!   overestimates true geodesics by a few percent on irregular meshes.
//! - Only translations are reproduced exactly; a rotation or scaling of the mask is
//!   interpolated, not reproduced, between feature points.

use glam::DVec3;
use rayon::prelude::*;

use super::binding::{Binding, LinearTerm};
use super::spec::AlgoSpec;
use super::Registration;
use crate::head::Topology;

/// A head vertex anchoring one or more control mask vertices.
#[derive(Debug, Clone, PartialEq)]
struct FeaturePoint {
    anchor: u32,
    /// Rest position of the anchor, head units.
    position: DVec3,
    /// Mask vertices anchored here, ascending; the feature point moves by their mean.
    controls: Vec<u32>,
}

/// A feature point as seen from one of its neighbours.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Neighbour {
    /// Surface distance between the two anchors, mm.
    distance_mm: f64,
    /// Unit vector from the other feature point towards this one.
    direction: DVec3,
}

pub fn bind(reg: &Registration, spec: AlgoSpec) -> Binding {
    let points = feature_points(reg);
    let n = reg.vertex_count();
    let distance_mm = |i: usize, v: u32| f64::from(reg.distance_to_control(points[i].controls[0], v));
    let regions: Vec<Option<usize>> = (0..n as u32)
        .into_par_iter()
        .map(|v| {
            (0..points.len())
                .map(|i| (i, distance_mm(i, v)))
                .filter(|(_, d)| d.is_finite())
                .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
                .map(|(i, _)| i)
        })
        .collect();
    let neighbours = neighbours(reg, &points, &regions);
    let candidates: Vec<Vec<(usize, f64)>> = (0..n as u32)
        .into_par_iter()
        .map(|v| {
            let p = reg.head.positions[v as usize].as_dvec3();
            candidates(p, &points, &neighbours, |i| distance_mm(i, v))
        })
        .collect();
    // Each feature point's traversal: the vertices joined to its anchor through vertices
    // that accept it (sorted, for the lookups below).
    let traversed: Vec<Vec<u32>> = points
        .par_iter()
        .enumerate()
        .map_init(
            || vec![false; n],
            |seen, (i, point)| {
                flood(&reg.head.topology, point.anchor, seen, |v| {
                    candidates[v as usize].iter().any(|&(k, _)| k == i)
                })
            },
        )
        .collect();
    let rows = candidates
        .into_par_iter()
        .enumerate()
        .map(|(v, mut found)| {
            let weights = match regions[v] {
                Some(region) => {
                    found.retain(|&(i, _)| traversed[i].binary_search(&(v as u32)).is_ok());
                    blend(found, region)
                }
                None => nearest_in_space(reg.head.positions[v].as_dvec3(), &points)
                    .map(|i| (i, 1.0))
                    .into_iter()
                    .collect(),
            };
            weights
                .into_iter()
                .flat_map(|(i, w)| {
                    let share = (w / points[i].controls.len() as f64) as f32;
                    points[i].controls.iter().map(move |&j| LinearTerm {
                        control: j as u16,
                        weight: share,
                    })
                })
                .collect()
        })
        .collect();
    Binding::linear(spec, rows)
}

/// The feature points: control anchors, mask vertices sharing an anchor merged, in order
/// of their first mask vertex.
fn feature_points(reg: &Registration) -> Vec<FeaturePoint> {
    let mut points: Vec<FeaturePoint> = Vec::new();
    for &j in &reg.controls {
        let anchor = reg.anchors.vertex[j as usize];
        match points.iter_mut().find(|p| p.anchor == anchor) {
            Some(point) => point.controls.push(j),
            None => points.push(FeaturePoint {
                anchor,
                position: reg.head.positions[anchor as usize].as_dvec3(),
                controls: vec![j],
            }),
        }
    }
    points
}

/// For each feature point, the feature points whose regions share an edge with its own,
/// ascending. A neighbour whose anchor coincides in space has no direction and is left
/// out (its angle is undefined).
fn neighbours(reg: &Registration, points: &[FeaturePoint], regions: &[Option<usize>]) -> Vec<Vec<Neighbour>> {
    let mut pairs: Vec<(usize, usize)> = reg
        .head
        .topology
        .edges
        .iter()
        .filter_map(|e| match (regions[e.a as usize], regions[e.b as usize]) {
            (Some(a), Some(b)) if a != b => Some((a, b)),
            _ => None,
        })
        .flat_map(|(a, b)| [(a, b), (b, a)])
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    let mut out = vec![Vec::new(); points.len()];
    for (a, b) in pairs {
        let distance_mm = f64::from(reg.distance_to_control(points[a].controls[0], points[b].anchor));
        let direction = (points[b].position - points[a].position).try_normalize();
        if let (true, Some(direction)) = (distance_mm.is_finite(), direction) {
            out[a].push(Neighbour {
                distance_mm,
                direction,
            });
        }
    }
    out
}

/// The feature points whose criteria accept a vertex at `p`, with their unnormalized eq. 5
/// weights `W_iP / d_iP^2`; `distance_mm(i)` is the surface distance from feature point
/// `i`. A feature point at distance 0 (the vertex is its anchor) accepts it with an
/// infinite weight. Ascending feature-point order.
fn candidates(
    p: DVec3,
    points: &[FeaturePoint],
    neighbours: &[Vec<Neighbour>],
    distance_mm: impl Fn(usize) -> f64,
) -> Vec<(usize, f64)> {
    points
        .iter()
        .zip(neighbours)
        .enumerate()
        .filter_map(|(i, (point, around))| {
            let d_ip = distance_mm(i);
            if d_ip == 0.0 {
                return Some((i, f64::INFINITY));
            }
            if !d_ip.is_finite() {
                return None;
            }
            let towards = (p - point.position).try_normalize()?;
            let d = reach(&smallest_angles(towards, around))?;
            let w = sine_weight(d_ip, d)?;
            Some((i, w / (d_ip * d_ip)))
        })
        .collect()
}

/// Eq. 5 as normalized weights over the influencing feature points `found` (ascending)
/// of a vertex in `region`: a feature point at distance 0 takes everything (the region's
/// first); nothing found falls back to the region's feature point alone.
fn blend(mut found: Vec<(usize, f64)>, region: usize) -> Vec<(usize, f64)> {
    let exact: Vec<usize> = found
        .iter()
        .filter(|(_, w)| w.is_infinite())
        .map(|&(i, _)| i)
        .collect();
    if let Some(&i) = exact.iter().find(|&&i| i == region).or(exact.first()) {
        return vec![(i, 1.0)];
    }
    let total: f64 = found.iter().map(|(_, w)| w).sum();
    if found.is_empty() || !total.is_normal() {
        return vec![(region, 1.0)];
    }
    for (_, w) in &mut found {
        *w /= total;
    }
    found
}

/// The vertices reachable from `start` along edges through vertices that `accepts`
/// (`start` always counts), ascending. `seen` must be all false and is left so.
fn flood(topology: &Topology, start: u32, seen: &mut [bool], accepts: impl Fn(u32) -> bool) -> Vec<u32> {
    let mut reached = vec![start];
    seen[start as usize] = true;
    let mut next = 0;
    while let Some(&v) = reached.get(next) {
        next += 1;
        for (w, _) in topology.neighbors_of(v) {
            if !seen[w as usize] && accepts(w) {
                seen[w as usize] = true;
                reached.push(w);
            }
        }
    }
    for &v in &reached {
        seen[v as usize] = false;
    }
    reached.sort_unstable();
    reached
}

/// `(d_1i, cos theta_i)` of the (at most two) neighbours with the smallest angles between
/// the direction to them and `towards` (unit), both below `pi/2`; the smaller first, ties
/// to the earlier neighbour.
fn smallest_angles(towards: DVec3, around: &[Neighbour]) -> Vec<(f64, f64)> {
    let mut best: Vec<(f64, f64)> = Vec::with_capacity(3);
    for n in around {
        let cos = n.direction.dot(towards);
        if cos > 0.0 {
            let at = best.iter().position(|&(_, c)| cos > c).unwrap_or(best.len());
            best.insert(at, (n.distance_mm, cos));
            best.truncate(2);
        }
    }
    best
}

/// Eq. 2: the reach `d` of a feature point from its selected neighbours `(d_1i, cos
/// theta_i)`; `None` without any (the angle criterion fails).
fn reach(selected: &[(f64, f64)]) -> Option<f64> {
    match *selected {
        [(d12, c2)] => Some(d12 / c2),
        [(d12, c2), (d13, c3), ..] => Some((d12 * c2 + d13 * c3) / (c2 + c3)),
        [] => None,
    }
}

/// Eq. 3-4: `W = sin(pi/2 (1 - d_1P / d))` while `d_1P < d`, else `None`.
fn sine_weight(d_1p: f64, d: f64) -> Option<f64> {
    if d_1p < d {
        let w = (std::f64::consts::FRAC_PI_2 * (1.0 - d_1p / d)).sin();
        (w > 0.0).then_some(w)
    } else {
        None
    }
}

/// The feature point nearest to `p` in space, ties to the lower index.
fn nearest_in_space(p: DVec3, points: &[FeaturePoint]) -> Option<usize> {
    points
        .iter()
        .enumerate()
        .min_by(|a, b| {
            a.1.position
                .distance_squared(p)
                .total_cmp(&b.1.position.distance_squared(p))
        })
        .map(|(i, _)| i)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * (1.0 + b.abs())
    }

    #[test]
    fn reach_with_two_neighbours_weights_by_cosine() {
        // theta_2 = 0 (cos 1), theta_3 = 60 deg (cos 1/2): (10 + 20 / 2) / 1.5
        let d = reach(&[(10.0, 1.0), (20.0, 0.5)]).unwrap();
        assert!(close(d, 40.0 / 3.0), "{d}");
        // equal angles: the mean
        assert!(close(reach(&[(10.0, 0.7), (20.0, 0.7)]).unwrap(), 15.0));
    }

    #[test]
    fn reach_with_one_neighbour_divides_by_cosine() {
        assert!(close(reach(&[(10.0, 0.5)]).unwrap(), 20.0));
        assert!(close(reach(&[(10.0, 1.0)]).unwrap(), 10.0));
        assert_eq!(reach(&[]), None);
    }

    #[test]
    fn sine_weight_falls_from_one_to_zero() {
        assert!(close(sine_weight(0.0, 10.0).unwrap(), 1.0));
        // 1 - 5/10 = 1/2: sin(pi/4)
        assert!(close(
            sine_weight(5.0, 10.0).unwrap(),
            std::f64::consts::FRAC_1_SQRT_2
        ));
        // 1 - 2.5/10 = 3/4: sin(3 pi / 8)
        assert!(close(
            sine_weight(2.5, 10.0).unwrap(),
            (3.0 * std::f64::consts::PI / 8.0).sin()
        ));
        assert_eq!(sine_weight(10.0, 10.0), None);
        assert_eq!(sine_weight(12.0, 10.0), None);
    }

    #[test]
    fn the_two_smallest_angles_below_a_right_angle_are_kept() {
        let n = |d: f64, x: f64, y: f64| Neighbour {
            distance_mm: d,
            direction: DVec3::new(x, y, 0.0).normalize(),
        };
        let around = [
            n(1.0, -1.0, 0.0),
            n(2.0, 0.0, 1.0),
            n(3.0, 1.0, 1.0),
            n(4.0, 1.0, 0.2),
        ];
        let got = smallest_angles(DVec3::X, &around);
        assert_eq!(got.len(), 2);
        assert_eq!(got[0].0, 4.0);
        assert_eq!(got[1].0, 3.0);
        assert!(close(got[1].1, std::f64::consts::FRAC_1_SQRT_2));
        // pointing away from all of them but the one behind
        let got = smallest_angles(-DVec3::X, &around);
        assert_eq!(got, vec![(1.0, 1.0)]);
        // exactly at a right angle does not count
        assert!(smallest_angles(DVec3::Z, &around).is_empty());
    }

    /// Three feature points on a flat sheet, surface distance = Euclidean distance (mm).
    fn triangle_sheet() -> (Vec<FeaturePoint>, Vec<Vec<Neighbour>>) {
        let positions = [
            DVec3::ZERO,
            DVec3::new(10.0, 0.0, 0.0),
            DVec3::new(0.0, 10.0, 0.0),
        ];
        let points: Vec<FeaturePoint> = positions
            .iter()
            .enumerate()
            .map(|(i, &position)| FeaturePoint {
                anchor: i as u32,
                position,
                controls: vec![i as u32],
            })
            .collect();
        let neighbours = (0..3)
            .map(|a| {
                (0..3)
                    .filter(|&b| b != a)
                    .map(|b| Neighbour {
                        distance_mm: positions[a].distance(positions[b]),
                        direction: (positions[b] - positions[a]).normalize(),
                    })
                    .collect()
            })
            .collect();
        (points, neighbours)
    }

    #[test]
    fn hand_computed_vertex_between_three_feature_points() {
        let (points, neighbours) = triangle_sheet();
        let p = DVec3::new(2.0, 1.0, 0.0);
        let weights = blend(
            candidates(p, &points, &neighbours, |i| points[i].position.distance(p)),
            0,
        );
        // FP0 at the origin: neighbours at 0 deg and 90 deg from (2, 1): angles
        // atan(1/2) and 90 - atan(1/2), cosines 2/sqrt5 and 1/sqrt5, both d = 10:
        // d = 10, d_0P = sqrt 5, W0 = sin(pi/2 (1 - sqrt5/10)).
        // FP1 at (10, 0): to P is (-8, 1); to FP0 (-1, 0): cos 8/sqrt65; to FP2 (-1, 1)/sqrt2:
        // cos 9/sqrt130. d = (10 * 8/sqrt65 + 10 sqrt2 * 9/sqrt130) / (8/sqrt65 + 9/sqrt130).
        // FP2 at (0, 10): to P is (2, -9); to FP0 (0, -1): cos 9/sqrt85; to FP1 (1, -1)/sqrt2:
        // cos 11/sqrt170. d likewise.
        let s5 = 5f64.sqrt();
        let w0 = (std::f64::consts::FRAC_PI_2 * (1.0 - s5 / 10.0)).sin() / 5.0;
        let (c10, c12) = (8.0 / 65f64.sqrt(), 9.0 / 130f64.sqrt());
        let d1 = (10.0 * c10 + 200f64.sqrt() * c12) / (c10 + c12);
        let d1p = 65f64.sqrt();
        let w1 = (std::f64::consts::FRAC_PI_2 * (1.0 - d1p / d1)).sin() / 65.0;
        let (c20, c21) = (9.0 / 85f64.sqrt(), 11.0 / 170f64.sqrt());
        let d2 = (10.0 * c20 + 200f64.sqrt() * c21) / (c20 + c21);
        let d2p = 85f64.sqrt();
        let w2 = (std::f64::consts::FRAC_PI_2 * (1.0 - d2p / d2)).sin() / 85.0;
        assert!(d1p < d1 && d2p < d2, "all three influence P");
        let total = w0 + w1 + w2;
        assert_eq!(weights.len(), 3);
        for ((i, w), expected) in weights.iter().zip([w0, w1, w2]) {
            assert!(close(*w, expected / total), "FP{i}: {w} vs {}", expected / total);
        }
        // Numerically: FP0 dominates.
        assert!(weights[0].1 > 0.9, "{weights:?}");
    }

    #[test]
    fn a_feature_point_takes_its_own_anchor_and_outside_points_fall_back() {
        let (points, neighbours) = triangle_sheet();
        let at = points[1].position;
        let weights = blend(
            candidates(at, &points, &neighbours, |i| points[i].position.distance(at)),
            1,
        );
        assert_eq!(weights, vec![(1, 1.0)]);
        // Behind FP0, away from both its neighbours and too far for the others' reach.
        let p = DVec3::new(-30.0, -30.0, 0.0);
        let weights = blend(
            candidates(p, &points, &neighbours, |i| points[i].position.distance(p)),
            0,
        );
        assert_eq!(weights, vec![(0, 1.0)]);
        assert_eq!(nearest_in_space(p, &points), Some(0));
        assert_eq!(nearest_in_space(p, &[]), None);
    }

    #[test]
    fn blend_prefers_exact_feature_points_and_falls_back_to_the_region() {
        assert_eq!(blend(vec![(0, 1.0), (2, 3.0)], 5), vec![(0, 0.25), (2, 0.75)]);
        assert_eq!(
            blend(vec![(0, 1.0), (2, f64::INFINITY), (3, f64::INFINITY)], 3),
            vec![(3, 1.0)]
        );
        assert_eq!(blend(vec![(0, 1.0), (2, f64::INFINITY)], 3), vec![(2, 1.0)]);
        assert_eq!(blend(Vec::new(), 4), vec![(4, 1.0)]);
    }

    #[test]
    fn a_traversal_stops_where_vertices_refuse_it() {
        // A strip of 5 squares: vertices 0..=5 at y = 0, 6..=11 at y = 1.
        let mut positions = Vec::new();
        for y in 0..2 {
            for x in 0..6 {
                positions.push(glam::Vec3::new(x as f32, y as f32, 0.0));
            }
        }
        let triangles: Vec<[u32; 3]> = (0..5u32)
            .flat_map(|x| [[x, x + 1, x + 7], [x, x + 7, x + 6]])
            .collect();
        let topology = Topology::new(&positions, &triangles);
        let mut seen = vec![false; 12];
        // Column x = 2 refuses: from vertex 0 only columns 0 and 1 are reached, although
        // columns 3-5 accept.
        let reached = flood(&topology, 0, &mut seen, |v| v % 6 != 2);
        assert_eq!(reached, vec![0, 1, 6, 7]);
        assert!(seen.iter().all(|s| !s), "seen is left clean");
        // The start counts even when it refuses; everything else accepting is reached.
        assert_eq!(flood(&topology, 2, &mut seen, |v| v != 2).len(), 12);
        assert_eq!(flood(&topology, 2, &mut seen, |_| false), vec![2]);
    }
}
