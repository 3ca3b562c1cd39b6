//! `renato1` (thesis N, the legacy tool): inside a mask triangle the vertex moves by the
//! barycentric blend of its corners' displacements, `d = sum mu_k delta_k`; outside, by the
//! same rule on the nearest reachable triangle with `|mu_k|`, not normalized. The absolute
//! values make the weights sum to more than 1 far from the triangle, so it overshoots: kept
//! as the thesis measured it.

use rayon::prelude::*;

use super::binding::{Binding, LinearTerm};
use super::spec::AlgoSpec;
use super::Registration;

pub fn bind(reg: &Registration, spec: AlgoSpec) -> Binding {
    let rows = (0..reg.vertex_count())
        .into_par_iter()
        .map(|v| {
            let projection = reg.projections[v];
            let corners = reg.mask_triangles()[projection.triangle as usize];
            corners
                .iter()
                .zip(projection.bary)
                .map(|(&j, mu)| LinearTerm {
                    control: j as u16,
                    weight: if projection.inside { mu } else { mu.abs() },
                })
                .collect()
        })
        .collect();
    Binding::linear(spec, rows)
}
