//! Which of the outer lip contours' plain anchors lie on their own lip. The lips are told
//! apart along the surface from those anchors ([`super::anchor_mask`]), which holds only
//! while each lies on its own lip. A mask whose lips do not follow the head's (a fit from
//! landmarks that hold only the mouth's corners, on a mouth that curves) can put a lower
//! contour vertex nearest the upper lip's inside; the lower lip then grows from there into
//! the upper lip, and the jaw drags it down (ICT identity 32's landmark fit: 1,230 lip
//! triangle-frames past 60 degrees on the syllable stream, where the lower lip's middle
//! took an upper-lip vertex; identity 4's: 493, its lower contour's sides).
//!
//! Along the surface the upper lip is nearer the nose tip than the chin, and the lower lip
//! nearer the chin, on every head: where the lips are separate surfaces the way from one
//! lip to the other's landmark goes round a mouth corner, and where they are one surface
//! (a scan of a closed mouth) the fissure still lies between the two. On the population's
//! 50 ICT identities, MakeHuman and the scan, with their landmark fits, every contour anchor
//! on its own lip is nearer its own landmark (the ratio of the two distances 0.28-0.96),
//! and the three on the other lip are not (1.32-2.10). An anchor that is not is left out of
//! its lip's seeds, unless that would leave the lip none.

use crate::head::{Head, SurfaceDistance};

/// `upper` and `lower` (head vertices: the outer contours' anchors) without those nearer,
/// along the surface, the other lip's landmark (`nose` for the upper lip, `chin` for the
/// lower) than their own. An anchor neither landmark reaches is kept.
pub fn on_their_own_lip(
    head: &Head,
    upper: &[u32],
    lower: &[u32],
    nose: u32,
    chin: u32,
) -> (Vec<u32>, Vec<u32>) {
    let from = |landmark: u32| {
        let mut distance = SurfaceDistance::new(head.positions.len());
        distance.run(&head.topology, &[(landmark, 0.0)], f32::INFINITY);
        distance
    };
    let (from_nose, from_chin) = (from(nose), from(chin));
    let kept = |seeds: &[u32], own: &SurfaceDistance, other: &SurfaceDistance| -> Vec<u32> {
        let kept: Vec<u32> = seeds
            .iter()
            .copied()
            .filter(|&v| other.distance(v) >= own.distance(v))
            .collect();
        if kept.is_empty() {
            seeds.to_vec()
        } else {
            kept
        }
    };
    (
        kept(upper, &from_nose, &from_chin),
        kept(lower, &from_chin, &from_nose),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A strip of 10 x 2 vertices along x, 1 apart: vertex `2 i` at (i, 0, 0).
    fn strip() -> Head {
        let positions = (0..10)
            .flat_map(|i| [Vec3::new(i as f32, 0.0, 0.0), Vec3::new(i as f32, 1.0, 0.0)])
            .collect();
        let triangles = (0..9u32)
            .flat_map(|i| {
                let (a, b, c, d) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
                [[a, c, b], [b, c, d]]
            })
            .collect();
        Head::new("strip", positions, triangles)
    }

    #[test]
    fn an_anchor_nearer_the_other_lips_landmark_is_left_out_but_never_the_last() {
        let head = strip();
        // The nose at x = 0, the chin at x = 9.
        let (nose, chin) = (0, 18);
        // Upper anchors at x = 2 and 7 (nearer the chin), lower ones at x = 8 and 3.
        let (upper, lower) = on_their_own_lip(&head, &[4, 14], &[16, 6], nose, chin);
        assert_eq!((upper, lower), (vec![4], vec![16]));
        // A lip whose every anchor is nearer the other landmark keeps them all.
        let (upper, lower) = on_their_own_lip(&head, &[14, 16], &[16], nose, chin);
        assert_eq!((upper, lower), (vec![14, 16], vec![16]));
        // Halfway (x = 4.5 is no vertex; x = 4 is nearer the nose) stays upper.
        let (upper, _) = on_their_own_lip(&head, &[8], &[16], nose, chin);
        assert_eq!(upper, [8]);
    }
}
