//! The centres of the eyes, read under a first fit, which set the mask's scale and width
//! (the pupils are what `mm_per_unit` is measured by). An eye is either an opening in the
//! mesh (seen through to the far inside of the head) or a closed lid, a dome that stands out
//! of the orbit around it. Looked for on each side where CANDIDE puts the eye, in mask units.
//!
//! An opening also shows where the eye's corners are: the ends of the opening, which set
//! the mask's eye width (the surface alone hardly does: the lids around an opening are
//! nearly flat across).

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
/// An opening's ends are followed this far out of the window, sideways (mask units); an
/// opening that reaches further is not an eye's alone, and shows no corners.
const CORNER_MARGIN: f64 = 0.1;

/// Where an eye was found, mask frame of the first fit (mask units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EyeCentre {
    pub x: f64,
    pub y: f64,
    /// The ends of the opening, inner then outer (x, y), when the eye is an opening whose
    /// ends are seen.
    pub corners: Option<[(f64, f64); 2]>,
}

/// The left (+x) and right eye centres, or `None` when either side shows neither an
/// opening nor a lid.
pub fn eye_centres(image: &FrontImage) -> Option<[EyeCentre; 2]> {
    Some([eye(image, 1.0)?, eye(image, -1.0)?])
}

/// Both eyes are openings whose ends are seen, as wide as each other within `ratio`.
pub fn opening_widths_agree(eyes: &[EyeCentre; 2], ratio: f64) -> bool {
    let width = |eye: &EyeCentre| eye.corners.map(|[inner, outer]| (outer.0 - inner.0).abs());
    match (width(&eyes[0]), width(&eyes[1])) {
        (Some(left), Some(right)) if left > 0.0 && right > 0.0 => left.max(right) / left.min(right) <= ratio,
        _ => false,
    }
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
        let corners = opening_ends(image, side, median - OPENING_BEHIND, (x, y));
        return Some(EyeCentre { x, y, corners });
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
            best = Some((prominence, EyeCentre { x, y, corners: None }));
        }
    }
    best.map(|(_, centre)| centre)
}

/// The inner and outer ends (x, y) of the opening around `centre`: the samples seen through
/// (nothing, or a surface behind `behind`) connected to the sample nearest `centre`, on a
/// grid [`CORNER_MARGIN`] wider than the window on both sides. `None` when the opening runs
/// off that grid (into the nose, or round the side of the head) or misses the centre.
fn opening_ends(image: &FrontImage, side: f64, behind: f64, centre: (f64, f64)) -> Option<[(f64, f64); 2]> {
    let first_x = WINDOW_X[0] - CORNER_MARGIN;
    let columns = ((WINDOW_X[1] + CORNER_MARGIN - first_x) / STEP) as usize + 1;
    let rows = ((WINDOW_Y[1] - WINDOW_Y[0]) / STEP) as usize + 1;
    let point = |column: usize, row: usize| {
        (
            side * (first_x + column as f64 * STEP),
            WINDOW_Y[0] + row as f64 * STEP,
        )
    };
    let open: Vec<bool> = (0..rows * columns)
        .map(|k| {
            let (x, y) = point(k % columns, k / columns);
            image.z_at(x, y).is_none_or(|z| z < behind)
        })
        .collect();
    let start_column = ((side * centre.0 - first_x) / STEP).round() as usize;
    let start_row = ((centre.1 - WINDOW_Y[0]) / STEP).round() as usize;
    let start = start_row.min(rows - 1) * columns + start_column.min(columns - 1);
    if !open[start] {
        return None;
    }
    let mut reached = vec![false; open.len()];
    reached[start] = true;
    let mut stack = vec![start];
    let (mut inner, mut outer) = (start, start);
    while let Some(k) = stack.pop() {
        let (column, row) = (k % columns, k / columns);
        if column == 0 || column == columns - 1 || row == 0 || row == rows - 1 {
            return None;
        }
        if column < inner % columns {
            inner = k;
        }
        if column > outer % columns {
            outer = k;
        }
        for next in [k - 1, k + 1, k - columns, k + columns] {
            if open[next] && !reached[next] {
                reached[next] = true;
                stack.push(next);
            }
        }
    }
    Some([
        point(inner % columns, inner / columns),
        point(outer % columns, outer / columns),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eye(corners: Option<[(f64, f64); 2]>) -> EyeCentre {
        EyeCentre {
            x: 0.3,
            y: 0.1,
            corners,
        }
    }

    #[test]
    fn the_corners_count_only_when_both_openings_are_about_as_wide() {
        let left = eye(Some([(0.2, 0.1), (0.42, 0.1)]));
        let right = |outer: f64| eye(Some([(-0.2, 0.1), (outer, 0.1)]));
        // 0.22 against 0.2: 1.1 apart.
        assert!(opening_widths_agree(&[left, right(-0.4)], 1.15));
        // 0.22 against 0.15: 1.47 apart, as on a first fit that sat aside.
        assert!(!opening_widths_agree(&[left, right(-0.35)], 1.15));
        assert!(!opening_widths_agree(&[left, eye(None)], 1.15));
    }
}
