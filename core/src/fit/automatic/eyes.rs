//! The centres and corners of the eyes, read in front of a fit, which set the mask's scale
//! and width (the pupils are what `mm_per_unit` is measured by). An eye is an opening in
//! the mesh (seen through to the far inside of the head), closed lids (the upper lid's
//! margin stands in front of the lower lid: a step down across the eye) or, when neither
//! shows, a dome that stands out of the orbit around it. Looked for on each side where
//! CANDIDE puts the eye, in mask units.
//!
//! An opening, and closed lids, also show where the eye's corners are (the surface alone
//! hardly does: the lids around an eye are nearly flat across). An opening's ends are
//! where the lids part; the inner corner lies a caruncle's width further in. Closed lids'
//! step fades at the corners themselves.

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
/// The inner eye corner (the medial canthus) lies this far toward the nose from where the
/// opening between the lids ends: the caruncle, the pink mound in the corner, fills the
/// gap (mask units, about 3 mm; 2.7-3.0 on the shipped ICT heads).
const CARUNCLE_WIDTH: f64 = 0.03;
/// CANDIDE's pupil, from the midline, and above the line through its eye corners.
const PUPIL_X: f64 = 0.3065;
const PUPIL_ABOVE_CORNERS: f64 = 0.009;
/// Closed lids: the surface this far (about 1.6 mm) above a sample of the lids' line lies
/// in front of it by at least this much (about 2 mm; 2.8 on the scan, whose brow and the
/// fold under it step as much but higher up) ...
const LID_STEP_SPAN: f64 = 0.016;
const MIN_LID_STEP: f64 = 0.02;
/// ... and the line is followed sideways, a sample up or down per sample across, while it
/// steps at least half as much, and, toward the outer corner, at least half its steepest
/// step so far (past the corner the orbit's rim steps on, but less).
const LID_DRIFT: isize = 1;

/// How an eye showed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EyeKind {
    /// An opening between the lids, seen through.
    Opening,
    /// Closed lids: the upper lid's margin steps down onto the lower lid (or an eyeball).
    ClosedLids,
    /// A dome standing out of the orbit; no corners.
    Dome,
}

/// Where an eye was found, mask frame of the first fit (mask units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EyeCentre {
    pub x: f64,
    pub y: f64,
    pub kind: EyeKind,
    /// The eye's corners, inner then outer (x, y), when they are seen: an opening's ends
    /// or closed lids'.
    pub corners: Option<[(f64, f64); 2]>,
}

/// The left (+x) and right eye centres, or `None` when either side shows neither an
/// opening nor lids. Closed lids' step is a millimetre or two high: `image` needs cells
/// finer than that.
pub fn eye_centres(image: &FrontImage) -> Option<[EyeCentre; 2]> {
    Some([eye(image, 1.0)?, eye(image, -1.0)?])
}

/// Both eyes' corners are seen, as far apart on one side as on the other within `ratio`.
pub fn eye_widths_agree(eyes: &[EyeCentre; 2], ratio: f64) -> bool {
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
        let corners = opening_ends(image, side, median - OPENING_BEHIND, (x, y))
            .map(|[inner, outer]| [(inner.0 - side * CARUNCLE_WIDTH, inner.1), outer]);
        return Some(EyeCentre {
            x,
            y,
            kind: EyeKind::Opening,
            corners,
        });
    }
    if let Some(closed) = closed_lids(image, side) {
        return Some(closed);
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
            best = Some((
                prominence,
                EyeCentre {
                    x,
                    y,
                    kind: EyeKind::Dome,
                    corners: None,
                },
            ));
        }
    }
    best.map(|(_, centre)| centre)
}

/// How far the surface at (`x`, `y`) lies behind the surface [`LID_STEP_SPAN`] above it.
fn step_down(image: &FrontImage, x: f64, y: f64) -> Option<f64> {
    Some(image.z_at(x, y + LID_STEP_SPAN)? - image.z_at(x, y)?)
}

/// Of the samples `y + k STEP` for `k` in `-rows..=rows`, the one that steps down most,
/// with that step.
fn steepest_near(image: &FrontImage, x: f64, y: f64, rows: isize) -> Option<(f64, f64)> {
    (-rows..=rows)
        .filter_map(|k| {
            let at = y + k as f64 * STEP;
            step_down(image, x, at).map(|step| (at, step))
        })
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

/// Closed lids: below CANDIDE's pupil, the lowest place in the window that steps down
/// [`MIN_LID_STEP`] (the brow and the fold under it step as much higher up), its steepest
/// sample there, and the line followed from it to both corners. `None` when nothing steps
/// that much, or the line runs off the grid of [`opening_ends`].
fn closed_lids(image: &FrontImage, side: f64) -> Option<EyeCentre> {
    let x = side * PUPIL_X;
    let rows = ((WINDOW_Y[1] - WINDOW_Y[0]) / STEP) as usize;
    let lowest = (0..=rows)
        .map(|k| WINDOW_Y[0] + k as f64 * STEP)
        .find(|&y| step_down(image, x, y).is_some_and(|step| step >= MIN_LID_STEP))?;
    let (y, step) = steepest_near(image, x, lowest + 2.0 * STEP, 2)?;
    let grid = WINDOW_X[0] - CORNER_MARGIN..=WINDOW_X[1] + CORNER_MARGIN;
    let follow = |direction: f64| {
        let outward = direction == side;
        let (mut end, mut steepest) = ((x, y), step);
        let mut across = x + direction * STEP;
        while grid.contains(&(side * across)) {
            match steepest_near(image, across, end.1, LID_DRIFT) {
                Some((at, step)) if step >= MIN_LID_STEP / 2.0 && (!outward || step >= steepest / 2.0) => {
                    steepest = steepest.max(step);
                    end = (across, at);
                }
                _ => return Some(end),
            }
            across += direction * STEP;
        }
        None
    };
    let (outer, inner) = (follow(side)?, follow(-side)?);
    Some(EyeCentre {
        x: (inner.0 + outer.0) / 2.0,
        y: (inner.1 + outer.1) / 2.0 + PUPIL_ABOVE_CORNERS,
        kind: EyeKind::ClosedLids,
        corners: Some([inner, outer]),
    })
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
    use crate::fit::automatic::depth_map::tests::grid_plate;
    use crate::fit::automatic::front_image::tests::seen_from_the_front;
    use crate::head::Head;
    use glam::Vec2;

    /// The left eye's closed lids on a plate facing +z, in mask units: the upper lid 0.03
    /// in front of the lower one from x = 0.13 to 0.47 above y = 0.08 (up to 0.16), a step
    /// a third as high going on from the outer corner (the orbit's rim), and a brow stepping
    /// 0.06 at y = 0.25.
    fn closed_left_eye() -> FrontImage {
        let height = |x: f32, y: f32| {
            let upper_lid = if (0.08..0.16).contains(&y) {
                match x {
                    x if (0.13..=0.47).contains(&x) => 0.03,
                    x if (0.47..=0.62).contains(&x) => 0.01,
                    _ => 0.0,
                }
            } else {
                0.0
            };
            let brow = if y > 0.25 { 0.06 } else { 0.0 };
            upper_lid + brow
        };
        front_of_plate("closed eye", height)
    }

    /// A plate (mask units) raised by `height`, seen from the front as the lids are.
    fn front_of_plate(name: &str, height: impl Fn(f32, f32) -> f32) -> FrontImage {
        let (positions, triangles) = grid_plate([176, 126], Vec2::new(0.0, -0.1), 0.004, height);
        seen_from_the_front(&Head::new(name, positions, triangles), 512)
    }

    #[test]
    fn closed_lids_are_found_below_the_brow_and_followed_to_their_corners() {
        let eye = closed_lids(&closed_left_eye(), 1.0).expect("the lids step");
        let [inner, outer] = eye.corners.expect("both corners");
        // Each end within a sample (0.008) and the step's span (0.016) of the lids' line.
        assert!((inner.0 - 0.13).abs() <= 0.009, "{inner:?}");
        assert!((outer.0 - 0.47).abs() <= 0.009, "{outer:?}");
        for (_, y) in [inner, outer] {
            assert!((0.06..=0.085).contains(&y), "{y}");
        }
        let corners_y = (inner.1 + outer.1) / 2.0;
        assert!((eye.x - 0.3).abs() <= 0.009 && (eye.y - corners_y - PUPIL_ABOVE_CORNERS).abs() < 1e-9);
    }

    #[test]
    fn a_plate_with_no_step_below_the_brow_shows_no_closed_lids() {
        let image = front_of_plate("brow only", |_, y| if y > 0.25 { 0.06 } else { 0.0 });
        // The brow's step is the lowest, and is followed until it runs off the grid.
        assert_eq!(closed_lids(&image, 1.0), None);
    }

    fn eye(corners: Option<[(f64, f64); 2]>) -> EyeCentre {
        EyeCentre {
            x: 0.3,
            y: 0.1,
            kind: EyeKind::Opening,
            corners,
        }
    }

    #[test]
    fn the_corners_count_only_when_both_openings_are_about_as_wide() {
        let left = eye(Some([(0.2, 0.1), (0.42, 0.1)]));
        let right = |outer: f64| eye(Some([(-0.2, 0.1), (outer, 0.1)]));
        // 0.22 against 0.2: 1.1 apart.
        assert!(eye_widths_agree(&[left, right(-0.4)], 1.15));
        // 0.22 against 0.15: 1.47 apart, as on a first fit that sat aside.
        assert!(!eye_widths_agree(&[left, right(-0.35)], 1.15));
        assert!(!eye_widths_agree(&[left, eye(None)], 1.15));
    }
}
