//! Weight systems over mask triangles: which triangles influence a head vertex and how
//! much (docs/ALGORITHMS.md, "Weight systems"). Distances are surface distances in mm from
//! the vertex to the triangle's nearest corner anchor. A vertex with no triangle in range
//! falls back to its projection triangle, so nothing is dropped.

use super::normalize::normalize;
use super::spec::Weights;
use super::Registration;

/// The triangles influencing head vertex `v` under `weights`, with normalized weights
/// (summing to 1), into `out` (cleared first).
pub fn triangle_weights(reg: &Registration, v: u32, weights: &Weights, out: &mut Vec<(u16, f32)>) {
    out.clear();
    let nearest = reg.projections[v as usize].triangle;
    let falloff = |t: usize, d: f32| -> Option<f32> {
        match *weights {
            Weights::None | Weights::Kshirsagar { .. } => None,
            Weights::Distance { r_mm, local } => (d < r_mm).then(|| 1.0 / (1.0 + d.powf(local))),
            Weights::PlanarBones { r_pct, n } => {
                let r = 0.01 * r_pct * reg.longest_edge_mm[t];
                (d < r).then(|| (0.5 * (1.0 + (std::f32::consts::PI * d / r).cos())).powf(n))
            }
        }
    };
    if !matches!(weights, Weights::None | Weights::Kshirsagar { .. }) {
        for t in 0..reg.mask_triangles().len() {
            let (d, _) = reg.distance_to_triangle(t, v);
            if let Some(w) = falloff(t, d).filter(|w| *w > 0.0) {
                out.push((t as u16, w));
            }
        }
    }
    if out.is_empty() {
        out.push((nearest, 1.0));
        return;
    }
    normalize(out);
}
