//! Features on the face's midline profile, read in front of a fit: the nose tip (the
//! profile's peak), the height of the mouth (the notch between the lips) and of the chin's
//! bottom (where the profile turns under the chin). Closest points alone let the mask slide
//! up or down the face, and its jaw shrink onto the chin's front; these pin them.
//!
//! The profile is the head's surface seen along the fitted mask's z axis, on the face's
//! midline, sampled in **mask units** (y up the face, z out of it). The midline is where
//! the nose is symmetric, read across the nose near its tip: the first fit's own plane of
//! symmetry (x = 0) lies up to a couple of millimetres aside, as its nose tip was placed on
//! a coarse range image (2.2 mm on MakeHuman, a mirror-symmetric head).

use glam::DVec3;

use super::front_image::FrontImage;

/// The profile is sampled from this height to that (mask units; CANDIDE's chin is at
/// -0.85, its forehead top at 1.06) ...
const LOWEST: f64 = -1.3;
const HIGHEST: f64 = 0.4;
/// ... this far apart.
const STEP: f64 = 0.004;
/// CANDIDE's nose tip (vertex 5) is 0.239 above its mouth (vertices 40, 87). The mouth is
/// looked for this far below the nose tip ...
const MOUTH_BELOW_NOSE: [f64; 2] = [0.15, 0.4];
/// ... with its upper lip at least this far below the nose tip (so that the nose is not
/// taken for a lip) ...
const UPPER_LIP_BELOW_NOSE: f64 = 0.1;
/// ... between lips that come forward within this distance above and below it, the upper
/// one falling again at least this far behind its peak above it (about 0.5 mm).
const LIP_REACH: f64 = 0.08;
const UPPER_LIP_DROP: f64 = 0.005;
/// The nose is read across at its tip and this far and twice as far below it ...
const NOSE_ACROSS_BELOW: f64 = 0.02;
/// ... within this distance of x = 0, in samples this far apart ...
const NOSE_ACROSS_REACH: f64 = 0.15;
const NOSE_ACROSS_STEP: f64 = 0.0025;
/// ... and its sides are where it has fallen this far behind its ridge (about 2 mm).
const NOSE_SIDE_DEPTH: f64 = 0.02;
/// The chin's most forward point is looked for this far below the mouth (CANDIDE's chin
/// is 0.25 below its mouth; the lower lip, more forward, lies above the window) ...
const CHIN_BELOW_MOUTH: [f64; 2] = [0.15, 0.45];
/// ... and its bottom is where the profile below it first falls back more steeply than
/// this (depth per height: 56 degrees from upright), over this height (about 2 mm): the
/// chin's underside. People mark CANDIDE's chin (FP 2.1) at the bottom of the chin seen
/// from the front; on the shipped heads this lies within 1.8 mm of the height their
/// landmark fits give it (0.3-1.8 mm). A slope needs no length: a first fit 10 % too small
/// (a face-only mesh) finds the same place, where a depth threshold had put it 2.5 mm
/// higher.
const CHIN_UNDERSIDE_SLOPE: f64 = 1.5;
const CHIN_SLOPE_SPAN: f64 = 0.02;

/// Midline features.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MidlineFeatures {
    /// Head units.
    pub nose_tip: DVec3,
    /// Where the midline crosses the first fit's x axis (mask units): the profile's x.
    pub midline_x: f64,
    /// The mouth's height in the first fit's mask frame (mask units): the notch between the
    /// lips lies behind where the mask's lips meet, so only its height is kept.
    pub mouth_height: f64,
    /// The height of the chin's bottom, mask frame of the first fit (mask units), or `None`
    /// when the profile ends before it turns under the chin (a face cut off there).
    pub chin_height: Option<f64>,
}

/// The midline features seen in `image`, or `None` when the profile shows no nose or no
/// mouth between two lips.
pub fn midline_features(image: &FrontImage) -> Option<MidlineFeatures> {
    let first_guess = Profile::along(image, 0.0);
    let nose = first_guess.highest_in(-0.45, 0.05)?;
    let midline_x = nose_centre_x(image, first_guess.heights[nose]).unwrap_or(0.0);
    let profile = Profile::along(image, midline_x);
    let nose = profile.highest_in(-0.45, 0.05)?;
    let nose_y = profile.heights[nose];
    let mouth = profile.deepest_notch(
        nose_y - MOUTH_BELOW_NOSE[1],
        nose_y - MOUTH_BELOW_NOSE[0],
        nose_y - UPPER_LIP_BELOW_NOSE,
    )?;
    let nose_z = profile.depths[nose].expect("the nose is on a covered sample");
    let mouth_height = profile.heights[mouth];
    Some(MidlineFeatures {
        nose_tip: image.head_point(DVec3::new(midline_x, nose_y, nose_z)),
        midline_x,
        mouth_height,
        chin_height: profile.chin_bottom(mouth_height),
    })
}

/// The x halfway between the nose's sides, averaged over its tip's height and
/// [`NOSE_ACROSS_BELOW`] and twice that below; `None` when no side shows at any of them.
fn nose_centre_x(image: &FrontImage, tip_y: f64) -> Option<f64> {
    let samples = (NOSE_ACROSS_REACH / NOSE_ACROSS_STEP).round() as isize;
    let centres: Vec<f64> = (0..3)
        .filter_map(|k| {
            let y = tip_y - k as f64 * NOSE_ACROSS_BELOW;
            let across: Vec<(f64, f64)> = (-samples..=samples)
                .map(|i| i as f64 * NOSE_ACROSS_STEP)
                .map(|x| (x, image.z_at(x, y).unwrap_or(f64::NEG_INFINITY)))
                .collect();
            let ridge = (0..across.len()).max_by(|&a, &b| across[a].1.total_cmp(&across[b].1))?;
            let level = across[ridge].1 - NOSE_SIDE_DEPTH;
            let side = |steps: &mut dyn Iterator<Item = usize>| {
                let mut inside = across[ridge];
                for i in steps {
                    let (x, z) = across[i];
                    if z < level {
                        let t = (inside.1 - level) / (inside.1 - z);
                        return Some(inside.0 + t * (x - inside.0));
                    }
                    inside = (x, z);
                }
                None
            };
            let right = side(&mut (0..ridge).rev())?;
            let left = side(&mut (ridge + 1..across.len()))?;
            Some((left + right) / 2.0)
        })
        .collect();
    (!centres.is_empty()).then(|| centres.iter().sum::<f64>() / centres.len() as f64)
}

/// z (mask units) against y along the midline; `None` where no surface is seen.
struct Profile {
    heights: Vec<f64>,
    depths: Vec<Option<f64>>,
}

impl Profile {
    /// The profile of `image` along the vertical line at `x`.
    fn along(image: &FrontImage, x: f64) -> Profile {
        Profile::sampled(|y| image.z_at(x, y))
    }

    /// The profile whose depth at height y is `depth(y)`, from [`LOWEST`] to [`HIGHEST`].
    fn sampled(depth: impl Fn(f64) -> Option<f64>) -> Profile {
        let samples = ((HIGHEST - LOWEST) / STEP) as usize + 1;
        let heights: Vec<f64> = (0..samples).map(|k| LOWEST + k as f64 * STEP).collect();
        let depths = heights.iter().map(|&y| depth(y)).collect();
        Profile { heights, depths }
    }

    fn indices_between(&self, low: f64, high: f64) -> impl Iterator<Item = usize> + '_ {
        (0..self.heights.len()).filter(move |&k| (low..=high).contains(&self.heights[k]))
    }

    /// The most forward sample with `low <= y <= high`.
    fn highest_in(&self, low: f64, high: f64) -> Option<usize> {
        self.indices_between(low, high)
            .filter_map(|k| self.depths[k].map(|z| (k, z)))
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(k, _)| k)
    }

    /// The height below the chin's most forward point (within [`CHIN_BELOW_MOUTH`] of
    /// `mouth_height`) where the profile first falls back more steeply than
    /// [`CHIN_UNDERSIDE_SLOPE`] over [`CHIN_SLOPE_SPAN`] (the middle of that span); `None`
    /// when no surface is seen before it does.
    fn chin_bottom(&self, mouth_height: f64) -> Option<f64> {
        let chin = self.highest_in(
            mouth_height - CHIN_BELOW_MOUTH[1],
            mouth_height - CHIN_BELOW_MOUTH[0],
        )?;
        let span = (CHIN_SLOPE_SPAN / STEP).round() as usize;
        for upper in (span..=chin).rev() {
            let lower = upper - span;
            let fall = self.depths[upper]? - self.depths[lower]?;
            if fall > CHIN_UNDERSIDE_SLOPE * (self.heights[upper] - self.heights[lower]) {
                return Some((self.heights[upper] + self.heights[lower]) / 2.0);
            }
        }
        None
    }

    /// The sample with `low <= y <= high` that lies furthest behind the lower of the
    /// surface's most forward points within [`LIP_REACH`] above it (and below `ceiling`)
    /// and below it, where the surface above falls again above its peak (an upper lip, not
    /// the nose's underside). A gap seen through between lips (no surface: a face-only mesh
    /// with its lips parted) is the deepest notch; its middle is taken.
    fn deepest_notch(&self, low: f64, high: f64, ceiling: f64) -> Option<usize> {
        let reach = (LIP_REACH / STEP).round() as usize;
        let top = self.heights.partition_point(|&y| y < ceiling);
        let mut best: Option<(usize, f64)> = None;
        for k in self.indices_between(low, high) {
            let z = self.depths[k].unwrap_or(f64::NEG_INFINITY);
            let end = (k + 1 + reach).min(top);
            let Some((highest, above)) = (k + 1..end)
                .filter_map(|j| self.depths[j].map(|z| (j, z)))
                .max_by(|a, b| a.1.total_cmp(&b.1))
            else {
                continue;
            };
            // An upper lip falls again above its peak (into the dip under the nose); the
            // nose's underside, above that dip, rises all the way to the ceiling.
            if !self.depths[highest + 1..top]
                .iter()
                .flatten()
                .any(|&z| z < above - UPPER_LIP_DROP)
            {
                continue;
            }
            let below = self.depths[k.saturating_sub(reach)..k]
                .iter()
                .flatten()
                .copied()
                .fold(f64::NEG_INFINITY, f64::max);
            // Infinite for a gap between lips; NaN (never taken) with no lip on a side.
            let notch = above.min(below) - z;
            if notch > 0.0 && best.is_none_or(|(_, n)| notch > n) {
                best = Some((k, notch));
            }
        }
        let (notch, _) = best?;
        if self.depths[notch].is_some() {
            return Some(notch);
        }
        let below = self.depths[..notch]
            .iter()
            .rev()
            .take_while(|z| z.is_none())
            .count();
        let above = self.depths[notch + 1..]
            .iter()
            .take_while(|z| z.is_none())
            .count();
        Some(notch - below + (below + above) / 2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::automatic::depth_map::tests::grid_plate;
    use crate::fit::automatic::front_image::tests::seen_from_the_front;
    use crate::head::Head;
    use glam::Vec2;

    #[test]
    fn the_midline_runs_through_the_middle_of_the_nose() {
        // A nose 0.25 high whose ridge runs at x = 0.021, on a plate seen from the front
        // (mask units), its tip at y = -0.25.
        let ridge_x = 0.021;
        let nose = move |x: f32, y: f32| {
            let along = (-((y + 0.25) / 0.08).powi(2)).exp();
            let across = (-((x - ridge_x) / 0.06).powi(2)).exp();
            0.25 * along * across
        };
        let (positions, triangles) = grid_plate([151, 151], Vec2::new(-0.3, -0.5), 0.004, nose);
        let image = seen_from_the_front(&Head::new("nose", positions, triangles), 256);
        let x = nose_centre_x(&image, -0.25).expect("both sides of the nose show");
        assert!((x - f64::from(ridge_x)).abs() < 0.002, "{x}");
    }

    /// A midline from the chin's underside up past the nose (mask units): the neck far
    /// behind below y = -0.95, a chin at 0.05 and the mouth's notch at y = -0.6 between lips
    /// at 0.12, a dip under the nose at y = -0.4 and the nose tip at 0.25.
    fn midline(gap_between_lips: bool) -> Profile {
        Profile::sampled(|y| {
            let bump =
                |centre: f64, width: f64, height: f64| height * (-((y - centre) / width).powi(2)).exp();
            if y < -0.95 {
                return Some(-0.6);
            }
            if gap_between_lips && (-0.62..=-0.58).contains(&y) {
                return None;
            }
            Some(
                bump(-0.8, 0.12, 0.05)
                    + bump(-0.66, 0.04, 0.12)
                    + bump(-0.52, 0.05, 0.12)
                    + bump(-0.33, 0.05, 0.1)
                    + bump(-0.2, 0.07, 0.25),
            )
        })
    }

    fn mouth_height(profile: &Profile) -> f64 {
        let nose = profile.highest_in(-0.45, 0.05).unwrap();
        let nose_y = profile.heights[nose];
        assert!((nose_y + 0.2).abs() < 0.01, "{nose_y}");
        let mouth = profile
            .deepest_notch(
                nose_y - MOUTH_BELOW_NOSE[1],
                nose_y - MOUTH_BELOW_NOSE[0],
                nose_y - UPPER_LIP_BELOW_NOSE,
            )
            .unwrap();
        profile.heights[mouth]
    }

    #[test]
    fn the_mouth_is_the_notch_between_the_lips_not_the_dip_under_the_nose() {
        let mouth = mouth_height(&midline(false));
        assert!((mouth + 0.59).abs() < 0.02, "{mouth}");
    }

    /// MakeHuman's midline with eyeballs behind its lids, as its first fit saw it (mask
    /// units, every 0.012 from y = -0.724): the dip under its nose (0.117 at y = -0.352)
    /// lies deeper behind the lips around it than the crease between its closed lips (0.098
    /// at y = -0.508), and within the mouth's window below the nose.
    #[test]
    fn a_dip_under_the_nose_deeper_than_the_lips_crease_is_not_the_mouth() {
        const DEPTHS: [f64; 61] = [
            0.05, 0.05, 0.05, 0.049, 0.047, 0.046, 0.051, 0.056, 0.061, 0.065, 0.109, 0.11, 0.112, 0.114,
            0.116, 0.115, 0.111, 0.106, 0.098, 0.108, 0.132, 0.138, 0.144, 0.15, 0.154, 0.151, 0.141, 0.131,
            0.126, 0.124, 0.119, 0.117, 0.12, 0.124, 0.131, 0.145, 0.175, 0.189, 0.202, 0.212, 0.222, 0.232,
            0.234, 0.234, 0.234, 0.231, 0.224, 0.22, 0.215, 0.211, 0.205, 0.192, 0.185, 0.178, 0.172, 0.165,
            0.152, 0.147, 0.142, 0.137, 0.133,
        ];
        let profile = Profile::sampled(|y| {
            let at = (y + 0.724) / 0.012;
            let i = at.floor();
            (0.0..60.0).contains(&i).then(|| {
                let (i, t) = (i as usize, at - i);
                DEPTHS[i] + t * (DEPTHS[i + 1] - DEPTHS[i])
            })
        });
        let mouth = mouth_height(&profile);
        assert!((mouth + 0.508).abs() < 0.01, "{mouth}");
    }

    #[test]
    fn a_gap_seen_through_between_parted_lips_is_the_mouth() {
        // A face-only mesh shows nothing between parted lips; the dip under the nose is
        // then the deepest notch with surface in it.
        let mouth = mouth_height(&midline(true));
        assert!((mouth + 0.6).abs() < 0.005, "{mouth}");
    }

    #[test]
    fn the_chin_s_bottom_is_where_the_profile_turns_under_it() {
        // The chin's front is at y = -0.8; below it the chin's bump falls back at most
        // 0.05 sqrt(2 / e) / 0.12 = 0.36 per unit of height, and then the neck steps
        // 0.6 back at y = -0.95: the first 0.02 span reaching across that step is centred
        // about 0.01 above it.
        let bottom = midline(false).chin_bottom(-0.59).unwrap();
        assert!((bottom + 0.94).abs() < 0.003, "{bottom}");
        // A chin falling back 0.5 per unit of height below y = -0.9 and 2 below y = -0.95:
        // a span falls 1.5 times its height once it reaches 0.0133 below y = -0.95, so the
        // first one lies between y = -0.943 and -0.963.
        let chin = Profile::sampled(|y| {
            Some(if y > -0.9 {
                0.0
            } else if y > -0.95 {
                0.5 * (y + 0.9)
            } else {
                -0.025 + 2.0 * (y + 0.95)
            })
        });
        let bottom = chin.chin_bottom(-0.59).unwrap();
        assert!((bottom + 0.954).abs() < 0.003, "{bottom}");
    }

    #[test]
    fn a_face_cut_off_above_the_chin_s_bottom_shows_no_chin() {
        let mut profile = midline(false);
        for (y, z) in profile.heights.iter().zip(profile.depths.iter_mut()) {
            if *y < -0.85 {
                *z = None;
            }
        }
        assert_eq!(profile.chin_bottom(-0.59), None);
    }
}
