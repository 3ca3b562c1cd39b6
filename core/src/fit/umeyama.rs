//! Least-squares similarity between point sets (Umeyama 1991): the rotation, uniform
//! scale and translation that carry `source` onto `target` with the smallest summed
//! squared distance. Computed in f64; reflections are excluded.

use glam::{DMat3, DVec3};
use nalgebra::Matrix3;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Similarity {
    pub rotation: DMat3,
    pub scale: f64,
    pub translation: DVec3,
}

impl Similarity {
    pub fn apply(&self, p: DVec3) -> DVec3 {
        self.scale * (self.rotation * p) + self.translation
    }

    /// `R^T (q - t) / s`: a target-frame point back in the source frame.
    pub fn invert_point(&self, q: DVec3) -> DVec3 {
        self.rotation.transpose() * (q - self.translation) / self.scale
    }
}

/// Solves `min sum |s R x_i + t - y_i|^2`. Needs at least three non-collinear pairs;
/// returns `None` for fewer or for a degenerate source set.
pub fn umeyama(source: &[DVec3], target: &[DVec3]) -> Option<Similarity> {
    if source.len() != target.len() {
        return None;
    }
    umeyama_pairs(|| source.iter().copied().zip(target.iter().copied()))
}

/// [`umeyama`] over the pairs `(x_i, y_i)` that `pairs` yields; it is called twice (the
/// means, then the covariance), and nothing is allocated, so per-frame code can use it.
pub fn umeyama_pairs<I: Iterator<Item = (DVec3, DVec3)>>(pairs: impl Fn() -> I) -> Option<Similarity> {
    let (mut n, mut sum_x, mut sum_y) = (0usize, DVec3::ZERO, DVec3::ZERO);
    for (x, y) in pairs() {
        n += 1;
        sum_x += x;
        sum_y += y;
    }
    if n < 3 {
        return None;
    }
    let mean_x = sum_x / n as f64;
    let mean_y = sum_y / n as f64;
    let mut covariance = Matrix3::<f64>::zeros();
    let mut variance_x = 0.0;
    for (x, y) in pairs() {
        let dx = x - mean_x;
        let dy = y - mean_y;
        variance_x += dx.length_squared();
        covariance += nalgebra::Vector3::new(dy.x, dy.y, dy.z) * nalgebra::RowVector3::new(dx.x, dx.y, dx.z);
    }
    covariance /= n as f64;
    variance_x /= n as f64;
    if variance_x <= f64::EPSILON {
        return None;
    }
    let svd = covariance.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let mut sign = Matrix3::<f64>::identity();
    if (u.determinant() * v_t.determinant()) < 0.0 {
        sign[(2, 2)] = -1.0;
    }
    let rotation = u * sign * v_t;
    let trace: f64 = (0..3).map(|i| svd.singular_values[i] * sign[(i, i)]).sum();
    if trace <= 0.0 {
        return None;
    }
    let scale = trace / variance_x;
    let rotation = DMat3::from_cols_array(&[
        rotation[(0, 0)],
        rotation[(1, 0)],
        rotation[(2, 0)],
        rotation[(0, 1)],
        rotation[(1, 1)],
        rotation[(2, 1)],
        rotation[(0, 2)],
        rotation[(1, 2)],
        rotation[(2, 2)],
    ]);
    let translation = mean_y - scale * (rotation * mean_x);
    Some(Similarity {
        rotation,
        scale,
        translation,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::EulerRot;

    #[test]
    fn recovers_a_known_similarity() {
        let truth = Similarity {
            rotation: DMat3::from_euler(EulerRot::ZYX, 0.4, -0.3, 0.2),
            scale: 2.5,
            translation: DVec3::new(1.0, -2.0, 0.5),
        };
        let source = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.0, 0.3, 1.0),
            DVec3::new(0.7, -0.2, 0.4),
        ];
        let target: Vec<DVec3> = source.iter().map(|&p| truth.apply(p)).collect();
        let found = umeyama(&source, &target).unwrap();
        assert!((found.scale - truth.scale).abs() < 1e-12);
        assert!(found.rotation.abs_diff_eq(truth.rotation, 1e-12));
        assert!(found.translation.abs_diff_eq(truth.translation, 1e-12));
        assert!(found.invert_point(target[3]).abs_diff_eq(source[3], 1e-12));
    }

    #[test]
    fn refuses_degenerate_input() {
        let p = [DVec3::ZERO; 4];
        assert!(umeyama(&p, &p).is_none());
        assert!(umeyama(&p[..2], &p[..2]).is_none());
    }
}
