//! What the interpolating algorithms share: the controls grouped by their anchor (several
//! mask vertices can anchor on one head vertex), and a robust inverse of the small dense
//! system that makes an interpolant pass through the control displacements at the anchors
//! (`rbf`'s kernel system, `point_distance:interpolate=true`'s weight matrix).
//!
//! The inverse is LU with partial pivoting in f64, accepted when it exists, is finite and
//! its 1-norm condition number `|M|_1 |M^-1|_1` is at most `MAX_CONDITION` (1e12);
//! otherwise the truncated SVD pseudo-inverse, dropping singular values below
//! `sigma_max / MAX_CONDITION`, so that in the dropped directions the anchors are matched
//! in the least-squares sense and the weights stay bounded.

use std::collections::HashMap;

use nalgebra::{DMatrix, SVD};

use super::Registration;

/// Largest 1-norm condition number accepted from the LU inverse; also the truncation
/// ratio of the pseudo-inverse fallback.
const MAX_CONDITION: f64 = 1e12;
/// Iteration cap of the fallback SVD (it converges in a few dozen sweeps on sane input).
const SVD_MAX_ITERATIONS: usize = 10_000;

/// A head vertex anchoring one or more control mask vertices.
#[derive(Debug)]
pub(super) struct Centre {
    pub vertex: u32,
    pub members: Vec<u32>,
}

/// The controls grouped by anchor, in control order.
pub(super) fn centres(reg: &Registration) -> Vec<Centre> {
    let mut index: HashMap<u32, usize> = HashMap::new();
    let mut centres: Vec<Centre> = Vec::new();
    for &j in &reg.controls {
        let vertex = reg.anchors.vertex[j as usize];
        match index.get(&vertex) {
            Some(&k) => centres[k].members.push(j),
            None => {
                index.insert(vertex, centres.len());
                centres.push(Centre {
                    vertex,
                    members: vec![j],
                });
            }
        }
    }
    centres
}

/// `M^-1` by LU, or the truncated SVD pseudo-inverse when LU fails or is ill-conditioned;
/// `None` when `M` is not finite or the SVD does not converge.
pub(super) fn invert(system: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    if !system.iter().all(|x| x.is_finite()) {
        return None;
    }
    lu_inverse(system).or_else(|| pseudo_inverse(system))
}

/// The LU inverse when it exists, is finite and has condition number at most
/// `MAX_CONDITION`.
fn lu_inverse(system: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let inverse = system.clone().lu().try_inverse()?;
    let condition = norm1(system) * norm1(&inverse);
    (condition.is_finite() && condition <= MAX_CONDITION).then_some(inverse)
}

fn pseudo_inverse(system: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let svd = SVD::try_new(system.clone(), true, true, f64::EPSILON, SVD_MAX_ITERATIONS)?;
    let largest = svd.singular_values.iter().copied().fold(0.0, f64::max);
    svd.pseudo_inverse(largest / MAX_CONDITION).ok()
}

/// Largest absolute column sum.
fn norm1(matrix: &DMatrix<f64>) -> f64 {
    matrix
        .column_iter()
        .map(|c| c.iter().map(|x| x.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn singular_systems_fall_back_to_the_pseudo_inverse() {
        let singular = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        assert!(lu_inverse(&singular).is_none());
        let inverse = invert(&singular).unwrap();
        assert!((inverse - DMatrix::from_element(2, 2, 0.25)).amax() < 1e-12);
        // Ill-conditioned but not singular: LU refuses, the pseudo-inverse drops the tiny
        // direction and stays bounded.
        let nearly = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0 + 1e-14]);
        assert!(lu_inverse(&nearly).is_none());
        assert!(invert(&nearly).unwrap().amax() < 1.0);
        assert!(invert(&DMatrix::from_row_slice(1, 1, &[f64::NAN])).is_none());
    }
}
