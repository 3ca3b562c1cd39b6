//! Anchors: the head vertex each fitted mask vertex is tied to (the thesis's
//! "projection"; Kshirsagar's feature points).
//!
//! Plain nearest-vertex fails on the lips: the neutral mask's inner-lip vertices coincide
//! in pairs (40 = 87, 81 = 83, 82 = 84) while the head's lips are separate surfaces, so an
//! upper and a lower mask vertex would share one anchor. Each lip vertex is therefore
//! anchored on its own lip: head vertices near the mouth are split by whether they are
//! closer *along the surface* to the upper or the lower outer lip contour, and upper-lip
//! mask vertices only take upper-lip head vertices (and so on). The inner-lip vertices
//! further keep to the lips' contact line: head vertices of one lip within
//! [`LIP_CONTACT_MM`] of the other lip, which is where the mouth opens; the outer-lip
//! vertices keep off it.

use glam::Vec3;

use super::lip_seeds::on_their_own_lip;
use crate::head::{Head, SurfaceDistance, VertexIndex};
use crate::mask::{
    CHIN, LOWER_LIP, LOWER_LIP_INNER, LOWER_LIP_OUTER, NOSE_TIP, UPPER_LIP, UPPER_LIP_INNER, UPPER_LIP_OUTER,
};

/// How far along the surface (mm) from the outer lip contours the lip split looks.
const LIP_SPLIT_RADIUS_MM: f32 = 40.0;
/// A lip vertex this close (mm, in space) to the other lip lies on the contact line.
pub const LIP_CONTACT_MM: f32 = 3.0;

/// Anchor of every mask vertex, with the distance to it.
#[derive(Debug, Clone, PartialEq)]
pub struct Anchors {
    /// `vertex[j]`: head vertex anchoring mask vertex j.
    pub vertex: Vec<u32>,
    /// Euclidean distance from the fitted mask vertex to its anchor, head units.
    pub distance: Vec<f32>,
}

/// Anchors the fitted neutral mask (`fitted`, head units) on `head`.
pub fn anchor_mask(head: &Head, fitted: &[Vec3], mm_per_unit: f32) -> Anchors {
    let mut vertex = Vec::with_capacity(fitted.len());
    let mut distance = Vec::with_capacity(fitted.len());
    for &p in fitted {
        let (v, d) = head.vertices.nearest(p).expect("a head has vertices");
        vertex.push(v);
        distance.push(d);
    }

    // Split the mouth region into upper and lower lip by surface distance to the outer
    // contours' plain anchors (the outer contours are far apart), those on the other lip
    // left out.
    let radius = LIP_SPLIT_RADIUS_MM / mm_per_unit;
    let anchored = |lip: &[usize]| lip.iter().map(|&j| vertex[j]).collect::<Vec<u32>>();
    let (upper_seeds, lower_seeds) = on_their_own_lip(
        head,
        &anchored(&UPPER_LIP_OUTER),
        &anchored(&LOWER_LIP_OUTER),
        vertex[NOSE_TIP],
        vertex[CHIN],
    );
    let mut from_upper = SurfaceDistance::new(head.positions.len());
    let mut from_lower = SurfaceDistance::new(head.positions.len());
    let seeds = |lip: &[u32]| lip.iter().map(|&v| (v, 0.0)).collect::<Vec<_>>();
    from_upper.run(&head.topology, &seeds(&upper_seeds), radius);
    from_lower.run(&head.topology, &seeds(&lower_seeds), radius);
    let side = |near: &SurfaceDistance, far: &SurfaceDistance| -> Vec<u32> {
        near.reached()
            .iter()
            .copied()
            .filter(|&v| near.distance(v) < far.distance(v))
            .collect()
    };
    let upper = side(&from_upper, &from_lower);
    let lower = side(&from_lower, &from_upper);
    let mut set = |lip: &[usize], candidates: &[u32]| {
        let points: Vec<Vec3> = candidates.iter().map(|&v| head.positions[v as usize]).collect();
        let index = VertexIndex::new(&points);
        for &j in lip {
            if let Some((k, d)) = index.nearest(fitted[j]) {
                vertex[j] = candidates[k as usize];
                distance[j] = d;
            }
        }
    };
    set(&UPPER_LIP, &upper);
    set(&LOWER_LIP, &lower);

    let contact_limit = LIP_CONTACT_MM / mm_per_unit;
    let upper_contact = facing(head, &upper, &lower, contact_limit);
    let lower_contact = facing(head, &lower, &upper, contact_limit);
    if upper_contact.is_empty() || lower_contact.is_empty() {
        return Anchors { vertex, distance };
    }
    // Outer contours keep off the contact line: a mask lip standing in front of the head's
    // can take a vertex where the lips meet for its outer contour, next to the one its
    // inner contour takes, and the lip then folds between them as the mouth opens.
    let off = |lip: &[u32], contact: &[u32]| -> Vec<u32> {
        lip.iter().copied().filter(|v| !contact.contains(v)).collect()
    };
    set(&UPPER_LIP_OUTER, &off(&upper, &upper_contact));
    set(&LOWER_LIP_OUTER, &off(&lower, &lower_contact));

    // Inner contours: the neutral mask puts 81/83, 87/40 and 82/84 on one point; anchor
    // each pair on two facing vertices of the contact line near it.
    let upper_points: Vec<Vec3> = upper_contact
        .iter()
        .map(|&v| head.positions[v as usize])
        .collect();
    let lower_points: Vec<Vec3> = lower_contact
        .iter()
        .map(|&v| head.positions[v as usize])
        .collect();
    let lower_index = VertexIndex::new(&lower_points);
    for (&up, &low) in UPPER_LIP_INNER.iter().zip(&LOWER_LIP_INNER) {
        let target = 0.5 * (fitted[up] + fitted[low]);
        // Score each upper contact vertex with its nearest lower one: close to the mask
        // point, and close to each other.
        let best = upper_points
            .iter()
            .enumerate()
            .filter_map(|(i, &u)| {
                let (k, gap) = lower_index.nearest(u)?;
                let l = lower_points[k as usize];
                let score = gap + (0.5 * (u + l)).distance(target);
                Some((score, i, k as usize))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0));
        if let Some((_, i, k)) = best {
            vertex[up] = upper_contact[i];
            distance[up] = fitted[up].distance(upper_points[i]);
            vertex[low] = lower_contact[k];
            distance[low] = fitted[low].distance(lower_points[k]);
        }
    }
    Anchors { vertex, distance }
}

/// Vertices of `side` within `limit` (head units) of some vertex of `other`.
fn facing(head: &Head, side: &[u32], other: &[u32], limit: f32) -> Vec<u32> {
    let other_points: Vec<Vec3> = other.iter().map(|&v| head.positions[v as usize]).collect();
    let other_index = VertexIndex::new(&other_points);
    side.iter()
        .copied()
        .filter(|&v| {
            other_index
                .nearest(head.positions[v as usize])
                .is_some_and(|(_, d)| d <= limit)
        })
        .collect()
}
