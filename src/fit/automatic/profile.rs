//! Features on the face's midline profile, read under a first fit: the nose tip (the
//! profile's peak) and the height of the mouth (the notch between the lips). Closest points
//! alone let the mask slide up or down the face; these pin it.
//!
//! The profile is the head's surface seen along the fitted mask's z axis, on the mask's
//! plane of symmetry (x = 0), sampled in **mask units** (y up the face, z out of it).

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
/// ... between lips that come forward within this distance above and below it.
const LIP_REACH: f64 = 0.08;

/// Midline features.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MidlineFeatures {
    /// Head units.
    pub nose_tip: DVec3,
    /// The mouth's height in the first fit's mask frame (mask units): the notch between the
    /// lips lies behind where the mask's lips meet, so only its height is kept.
    pub mouth_height: f64,
}

/// The midline features seen in `image`, or `None` when the profile shows no nose or no
/// mouth between two lips.
pub fn midline_features(image: &FrontImage) -> Option<MidlineFeatures> {
    let samples = ((HIGHEST - LOWEST) / STEP) as usize + 1;
    let heights: Vec<f64> = (0..samples).map(|k| LOWEST + k as f64 * STEP).collect();
    let depths: Vec<Option<f64>> = heights.iter().map(|&y| image.z_at(0.0, y)).collect();
    let profile = Profile { heights, depths };
    let nose = profile.highest_in(-0.45, 0.05)?;
    let nose_y = profile.heights[nose];
    let mouth = profile.deepest_notch(
        nose_y - MOUTH_BELOW_NOSE[1],
        nose_y - MOUTH_BELOW_NOSE[0],
        nose_y - UPPER_LIP_BELOW_NOSE,
    )?;
    let nose_z = profile.depths[nose].expect("the nose is on a covered sample");
    Some(MidlineFeatures {
        nose_tip: image.head_point(DVec3::new(0.0, nose_y, nose_z)),
        mouth_height: profile.heights[mouth],
    })
}

/// z (mask units) against y along the midline; `None` where no surface is seen.
struct Profile {
    heights: Vec<f64>,
    depths: Vec<Option<f64>>,
}

impl Profile {
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

    /// The sample with `low <= y <= high` that lies furthest behind the lower of the
    /// surface's most forward points within [`LIP_REACH`] above it (and below `ceiling`)
    /// and below it.
    fn deepest_notch(&self, low: f64, high: f64, ceiling: f64) -> Option<usize> {
        let reach = (LIP_REACH / STEP).round() as usize;
        let top = self.heights.partition_point(|&y| y < ceiling);
        let mut best: Option<(usize, f64)> = None;
        for k in self.indices_between(low, high) {
            let Some(z) = self.depths[k] else { continue };
            let above = self.depths[(k + 1).min(top)..(k + 1 + reach).min(top)]
                .iter()
                .flatten()
                .copied()
                .fold(f64::NEG_INFINITY, f64::max);
            let below = self.depths[k.saturating_sub(reach)..k]
                .iter()
                .flatten()
                .copied()
                .fold(f64::NEG_INFINITY, f64::max);
            let notch = above.min(below) - z;
            if notch > 0.0 && best.is_none_or(|(_, n)| notch > n) {
                best = Some((k, notch));
            }
        }
        best.map(|(k, _)| k)
    }
}
