//! Step 4 of the automatic fit: reading the face. A laid start is pinned to what its face
//! shows in front of it ([`super::pins`]) and laid again, then read again in front of that
//! fit and laid once more: a first fit that lay small or tilted reads the features off.

use super::closest_points::{self, lay_mask, Pin, Surface};
use super::front_image;
use super::pins::{face_pins, with_midline};
use super::FoundFeatures;
use crate::fit::{FitSolution, SolveError};
use crate::head::Head;
use crate::mask::Mask;

/// Cells along the longer side of the range image the face's features are read on (about
/// 0.5 mm on a head of the usual size: closed lids step 1-2 mm).
pub(super) const FRONT_IMAGE_CELLS: usize = 512;
/// The face's features are read in front of the first fit, then again in front of the mask
/// laid on them.
const FEATURE_READINGS: usize = 2;

/// A start laid again on what the face shows in front of it, read twice: the laid mask,
/// the fit it was read in front of, that image, the pins and what they hold.
pub(super) type FeaturesRead = (
    closest_points::Laid,
    FitSolution,
    front_image::FrontImage,
    Vec<Pin>,
    FoundFeatures,
);

/// Pins the laid mask's nose tip, mouth, chin, pupils and eye corners to what the face
/// shows in front of it and lays it again, then reads them again in front of that fit and
/// lays it once more. `None` when the profile in front of it shows no mouth below the nose.
pub(super) fn read_features(
    head: &Head,
    mask: &Mask,
    surface: &Surface,
    used: &[u32],
    midline: &[Pin],
    mut laid: closest_points::Laid,
    winding: f32,
) -> Result<Option<FeaturesRead>, SolveError> {
    let mut pinned = None;
    for _ in 0..FEATURE_READINGS {
        let seen_from = laid.solution.clone();
        let image = front_image::FrontImage::render(head, &seen_from.similarity, winding, FRONT_IMAGE_CELLS);
        let Some((pins, found)) = face_pins(mask, &seen_from, &image) else {
            return Ok(None);
        };
        laid = lay_mask(
            surface,
            mask,
            used,
            seen_from.similarity,
            &with_midline(&pins, midline),
        )?;
        pinned = Some((seen_from, image, pins, found));
    }
    Ok(pinned.map(|(seen_from, image, pins, found)| (laid, seen_from, image, pins, found)))
}
