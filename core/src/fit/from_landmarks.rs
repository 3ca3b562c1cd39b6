//! A fit from a landmarks file, in one place for `facewire fit` and the service's
//! registration: validate the landmarks against the mask and the head, solve pose and
//! shape units, take `mm_per_unit` from the file or from 63 mm pupils, and check the
//! result's ranges.

use super::limits::{in_range, RangeError, MM_PER_UNIT_RANGE};
use super::{solve_fit, Fit, LandmarkError, Landmarks, SolveError, SolveOptions};
use crate::head::Head;
use crate::mask::Mask;

#[derive(Debug, thiserror::Error)]
pub enum FitError {
    #[error(transparent)]
    Landmarks(#[from] LandmarkError),
    #[error("{origin}: {source}")]
    Solve { origin: String, source: SolveError },
    #[error("{origin}: the solved fit is out of range: {source}")]
    Range { origin: String, source: RangeError },
}

/// A fit solved from landmarks, with how it was reached.
#[derive(Debug, Clone, PartialEq)]
pub struct LandmarkFit {
    pub fit: Fit,
    /// Solver iterations.
    pub iterations: usize,
    /// RMS distance between the fitted landmark vertices and their head vertices, head units.
    pub rms: f64,
    /// The landmarks gave no `mm_per_unit`; it comes from 63 mm pupils.
    pub mm_per_unit_from_pupils: bool,
}

/// Validates `landmarks` (named `origin` in errors) against `mask` and `head`, solves the
/// similarity and shape units, and sets `mm_per_unit` from the landmarks or, when they
/// give none, from 63 mm pupils. No nudges.
pub fn fit_from_landmarks(
    head: &Head,
    landmarks: &Landmarks,
    origin: &str,
    mask: &Mask,
) -> Result<LandmarkFit, FitError> {
    landmarks.validate(origin, mask.vertices.len(), head.positions.len())?;
    let solution =
        solve_fit(mask, &landmarks.targets(head), &[], &SolveOptions::default()).map_err(|source| {
            FitError::Solve {
                origin: origin.to_string(),
                source,
            }
        })?;
    let range = |source| FitError::Range {
        origin: origin.to_string(),
        source,
    };
    let mm_per_unit = match landmarks.mm_per_unit {
        Some(mm) => mm,
        None => in_range(
            "mm_per_unit (from 63 mm pupils)",
            Fit::mm_per_unit_from_pupils(mask, &solution.shape, &solution.pose),
            MM_PER_UNIT_RANGE,
        )
        .map_err(range)?,
    };
    let fit = Fit {
        pose: solution.pose,
        shape: solution.shape,
        nudges: Vec::new(),
        mm_per_unit,
    };
    fit.check_ranges().map_err(range)?;
    Ok(LandmarkFit {
        fit,
        iterations: solution.iterations,
        rms: solution.rms,
        mm_per_unit_from_pupils: landmarks.mm_per_unit.is_none(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::{FitFile, Landmark};
    use crate::mask::MaskPose;
    use glam::Vec3;

    /// A head made of the mask itself, posed by a known fit: the landmarks recover it.
    fn posed_mask_head(pose: MaskPose) -> (Mask, Head) {
        let mask = Mask::candide3();
        let mut positions = mask.vertices.clone();
        pose.apply_all(&mut positions);
        let head = Head::new("mask.obj", positions, mask.triangles.clone());
        (mask, head)
    }

    fn landmarks(vertices: &[u32], mm_per_unit: Option<f32>) -> Landmarks {
        Landmarks {
            head: None,
            mm_per_unit,
            landmarks: vertices
                .iter()
                .map(|&v| Landmark {
                    mask_vertex: v,
                    head_vertex: v,
                    name: None,
                })
                .collect(),
        }
    }

    #[test]
    fn recovers_a_known_pose_and_derives_the_scale_from_pupils() {
        let truth = MaskPose::similarity(Vec3::new(0.1, -0.2, 0.05), 0.55, Vec3::new(0.0, 7.2, 1.0));
        let (mask, head) = posed_mask_head(truth);
        let corners = [20, 53, 23, 56, 5, 26, 59, 31, 64, 10];
        let solved = fit_from_landmarks(&head, &landmarks(&corners, None), "l", &mask).unwrap();
        assert!(solved.rms < 1e-4, "rms {}", solved.rms);
        assert!((solved.fit.pose.scale.x - 0.55).abs() < 1e-4);
        assert!(solved.mm_per_unit_from_pupils);
        let expected = Fit::mm_per_unit_from_pupils(&mask, &solved.fit.shape, &solved.fit.pose);
        assert_eq!(solved.fit.mm_per_unit, expected);
        let given = fit_from_landmarks(&head, &landmarks(&corners, Some(100.0)), "l", &mask).unwrap();
        assert_eq!(given.fit.mm_per_unit, 100.0);
        assert!(!given.mm_per_unit_from_pupils);
        // The file form resolves back to an equivalent fit.
        let again = FitFile::from_fit(&given.fit, &mask, None)
            .resolve("again", &mask)
            .unwrap();
        assert_eq!(again.mm_per_unit, 100.0);
    }

    #[test]
    fn invalid_landmarks_and_degenerate_solves_are_errors() {
        let (mask, head) = posed_mask_head(MaskPose::IDENTITY);
        let err = fit_from_landmarks(&head, &landmarks(&[20, 53, 999], None), "l", &mask).unwrap_err();
        assert!(
            matches!(err, FitError::Landmarks(LandmarkError::OutOfRange { .. })),
            "{err}"
        );
        let err = fit_from_landmarks(&head, &landmarks(&[20, 53, 5], Some(f32::NAN)), "l", &mask)
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("l: field mm_per_unit: "), "{err}");
        // Three landmarks on one head vertex: no similarity fits them.
        let mut same = landmarks(&[20, 53, 5], None);
        for l in &mut same.landmarks {
            l.head_vertex = 0;
        }
        let err = fit_from_landmarks(&head, &same, "l", &mask).unwrap_err();
        assert!(
            matches!(err, FitError::Solve { .. } | FitError::Range { .. }),
            "{err}"
        );
    }
}
