//! The lip tint on the shipped heads: the lips (inside the fitted mask's outer lip contour,
//! on the lips' own surface) get the full weight, the face around them and the rest of the
//! head none, and the tinted area is a pair of lips, not a patch of face.

use crate::common::register;

use facewire::animate::lip_tint;
use facewire::mask::{INNER_LIP_MID_LOWER, INNER_LIP_MID_UPPER, LOWER_LIP_INNER, UPPER_LIP_INNER};

/// Area of the triangles whose three corners are at least half lip, mm².
fn lip_area_mm2(reg: &facewire::deform::Registration, weights: &[u8]) -> f32 {
    let mm = reg.mm_per_unit();
    reg.head
        .triangles
        .iter()
        .filter(|t| t.iter().all(|&c| weights[c as usize] >= 128))
        .map(|t| {
            let [a, b, c] = t.map(|v| reg.head.positions[v as usize]);
            (b - a).cross(c - a).length() / 2.0 * mm * mm
        })
        .sum()
}

#[test]
fn the_shipped_heads_lips_and_nothing_else_are_tinted() {
    for name in ["lee_perry_smith_head", "makehuman_head", "ict_head"] {
        let reg = register(name);
        let weights = lip_tint(&reg);
        assert_eq!(weights.len(), reg.head.positions.len(), "{name}");
        let anchor = |j: usize| reg.anchors.vertex[j] as usize;
        // The middle of each lip, on the inner contour: lip through and through.
        for j in [INNER_LIP_MID_UPPER, INNER_LIP_MID_LOWER] {
            assert_eq!(weights[anchor(j)], 255, "{name}: mask vertex {j}");
        }
        // Nothing is lip that is further from the mouth than the mouth is wide (the outer
        // lip corners apart): the inside of the cheeks behind the corners may be, the rest
        // of the face and head not.
        let mm = reg.mm_per_unit();
        let width = reg.head.positions[anchor(31)].distance(reg.head.positions[anchor(64)]);
        let mouth = (reg.head.positions[anchor(INNER_LIP_MID_UPPER)]
            + reg.head.positions[anchor(INNER_LIP_MID_LOWER)])
            / 2.0;
        let far = reg
            .head
            .positions
            .iter()
            .zip(&weights)
            .filter(|(p, &w)| w > 0 && p.distance(mouth) > width)
            .count();
        assert_eq!(
            far,
            0,
            "{name}: {far} vertices further than {:.0} mm from the mouth are tinted",
            width * mm
        );
        // Every lip anchor is at least partly lip (the outer contour's lie on the edge).
        // The inner contour, between the corners, is well inside the outer one. (The outer
        // contour's own anchors lie on the edge, within a triangle of it either way.)
        for j in UPPER_LIP_INNER.into_iter().chain(LOWER_LIP_INNER) {
            assert!(
                weights[anchor(j)] >= 192,
                "{name}: mask vertex {j}: {}",
                weights[anchor(j)]
            );
        }
        let area = lip_area_mm2(&reg, &weights);
        assert!((300.0..2500.0).contains(&area), "{name}: {area:.0} mm² of lip");
        println!("{name}: {area:.0} mm² of lip");
    }
}
