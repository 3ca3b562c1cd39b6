//! Smoothing the default's field over the lips (docs/ALGORITHMS.md, "Biharmonic", "Over
//! the lips").
//!
//! The biharmonic field passes exactly through every anchor. Around the mouth the anchors
//! crowd: the outer and inner mouth corners and the two lip contours lie a few millimetres
//! apart, and where a head's mouth corner makes a crease at rest, the field's steep
//! sub-millimetre slopes between them turn the crease's small triangles past 60 degrees as
//! the jaw drops (docs/METRICS.md section 11: most ICT identities, none of the shipped
//! heads). A lip vertex's displacement is therefore replaced by the mean of its
//! neighbours' within `r` along the surface, weighted `(1 - (s / r)^2)^2`, `r` a share of
//! the mouth's width (the head's own length, not millimetres). Its full strength holds
//! within `r` of a lip anchor and fades as `(1 - ((s - r) / r)^2)^2` to nothing at `2 r`,
//! so that the field stays continuous where the smoothing ends.
//!
//! The mean is over the head without the lip seam ([`without_seam`]): the upper lip is
//! never averaged with the lower lip that touches it. It is linear in the displacements,
//! so it is folded into the bound rows once, each cut back to the field's `k` terms:
//! deforming stays the same sparse gather at the same cost. The lip anchors move with
//! their neighbours' mean too, so they follow their controls within a fraction of a
//! millimetre rather than exactly (the price of the smooth corner; `smooth_lips=0` turns
//! it off).

use rayon::prelude::*;

use super::binding::LinearTerm;
use super::lip_seam::without_seam;
use super::row_merge::merge_by_control;
use super::Registration;
use crate::head::{SurfaceDistance, Topology};
use crate::mask::LIP_VERTICES;

/// `rows` (one per head vertex, as bound) with each vertex near the lips replaced by the
/// mean of its neighbours' rows within `share` of the mouth's width (see the module docs),
/// each keeping its `k` largest terms (corrected to their full sum, as the field's own
/// rows are, so that deforming costs what it did); unchanged for `share` 0 or a head whose
/// mouth has no width.
pub fn smooth_over_lips(
    reg: &Registration,
    rows: Vec<Vec<LinearTerm>>,
    share: f32,
    k: usize,
) -> Vec<Vec<LinearTerm>> {
    let radius = share * reg.mouth_width();
    if !(radius > 0.0 && radius.is_finite()) {
        return rows;
    }
    let topology = Topology::new(&reg.head.positions, &without_seam(reg));
    let vertex_count = reg.vertex_count();
    let lip_anchors: Vec<(u32, f32)> = LIP_VERTICES
        .iter()
        .map(|&j| (reg.anchors.vertex[j], 0.0))
        .collect();
    let mut zone = SurfaceDistance::new(vertex_count);
    zone.run(&topology, &lip_anchors, 2.0 * radius);
    let strength: Vec<(u32, f32)> = zone
        .reached()
        .iter()
        .map(|&v| (v, strength_at(zone.distance(v), radius)))
        .filter(|&(_, strength)| strength > 0.0)
        .collect();
    let smoothed: Vec<(u32, Vec<LinearTerm>)> = strength
        .par_iter()
        .map_init(
            || (SurfaceDistance::new(vertex_count), Vec::new()),
            |(search, merged), &(v, strength)| {
                merged.clear();
                search.run(&topology, &[(v, 0.0)], radius);
                let neighbours = search.reached();
                let kernel = |u: u32| {
                    let s = search.distance(u) / radius;
                    (1.0 - s * s).powi(2)
                };
                let total: f32 = neighbours.iter().map(|&u| kernel(u)).sum();
                for &u in neighbours {
                    let weight = strength * kernel(u) / total;
                    merged.extend(rows[u as usize].iter().map(|t| LinearTerm {
                        control: t.control,
                        weight: weight * t.weight,
                    }));
                }
                merged.extend(rows[v as usize].iter().map(|t| LinearTerm {
                    control: t.control,
                    weight: (1.0 - strength) * t.weight,
                }));
                (v, merge_by_control(merged, k))
            },
        )
        .collect();
    let mut rows = rows;
    for (v, row) in smoothed {
        rows[v as usize] = row;
    }
    rows
}

/// How much of the mean a vertex `distance` (head units) from the nearest lip anchor takes:
/// 1 within `radius`, fading smoothly to 0 at twice it.
fn strength_at(distance: f32, radius: f32) -> f32 {
    let beyond = ((distance - radius) / radius).clamp(0.0, 1.0);
    (1.0 - beyond * beyond).powi(2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_strength_is_full_near_the_lips_and_fades_to_nothing_at_twice_the_radius() {
        assert_eq!(strength_at(0.0, 2.0), 1.0);
        assert_eq!(strength_at(2.0, 2.0), 1.0);
        // Halfway through the fade: (1 - 1/4)^2 = 9/16.
        assert_eq!(strength_at(3.0, 2.0), 0.5625);
        assert_eq!(strength_at(4.0, 2.0), 0.0);
        assert_eq!(strength_at(9.0, 2.0), 0.0);
    }
}
