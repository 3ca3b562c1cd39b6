//! A part's role when none is given: parts whose centre lies below the mouth line (the
//! fitted mask's inner-lip corners, the occlusal plane at rest) move with the jaw, the
//! others with the skull. A tongue is never guessed: it is given as one.

use glam::Vec3;

use crate::fit::FittedMask;
use crate::head::{Head, PartRole};
use crate::mask::INNER_LIP_CORNERS;

/// Skull or jaw, by which side of the mouth line `mesh`'s centre lies on.
pub fn infer_role(mesh: &Head, fitted: &FittedMask) -> PartRole {
    let to_mask = fitted.fit.pose.affine().inverse();
    let centre = mesh.positions.iter().copied().sum::<Vec3>() / mesh.positions.len().max(1) as f32;
    let mouth_line = INNER_LIP_CORNERS.iter().map(|&j| fitted.base[j].y).sum::<f32>() / 2.0;
    match to_mask.transform_point3(centre).y < mouth_line {
        true => PartRole::Jaw,
        false => PartRole::Skull,
    }
}
