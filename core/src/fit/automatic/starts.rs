//! Step 2 of the automatic fit: starts. The mask is placed on every candidate nose of each
//! view found, upright and upside down (which way is up shows in how the mask lies), at a
//! few scales guessed from the face's width there; every start is screened by the
//! similarity alone, and the closest few are laid in full by iterated closest points.

use glam::DMat3;
use rayon::prelude::*;

use super::closest_points::{lay_mask, screen_start, Laid, Pin, Surface};
use super::depth_map::{NoseCandidate, View};
use super::nose_search::MIN_NOSE_PROMINENCE;
use super::pins::{with_midline, MASK_NOSE_TIP};
use super::AutomaticFitError;
use crate::fit::umeyama::Similarity;
use crate::fit::SolveError;
use crate::mask::Mask;

/// Starts laid in full after the screening, the closest first.
const LAID_STARTS: usize = 6;
/// The width of the head across the nose tip, in mask units (the spread of landmark fits
/// is in docs/FITTING.md); the starting scale is the measured width over this, and
/// [`START_SCALES`] cover the spread.
const HEAD_WIDTH_AT_NOSE: f64 = 1.7;
/// Starting scales, as factors of the one guessed from the width.
const START_SCALES: [f64; 3] = [0.8, 1.0, 1.25];

/// The starts laid in full, the closest first, each with the view and nose it was placed
/// on. `go_on` stops between steps when the fit is cancelled.
pub(super) fn lay_starts(
    surface: &Surface,
    mask: &Mask,
    used: &[u32],
    midline: &[Pin],
    views: &[(View, Vec<NoseCandidate>)],
    go_on: &dyn Fn() -> Result<(), AutomaticFitError>,
    solve_error: &dyn Fn(SolveError) -> AutomaticFitError,
) -> Result<Vec<(Laid, View, NoseCandidate)>, AutomaticFitError> {
    let mask_tip = mask.vertices[MASK_NOSE_TIP as usize].as_dvec3();
    let mut placed: Vec<(Similarity, View, NoseCandidate)> = Vec::new();
    for (view, noses) in views {
        for view in [*view, view.upside_down()] {
            let rotation = DMat3::from_cols(
                view.lateral.as_dvec3(),
                view.up.as_dvec3(),
                view.forward.as_dvec3(),
            );
            for candidate in noses.iter().filter(|n| n.prominence >= MIN_NOSE_PROMINENCE) {
                let tip = candidate.tip.as_dvec3();
                let guessed_scale = f64::from(candidate.width_at_tip) / HEAD_WIDTH_AT_NOSE;
                for factor in START_SCALES {
                    let scale = guessed_scale * factor;
                    let start = Similarity {
                        rotation,
                        scale,
                        translation: tip - scale * (rotation * mask_tip),
                    };
                    placed.push((start, view, *candidate));
                }
            }
        }
    }
    // Each start is screened and laid on its own, so they are spread over the cores; the
    // results come back in the order the starts were placed, whatever the cores' timing.
    let nose_pins = |candidate: &NoseCandidate| {
        with_midline(&[Pin::at(MASK_NOSE_TIP, candidate.tip.as_dvec3())], midline)
    };
    go_on()?;
    let mut screened = placed
        .par_iter()
        .map(|(start, view, candidate)| {
            let laid = screen_start(surface, mask, used, *start, &nose_pins(candidate))?;
            Ok((laid, *view, *candidate))
        })
        .collect::<Result<Vec<(Laid, View, NoseCandidate)>, SolveError>>()
        .map_err(solve_error)?;
    screened.sort_by(|a, b| a.0.score.total_cmp(&b.0.score));
    screened.truncate(LAID_STARTS);
    go_on()?;
    let mut starts = screened
        .par_iter()
        .map(|(screen, view, candidate)| {
            let laid = lay_mask(
                surface,
                mask,
                used,
                screen.solution.similarity,
                &nose_pins(candidate),
            )?;
            Ok((laid, *view, *candidate))
        })
        .collect::<Result<Vec<(Laid, View, NoseCandidate)>, SolveError>>()
        .map_err(solve_error)?;
    starts.sort_by(|a, b| a.0.score.total_cmp(&b.0.score));
    Ok(starts)
}
