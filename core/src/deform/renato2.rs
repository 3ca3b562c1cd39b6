//! `renato2` (thesis O, the legacy tool's method): inside a mask triangle the barycentric
//! blend `d = sum mu_k delta_k`; outside, eq. 1.2 over the nearest reachable triangle's
//! corners, `d = sum_k delta_k exp(-|P - C_k| / alpha^2)`, |P - C_k| in mask units.

use rayon::prelude::*;

use super::binding::{Binding, LinearTerm};
use super::spec::AlgoSpec;
use super::{legacy_falloff, Registration};

pub fn bind(reg: &Registration, spec: AlgoSpec, alpha: f32) -> Binding {
    let mask_unit = reg.fitted.fit.pose.scale.x;
    let rows = (0..reg.vertex_count())
        .into_par_iter()
        .map(|v| {
            let projection = reg.projections[v];
            let p = reg.head.positions[v];
            let corners = reg.mask_triangles()[projection.triangle as usize];
            corners
                .iter()
                .zip(projection.bary)
                .map(|(&j, mu)| LinearTerm {
                    control: j as u16,
                    weight: if projection.inside {
                        mu
                    } else {
                        legacy_falloff(p.distance(reg.mask_rest()[j as usize]) / mask_unit, alpha)
                    },
                })
                .collect()
        })
        .collect();
    Binding::linear(spec, rows)
}
