//! Lengths across a fitted face (pupils, eye corners, mouth, nose, chin), the cues a head's
//! unit is guessed from when the file does not say it: people's faces differ in these by a
//! few per cent, far less than the units files are written in (mm, cm, inches, m).
//!
//! Measured on a neutral CANDIDE-3 mask (the fitted person's `neutral_mask_units`, or the
//! same posed into head units): each length is in the units of the vertices given.

use glam::Vec3;

use crate::mask::{fap, OUTER_LIP_CORNERS};

/// CANDIDE-3 vertices the lengths run between.
const INNER_EYE_CORNERS: [usize; 2] = [23, 56];
const OUTER_EYE_CORNERS: [usize; 2] = [20, 53];
/// The base of the nose (subnasale), the upper lip's middle, the chin.
const NOSE_BASE: usize = 6;
const UPPER_LIP_MIDDLE: usize = 87;
const CHIN: usize = 10;

/// Number of lengths in [`FaceLengths`].
pub const FACE_LENGTHS: usize = 7;

/// Lengths across a face, in the units of the mask they were measured on.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FaceLengths {
    /// Between the pupils.
    pub pupils: f32,
    /// Between the eyes' inner corners.
    pub inner_eye_corners: f32,
    /// Between the eyes' outer corners.
    pub outer_eye_corners: f32,
    /// Between the mouth's corners.
    pub mouth_width: f32,
    /// From the pupils' midpoint to the base of the nose.
    pub eyes_to_nose: f32,
    /// From the base of the nose to the upper lip's middle.
    pub nose_to_mouth: f32,
    /// From the base of the nose to the chin.
    pub nose_to_chin: f32,
}

impl FaceLengths {
    /// The names of the lengths, in the order of [`FaceLengths::to_array`].
    pub const NAMES: [&'static str; FACE_LENGTHS] = [
        "pupils",
        "inner_eye_corners",
        "outer_eye_corners",
        "mouth_width",
        "eyes_to_nose",
        "nose_to_mouth",
        "nose_to_chin",
    ];

    /// Measures a neutral CANDIDE-3 mask's vertices (any units; the lengths are in them).
    pub fn measure(vertices: &[Vec3]) -> FaceLengths {
        let at = |i: usize| vertices[i];
        let apart = |[a, b]: [usize; 2]| at(a).distance(at(b));
        let left = fap::centroid(vertices, &fap::LEFT_PUPIL);
        let right = fap::centroid(vertices, &fap::RIGHT_PUPIL);
        FaceLengths {
            pupils: left.distance(right),
            inner_eye_corners: apart(INNER_EYE_CORNERS),
            outer_eye_corners: apart(OUTER_EYE_CORNERS),
            mouth_width: apart(OUTER_LIP_CORNERS),
            eyes_to_nose: (0.5 * (left + right)).distance(at(NOSE_BASE)),
            nose_to_mouth: apart([NOSE_BASE, UPPER_LIP_MIDDLE]),
            nose_to_chin: apart([NOSE_BASE, CHIN]),
        }
    }

    /// The lengths in the order of [`FaceLengths::NAMES`].
    pub fn to_array(self) -> [f32; FACE_LENGTHS] {
        [
            self.pupils,
            self.inner_eye_corners,
            self.outer_eye_corners,
            self.mouth_width,
            self.eyes_to_nose,
            self.nose_to_mouth,
            self.nose_to_chin,
        ]
    }

    /// Every length times `factor` (from mask units to millimetres, say).
    pub fn scaled(self, factor: f32) -> FaceLengths {
        let [a, b, c, d, e, f, g] = self.to_array().map(|l| l * factor);
        FaceLengths {
            pupils: a,
            inner_eye_corners: b,
            outer_eye_corners: c,
            mouth_width: d,
            eyes_to_nose: e,
            nose_to_mouth: f,
            nose_to_chin: g,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mask::Mask;

    #[test]
    fn lengths_scale_with_the_mask_and_do_not_turn_or_move() {
        let mask = Mask::candide3();
        let lengths = FaceLengths::measure(&mask.vertices);
        for (name, length) in FaceLengths::NAMES.iter().zip(lengths.to_array()) {
            assert!(length > 0.0, "{name}: {length}");
        }
        let turned: Vec<Vec3> = mask
            .vertices
            .iter()
            .map(|&v| glam::Quat::from_rotation_y(0.7) * (2.5 * v) + Vec3::new(3.0, -1.0, 2.0))
            .collect();
        let moved = FaceLengths::measure(&turned).to_array();
        for ((name, a), b) in FaceLengths::NAMES
            .iter()
            .zip(lengths.scaled(2.5).to_array())
            .zip(moved)
        {
            assert!((a - b).abs() < 1e-5 * a.max(1.0), "{name}: {a} vs {b}");
        }
        // The pupils' length is the one the FAPU ES measures on an upright mask.
        let es = crate::mask::FapuValues::measure(&mask.vertices).es;
        assert!((lengths.pupils - es).abs() < 1e-4, "{} vs {es}", lengths.pupils);
    }
}
