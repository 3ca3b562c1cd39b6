//! The plane a head is mirror-symmetric about, found from the head alone: a face has one
//! such plane (through the nose, between the eyes), whichever way the file has it turned.
//! Every plane through the head's centre is tried (normals spread evenly over a
//! hemisphere, scored by how far the head's vertices land from its other vertices once
//! reflected), and the few best refined by a pattern search over tilt and offset.
//!
//! Lengths in head units.

use glam::Vec3;
use rayon::prelude::*;

use crate::head::Head;

/// Plane normals tried, spread over a hemisphere (about 11 degrees apart).
const NORMALS: usize = 160;
/// Vertices reflected for the coarse score (spread over the file order).
const COARSE_SAMPLES: usize = 250;
/// Vertices reflected while refining.
const FINE_SAMPLES: usize = 400;
/// The best coarse planes refined, each at least this far (degrees) from those before it.
const REFINED: usize = 2;
const REFINED_APART_DEG: f32 = 20.0;
/// The refining search's first steps: tilts of half the spacing of the normals tried,
/// shifts of this fraction of the head's diagonal; it ends when the tilt step is finer
/// than [`FINEST_TILT_DEG`].
const START_TILT_DEG: f32 = 6.0;
const START_SHIFT: f32 = 0.02;
const FINEST_TILT_DEG: f32 = 0.1;

/// A plane of mirror symmetry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MirrorPlane {
    pub point: Vec3,
    /// Unit normal; either sign.
    pub normal: Vec3,
    /// Median distance from the head's reflected vertices to its surface, head units.
    pub asymmetry: f32,
}

impl MirrorPlane {
    pub fn reflect(&self, p: Vec3) -> Vec3 {
        p - 2.0 * (p - self.point).dot(self.normal) * self.normal
    }
}

/// The head's plane of mirror symmetry (the one it is closest to symmetric about), or
/// `None` for a mesh with fewer than four vertices.
pub fn mirror_plane(head: &Head) -> Option<MirrorPlane> {
    if head.positions.len() < 4 {
        return None;
    }
    let coarse = samples(&head.positions, COARSE_SAMPLES);
    let centre = coarse.iter().copied().sum::<Vec3>() / coarse.len() as f32;
    // The planes are scored, and the best refined, on every core; each result is the
    // same whatever the cores' timing.
    let normals: Vec<Vec3> = hemisphere(NORMALS).collect();
    let mut scored: Vec<(f32, Vec3)> = normals
        .par_iter()
        .map(|&normal| {
            let plane = MirrorPlane {
                point: centre,
                normal,
                asymmetry: 0.0,
            };
            (asymmetry_to_vertices(head, &coarse, &plane), normal)
        })
        .collect();
    scored.sort_by(|a, b| a.0.total_cmp(&b.0));
    let min_cos = REFINED_APART_DEG.to_radians().cos();
    let mut starts: Vec<Vec3> = Vec::new();
    for (_, normal) in scored {
        if starts.len() == REFINED {
            break;
        }
        if starts.iter().all(|s| s.dot(normal).abs() < min_cos) {
            starts.push(normal);
        }
    }
    let fine = samples(&head.positions, FINE_SAMPLES);
    starts
        .into_par_iter()
        .map(|normal| {
            refine(
                head,
                &fine,
                MirrorPlane {
                    point: centre,
                    normal,
                    asymmetry: f32::INFINITY,
                },
            )
        })
        .min_by(|a, b| a.asymmetry.total_cmp(&b.asymmetry))
}

/// Refines a plane by a pattern search over its two tilts and its offset: each step tries
/// the plane tilted or moved by the step either way, keeps the best, and halves the steps
/// when none is better, until the tilt step is below [`FINEST_TILT_DEG`].
fn refine(head: &Head, samples: &[Vec3], start: MirrorPlane) -> MirrorPlane {
    let score = |plane: &MirrorPlane| asymmetry_to_vertices(head, samples, plane);
    let mut best = MirrorPlane {
        asymmetry: 0.0,
        ..start
    };
    let mut best_score = score(&best);
    let mut tilt = START_TILT_DEG.to_radians();
    let mut shift = START_SHIFT * head.bounds().size().length();
    while tilt > FINEST_TILT_DEG.to_radians() {
        let (u, v) = best.normal.any_orthonormal_pair();
        let mut improved = false;
        for candidate in [
            tilted(&best, u, tilt),
            tilted(&best, u, -tilt),
            tilted(&best, v, tilt),
            tilted(&best, v, -tilt),
            shifted(&best, shift),
            shifted(&best, -shift),
        ] {
            let s = score(&candidate);
            if s < best_score {
                (best, best_score, improved) = (candidate, s, true);
            }
        }
        if !improved {
            tilt /= 2.0;
            shift /= 2.0;
        }
    }
    let mut distances: Vec<f32> = samples
        .iter()
        .filter_map(|&p| head.surface.closest_point(best.reflect(p)).map(|s| s.distance))
        .collect();
    best.asymmetry = median(&mut distances);
    best
}

fn tilted(plane: &MirrorPlane, towards: Vec3, radians: f32) -> MirrorPlane {
    MirrorPlane {
        normal: (plane.normal * radians.cos() + towards * radians.sin()).normalize(),
        ..*plane
    }
}

fn shifted(plane: &MirrorPlane, by: f32) -> MirrorPlane {
    MirrorPlane {
        point: plane.point + by * plane.normal,
        ..*plane
    }
}

/// Median distance from `samples`, reflected across `plane`, to the nearest vertex.
fn asymmetry_to_vertices(head: &Head, samples: &[Vec3], plane: &MirrorPlane) -> f32 {
    let mut distances: Vec<f32> = samples
        .iter()
        .filter_map(|&p| head.vertices.nearest(plane.reflect(p)).map(|(_, d)| d))
        .collect();
    median(&mut distances)
}

/// The direction in `plane` along which `positions` spread most (unit; either sign): the
/// principal axis of their covariance with the plane's normal projected out.
pub fn principal_axis_in(positions: &[Vec3], plane: &MirrorPlane) -> Vec3 {
    let n = plane.normal.as_dvec3();
    let centre = positions.iter().map(|p| p.as_dvec3()).sum::<glam::DVec3>() / positions.len().max(1) as f64;
    let mut covariance = nalgebra::Matrix3::<f64>::zeros();
    for p in positions {
        let d = p.as_dvec3() - centre;
        let d = d - n * d.dot(n);
        let v = nalgebra::Vector3::new(d.x, d.y, d.z);
        covariance += v * v.transpose();
    }
    let eigen = covariance.symmetric_eigen();
    let largest = eigen.eigenvalues.imax();
    let axis = eigen.eigenvectors.column(largest);
    let axis = glam::DVec3::new(axis[0], axis[1], axis[2]);
    let axis = (axis - n * axis.dot(n))
        .try_normalize()
        .unwrap_or_else(|| n.any_orthonormal_vector());
    axis.as_vec3()
}

/// About `count` points of `positions`, spread evenly over their order.
fn samples(positions: &[Vec3], count: usize) -> Vec<Vec3> {
    let step = positions.len().div_ceil(count).max(1);
    positions.iter().step_by(step).copied().collect()
}

/// `count` unit vectors spread evenly over the hemisphere z >= 0 (a Fibonacci lattice).
fn hemisphere(count: usize) -> impl Iterator<Item = Vec3> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..count).map(move |i| {
        let z = 1.0 - (i as f32 + 0.5) / count as f32;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = i as f32 * golden;
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    })
}

fn median(values: &mut [f32]) -> f32 {
    if values.is_empty() {
        return f32::INFINITY;
    }
    let middle = values.len() / 2;
    *values.select_nth_unstable_by(middle, f32::total_cmp).1
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat3;

    #[test]
    fn the_ict_head_is_symmetric_about_its_sagittal_plane_however_turned() {
        let head =
            Head::load(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/heads/ict_head.obj"))
                .unwrap();
        for turn in [
            Mat3::IDENTITY,
            Mat3::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 1.1),
            Mat3::from_rotation_z(0.6) * Mat3::from_rotation_x(2.0),
        ] {
            let turned = Head::new(
                "turned",
                head.positions.iter().map(|&p| turn * p).collect(),
                head.triangles.clone(),
            );
            let plane = mirror_plane(&turned).unwrap();
            // The generic ICT head is modelled symmetric about x = 0 (cm).
            let expected = turn * Vec3::X;
            assert!(
                plane.normal.dot(expected).abs() > 1f32.to_radians().cos(),
                "{} against {expected}",
                plane.normal
            );
            assert!(plane.point.dot(expected).abs() < 0.1, "{}", plane.point);
            assert!(plane.asymmetry < 0.1, "{}", plane.asymmetry);
        }
    }

    #[test]
    fn hemisphere_directions_are_unit_and_spread() {
        let all: Vec<Vec3> = hemisphere(NORMALS).collect();
        assert!(all.iter().all(|v| (v.length() - 1.0).abs() < 1e-5 && v.z >= 0.0));
        // Every direction of the hemisphere lies within 7 degrees of one of them.
        for probe in [Vec3::X, Vec3::Z, Vec3::new(1.0, 1.0, 0.2).normalize()] {
            let best = all.iter().map(|v| v.dot(probe)).fold(-1.0, f32::max);
            assert!(best > 11f32.to_radians().cos(), "{probe}: {best}");
        }
    }
}
