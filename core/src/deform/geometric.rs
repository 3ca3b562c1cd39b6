//! `geometric` (thesis E, F): feature-point interpolation in the thesis's form. Without
//! weights the vertex moves rigidly with one feature point: the corner of its projection
//! triangle nearest along the surface. With `weights=kshirsagar` every feature point within
//! `r_mm` contributes with Kshirsagar's `W = sin(pi/2 (1 - d/r))` and eq. 5's `1/d^2`
//! blend (exact at a feature point); with `weights=distance`, Singh's `1 / (1 + d^local)`.
//! Distances are surface distances in mm; no feature point in range falls back to the
//! rigid rule.

use rayon::prelude::*;

use super::binding::{Binding, LinearTerm};
use super::normalize::normalize;
use super::spec::{AlgoSpec, Weights};
use super::Registration;

pub fn bind(reg: &Registration, spec: AlgoSpec, weights: &Weights) -> Binding {
    let rows = (0..reg.vertex_count() as u32)
        .into_par_iter()
        .map(|v| {
            let blended = match *weights {
                Weights::Kshirsagar { r_mm } => blend(reg, v, r_mm, |d| {
                    if d == 0.0 {
                        f32::INFINITY
                    } else {
                        (std::f32::consts::FRAC_PI_2 * (1.0 - d / r_mm)).sin() / (d * d)
                    }
                }),
                Weights::Distance { r_mm, local } => blend(reg, v, r_mm, |d| 1.0 / (1.0 + d.powf(local))),
                Weights::None | Weights::PlanarBones { .. } => Vec::new(),
            };
            if !blended.is_empty() {
                return blended;
            }
            let projection = reg.projections[v as usize];
            let (_, corner) = reg.distance_to_triangle(projection.triangle as usize, v);
            vec![LinearTerm {
                control: corner as u16,
                weight: 1.0,
            }]
        })
        .collect();
    Binding::linear(spec, rows)
}

/// Normalized weights `falloff(d)` over the feature points within `r_mm`; an infinite
/// weight (the vertex is a feature point) takes everything.
fn blend(reg: &Registration, v: u32, r_mm: f32, falloff: impl Fn(f32) -> f32) -> Vec<LinearTerm> {
    let near: Vec<(u32, f32)> = reg
        .controls
        .iter()
        .map(|&j| (j, reg.distance_to_control(j, v)))
        .filter(|&(_, d)| d < r_mm)
        .map(|(j, d)| (j, falloff(d)))
        .filter(|&(_, w)| w > 0.0)
        .collect();
    if let Some(&(j, _)) = near.iter().find(|(_, w)| w.is_infinite()) {
        return vec![LinearTerm {
            control: j as u16,
            weight: 1.0,
        }];
    }
    let mut terms: Vec<LinearTerm> = near
        .into_iter()
        .map(|(j, weight)| LinearTerm {
            control: j as u16,
            weight,
        })
        .collect();
    normalize(&mut terms);
    terms
}
