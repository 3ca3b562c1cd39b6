//! Step 1 of the automatic fit: where the nose may be. The head is looked at from [`VIEWS`]
//! directions across its mirror plane, each a range image, and the places that stand out
//! like a nose tip on the plane are kept, the likeliest views first. What each constant
//! was checked on: docs/FITTING.md, "The automatic fit's constants".

use glam::Vec3;

use super::depth_map::{DepthMap, NoseCandidate, View};
use super::mirror_plane::{self, MirrorPlane};
use crate::head::Head;

/// Directions the head is looked at from, evenly around the normal of its mirror plane.
const VIEWS: usize = 72;
/// Cells along the longer side of each range image.
const DEPTH_MAP_CELLS: usize = 96;
/// Views whose noses are tried: the likeliest, and the next likeliest looking at least
/// [`FACING_VIEWS_APART_DEG`] away from it.
const FACING_VIEWS: usize = 4;
const FACING_VIEWS_APART_DEG: f32 = 20.0;
/// The sides of a nose are compared this far from the tip, as a fraction of the head's size.
const NOSE_RADIUS: f32 = 0.1;
/// A nose must stand out of the surface beside it by at least this fraction of that radius.
pub(super) const MIN_NOSE_PROMINENCE: f32 = 0.15;
/// A nose stands out of the surface beside it by at most this fraction of that radius: its
/// ridge rises to the brow at less than 45 degrees. A cell standing out more is the rim
/// of a hole (a neck's cut, seen from below, with the inside of the head behind it).
const MAX_NOSE_PROMINENCE: f32 = 1.0;
/// A nose tip lies this close to the mirror plane, as a fraction of the nose's radius
/// (three cells of the range image: the tip is read to a cell, and faces are not exactly
/// symmetric).
const NOSE_OFF_PLANE: f32 = 0.3;
/// Places tried as the nose tip in the chosen view, the most prominent first: a chin
/// lowered by a mouth open at rest can stand out more than the nose.
const NOSE_CANDIDATES: usize = 3;

/// The views that may look at the face, each with the places in it that could be the nose
/// tip ([`DepthMap::noses`]; never empty), the likeliest first: of [`VIEWS`] directions
/// across the head's mirror plane (from the head's longest axis in it, so that a head
/// turned is seen from the same directions, turned), those whose most prominent place stands out like a nose
/// (within [`MIN_NOSE_PROMINENCE`] and [`MAX_NOSE_PROMINENCE`]) and lies on the plane
/// (within [`NOSE_OFF_PLANE`] of the nose's radius: a brow or a cheekbone seen aslant can
/// stand out as much, but off the plane), the most prominent first, each at least
/// [`FACING_VIEWS_APART_DEG`] from those before. The back of a head can stand out on the
/// plane too: the fit that follows tells them apart. Which way is up is left to the fit.
pub(super) fn find_nose(head: &Head, winding: f32, plane: &MirrorPlane) -> Vec<(View, Vec<NoseCandidate>)> {
    let lateral = plane.normal;
    let across = mirror_plane::principal_axis_in(&head.positions, plane);
    let look = |forward: Vec3| {
        let view = View::with_lateral(forward, lateral);
        let map = DepthMap::render(&head.positions, &head.triangles, view, DEPTH_MAP_CELLS, winding);
        let radius = NOSE_RADIUS * map.extent();
        let noses: Vec<NoseCandidate> = map
            .noses(radius, NOSE_CANDIDATES)
            .into_iter()
            .filter(|n| {
                n.prominence <= MAX_NOSE_PROMINENCE
                    && (n.tip - plane.point).dot(lateral).abs() < NOSE_OFF_PLANE * radius
            })
            .collect();
        (!noses.is_empty()).then_some((view, noses))
    };
    let mut scored: Vec<(View, Vec<NoseCandidate>)> = Vec::new();
    let mut most_prominent: Option<(View, NoseCandidate)> = None;
    for k in 0..VIEWS {
        let angle = k as f32 * std::f32::consts::TAU / VIEWS as f32;
        let Some((view, noses)) = look(across * angle.cos() + lateral.cross(across) * angle.sin()) else {
            continue;
        };
        let nose = noses[0];
        if most_prominent.is_none_or(|(_, m)| nose.prominence > m.prominence) {
            most_prominent = Some((view, nose));
        }
        if nose.prominence >= MIN_NOSE_PROMINENCE {
            scored.push((view, noses));
        }
    }
    // The file's own axes, as far as they lie across the plane: a head written upright is
    // seen straight from the front, where the most prominent view of its nose can be
    // pitched by a few degrees, and the fit keeps a start's pitch.
    let file_views: Vec<(View, Vec<NoseCandidate>)> = [Vec3::X, Vec3::Y, Vec3::Z]
        .into_iter()
        .flat_map(|axis| [axis, -axis])
        .filter_map(|axis| (axis - lateral * axis.dot(lateral)).try_normalize())
        .filter_map(look)
        .filter(|(_, noses)| noses[0].prominence >= MIN_NOSE_PROMINENCE)
        .collect();
    scored.sort_by(|a, b| b.1[0].prominence.total_cmp(&a.1[0].prominence));
    let min_cos = FACING_VIEWS_APART_DEG.to_radians().cos();
    let mut views: Vec<(View, Vec<NoseCandidate>)> = Vec::new();
    for (view, noses) in scored {
        if views.iter().all(|(v, _)| v.forward.dot(view.forward) < min_cos) {
            let nearest_file_view = file_views
                .iter()
                .filter(|(v, _)| v.forward.dot(view.forward) >= min_cos)
                .max_by(|a, b| {
                    a.0.forward
                        .dot(view.forward)
                        .total_cmp(&b.0.forward.dot(view.forward))
                });
            views.push(nearest_file_view.cloned().unwrap_or((view, noses)));
        }
        if views.len() == FACING_VIEWS {
            break;
        }
    }
    if views.is_empty() {
        views.extend(most_prominent.map(|(view, nose)| (view, vec![nose])));
    }
    views
}
