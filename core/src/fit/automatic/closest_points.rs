//! Laying the mask on a surface by iterated closest points: pair every mask vertex with the
//! nearest point of the head, solve pose (and then shape units) for those pairs with the
//! landmark solver, move the mask, repeat. Pairs much further than the typical one are left
//! out each round (a mask vertex over a hole, or past the edge of a face-only mesh).
//!
//! A mask vertex whose nearest surface point lies on a triangle at the mesh's edge, away
//! from the face's openings, is past the end of the face: it is held to the plane of that
//! triangle, not dragged onto the edge. Dragged, the outline of the mask (forehead top,
//! temples, jaw) shrank the mask onto a face-only mesh: ICT's face cut came out 3 % small.
//!
//! Positions are head units; the score is in mask units so that starts of different scale
//! compare fairly (a mask shrunk onto a small patch is not a better fit).

use glam::DVec3;
use rayon::prelude::*;

use super::super::report::edge_vertices;
use super::super::umeyama::Similarity;
use super::super::{solve_fit, FitSolution, SolveError, SolveOptions};
use crate::head::Head;
use crate::mask::Mask;

/// Rounds with the similarity alone before the shape units join.
const SIMILARITY_ROUNDS: usize = 12;
/// Rounds with shape units.
const SHAPE_ROUNDS: usize = 24;
/// Pairs further than this many times the median distance are left out of a round.
const OUTLIER_FACTOR: f64 = 2.5;
/// Ridge weight on the shape units (mask units squared per pair, so the same in any head
/// unit): the surface constrains most units, but only loosely; this keeps a unit at zero
/// unless the surface asks for it. Chosen on the population from 1e-4 to 2e-3
/// (docs/FITTING.md, "The automatic fit"): stronger pulls every fit towards the mean mask.
const SHAPE_RIDGE: f64 = 2e-4;
/// A pin counts as this many vertices.
const PIN_WEIGHT: usize = 10;
/// Distances above this (mask units, about 5 mm) count as this much in the score.
const SCORE_CAP: f64 = 0.05;

/// A mask vertex held to a point (head units) in every round: wholly, or only along one
/// direction (to the plane through the point across it), leaving the surface to place it
/// in the other two.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pin {
    pub vertex: u32,
    pub point: DVec3,
    /// The unit direction (head frame) the pin holds along; `None`: every direction.
    pub along: Option<DVec3>,
}

impl Pin {
    pub fn at(vertex: u32, point: DVec3) -> Pin {
        Pin {
            vertex,
            point,
            along: None,
        }
    }

    pub fn along(vertex: u32, point: DVec3, direction: DVec3) -> Pin {
        Pin {
            vertex,
            point,
            along: Some(direction.normalize()),
        }
    }

    /// Where the vertex, now at `posed`, is pulled to.
    fn target(&self, posed: DVec3) -> DVec3 {
        match self.along {
            None => self.point,
            Some(direction) => posed + direction * (self.point - posed).dot(direction),
        }
    }
}

/// The result of one start.
#[derive(Debug, Clone)]
pub struct Laid {
    pub solution: FitSolution,
    /// Mean distance from the used mask vertices to the surface, each capped at
    /// [`SCORE_CAP`], mask units.
    pub score: f64,
}

/// Lays `mask` on the head of `surface` from the similarity `start` (mask units to head
/// units), pulling each pinned mask vertex toward its pin in every round.
pub fn lay_mask(
    surface: &Surface,
    mask: &Mask,
    used: &[u32],
    start: Similarity,
    pins: &[Pin],
) -> Result<Laid, SolveError> {
    lay(surface, mask, used, start, pins, SHAPE_ROUNDS)
}

/// Like [`lay_mask`] with the similarity rounds alone: a cheap first look at a start, to
/// choose the few worth laying in full.
pub fn screen_start(
    surface: &Surface,
    mask: &Mask,
    used: &[u32],
    start: Similarity,
    pins: &[Pin],
) -> Result<Laid, SolveError> {
    lay(surface, mask, used, start, pins, 0)
}

fn lay(
    surface: &Surface,
    mask: &Mask,
    used: &[u32],
    start: Similarity,
    pins: &[Pin],
    shape_rounds: usize,
) -> Result<Laid, SolveError> {
    let neutral: Vec<DVec3> = mask.vertices.iter().map(|v| v.as_dvec3()).collect();
    let mut posed: Vec<DVec3> = neutral.iter().map(|&p| start.apply(p)).collect();
    let mut pairs: Vec<(u32, DVec3)> = Vec::with_capacity(used.len() + PIN_WEIGHT * pins.len());
    let mut distances: Vec<f64> = Vec::with_capacity(used.len());
    let mut solution = None;
    for round in 0..SIMILARITY_ROUNDS + shape_rounds {
        let with_shape = round >= SIMILARITY_ROUNDS;
        surface.closest_pairs(used, &posed, &mut pairs, &mut distances);
        for pin in pins {
            let target = pin.target(posed[pin.vertex as usize]);
            pairs.extend(std::iter::repeat_n((pin.vertex, target), PIN_WEIGHT));
        }
        let options = SolveOptions {
            solve_shape: with_shape,
            regularization: SHAPE_RIDGE,
            max_iterations: 40,
            tolerance: 1e-9,
            ..SolveOptions::default()
        };
        let next = solve_fit(mask, &pairs, &[], &options)?;
        let shaped = mask.shaped(&next.shape);
        let moved = shaped
            .iter()
            .zip(&posed)
            .map(|(p, q)| next.similarity.apply(p.as_dvec3()).distance_squared(*q))
            .fold(0.0f64, f64::max)
            .sqrt();
        for (q, p) in posed.iter_mut().zip(&shaped) {
            *q = next.similarity.apply(p.as_dvec3());
        }
        let settled = with_shape && moved < 1e-4 * next.similarity.scale;
        solution = Some(next);
        if settled {
            break;
        }
    }
    let solution = solution.expect("at least one round");
    let score = used
        .iter()
        .map(|&j| {
            let p = posed[j as usize].as_vec3();
            let d = surface
                .head
                .surface
                .closest_point(p)
                .map_or(f32::INFINITY, |s| s.distance);
            (f64::from(d) / solution.similarity.scale).min(SCORE_CAP)
        })
        .sum::<f64>()
        / used.len().max(1) as f64;
    Ok(Laid { solution, score })
}

/// The head's surface as the mask is laid on it: which of its vertices are on the mesh's
/// edge, and which mask vertices belong at the face's openings.
pub struct Surface<'a> {
    pub head: &'a Head,
    /// Per head vertex: on the mesh's edge.
    at_edge: Vec<bool>,
    /// Per mask vertex: [`Mask::at_an_opening`].
    at_an_opening: Vec<bool>,
}

impl<'a> Surface<'a> {
    pub fn new(head: &'a Head, mask: &Mask) -> Surface<'a> {
        Surface {
            head,
            at_edge: edge_vertices(head),
            at_an_opening: (0..mask.vertices.len()).map(|j| mask.at_an_opening(j)).collect(),
        }
    }

    /// Whether mask vertex `vertex`, nearest to head triangle `triangle`, lies past the
    /// end of the face: the triangle is at the mesh's edge, and the vertex is not at one of
    /// the face's openings (whose rims are edges too).
    pub fn past_the_edge(&self, vertex: u32, triangle: u32) -> bool {
        !self.at_an_opening[vertex as usize]
            && self.head.triangles[triangle as usize]
                .iter()
                .any(|&v| self.at_edge[v as usize])
    }

    /// Pairs each used mask vertex with its closest surface point (or, past the mesh's
    /// edge, with the nearest point of that triangle's plane), leaving out those further
    /// than [`OUTLIER_FACTOR`] times the median distance.
    fn closest_pairs(
        &self,
        used: &[u32],
        posed: &[DVec3],
        pairs: &mut Vec<(u32, DVec3)>,
        distances: &mut Vec<f64>,
    ) {
        pairs.clear();
        distances.clear();
        // The queries are independent: spread over the cores, gathered in `used`'s order.
        let found: Vec<Option<(u32, DVec3, f64)>> = used
            .par_iter()
            .map(|&j| {
                let p = posed[j as usize];
                let s = self.head.surface.closest_point(p.as_vec3())?;
                let target = if self.past_the_edge(j, s.triangle) {
                    let [a, b, c] = self.head.triangles[s.triangle as usize]
                        .map(|v| self.head.positions[v as usize].as_dvec3());
                    let normal = (b - a).cross(c - a).normalize_or_zero();
                    p + normal * (s.point.as_dvec3() - p).dot(normal)
                } else {
                    s.point.as_dvec3()
                };
                Some((j, target, f64::from(s.distance)))
            })
            .collect();
        for (j, target, distance) in found.into_iter().flatten() {
            pairs.push((j, target));
            distances.push(distance);
        }
        let mut sorted = distances.clone();
        sorted.sort_by(f64::total_cmp);
        let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
        let limit = OUTLIER_FACTOR * median.max(f64::MIN_POSITIVE);
        let mut kept = 0;
        for i in 0..pairs.len() {
            if distances[i] <= limit {
                pairs[kept] = pairs[i];
                kept += 1;
            }
        }
        pairs.truncate(kept);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::automatic::depth_map::tests::grid_plate;
    use glam::Vec2;

    #[test]
    fn past_the_mesh_s_edge_a_vertex_is_held_to_the_edge_triangle_s_plane() {
        // A plate at z = 0.15 over -0.2 <= x, y <= 0.2; two mask vertices hover at x = 0.5,
        // past its edge, the second one at an opening.
        let (positions, triangles) = grid_plate([9, 9], Vec2::new(-0.2, -0.2), 0.05, |_, _| 0.15);
        let head = Head::new("plate", positions, triangles);
        let surface = Surface {
            head: &head,
            at_edge: edge_vertices(&head),
            at_an_opening: vec![false, true],
        };
        let posed = [DVec3::new(0.5, 0.1, 0.3); 2];
        let (mut pairs, mut distances) = (Vec::new(), Vec::new());
        surface.closest_pairs(&[0, 1], &posed, &mut pairs, &mut distances);
        assert_eq!(pairs.len(), 2);
        assert!(
            pairs[0].1.distance(DVec3::new(0.5, 0.1, 0.15)) < 1e-6,
            "{:?}",
            pairs[0]
        );
        assert!(
            pairs[1].1.distance(DVec3::new(0.2, 0.1, 0.15)) < 1e-6,
            "{:?}",
            pairs[1]
        );
    }

    #[test]
    fn a_pin_along_a_direction_moves_its_vertex_only_along_it() {
        let pin = Pin::along(3, DVec3::new(2.0, 5.0, -1.0), DVec3::new(0.0, 0.0, 4.0));
        assert_eq!(pin.target(DVec3::new(1.0, 1.0, 1.0)), DVec3::new(1.0, 1.0, -1.0));
        let whole = Pin::at(3, DVec3::new(2.0, 5.0, -1.0));
        assert_eq!(
            whole.target(DVec3::new(1.0, 1.0, 1.0)),
            DVec3::new(2.0, 5.0, -1.0)
        );
    }
}
