//! `planar_bones` (thesis I-M; Sanchez Lorenzo & Maddock 2003): each mask triangle is a
//! "bone" whose influence on a point depends on where the point lies relative to it
//! (thesis eq. 2.8-2.14), classified by the Voronoi regions of the triangle in its plane:
//!
//! - **R_A**, foot point inside: the triangle's affine basis `(B-A, C-A, n)` (eq. 2.8).
//! - **R_B,i**, nearest to the interior of edge i (V_i -> V_i+1): the edge basis
//!   `(e_i, u_i, n)` with `u_i = e_i x n / |e_i x n|` the edge's outward normal (eq. 2.9-2.10):
//!   the point stretches along the edge and keeps its distance from it.
//! - **R_C,i**, nearest to corner i: the corner basis `(u_i, u_i-1, n)` of the two
//!   outward edge normals; the in-plane offset is carried by it and rescaled to keep its
//!   length (the `D_i(P) / d_i(P)` factor of eq. 2.12-2.14).
//!
//! Rest bases use the rest normal n and moved bases the moved normal n' (the thesis prints
//! n' in both, which cannot be meant). With this classification the three rules agree on
//! every region border, so a single bone is continuous; several bones are blended with a
//! weight system (eq. 2.15-2.16). Every basis is rigid under a rigid motion of the mask.

use super::binding::{Binding, Csr};
use super::bones::{Bone, BoneTerm};
use super::normalize::normalize;
use super::spec::{AlgoSpec, Weights};
use super::{triangle_weights, Registration};
use rayon::prelude::*;

pub fn bind(reg: &Registration, spec: AlgoSpec, weights: &Weights) -> Binding {
    let mask = reg.mask_rest();
    let bones: Vec<Bone> = reg
        .mask_triangles()
        .iter()
        .map(|t| Bone::of(mask[t[0] as usize], mask[t[1] as usize], mask[t[2] as usize]))
        .collect();
    let rows: Vec<Vec<BoneTerm>> = (0..reg.vertex_count() as u32)
        .into_par_iter()
        .map_init(Vec::new, |chosen, v| {
            triangle_weights(reg, v, weights, chosen);
            let p = reg.head.positions[v as usize];
            let mut terms: Vec<BoneTerm> = chosen
                .iter()
                .filter_map(|&(t, weight)| {
                    let (region, coords, offset_length) = bones[t as usize].bind(p)?;
                    Some(BoneTerm {
                        triangle: t,
                        basis: u32::from(t) * 7 + region.slot() as u32,
                        region,
                        coords,
                        offset_length,
                        weight,
                    })
                })
                .collect();
            normalize(&mut terms);
            terms
        })
        .collect();
    let n = rows.len();
    Binding::new(spec, Csr::empty(n), Csr::empty(n), Csr::from_rows(rows))
}
