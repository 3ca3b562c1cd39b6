//! Where a head's lips are, for drawing them in their own colour. A lip-reader follows the
//! lip contour; a head drawn in one colour shows it only by shading, and a head without a
//! texture has nothing else. The fitted mask knows where the lips are: a head vertex is lip
//! when, seen from the mask's front, it lies inside the mask's outer lip contour and it is
//! part of the lips' own surface (within the lips' thickness of a lip anchor along the
//! surface, which keeps out the back of the head behind the mouth and the cheeks around
//! it). The edge is soft over [`SOFT_EDGE_MM`] either side of the contour.
//!
//! Built once per head and fit; the weights are served to viewers (`lips.bin`).

use glam::{Vec2, Vec3};

use crate::deform::Registration;
use crate::head::SurfaceDistance;
use crate::mask::{
    INNER_LIP_CORNERS, LIP_VERTICES, LOWER_LIP_INNER, LOWER_LIP_OUTER, OUTER_LIP_CORNERS, UPPER_LIP_INNER,
    UPPER_LIP_OUTER,
};

/// Half the width of the tint's edge, millimetres: the weight goes from 0 this far outside
/// the outer lip contour to 1 this far inside it. A lip's vermilion border is sharp; a
/// millimetre keeps it from aliasing and is finer than most heads' triangles, whose
/// interpolation softens it further.
pub const SOFT_EDGE_MM: f32 = 1.0;

/// Per head vertex, how much it is lip: 0 skin, 255 lip (the rest mesh's vertex order).
pub fn lip_tint(registration: &Registration) -> Vec<u8> {
    let head = &registration.head;
    let mask = &registration.fitted.neutral;
    let rotation = registration.fitted.fit.pose.rotation();
    let (right, up) = ((rotation * Vec3::X).normalize(), (rotation * Vec3::Y).normalize());
    let outer: Vec<usize> = OUTER_LIP_CORNERS
        .iter()
        .chain(&UPPER_LIP_OUTER)
        .chain(&LOWER_LIP_OUTER)
        .copied()
        .collect();
    let centre = outer.iter().map(|&v| mask[v]).sum::<Vec3>() / outer.len() as f32;
    let front = |p: Vec3| Vec2::new((p - centre).dot(right), (p - centre).dot(up));
    let contour = around_centre(outer.iter().map(|&v| front(mask[v])).collect());

    // The lips' thickness as the fit has them: the furthest an outer contour vertex lies
    // from the inner contour. Every point of a lip is about that close to a lip anchor.
    let inner: Vec<Vec3> = UPPER_LIP_INNER
        .iter()
        .chain(&LOWER_LIP_INNER)
        .chain(&INNER_LIP_CORNERS)
        .map(|&v| mask[v])
        .collect();
    let thickness = outer
        .iter()
        .map(|&v| {
            inner
                .iter()
                .map(|&q| q.distance(mask[v]))
                .fold(f32::INFINITY, f32::min)
        })
        .fold(0.0, f32::max);
    let edge = SOFT_EDGE_MM / registration.mm_per_unit();
    let reach = thickness + edge;

    let vertex_count = head.positions.len();
    let sources: Vec<(u32, f32)> = LIP_VERTICES
        .iter()
        .map(|&j| (registration.anchors.vertex[j], 0.0))
        .filter(|&(v, _)| (v as usize) < vertex_count)
        .collect();
    let mut search = SurfaceDistance::new(vertex_count);
    let mut weights = vec![0u8; vertex_count];
    for &v in search.run(&head.topology, &sources, reach) {
        let inside = signed_distance(&contour, front(head.positions[v as usize]));
        let t = ((inside + edge) / (2.0 * edge)).clamp(0.0, 1.0);
        let smooth = t * t * (3.0 - 2.0 * t);
        weights[v as usize] = (smooth * 255.0).round() as u8;
    }
    weights
}

/// The points in order of their angle about their centroid: a closed contour for a
/// star-shaped outline (a mouth is one about its middle), whatever order they came in.
fn around_centre(mut points: Vec<Vec2>) -> Vec<Vec2> {
    let centroid = points.iter().copied().sum::<Vec2>() / points.len() as f32;
    points.sort_by(|a, b| {
        let (a, b) = (*a - centroid, *b - centroid);
        a.y.atan2(a.x).total_cmp(&b.y.atan2(b.x))
    });
    points
}

/// Distance from `p` to the closed polygon's outline, positive inside, negative outside.
fn signed_distance(polygon: &[Vec2], p: Vec2) -> f32 {
    let mut nearest = f32::INFINITY;
    let mut inside = false;
    for (i, &a) in polygon.iter().enumerate() {
        let b = polygon[(i + 1) % polygon.len()];
        let ab = b - a;
        let along = ((p - a).dot(ab) / ab.length_squared().max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
        nearest = nearest.min(p.distance(a + ab * along));
        if (a.y > p.y) != (b.y > p.y) && p.x < a.x + (p.y - a.y) / (b.y - a.y) * ab.x {
            inside = !inside;
        }
    }
    if inside {
        nearest
    } else {
        -nearest
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> Vec<Vec2> {
        around_centre(vec![
            Vec2::new(1.0, 1.0),
            Vec2::new(-1.0, -1.0),
            Vec2::new(1.0, -1.0),
            Vec2::new(-1.0, 1.0),
        ])
    }

    #[test]
    fn points_in_any_order_make_the_outline() {
        let s = square();
        // Consecutive corners share a side: no diagonal in the outline.
        for i in 0..4 {
            assert_eq!(s[i].distance(s[(i + 1) % 4]), 2.0, "{s:?}");
        }
    }

    #[test]
    fn signed_distance_is_positive_inside_and_negative_outside() {
        let s = square();
        assert_eq!(signed_distance(&s, Vec2::ZERO), 1.0);
        assert_eq!(signed_distance(&s, Vec2::new(0.5, 0.0)), 0.5);
        assert_eq!(signed_distance(&s, Vec2::new(3.0, 0.0)), -2.0);
        assert!((signed_distance(&s, Vec2::new(2.0, 2.0)) + 2f32.sqrt()).abs() < 1e-6);
    }
}
