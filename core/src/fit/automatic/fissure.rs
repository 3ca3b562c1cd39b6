//! The corners of the mouth: the ends of the lips' fissure, the line where the two lips
//! meet. Seen from the front a fissure is either an opening (nothing, or something far
//! behind, between the lips) or a narrow crease: samples that lie behind the surface just
//! above and below them. It is followed sideways from the midline, a sample at a time,
//! until it fades.
//!
//! Read on a [`FrontImage`] in **mask units** (x to the face's left, y up, z out of it).

use super::front_image::FrontImage;

/// Samples along the fissure, this far apart (about 0.4 mm).
const STEP: f64 = 0.004;
/// The surface above and below a sample is looked at within this distance (about 2 mm):
/// narrow, so that a lip's own curve is not taken for the crease.
const REACH: f64 = 0.02;
/// A sample seen through an opening, or this far behind the surface beside it, counts as
/// this deep ...
const OPENING_DEPTH: f64 = 0.05;
/// ... where an opening is a sample with no surface but surface within this distance above
/// and below (about 8 mm; past the edge of a face-only mesh there is none on one side).
const OPENING_REACH: f64 = 0.08;
/// The fissure is followed while it is at least this deep (about 0.3 mm) ...
const MIN_DEPTH: f64 = 0.003;
/// ... moving at most this many samples up or down from one step to the next.
const DRIFT: isize = 2;

/// How far the sample at (`x`, `y`) lies behind the lower of the most forward surface just
/// above and just below it (mask units), at most [`OPENING_DEPTH`], which is also the depth
/// of an opening; `None` past the edge of the mesh.
fn depth(image: &FrontImage, x: f64, y: f64) -> Option<f64> {
    let most_forward = |sign: f64, reach: f64| {
        (1..=(reach / STEP).round() as usize)
            .filter_map(|k| image.z_at(x, y + sign * k as f64 * STEP))
            .reduce(f64::max)
    };
    let Some(z) = image.z_at(x, y) else {
        most_forward(1.0, OPENING_REACH)?;
        most_forward(-1.0, OPENING_REACH)?;
        return Some(OPENING_DEPTH);
    };
    let walls = most_forward(1.0, REACH)?.min(most_forward(-1.0, REACH)?);
    Some((walls - z).min(OPENING_DEPTH))
}

/// Of the samples `y + k STEP` for `k` in `-samples..=samples`, the one where the crease
/// at `x` is deepest (the nearest to `y` among equals: inside an opening every sample is
/// as deep), with its depth.
fn deepest_near(image: &FrontImage, x: f64, y: f64, samples: isize) -> Option<(f64, f64)> {
    let mut best: Option<(isize, f64)> = None;
    for k in -samples..=samples {
        let Some(depth) = depth(image, x, y + k as f64 * STEP) else {
            continue;
        };
        if best.is_none_or(|(b, d)| depth > d || (depth == d && k.abs() < b.abs())) {
            best = Some((k, depth));
        }
    }
    best.map(|(k, depth)| (y + k as f64 * STEP, depth))
}

/// The height near `y` (within `window` above and below) where a fissure at `x` is
/// deepest, when it is deep enough to follow.
pub fn crease_height(image: &FrontImage, x: f64, y: f64, window: f64) -> Option<f64> {
    deepest_near(image, x, y, (window / STEP).round() as isize)
        .filter(|&(_, depth)| depth >= MIN_DEPTH)
        .map(|(y, _)| y)
}

/// Follows the fissure through `(x, y)` toward `direction` (+1: toward +x) for at most
/// `max_length` and returns its last point deep enough.
pub fn fissure_end(image: &FrontImage, (x, y): (f64, f64), direction: f64, max_length: f64) -> (f64, f64) {
    let mut end = (x, y);
    let steps = (max_length / STEP) as usize;
    for k in 1..=steps {
        let at = x + direction * k as f64 * STEP;
        match deepest_near(image, at, end.1, DRIFT) {
            Some((beside, depth)) if depth >= MIN_DEPTH => end = (at, beside),
            _ => break,
        }
    }
    end
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::automatic::depth_map::tests::grid_plate;
    use crate::fit::automatic::front_image::tests::seen_from_the_front;
    use crate::head::Head;
    use glam::Vec2;

    /// A plate facing +z, in mask units, with a crease 0.02 deep and 0.03 wide along y = 0
    /// from x = -0.2 to 0.2.
    fn creased_plate() -> Head {
        let crease = |x: f32, y: f32| {
            if x.abs() <= 0.2 {
                -0.02 * (1.0 - y.abs() / 0.015).max(0.0)
            } else {
                0.0
            }
        };
        let (positions, triangles) = grid_plate([201, 121], Vec2::new(-0.5, -0.3), 0.005, crease);
        Head::new("creased plate", positions, triangles)
    }

    #[test]
    fn the_crease_is_found_at_its_height_and_followed_to_its_ends() {
        let image = seen_from_the_front(&creased_plate(), 256);
        let y = crease_height(&image, 0.0, 0.02, 0.03).expect("the crease is there");
        assert!(y.abs() <= 0.004, "{y}");
        let (left, at) = fissure_end(&image, (0.0, y), 1.0, 0.45);
        assert!((0.19..=0.21).contains(&left) && at.abs() <= 0.004, "{left}, {at}");
        let (right, _) = fissure_end(&image, (0.0, y), -1.0, 0.45);
        assert!((-0.21..=-0.19).contains(&right), "{right}");
        // Where the plate is flat there is no crease to follow.
        assert_eq!(crease_height(&image, 0.35, 0.0, 0.03), None);
    }
}
