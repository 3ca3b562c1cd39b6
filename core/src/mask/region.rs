//! Parts of the face as fixed sets of CANDIDE-3 vertices, picked by where the standard
//! mask puts them (mask units): every head's fit report speaks of the same vertices, and a
//! deformer can treat the eyes' controls unlike the jaw's.

use glam::Vec3;
use serde::Serialize;

/// A part of the face, by CANDIDE-3 vertices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FaceRegion {
    Eyes,
    Brow,
    Nose,
    Mouth,
    Jaw,
    ForeheadAndCheeks,
}

impl FaceRegion {
    pub const ALL: [FaceRegion; 6] = [
        FaceRegion::Eyes,
        FaceRegion::Brow,
        FaceRegion::Nose,
        FaceRegion::Mouth,
        FaceRegion::Jaw,
        FaceRegion::ForeheadAndCheeks,
    ];

    /// The region of a vertex of the standard mask at `p` (mask units).
    pub fn of(p: Vec3) -> FaceRegion {
        let (x, y) = (p.x.abs(), p.y);
        if (0.08..=0.56).contains(&x) && (0.04..=0.26).contains(&y) {
            FaceRegion::Eyes
        } else if y > 0.26 && y <= 0.5 && x <= 0.6 {
            FaceRegion::Brow
        } else if x < 0.2 && (-0.3..0.26).contains(&y) {
            FaceRegion::Nose
        } else if x <= 0.3 && (-0.62..-0.3).contains(&y) {
            FaceRegion::Mouth
        } else if y < -0.3 {
            FaceRegion::Jaw
        } else {
            FaceRegion::ForeheadAndCheeks
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            FaceRegion::Eyes => "eyes",
            FaceRegion::Brow => "brow",
            FaceRegion::Nose => "nose",
            FaceRegion::Mouth => "mouth",
            FaceRegion::Jaw => "jaw",
            FaceRegion::ForeheadAndCheeks => "forehead and cheeks",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mask::Mask;

    #[test]
    fn every_region_holds_its_features() {
        let mask = Mask::candide3();
        let region = |j: usize| FaceRegion::of(mask.vertices[j]);
        // Outer eye corners, the nose tip, the mouth's middle, the chin, the forehead top.
        assert_eq!(region(20), FaceRegion::Eyes);
        assert_eq!(region(53), FaceRegion::Eyes);
        assert_eq!(region(5), FaceRegion::Nose);
        assert_eq!(region(40), FaceRegion::Mouth);
        assert_eq!(region(10), FaceRegion::Jaw);
        assert_eq!(region(0), FaceRegion::ForeheadAndCheeks);
        assert_eq!(region(17), FaceRegion::Brow);
        let counts: Vec<usize> = FaceRegion::ALL
            .iter()
            .map(|&r| mask.vertices.iter().filter(|&&p| FaceRegion::of(p) == r).count())
            .collect();
        assert_eq!(counts, [36, 10, 19, 21, 8, 19]);
    }
}
