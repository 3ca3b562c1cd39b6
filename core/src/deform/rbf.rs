//! `rbf` (thesis T, section 2.4.4): radial basis interpolation of the control
//! displacements, with an optional linear polynomial.
//!
//! # The interpolant
//!
//! The centres `c_k` are the anchors of the control mask vertices (head vertices, so both
//! the centres and the evaluation points lie on the head). Each coordinate of the
//! displacement field is
//!
//! ```text
//! d(P) = sum_k lambda_k phi(dist(P, c_k)) + a0 + a . x(P)          (linear term on)
//! d(P) = sum_k lambda_k phi(dist(P, c_k))                          (poly=none)
//! ```
//!
//! with the coefficients from the interpolation conditions `d(c_k) = delta_k` and, with the
//! linear term, the side conditions `sum_k lambda_k = 0`, `sum_k lambda_k x(c_k) = 0`:
//!
//! ```text
//! [ Phi  P ] [ lambda ]   [ delta ]      Phi_kl = phi(dist(c_k, c_l))
//! [ P^T  0 ] [   a    ] = [   0   ]      P_k    = [1, x(c_k)]
//! ```
//!
//! `x` is the head position in a normalized frame (centred on the centres' centroid and
//! divided by their largest distance from it) so the polynomial columns have the same
//! magnitude as the kernel columns; the span, and so the interpolant, does not depend on
//! this choice. The linear term makes the interpolant reproduce any affine motion of the
//! centres exactly (translations, rotations, scalings of the whole mask), which the kernels
//! alone do not.
//!
//! Everything is linear in `delta`, so binding solves the system once: with `M` the matrix
//! above and `b(P) = [phi(dist(P, c_1)) .. phi(dist(P, c_m)), 1, x(P)]`, the weights of
//! head vertex P are `w(P) = b(P) M^-1` restricted to the `delta` columns, and deforming is
//! `d(P) = sum_k w_k(P) delta_k`: a dense `n x m` weight matrix (n head vertices, m
//! centres). At an anchor, `b(c_k)` is row k of `M`, so `w(c_k)` is the unit vector `e_k` and
//! the control displacement is reproduced (up to rounding and the dropped weights).
//!
//! # Kernels and distances (mm)
//!
//! With `s = r / r_mm` (`r_mm`: the kernel's scale, or the support radius of Wendland):
//! gaussian `exp(-s^2)`; multiquadric `sqrt(1 + s^2)`; inverse multiquadric
//! `1 / sqrt(1 + s^2)`; thin plate `s^2 ln s` (0 at s = 0); Wendland C2
//! `(1 - s)^4 (4 s + 1)` for `s < 1`, else 0. With Euclidean distances and the linear term
//! the thin plate interpolant does not depend on `r_mm` (the `-s^2 ln r_mm` part sums to a
//! constant under the side conditions).
//!
//! `distance=euclidean`: straight-line distance between head positions times
//! `mm_per_unit`. `distance=surface`: the registration's surface distance (shortest path
//! along head edges, mm) from the centre's anchor, for head vertices and centres alike. An
//! **infinite** (unreachable: another mesh component) or otherwise non-finite distance
//! means **no influence**: its kernel term is 0 for every kernel, the growing ones
//! (multiquadric, thin plate) included. A vertex that reaches no centre moves with the
//! linear term alone (not at all with `poly=none`).
//!
//! Defaults (`rbf`, preset T): Wendland C2, surface distance, `r_mm = 30`, linear term.
//! 30 mm is about the surface distance from the middle of the upper lip round a mouth
//! corner to the lower lip: a wider support reaches across (with the lower lip dropped
//! alone, the upper lip of the scan moves 4.7 % of it at 30 mm and 10.4 % at 40 mm).
//!
//! # Shared anchors
//!
//! Several mask vertices can have the same anchor (one head vertex): two equal centres
//! would make `M` singular. They are merged into one centre whose value is the mean of
//! their displacements, so each member gets the centre's weight divided by the number of
//! members. At such an anchor the interpolant reproduces that mean.
//!
//! # Solving, and the singular-system fallback
//!
//! `M` is inverted by `anchor_system::invert`: LU with partial pivoting in f64 (`M` is not
//! symmetric positive definite in general: the linear term makes it indefinite, and with
//! surface distances `Phi` need not be positive definite even for the positive-definite
//! kernels), accepted up to a 1-norm condition number of 1e12. Otherwise (a singular or
//! ill-conditioned system: fewer than four affinely independent centres with the linear
//! term, a surface `Phi` that happens to be singular, a very wide gaussian or
//! multiquadric: Euclidean at `r_mm = 60` on the MakeHuman head reaches 1e13) the
//! **truncated SVD pseudo-inverse** is used: in the dropped directions the anchors are
//! matched in the least-squares sense instead of exactly, and the weights stay bounded.
//! A system with non-finite entries, or whose SVD does not converge, binds every vertex to
//! nothing (the head stays at rest) rather than panicking.
//!
//! Weights with `|w| < 1e-7` are dropped. Each dropped term changes a displacement by less
//! than `1e-7 |delta|`, so with about a hundred centres the interpolation error at the
//! anchors stays below `1e-5` of the largest control displacement. Rows stay dense in
//! general (`M^-1` is dense even for the compact Wendland kernel); only vertices beyond
//! every centre's support without the linear term get short or empty rows.
//!
//! # Cost
//!
//! Binding: one `(m + 4)^2` inverse (m about 100 on CANDIDE-3), then `n (m + 4) m`
//! multiply-adds in parallel over head vertices: 40-140 ms for the 8.8k-vertex scan and
//! 15-30 ms for the 4.4k-vertex MakeHuman head on two cores (test profile).
//! Deforming: `n x m` terms per frame (8.8k x 104 = 0.9 M for the scan, about 7 MB of
//! weights; a 100k-vertex head holds about 80 MB), an order of magnitude more than the
//! sparse algorithms.
//!
//! # Known weaknesses
//!
//! - **Euclidean distances leak across the mouth**: the upper lip is 0.1-1.5 mm from the
//!   lower lip in space, so the interpolant must jump between two nearly coincident centres;
//!   dropping the jaw drags (for wide global kernels: throws) the upper lip along. On the
//!   shipped heads the mean upper-lip motion is 0.35-3.7 times the lower lip's, whatever
//!   the kernel (tests/core/rbf.rs). Surface distances put the lips 25-60 mm apart.
//! - **Surface distances make `Phi` indefinite**: geodesic distance is not a Euclidean
//!   metric, so even the positive-definite kernels lose definiteness (on the scan, the
//!   gaussian at `r_mm = 30` has 27 negative eigenvalues out of 98, Wendland at 40 has 9).
//!   The system stays solvable and well conditioned (1-norm condition 1e4-1e7), but as
//!   `r_mm` varies an eigenvalue can pass close to zero and the interpolant then rings
//!   between the anchors. The compact Wendland kernel is robust at the default radius
//!   (upper lip moves 1-5 % of the lower lip); the global kernels (gaussian,
//!   multiquadrics, thin plate) on surface distances leak 20-50 % there, erratically in
//!   `r_mm`, and up to several times the lower lip's motion for some radii without the
//!   linear term. That is why the default is Wendland on surface distances.
//! - Global kernels make every control move every reachable vertex, including the back of
//!   the head, and with the linear term an unreachable vertex follows the mask's affine
//!   trend. A wide gaussian or multiquadric with the linear term splits the field between
//!   a large kernel part and a large affine part that cancel on the face but not far from
//!   it: back-of-head vertices can move far more than any control.
//! - Wide global kernels give large weights (Lebesgue constant `max sum |w|` up to 1e4-1e5),
//!   so f32 rounding of the displacements is amplified by as much.
//! - Merged anchors get the mean of their members' displacements, not each one's.

use glam::DVec3;
use nalgebra::DMatrix;
use rayon::prelude::*;

use super::anchor_system::{centres, invert, Centre};
use super::binding::{Binding, LinearTerm};
use super::spec::{AlgoSpec, Kernel, Metric, RbfParams};
use super::Registration;

/// Weights of smaller magnitude are dropped from the rows.
const DROP_BELOW: f32 = 1e-7;
/// Binds the RBF interpolant of the control displacements: one dense row of weights per
/// head vertex (see the module docs).
pub fn bind(reg: &Registration, spec: AlgoSpec, params: &RbfParams) -> Binding {
    let centres = centres(reg);
    let n = reg.vertex_count();
    if centres.is_empty() {
        return Binding::linear(spec, vec![Vec::new(); n]);
    }
    let basis = Basis::new(reg, params, &centres);
    let Some(inverse) = invert(&basis.system()) else {
        return Binding::linear(spec, vec![Vec::new(); n]);
    };
    let size = basis.size();
    // Column k of `inverse` (contiguous, column-major) maps b(P) to the weight of centre k.
    let columns = inverse.as_slice();
    let terms_per_row = centres.iter().map(|c| c.members.len()).sum::<usize>();
    let rows = (0..n as u32)
        .into_par_iter()
        .map_init(
            || vec![0.0f64; size],
            |b, v| {
                basis.row(v, b);
                let mut terms = Vec::with_capacity(terms_per_row);
                for (k, centre) in centres.iter().enumerate() {
                    let column = &columns[k * size..(k + 1) * size];
                    let w: f64 = b.iter().zip(column).map(|(x, y)| x * y).sum();
                    let weight = (w / centre.members.len() as f64) as f32;
                    if weight.abs() >= DROP_BELOW {
                        terms.extend(centre.members.iter().map(|&j| LinearTerm {
                            control: j as u16,
                            weight,
                        }));
                    }
                }
                terms
            },
        )
        .collect();
    Binding::linear(spec, rows)
}

/// `phi(r)` for a distance `r` and scale `r_mm` (both mm). A non-finite distance
/// (unreachable along the surface) has no influence: 0 for every kernel.
fn phi(kernel: Kernel, r: f64, r_mm: f64) -> f64 {
    if !r.is_finite() {
        return 0.0;
    }
    let s = r / r_mm;
    match kernel {
        Kernel::Gaussian => (-s * s).exp(),
        Kernel::Multiquadric => (1.0 + s * s).sqrt(),
        Kernel::InverseMultiquadric => 1.0 / (1.0 + s * s).sqrt(),
        Kernel::ThinPlate => {
            if s > 0.0 {
                s * s * s.ln()
            } else {
                0.0
            }
        }
        Kernel::Wendland => {
            if s < 1.0 {
                (1.0 - s).powi(4) * (4.0 * s + 1.0)
            } else {
                0.0
            }
        }
    }
}

/// Evaluates `b(P)`: the kernel columns, then the polynomial columns.
struct Basis<'a> {
    reg: &'a Registration,
    params: &'a RbfParams,
    centres: &'a [Centre],
    /// Centre positions in mm (Euclidean metric).
    centre_mm: Vec<DVec3>,
    /// Normalized polynomial frame: `x(P) = (P - origin) * inv_extent`, head units.
    origin: DVec3,
    inv_extent: f64,
}

impl<'a> Basis<'a> {
    fn new(reg: &'a Registration, params: &'a RbfParams, centres: &'a [Centre]) -> Basis<'a> {
        let position = |c: &Centre| reg.head.positions[c.vertex as usize].as_dvec3();
        let origin = centres.iter().map(position).sum::<DVec3>() / centres.len() as f64;
        let extent = centres
            .iter()
            .map(|c| position(c).distance(origin))
            .fold(0.0, f64::max);
        let mm = f64::from(reg.mm_per_unit());
        Basis {
            reg,
            params,
            centres,
            centre_mm: centres.iter().map(|c| position(c) * mm).collect(),
            origin,
            inv_extent: if extent > 0.0 && extent.is_finite() {
                1.0 / extent
            } else {
                1.0
            },
        }
    }

    /// Length of `b(P)`, and the size of the system.
    fn size(&self) -> usize {
        self.centres.len() + if self.params.polynomial { 4 } else { 0 }
    }

    /// Writes `b(v)` for head vertex `v` into `out` (`size()` long).
    fn row(&self, v: u32, out: &mut [f64]) {
        let p = self.reg.head.positions[v as usize].as_dvec3();
        let (kernel, r_mm) = (self.params.kernel, f64::from(self.params.r_mm));
        match self.params.metric {
            Metric::Euclidean => {
                let p_mm = p * f64::from(self.reg.mm_per_unit());
                for (o, c) in out.iter_mut().zip(&self.centre_mm) {
                    *o = phi(kernel, p_mm.distance(*c), r_mm);
                }
            }
            Metric::Surface => {
                for (o, c) in out.iter_mut().zip(self.centres) {
                    *o = phi(
                        kernel,
                        f64::from(self.reg.distance_to_control(c.members[0], v)),
                        r_mm,
                    );
                }
            }
        }
        if self.params.polynomial {
            let x = (p - self.origin) * self.inv_extent;
            out[self.centres.len()..].copy_from_slice(&[1.0, x.x, x.y, x.z]);
        }
    }

    /// `M`: rows `b(c_k)` for the centres, then (linear term) `[P^T 0]`.
    fn system(&self) -> DMatrix<f64> {
        let (m, size) = (self.centres.len(), self.size());
        let mut system = DMatrix::zeros(size, size);
        let mut b = vec![0.0; size];
        for (k, centre) in self.centres.iter().enumerate() {
            self.row(centre.vertex, &mut b);
            for (l, &x) in b.iter().enumerate() {
                system[(k, l)] = x;
                if l >= m {
                    system[(l, k)] = x;
                }
            }
        }
        system
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const KERNELS: [Kernel; 5] = [
        Kernel::Gaussian,
        Kernel::Multiquadric,
        Kernel::InverseMultiquadric,
        Kernel::ThinPlate,
        Kernel::Wendland,
    ];

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * (1.0 + b.abs())
    }

    #[test]
    fn kernels_by_hand() {
        // r = R (s = 1).
        assert!(close(phi(Kernel::Gaussian, 30.0, 30.0), (-1.0f64).exp()));
        assert!(close(phi(Kernel::Multiquadric, 30.0, 30.0), 2.0f64.sqrt()));
        assert!(close(phi(Kernel::InverseMultiquadric, 30.0, 30.0), 0.5f64.sqrt()));
        assert!(close(phi(Kernel::ThinPlate, 30.0, 30.0), 0.0));
        assert!(close(phi(Kernel::Wendland, 30.0, 30.0), 0.0));
        // s = 2: e^-4, sqrt 5, 1/sqrt 5, 4 ln 2, outside the support.
        assert!(close(phi(Kernel::Gaussian, 20.0, 10.0), (-4.0f64).exp()));
        assert!(close(phi(Kernel::Multiquadric, 20.0, 10.0), 5.0f64.sqrt()));
        assert!(close(
            phi(Kernel::InverseMultiquadric, 20.0, 10.0),
            1.0 / 5.0f64.sqrt()
        ));
        assert!(close(phi(Kernel::ThinPlate, 20.0, 10.0), 4.0 * 2.0f64.ln()));
        assert!(close(phi(Kernel::Wendland, 20.0, 10.0), 0.0));
        // s = 1/2: Wendland (1/2)^4 * 3 = 0.1875; thin plate (1/4) ln(1/2) < 0.
        assert!(close(phi(Kernel::Wendland, 20.0, 40.0), 0.1875));
        assert!(close(phi(Kernel::ThinPlate, 20.0, 40.0), -0.25 * 2.0f64.ln()));
        // r = 0.
        for (kernel, at_zero) in KERNELS.into_iter().zip([1.0, 1.0, 1.0, 0.0, 1.0]) {
            assert_eq!(phi(kernel, 0.0, 40.0), at_zero, "{kernel:?}");
            assert_eq!(phi(kernel, f64::INFINITY, 40.0), 0.0, "{kernel:?}");
            assert_eq!(phi(kernel, f64::NAN, 40.0), 0.0, "{kernel:?}");
        }
    }

    #[test]
    fn two_centre_gaussian_system_by_hand() {
        // Centres 10 mm apart, R = 10: Phi = [[1, g], [g, 1]] with g = e^-1, inverse
        // [[1, -g], [-g, 1]] / (1 - g^2). Interpolating (1, 0) at the midpoint (phi = e^-1/4
        // to both) gives e^-1/4 (1 - g) / (1 - g^2) = e^-1/4 / (1 + g).
        let g = phi(Kernel::Gaussian, 10.0, 10.0);
        let system = DMatrix::from_row_slice(2, 2, &[1.0, g, g, 1.0]);
        let inverse = invert(&system).unwrap();
        let det = 1.0 - g * g;
        let expected = DMatrix::from_row_slice(2, 2, &[1.0 / det, -g / det, -g / det, 1.0 / det]);
        assert!((&inverse - &expected).amax() < 1e-12);
        let mid = phi(Kernel::Gaussian, 5.0, 10.0);
        let weights = DMatrix::from_row_slice(1, 2, &[mid, mid]) * inverse;
        assert!(close(weights[0], (-0.25f64).exp() / (1.0 + g)));
    }
}
