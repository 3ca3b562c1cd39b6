//! `point_distance` (thesis G: k = 3, H: k = all): the vertex moves by a normalized blend of
//! the control displacements, weighted by Singh's `1 / (1 + d^local)` on the surface
//! distance d (mm) to each control's anchor.
//!
//! As the thesis wrote it (`interpolate=false`, presets G and H) it does not interpolate:
//! the own weight is 1 at d = 0 but the other controls keep `1 / (1 + d^2)`, so at an
//! anchor whose neighbours are a few millimetres away (the lips, the mouth corners) a
//! control's motion is averaged with theirs, and with k = all every control pulls a little
//! (the "squashed mouth" the thesis saw).
//!
//! `interpolate=true` (the default; preset U) keeps the same sparse weights `u_j(P)` but
//! blends corrected values `s_j` instead of the displacements: `d(P) = sum_j u_j(P) s_j`,
//! with `s` chosen so that `d(anchor_i) = delta_i` for every control. With `A` the weights
//! at the anchors (`A_ij = u_j(anchor_i)`, controls sharing an anchor merged as one),
//! `s = A^-1 delta`. `A`'s rows sum to 1, so a translation `delta = t` gives `s = t` and
//! the head still translates rigidly. `A^-1` is dense (about 100 x 100 on CANDIDE-3) and
//! applied once per frame; the per-vertex rows stay k terms long.

use nalgebra::DMatrix;
use rayon::prelude::*;

use super::anchor_system::{centres, invert};
use super::binding::{Binding, LinearTerm, SourceMap};
use super::normalize::normalize;
use super::spec::AlgoSpec;
use super::Registration;

pub fn bind(reg: &Registration, spec: AlgoSpec, k: Option<u32>, local: f32, interpolate: bool) -> Binding {
    let rows: Vec<Vec<LinearTerm>> = (0..reg.vertex_count() as u32)
        .into_par_iter()
        .map(|v| {
            let chosen = nearest_controls(reg, v, k.map(|k| k as usize));
            let mut terms: Vec<LinearTerm> = chosen
                .iter()
                .map(|&(j, d)| LinearTerm {
                    control: j as u16,
                    weight: 1.0 / (1.0 + d.powf(local)),
                })
                .collect();
            normalize(&mut terms);
            terms
        })
        .collect();
    let sources = interpolate.then(|| anchor_sources(reg, &rows)).flatten();
    let binding = Binding::linear(spec, rows);
    match sources {
        Some(sources) => binding.with_sources(sources),
        None => binding,
    }
}

/// `s = A^-1 delta` as a map over the controls (see the module docs). Controls sharing an
/// anchor form one group whose value is the mean of their displacements; every member
/// gets the group's source. `None` when `A` cannot be inverted even approximately (then
/// the binding blends the displacements themselves).
fn anchor_sources(reg: &Registration, rows: &[Vec<LinearTerm>]) -> Option<SourceMap> {
    let groups = centres(reg);
    let mut group_of = vec![usize::MAX; reg.mask_rest().len()];
    for (g, centre) in groups.iter().enumerate() {
        for &j in &centre.members {
            group_of[j as usize] = g;
        }
    }
    let mut weights_at_anchors = DMatrix::<f64>::zeros(groups.len(), groups.len());
    for (g, centre) in groups.iter().enumerate() {
        for term in &rows[centre.vertex as usize] {
            weights_at_anchors[(g, group_of[term.control as usize])] += f64::from(term.weight);
        }
    }
    let inverse = invert(&weights_at_anchors)?;
    let controls = reg.controls.iter().map(|&j| j as u16).collect();
    Some(SourceMap::new(controls, |row, column| {
        let gj = group_of[reg.controls[row] as usize];
        let gk = group_of[reg.controls[column] as usize];
        (inverse[(gj, gk)] / groups[gk].members.len() as f64) as f32
    }))
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
