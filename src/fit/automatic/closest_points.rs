//! Laying the mask on a surface by iterated closest points: pair every mask vertex with the
//! nearest point of the head, solve pose (and then shape units) for those pairs with the
//! landmark solver, move the mask, repeat. Pairs much further than the typical one are left
//! out each round (a mask vertex over a hole, or past the edge of a face-only mesh).
//!
//! Positions are head units; the score is in mask units so that starts of different scale
//! compare fairly (a mask shrunk onto a small patch is not a better fit).

use glam::{DVec3, Vec3};

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
/// Ridge weight on the shape units (mask units squared): the surface constrains most
/// units, but only loosely; this keeps a unit at zero unless the surface asks for it.
const SHAPE_RIDGE: f64 = 2e-3;
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

/// Lays `mask` on `head` from the similarity `start` (mask units to head units), pulling
/// each pinned mask vertex toward its pin in every round.
pub fn lay_mask(
    head: &Head,
    mask: &Mask,
    used: &[u32],
    start: Similarity,
    pins: &[Pin],
) -> Result<Laid, SolveError> {
    let neutral: Vec<DVec3> = mask.vertices.iter().map(|v| v.as_dvec3()).collect();
    let mut posed: Vec<DVec3> = neutral.iter().map(|&p| start.apply(p)).collect();
    let mut pairs: Vec<(u32, DVec3)> = Vec::with_capacity(used.len() + PIN_WEIGHT * pins.len());
    let mut distances: Vec<f64> = Vec::with_capacity(used.len());
    let mut solution = None;
    for round in 0..SIMILARITY_ROUNDS + SHAPE_ROUNDS {
        let with_shape = round >= SIMILARITY_ROUNDS;
        closest_pairs(head, used, &posed, &mut pairs, &mut distances);
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
            let d = head
                .surface
                .closest_point(p)
                .map_or(f32::INFINITY, |s| s.distance);
            (f64::from(d) / solution.similarity.scale).min(SCORE_CAP)
        })
        .sum::<f64>()
        / used.len().max(1) as f64;
    Ok(Laid { solution, score })
}

/// Pairs each used mask vertex with its closest surface point, leaving out those further
/// than [`OUTLIER_FACTOR`] times the median distance.
fn closest_pairs(
    head: &Head,
    used: &[u32],
    posed: &[DVec3],
    pairs: &mut Vec<(u32, DVec3)>,
    distances: &mut Vec<f64>,
) {
    pairs.clear();
    distances.clear();
    for &j in used {
        let p: Vec3 = posed[j as usize].as_vec3();
        if let Some(s) = head.surface.closest_point(p) {
            pairs.push((j, s.point.as_dvec3()));
            distances.push(f64::from(s.distance));
        }
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

#[cfg(test)]
mod tests {
    use super::*;

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
