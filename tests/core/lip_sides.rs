//! Each lip of the mask is anchored on the same lip of the head, on heads whose fitted
//! mask does not follow their lips closely. The ICT identities share one numbering, so
//! the generic ICT head's lips (split where its mask lies on them) name every identity's
//! upper and lower lip vertices: a ground truth for where each mask lip vertex may anchor.

use facewire::fit::{anchor_mask, FitFile, FittedMask};
use facewire::head::{Head, SurfaceDistance};
use facewire::mask::{Mask, LOWER_LIP, LOWER_LIP_OUTER, UPPER_LIP, UPPER_LIP_OUTER};
use facewire::population::{self, Maker};

use crate::common::data;

/// The generic ICT head's lips: each vertex within 40 mm along the surface of the outer
/// lip contours' anchors, on the side it is nearer (true: upper).
fn generic_lips() -> Vec<Option<bool>> {
    let head = Head::load(&data("heads/ict_head.obj")).unwrap();
    let mask = Mask::candide3();
    let text = std::fs::read_to_string(data("heads/ict_head.fit.toml")).unwrap();
    let fit = FitFile::parse("ict_head.fit.toml", &text)
        .unwrap()
        .resolve("ict_head.fit.toml", &mask)
        .unwrap();
    let mm_per_unit = fit.mm_per_unit;
    let fitted = FittedMask::new(mask, fit);
    let anchors = anchor_mask(&head, &fitted.neutral, mm_per_unit);
    let from = |lip: &[usize]| {
        let mut distance = SurfaceDistance::new(head.positions.len());
        let seeds: Vec<(u32, f32)> = lip.iter().map(|&j| (anchors.vertex[j], 0.0)).collect();
        distance.run(&head.topology, &seeds, 40.0 / mm_per_unit);
        distance
    };
    let (upper, lower) = (from(&UPPER_LIP_OUTER), from(&LOWER_LIP_OUTER));
    (0..head.positions.len() as u32)
        .map(|v| {
            let (u, l) = (upper.distance(v), lower.distance(v));
            (u.is_finite() || l.is_finite()).then_some(u < l)
        })
        .collect()
}

#[test]
fn lip_vertices_anchor_on_their_own_lip_on_every_identity() {
    let lips = generic_lips();
    let maker = Maker::new(&crate::common::repo_path("data")).unwrap();
    let mask = Mask::candide3();
    let mut wrong = Vec::new();
    let mut identities = 0;
    for spec in population::whole_heads() {
        let member = maker.make(&spec).unwrap();
        if member.head.positions.len() != lips.len() {
            continue;
        }
        identities += 1;
        let fit = member
            .landmark_fit
            .clone()
            .expect("a whole head has its landmark fit");
        let fitted = FittedMask::new(mask.clone(), fit);
        let anchors = anchor_mask(&member.head, &fitted.neutral, member.mm_per_unit);
        for (lip, upper) in [(&UPPER_LIP[..], true), (&LOWER_LIP[..], false)] {
            for &j in lip {
                let anchor = anchors.vertex[j];
                if lips[anchor as usize] != Some(upper) {
                    wrong.push(format!(
                        "{}: mask {j} on head vertex {anchor}",
                        member.spec.name()
                    ));
                }
            }
        }
    }
    assert!(identities >= 50, "{identities} identities");
    assert!(wrong.is_empty(), "anchored on the other lip: {wrong:#?}");
}
