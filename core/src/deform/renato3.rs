//! `renato3` (thesis P; with weights Q, R): the barycentric rule of the nearest triangle
//! everywhere, `d = sum mu_k delta_k` with the foot point's barycentrics even when they are
//! negative (linear extrapolation), blended over the triangles a weight system selects.

use rayon::prelude::*;

use super::binding::{Binding, LinearTerm};
use super::projection::barycentric;
use super::spec::{AlgoSpec, Weights};
use super::{triangle_weights, Registration};

pub fn bind(reg: &Registration, spec: AlgoSpec, weights: &Weights) -> Binding {
    let mask = reg.mask_rest();
    let rows = (0..reg.vertex_count() as u32)
        .into_par_iter()
        .map_init(Vec::new, |chosen, v| {
            triangle_weights(reg, v, weights, chosen);
            let p = reg.head.positions[v as usize];
            let mut terms: Vec<LinearTerm> = Vec::with_capacity(3 * chosen.len());
            for &(t, w) in chosen.iter() {
                let corners = reg.mask_triangles()[t as usize];
                let [a, b, c] = corners.map(|j| mask[j as usize]);
                if let Some((bary, _)) = barycentric(p, a, b, c) {
                    for (&j, mu) in corners.iter().zip(bary) {
                        match terms.iter_mut().find(|term| term.control == j as u16) {
                            Some(term) => term.weight += w * mu,
                            None => terms.push(LinearTerm {
                                control: j as u16,
                                weight: w * mu,
                            }),
                        }
                    }
                }
            }
            terms
        })
        .collect();
    Binding::linear(spec, rows)
}
