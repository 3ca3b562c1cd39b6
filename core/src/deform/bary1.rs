//! `bary1` (thesis A): a vertex inside a mask triangle follows that triangle's local basis;
//! a vertex outside every triangle moves by eq. 1.2 over its 3 nearest reachable controls,
//! `d = sum_k delta_k exp(-|P - C_k| / alpha^2)` (|P - C_k| in mask units; not normalized,
//! as in the legacy tool).

use rayon::prelude::*;

use super::bary2::triangle_terms;
use super::binding::{Binding, Csr, LinearTerm, TriangleTerm};
use super::point_distance::nearest_controls;
use super::spec::AlgoSpec;
use super::{legacy_falloff, Registration};

pub fn bind(reg: &Registration, spec: AlgoSpec, alpha: f32) -> Binding {
    let per_vertex: Vec<(Vec<LinearTerm>, Vec<TriangleTerm>)> = (0..reg.vertex_count() as u32)
        .into_par_iter()
        .map(|v| {
            let projection = reg.projections[v as usize];
            if projection.inside {
                return (Vec::new(), triangle_terms(reg, v, &[(projection.triangle, 1.0)]));
            }
            let p = reg.head.positions[v as usize];
            let mask_units = reg.fitted.fit.pose.scale.x;
            let linear = nearest_controls(reg, v, Some(3))
                .into_iter()
                .map(|(j, _)| LinearTerm {
                    control: j as u16,
                    weight: legacy_falloff(p.distance(reg.mask_rest()[j as usize]) / mask_units, alpha),
                })
                .collect();
            (linear, Vec::new())
        })
        .collect();
    let (linear, triangle_terms): (Vec<_>, Vec<_>) = per_vertex.into_iter().unzip();
    let n = linear.len();
    Binding::new(
        spec,
        Csr::from_rows(linear),
        Csr::from_rows(triangle_terms),
        Csr::empty(n),
    )
}
