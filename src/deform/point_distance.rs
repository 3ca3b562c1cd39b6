//! `point_distance` (thesis G: k = 3, H: k = all): the vertex moves by a normalized blend of
//! the control displacements, weighted by Singh's `1 / (1 + d^local)` on the surface
//! distance d (mm) to each control's anchor. Not interpolating: at an anchor the other
//! controls still pull (the "squashed mouth" the thesis saw with k = all).

use rayon::prelude::*;

use super::binding::{Binding, LinearTerm};
use super::spec::AlgoSpec;
use super::Registration;

pub fn bind(reg: &Registration, spec: AlgoSpec, k: Option<u32>, local: f32) -> Binding {
    let rows: Vec<Vec<LinearTerm>> = (0..reg.vertex_count() as u32)
        .into_par_iter()
        .map(|v| {
            let chosen = nearest_controls(reg, v, k.map(|k| k as usize));
            let weights: Vec<f32> = chosen.iter().map(|&(_, d)| 1.0 / (1.0 + d.powf(local))).collect();
            let total: f32 = weights.iter().sum();
            chosen
                .iter()
                .zip(weights)
                .map(|(&(j, _), w)| LinearTerm {
                    control: j as u16,
                    weight: w / total,
                })
                .collect()
        })
        .collect();
    Binding::linear(spec, rows)
}

/// The `k` (or all, for `None`) controls nearest to head vertex `v` along the surface, with
/// their distances in mm, nearest first; ties by Euclidean distance. Only reachable
/// controls count; a vertex that reaches none (a separate mesh component) uses Euclidean
/// distances instead.
pub(super) fn nearest_controls(reg: &Registration, v: u32, k: Option<usize>) -> Vec<(u32, f32)> {
    let p = reg.head.positions[v as usize];
    let euclid_mm = |j: u32| p.distance(reg.mask_rest()[j as usize]) * reg.mm_per_unit();
    let mut found: Vec<(u32, f32, f32)> = reg
        .controls
        .iter()
        .map(|&j| (j, reg.distance_to_control(j, v), euclid_mm(j)))
        .filter(|(_, d, _)| d.is_finite())
        .collect();
    if found.is_empty() {
        found = reg
            .controls
            .iter()
            .map(|&j| (j, euclid_mm(j), euclid_mm(j)))
            .collect();
    }
    found.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.2.total_cmp(&b.2)));
    if let Some(k) = k {
        found.truncate(k);
    }
    found.into_iter().map(|(j, d, _)| (j, d)).collect()
}
