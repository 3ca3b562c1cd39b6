//! The lip seam: the head triangles that join the upper lip to the lower lip, where the
//! mouth opens (docs/ALGORITHMS.md, "Biharmonic").
//!
//! Some heads join their lips along the contact line (ICT identities made from the shipped
//! identity model, seed 4 among them; the shipped heads join theirs only deep in the mouth,
//! or not at all, and have no seam): an upper-lip vertex and the lower-lip vertex facing it
//! share an edge under a millimetre long. The inner-lip controls anchor on exactly such a
//! pair, and as the jaw drops one anchor stays while its neighbour moves 10 mm and more. A
//! smooth field through both carries that slope on past the still anchor: the upper lip
//! bulges up by several millimetres between its inner and outer contours and folds. The
//! lips are two bodies that touch, so the energy is left to each: a triangle with a corner
//! on each lip is left out of it (it stretches as the mouth opens, as it must), and neither
//! lip's field runs on into the other's.
//!
//! Which lip a vertex belongs to is which lip control's anchor is nearest it along the
//! surface: the upper lip's (`mask::UPPER_LIP`), the lower lip's (`mask::LOWER_LIP`) or a
//! mouth corner's (neither; the corners keep the lips joined at their ends). A vertex
//! every one of whose triangles would be left out is counted with neither lip, so that
//! every vertex keeps some of the energy.

use super::Registration;
use crate::mask::{LIP_VERTICES, LOWER_LIP, UPPER_LIP};

/// Which lip a head vertex belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Lip {
    Upper,
    Lower,
    Neither,
}

/// The head's triangles without the seam's.
pub fn without_seam(reg: &Registration) -> Vec<[u32; 3]> {
    let triangles = &reg.head.triangles;
    let mut lips: Vec<Lip> = (0..reg.vertex_count() as u32)
        .map(|v| nearest_lip(reg, v))
        .collect();
    let joins = |lips: &[Lip], t: &[u32; 3]| {
        let has = |lip| t.iter().any(|&v| lips[v as usize] == lip);
        has(Lip::Upper) && has(Lip::Lower)
    };
    // A vertex left with no triangle joins neither lip, which keeps its triangles; each
    // round only takes lips away, so this ends.
    loop {
        let mut kept = vec![false; lips.len()];
        for t in triangles.iter().filter(|t| !joins(&lips, t)) {
            for &v in t {
                kept[v as usize] = true;
            }
        }
        let mut changed = false;
        for (lip, kept) in lips.iter_mut().zip(kept) {
            if !kept && *lip != Lip::Neither {
                *lip = Lip::Neither;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    triangles.iter().copied().filter(|t| !joins(&lips, t)).collect()
}

/// The lip of the lip control whose anchor is nearest `v` along the surface; `Neither`
/// for a mouth corner's or when no lip anchor reaches it.
fn nearest_lip(reg: &Registration, v: u32) -> Lip {
    let nearest = LIP_VERTICES
        .iter()
        .map(|&j| (j, reg.distance_to_control(j as u32, v)))
        .filter(|(_, d)| d.is_finite())
        .min_by(|a, b| a.1.total_cmp(&b.1));
    match nearest {
        Some((j, _)) if UPPER_LIP.contains(&j) => Lip::Upper,
        Some((j, _)) if LOWER_LIP.contains(&j) => Lip::Lower,
        _ => Lip::Neither,
    }
}
