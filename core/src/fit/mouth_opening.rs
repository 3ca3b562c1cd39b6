//! How far apart the lips stand on the face's midline, seen from the front: the run of
//! heights, through the mouth, where a ray along the fitted mask's -z axis meets nothing or
//! meets the surface far behind the lips. The lips' depth is the fitted mask's outer lip
//! midpoints' (the fit lays them on closed lips, and hangs them in front of an open
//! mouth's gap), or the frontmost surface up to the mask's subnasale where that lies
//! behind them (a mask whose lips stand in front of the head's). The frontmost surface
//! alone was a large nose's underside whenever a fit's subnasale sat a few millimetres
//! high, and read the closed lips of a generated head as 43 mm apart, so that
//! registration "closed" them and folded them. Exact ray-triangle tests every [`STEP`]
//! (about 0.05 mm), so a gap of a few tenths of a millimetre shows; zero for lips that
//! meet, however deep the notch between them. The fit report's "lips apart at rest" and
//! the calibration that closes such a mouth (`crate::deform::mouth_calibration`) both
//! read it.
//!
//! Everything here is in **mask units** of the fitted mask's frame (x to the face's left,
//! y up, z out of the face).

use glam::{DVec3, Vec3};
use serde::Serialize;

use super::FittedMask;
use crate::mask::{INNER_LIP_MID_LOWER, INNER_LIP_MID_UPPER};

/// CANDIDE-3's outer lip midpoints, upper and lower (FP 8.1, 8.2).
const MASK_UPPER_LIP: usize = 7;
const MASK_LOWER_LIP: usize = 8;
/// CANDIDE-3's subnasale (FP 9.15): the top of the mouth's window.
const MASK_SUBNASALE: usize = 6;
/// The lips' gap is looked for up to this far above and below the mask's mouth ...
const MOUTH_WINDOW: f64 = 0.25;
/// ... every this far ...
pub const STEP: f64 = 0.0005;
/// ... as the run, through the mouth's height (within [`MOUTH_BAND`]), where the surface
/// seen from the front lies this far behind the lips (about 20 mm: lips that meet inside
/// the mouth, as the ICT head's do, leave a notch more than 12 mm deep), or is not there.
const OPENING_DEPTH: f64 = 0.2;
const MOUTH_BAND: f64 = 0.05;
/// Barycentric slack: a ray through an edge or a vertex hits the triangles that share it.
const ON_EDGE: f64 = 1e-9;

/// What registration did to a head whose lips were apart at rest
/// (`crate::deform::close_rest_mouth`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MouthCalibration {
    /// The lips' gap at rest on the head as given, mm (midline).
    pub open_mm: f32,
    /// How far the jaw raised the inner lower lip to close it, mm.
    pub raised_mm: f32,
}

/// The mouth's opening on the midline, mask units.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MouthOpening {
    /// The lower lip's top (where the opening starts); equal to `top` for closed lips.
    pub bottom: f64,
    /// The upper lip's lowest point.
    pub top: f64,
}

impl MouthOpening {
    /// The opening's height, mask units.
    pub fn height(&self) -> f64 {
        self.top - self.bottom
    }

    pub fn is_closed(&self) -> bool {
        self.height() <= 0.0
    }
}

/// The opening of the head `positions` (head units) with `triangles`, in the frame of
/// `fitted` (the mouth is looked for around its inner lips).
pub fn mouth_opening(positions: &[Vec3], triangles: &[[u32; 3]], fitted: &FittedMask) -> MouthOpening {
    let to_mask = fitted.fit.pose.affine().inverse();
    let base = &fitted.base;
    let mouth = f64::from(base[INNER_LIP_MID_UPPER].y + base[INNER_LIP_MID_LOWER].y) / 2.0;
    // From below the mouth up to the nose's base, which stands further forward than lips.
    let top = f64::from(base[MASK_SUBNASALE].y).min(mouth + MOUTH_WINDOW);
    let bottom = mouth - MOUTH_WINDOW;
    let crossing: Vec<[DVec3; 3]> = triangles
        .iter()
        .map(|t| t.map(|v| to_mask.transform_point3(positions[v as usize]).as_dvec3()))
        .filter(|c| {
            let (xs, ys) = (c.map(|p| p.x), c.map(|p| p.y));
            min3(xs) <= 0.0 && max3(xs) >= 0.0 && max3(ys) >= bottom && min3(ys) <= top
        })
        .collect();
    let samples = ((top - bottom) / STEP).max(0.0) as usize + 1;
    let height = |k: usize| bottom + k as f64 * STEP;
    let depths: Vec<Option<f64>> = (0..samples).map(|k| front_z(&crossing, height(k))).collect();
    let at_mouth = (((mouth - bottom) / STEP).round().max(0.0) as usize).min(samples - 1);
    // The lips' depth: the fitted mask's, which lies on closed lips and in front of an open
    // mouth's gap, or the frontmost surface in the window if that lies behind it (a mask
    // whose lips stand in front of the head's).
    let frontmost = depths.iter().flatten().copied().fold(f64::NEG_INFINITY, f64::max);
    let lips = f64::from(base[MASK_UPPER_LIP].z.max(base[MASK_LOWER_LIP].z)).min(frontmost);
    let open = |k: usize| depths[k].is_none_or(|z| z < lips - OPENING_DEPTH);
    let closed = MouthOpening {
        bottom: mouth,
        top: mouth,
    };
    // The run through the mouth's own height (under the chin the surface falls away too).
    let band = (MOUTH_BAND / STEP) as usize;
    let Some(inside) =
        (at_mouth.saturating_sub(band)..=(at_mouth + band).min(samples - 1)).find(|&k| open(k))
    else {
        return closed;
    };
    let first = (0..=inside)
        .rev()
        .take_while(|&k| open(k))
        .last()
        .unwrap_or(inside);
    let last = (inside..samples)
        .take_while(|&k| open(k))
        .last()
        .unwrap_or(inside);
    // Each open sample stands for one step of height.
    MouthOpening {
        bottom: height(first) - STEP / 2.0,
        top: height(last) + STEP / 2.0,
    }
}

/// The largest z where the line x = 0, y = `y` meets a triangle, if it meets one.
fn front_z(triangles: &[[DVec3; 3]], y: f64) -> Option<f64> {
    triangles
        .iter()
        .filter_map(|&[a, b, c]| {
            // Barycentric coordinates of (0, y) in the triangle's xy projection.
            let det = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
            if det.abs() < 1e-18 {
                return None;
            }
            let (px, py) = (-a.x, y - a.y);
            let u = (px * (c.y - a.y) - (c.x - a.x) * py) / det;
            let v = ((b.x - a.x) * py - px * (b.y - a.y)) / det;
            (u >= -ON_EDGE && v >= -ON_EDGE && u + v <= 1.0 + ON_EDGE)
                .then_some(a.z + u * (b.z - a.z) + v * (c.z - a.z))
        })
        .reduce(f64::max)
}

fn min3(v: [f64; 3]) -> f64 {
    v[0].min(v[1]).min(v[2])
}

fn max3(v: [f64; 3]) -> f64 {
    v[0].max(v[1]).max(v[2])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::Fit;
    use crate::mask::Mask;

    /// Two lips as flat slabs facing +z in the mask frame (identity pose) at the mask's lip
    /// depth, a gap of `gap` mask units between them at the CANDIDE mouth's height, and a
    /// back wall 0.5 behind.
    fn lips(gap: f64) -> (Vec<Vec3>, Vec<[u32; 3]>, FittedMask) {
        let mask = Mask::candide3();
        let fit = Fit {
            pose: crate::mask::MaskPose::IDENTITY,
            shape: vec![0.0; mask.shape_units.len()],
            nudges: Vec::new(),
            mm_per_unit: 100.0,
        };
        let fitted = FittedMask::new(mask, fit);
        let mouth = f64::from(fitted.base[INNER_LIP_MID_UPPER].y);
        let lip = lip_depth(&fitted);
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        let mut quad = |x0: f64, x1: f64, y0: f64, y1: f64, z: f64| {
            let at = positions.len() as u32;
            for (x, y) in [(x0, y0), (x1, y0), (x1, y1), (x0, y1)] {
                positions.push(Vec3::new(x as f32, y as f32, z as f32));
            }
            triangles.push([at, at + 1, at + 2]);
            triangles.push([at, at + 2, at + 3]);
        };
        quad(-0.3, 0.3, mouth + gap / 2.0, mouth + 0.1, lip);
        quad(-0.3, 0.3, mouth - 0.2, mouth - gap / 2.0, lip);
        quad(-0.3, 0.3, mouth - 0.2, mouth + 0.1, lip - 0.5);
        (positions, triangles, fitted)
    }

    fn lip_depth(fitted: &FittedMask) -> f64 {
        f64::from(fitted.base[MASK_UPPER_LIP].z.max(fitted.base[MASK_LOWER_LIP].z))
    }

    /// A nose 30 mm in front of the lips, from just above the mask's upper lip to just
    /// below its subnasale: inside the mouth's window, as when a fit's subnasale sits high.
    fn with_nose(positions: &mut Vec<Vec3>, triangles: &mut Vec<[u32; 3]>, fitted: &FittedMask) {
        let (low, high) = (
            fitted.base[MASK_UPPER_LIP].y + 0.005,
            fitted.base[MASK_SUBNASALE].y - 0.005,
        );
        assert!(high - low > 0.01, "{low} {high}");
        let z = (lip_depth(fitted) + 0.3) as f32;
        let at = positions.len() as u32;
        for (x, y) in [(-0.1, low), (0.1, low), (0.1, high), (-0.1, high)] {
            positions.push(Vec3::new(x, y, z));
        }
        triangles.push([at, at + 1, at + 2]);
        triangles.push([at, at + 2, at + 3]);
    }

    #[test]
    fn the_gap_between_two_lips_is_measured_to_a_step() {
        // Within a step and a half: the samples fall where they fall, the slabs are f32.
        for gap in [0.004, 0.02, 0.1] {
            let (positions, triangles, fitted) = lips(gap);
            let opening = mouth_opening(&positions, &triangles, &fitted);
            assert!((opening.height() - gap).abs() <= 1.5 * STEP, "{gap}: {opening:?}");
        }
    }

    #[test]
    fn lips_that_meet_are_closed_and_a_shallow_notch_is_not_an_opening() {
        let (positions, triangles, fitted) = lips(0.0);
        assert!(mouth_opening(&positions, &triangles, &fitted).is_closed());
        // A gap with a wall 0.1 behind the lips (10 mm): a notch, not an opening.
        let (mut positions, triangles, fitted) = lips(0.05);
        let lip = lip_depth(&fitted);
        for p in positions[8..].iter_mut() {
            p.z = (lip - 0.1) as f32;
        }
        assert!(mouth_opening(&positions, &triangles, &fitted).is_closed());
    }

    #[test]
    fn a_nose_in_front_of_the_lips_opens_no_mouth() {
        let (mut positions, mut triangles, fitted) = lips(0.0);
        with_nose(&mut positions, &mut triangles, &fitted);
        let opening = mouth_opening(&positions, &triangles, &fitted);
        assert!(opening.is_closed(), "{opening:?}");
        // An open mouth under the same nose is measured as without it.
        let (mut positions, mut triangles, fitted) = lips(0.02);
        with_nose(&mut positions, &mut triangles, &fitted);
        let opening = mouth_opening(&positions, &triangles, &fitted);
        assert!((opening.height() - 0.02).abs() <= 1.5 * STEP, "{opening:?}");
    }
}
