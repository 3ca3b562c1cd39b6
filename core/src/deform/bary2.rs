//! `bary2` (thesis B; with weights C, D = Singh's surface-oriented FFD): every head vertex
//! is expressed in the local basis `(B - A, C - A, n)` of its projection triangle, or of
//! every triangle the weight system selects, and follows those bases. Rigid motions of
//! the mask move the head rigidly; outside the mask the bases extrapolate.

use rayon::prelude::*;

use super::binding::{Binding, Csr, TriangleTerm};
use super::normalize::normalize;
use super::spec::{AlgoSpec, Weights};
use super::triangle_basis::TriangleBasis;
use super::{triangle_weights, Registration};

pub fn bind(reg: &Registration, spec: AlgoSpec, weights: &Weights) -> Binding {
    let rows: Vec<Vec<TriangleTerm>> = (0..reg.vertex_count() as u32)
        .into_par_iter()
        .map_init(Vec::new, |chosen, v| {
            triangle_weights(reg, v, weights, chosen);
            triangle_terms(reg, v, chosen)
        })
        .collect();
    Binding::new(
        spec,
        Csr::empty(rows.len()),
        Csr::from_rows(rows),
        Csr::empty(reg.vertex_count()),
    )
}

/// Frame terms of head vertex `v` for weighted triangles; degenerate triangles are skipped
/// and the remaining weights renormalized.
pub(super) fn triangle_terms(reg: &Registration, v: u32, chosen: &[(u16, f32)]) -> Vec<TriangleTerm> {
    let p = reg.head.positions[v as usize];
    let mask = reg.mask_rest();
    let mut terms: Vec<TriangleTerm> = chosen
        .iter()
        .filter_map(|&(t, weight)| {
            let [a, b, c] = reg.mask_triangles()[t as usize].map(|j| mask[j as usize]);
            let coords = TriangleBasis::of(a, b, c).coords(p)?;
            Some(TriangleTerm {
                triangle: t,
                coords,
                weight,
            })
        })
        .collect();
    normalize(&mut terms);
    terms
}
