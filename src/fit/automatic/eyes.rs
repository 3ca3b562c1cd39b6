//! The centres of the eyes, read under a first fit, which set the mask's scale and width
//! (the pupils are what `mm_per_unit` is measured by). An eye is either an opening in the
//! mesh (seen through to the far inside of the head) or a closed lid, a dome that stands out
//! of the orbit around it. Looked for on each side where CANDIDE puts the eye, in mask units.

use super::front_image::FrontImage;

/// CANDIDE's pupils are at x = +-0.3065, y = 0.157; each eye is looked for within this
/// window (x from the midline outwards, y), mask units.
const WINDOW_X: [f64; 2] = [0.12, 0.5];
const WINDOW_Y: [f64; 2] = [-0.05, 0.35];
const STEP: f64 = 0.008;
/// A sample this far behind the window's median surface is seen through an opening.
const OPENING_BEHIND: f64 = 0.25;
/// An opening counts when it covers at least this many samples (about 8 mm^2).
const MIN_OPENING_SAMPLES: usize = 12;
/// A closed lid is compared with the surface this far around it.
const LID_REACH: f64 = 0.07;

/// Where an eye was found, mask frame of the first fit (mask units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EyeCentre {
    pub x: f64,
    pub y: f64,
}

/// The left (+x) and right eye centres, or `None` when either side shows neither an
/// opening nor a lid.
pub fn eye_centres(image: &FrontImage) -> Option<[EyeCentre; 2]> {
    Some([eye(image, 1.0)?, eye(image, -1.0)?])
}

fn eye(image: &FrontImage, side: f64) -> Option<EyeCentre> {
    let columns = ((WINDOW_X[1] - WINDOW_X[0]) / STEP) as usize + 1;
    let rows = ((WINDOW_Y[1] - WINDOW_Y[0]) / STEP) as usize + 1;
    let mut samples = Vec::with_capacity(columns * rows);
    for row in 0..rows {
        for column in 0..columns {
            let x = side * (WINDOW_X[0] + column as f64 * STEP);
            let y = WINDOW_Y[0] + row as f64 * STEP;
            samples.push((x, y, image.z_at(x, y)));
        }
    }
    let mut covered: Vec<f64> = samples.iter().filter_map(|s| s.2).collect();
    if covered.is_empty() {
        return None;
    }
    let middle = covered.len() / 2;
    let median = *covered.select_nth_unstable_by(middle, f64::total_cmp).1;
    let opening: Vec<(f64, f64)> = samples
        .iter()
        .filter(|s| s.2.is_none_or(|z| z < median - OPENING_BEHIND))
        .map(|s| (s.0, s.1))
        .collect();
    if opening.len() >= MIN_OPENING_SAMPLES {
        let n = opening.len() as f64;
        let x = opening.iter().map(|p| p.0).sum::<f64>() / n;
        let y = opening.iter().map(|p| p.1).sum::<f64>() / n;
        return Some(EyeCentre { x, y });
    }
    let mut best: Option<(f64, EyeCentre)> = None;
    for &(x, y, z) in &samples {
        let Some(z) = z else { continue };
        let around = [
            image.z_at(x + LID_REACH, y),
            image.z_at(x - LID_REACH, y),
            image.z_at(x, y + LID_REACH),
            image.z_at(x, y - LID_REACH),
        ];
        let Some(highest_around) = around
            .iter()
            .try_fold(f64::NEG_INFINITY, |m, z| z.map(|z| m.max(z)))
        else {
            continue;
        };
        let prominence = z - highest_around;
        if prominence > 0.0 && best.is_none_or(|(p, _)| prominence > p) {
            best = Some((prominence, EyeCentre { x, y }));
        }
    }
    best.map(|(_, centre)| centre)
}
