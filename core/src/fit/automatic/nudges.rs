//! Nudges for an automatic fit: CANDIDE's shape units cannot follow every face, so once
//! the pose and shape units are solved, each mask vertex that no found feature holds is
//! moved onto the surface nearest it. With its eye corners on the skin where the lids meet,
//! the mask's brow stood 5.8 mm off MakeHuman's (as on its landmark fit, 6.5 mm).
//!
//! Left alone: the held (pinned) vertices, the lips (their inner contours meet at rest and
//! the open-mouth calibration moves them), the eyes (an opening has no surface to lie on),
//! vertices further than [`NUDGE_REACH`] from the surface, and those nearest a triangle on
//! the mesh's edge (past the edge of a face-only mesh).

use glam::Vec3;

use super::closest_points::Surface;
use crate::fit::FitSolution;
use crate::mask::Mask;

/// Mask vertices further than this from the surface (mask units, about 10 mm) keep their
/// place.
const NUDGE_REACH: f64 = 0.1;

/// (mask vertex, offset in mask units) moving each free vertex of `used` onto the surface.
pub fn onto_surface(
    surface: &Surface,
    mask: &Mask,
    laid: &FitSolution,
    used: &[u32],
    held: &[u32],
) -> Vec<(u32, Vec3)> {
    let shaped = mask.shaped(&laid.shape);
    let similarity = laid.similarity;
    used.iter()
        .copied()
        .filter(|&j| !held.contains(&j) && !mask.at_an_opening(j as usize))
        .filter_map(|j| {
            let posed = similarity.apply(shaped[j as usize].as_dvec3());
            let nearest = surface.head.surface.closest_point(posed.as_vec3())?;
            if surface.past_the_edge(j, nearest.triangle) {
                return None;
            }
            let offset = nearest.point.as_dvec3() - posed;
            (offset.length() < NUDGE_REACH * similarity.scale).then(|| {
                (
                    j,
                    (similarity.rotation.transpose() * offset / similarity.scale).as_vec3(),
                )
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::automatic::depth_map::tests::grid_plate;
    use crate::fit::umeyama::Similarity;
    use crate::head::Head;
    use crate::mask::{FaceRegion, MaskPose, LIP_VERTICES};
    use glam::{DMat3, DVec3, Vec2};

    #[test]
    fn free_vertices_near_the_surface_are_moved_onto_it_and_no_others() {
        let mask = Mask::candide3();
        // A flat face at z = 0.15 (mask units, the mask laid as it is): the mask's nose
        // stands out of it, its cheeks lie behind it.
        let (positions, triangles) = grid_plate([61, 61], Vec2::new(-1.2, -1.2), 0.04, |_, _| 0.15);
        let head = Head::new("plate", positions, triangles);
        let laid = FitSolution {
            pose: MaskPose::IDENTITY,
            shape: vec![0.0; mask.shape_units.len()],
            rms: 0.0,
            iterations: 0,
            similarity: Similarity {
                rotation: DMat3::IDENTITY,
                scale: 1.0,
                translation: DVec3::ZERO,
            },
            shape_f64: vec![0.0; mask.shape_units.len()],
        };
        let used: Vec<u32> = (0..mask.vertices.len() as u32)
            .filter(|&j| mask.used_vertices()[j as usize])
            .collect();
        let held = [5u32];
        let nudges = onto_surface(&Surface::new(&head, &mask), &mask, &laid, &used, &held);
        assert!(!nudges.is_empty());
        for &(j, offset) in &nudges {
            let p = mask.vertices[j as usize];
            assert!(
                ((p + offset).z - 0.15).abs() < 1e-5 && (p.z - 0.15).abs() < 0.1,
                "vertex {j} at {p} by {offset}"
            );
            assert!(
                offset.x.abs() < 1e-5 && offset.y.abs() < 1e-5,
                "vertex {j} by {offset}"
            );
            assert!(!held.contains(&j) && !LIP_VERTICES.contains(&(j as usize)));
            assert_ne!(FaceRegion::of(p), FaceRegion::Eyes);
        }
        let free_and_near = used.iter().filter(|&&j| {
            let p = mask.vertices[j as usize];
            !held.contains(&j)
                && !LIP_VERTICES.contains(&(j as usize))
                && FaceRegion::of(p) != FaceRegion::Eyes
                && (p.z - 0.15).abs() < 0.1
        });
        assert_eq!(nudges.len(), free_and_near.count());
    }
}
