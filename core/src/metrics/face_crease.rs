//! The whole-face crease measure of `facewire compare` (docs/METRICS.md): roughness over
//! the face region, which the lip roughness does not see, and the largest rise of one
//! triangle's dihedral roughness over its rest value, a new crease.

use glam::Vec3;

use super::face_region::triangles_within;
use super::{Roughness, RoughnessError};
use crate::head::Head;

/// Roughness over the whole face region, which the lip roughness does not see: its mean,
/// and the largest rise of one triangle's `rho(T)` over its rest value (a new crease).
pub struct FaceCrease {
    roughness: Roughness,
    /// `rho(T)` of each face triangle at rest, in the evaluator's order.
    rest: Vec<f64>,
    rest_mean: f64,
}

impl FaceCrease {
    /// Over the head triangles whose three corners are in `face` (head vertex indexes,
    /// such as [`super::FaceVertices::vertices`]).
    pub fn new(head: &Head, face: &[u32]) -> Result<FaceCrease, RoughnessError> {
        let triangles = triangles_within(head, face);
        let mut roughness = Roughness::new(head, &triangles)?;
        roughness.evaluate(&head.positions)?;
        let rest = roughness.triangle_roughness().to_vec();
        let rest_mean = mean(&rest);
        Ok(FaceCrease {
            roughness,
            rest,
            rest_mean,
        })
    }

    /// Mean `rho(T)` of the face triangles at rest.
    pub fn rest_mean(&self) -> f64 {
        self.rest_mean
    }

    pub fn triangles(&self) -> usize {
        self.rest.len()
    }

    /// Mean `rho(T)` of the face triangles, and the largest rise over rest, for a pose.
    pub fn measure(&mut self, positions: &[Vec3]) -> Result<(f64, f64), RoughnessError> {
        self.roughness.evaluate(positions)?;
        let rho = self.roughness.triangle_roughness();
        let crease = rho
            .iter()
            .zip(&self.rest)
            .map(|(now, was)| now - was)
            .fold(f64::NEG_INFINITY, f64::max);
        Ok((mean(rho), crease))
    }
}

/// Mean of values; NaN for none.
fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3 x 3 grid of unit squares in z = 0, two triangles each.
    fn grid() -> Head {
        crate::head::flat_grid(3)
    }

    #[test]
    fn rest_has_no_crease_and_a_fold_does() {
        let head = grid();
        let face: Vec<u32> = (0..16).collect();
        let mut crease = FaceCrease::new(&head, &face).unwrap();
        assert_eq!(crease.triangles(), 18);
        let (_, at_rest) = crease.measure(&head.positions).unwrap();
        assert_eq!(at_rest, 0.0);
        // Lifting the middle column folds the sheet: some triangle gets rougher.
        let mut folded = head.positions.clone();
        for v in [1, 5, 9, 13] {
            folded[v].z = 1.0;
        }
        let (_, fold) = crease.measure(&folded).unwrap();
        assert!(fold > 0.1, "{fold}");
    }
}
