//! An eyeball as the animation sees it: a rigid part that turns about its own centre.
//! A part given the role `eyes` may hold both eyeballs (as the ICT Face Model ships them);
//! it is split by side of the face's mid-plane (the fitted mask's x = 0; +x is the face's
//! left) into `{name}_left` and `{name}_right`, one eyeball each.
//!
//! The centre is the least-squares sphere through the eyeball's vertices (an algebraic fit:
//! `|p|^2 = 2 c.p + d` is linear in `c` and `d`), which a cornea's bulge moves little: the
//! bulge is a small share of the vertices. The eyeball looks along the face's forward
//! (the fitted mask's +z in head units) at rest. Its surface, for the lids, is a radius
//! for each angle from that axis ([`RadialProfile`]): an eyeball is round about its axis,
//! so one radius per angle holds the cornea as well as the sclera, whatever the mesh.

use glam::{DVec3, DVec4, Vec3};
use serde::Serialize;

use crate::fit::FittedMask;
use crate::head::{Head, Pieces, NO_PIECE};

/// Which eye, as the face sees it (the face's own left is the mask's +x).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Side {
    Left,
    Right,
}

impl Side {
    pub fn name(self) -> &'static str {
        match self {
            Side::Left => "left",
            Side::Right => "right",
        }
    }
}

/// Angles from the eyeball's axis the profile keeps a radius for, over 0..=180 degrees.
pub const PROFILE_BINS: usize = 90;

/// The radius of an eyeball's surface (head units) as a function of the angle from its
/// axis: for each of [`PROFILE_BINS`] bands of angle, the furthest vertex in it; bands no
/// vertex falls in take their nearest filled neighbour's. Read with linear interpolation.
#[derive(Debug, Clone, PartialEq)]
pub struct RadialProfile {
    radius: [f32; PROFILE_BINS],
}

impl RadialProfile {
    /// The profile of `points` about `centre`, `axis` (unit) at angle 0.
    pub fn of(points: &[Vec3], centre: Vec3, axis: Vec3) -> RadialProfile {
        let mut radius = [f32::NAN; PROFILE_BINS];
        for &p in points {
            let offset = p - centre;
            let r = offset.length();
            if r > 0.0 {
                let bin = Self::bin_of(offset.dot(axis) / r);
                radius[bin] = if radius[bin].is_nan() {
                    r
                } else {
                    radius[bin].max(r)
                };
            }
        }
        let filled: Vec<usize> = (0..PROFILE_BINS).filter(|&b| !radius[b].is_nan()).collect();
        let copy = radius;
        for (bin, slot) in radius.iter_mut().enumerate() {
            if slot.is_nan() {
                *slot = filled
                    .iter()
                    .min_by_key(|&&f| f.abs_diff(bin))
                    .map_or(0.0, |&f| copy[f]);
            }
        }
        RadialProfile { radius }
    }

    fn bin_of(cos: f32) -> usize {
        let angle = cos.clamp(-1.0, 1.0).acos();
        ((angle / std::f32::consts::PI * PROFILE_BINS as f32) as usize).min(PROFILE_BINS - 1)
    }

    /// The surface's radius (head units) at `cos` of the angle from the axis.
    pub fn radius_at(&self, cos: f32) -> f32 {
        let at = cos.clamp(-1.0, 1.0).acos() / std::f32::consts::PI * PROFILE_BINS as f32 - 0.5;
        let low = at.floor().clamp(0.0, (PROFILE_BINS - 1) as f32);
        let high = (low + 1.0).min((PROFILE_BINS - 1) as f32);
        let t = (at - low).clamp(0.0, 1.0);
        let (a, b) = (self.radius[low as usize], self.radius[high as usize]);
        a + (b - a) * t
    }
}

/// One eyeball, in the head's frame and units.
#[derive(Debug, Clone)]
pub struct Eyeball {
    /// Its name, unique among the head's parts and eyes (`eyes_left`).
    pub name: String,
    pub side: Side,
    pub mesh: Head,
    /// The eyeball as given, when it was one of two in a part and this is one of them.
    pub split_from: Option<String>,
    /// Centre of the fitted sphere: what it turns about (head units).
    pub centre: Vec3,
    /// The centre in mask units (the fit's pose undone).
    pub centre_mask: Vec3,
    /// Where it looks at rest: the face's forward, unit length.
    pub forward: Vec3,
    /// The fitted sphere's radius (head units).
    pub radius: f32,
    pub profile: RadialProfile,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EyeballError {
    #[error("eyes part {name:?}: its vertices do not fit a sphere (all on a plane or a line?)")]
    NotRound { name: String },
}

impl Eyeball {
    /// The eyeballs of an eyes part `mesh` named `name`: one, or two split by side.
    pub fn of_part(mesh: &Head, name: &str, fitted: &FittedMask) -> Result<Vec<Eyeball>, EyeballError> {
        let to_mask = fitted.fit.pose.affine().inverse();
        let forward = fitted.fit.pose.rotation() * Vec3::Z;
        let pieces = Pieces::of(mesh);
        let mut x_sum = vec![0.0f32; pieces.count];
        for (v, &piece) in pieces.of_vertex.iter().enumerate() {
            if piece != NO_PIECE {
                x_sum[piece as usize] += to_mask.transform_point3(mesh.positions[v]).x;
            }
        }
        // A piece lies on the face's left when its vertices do on average (mask +x).
        let left: Vec<bool> = x_sum.iter().map(|&x| x > 0.0).collect();
        let sides: Vec<Side> = [Side::Left, Side::Right]
            .into_iter()
            .filter(|&s| left.iter().any(|&l| l == (s == Side::Left)))
            .collect();
        let whole = sides.len() < 2;
        let mut eyes = Vec::with_capacity(sides.len());
        for side in sides {
            let triangles: Vec<[u32; 3]> = mesh
                .triangles
                .iter()
                .filter(|t| left[pieces.of_vertex[t[0] as usize] as usize] == (side == Side::Left))
                .copied()
                .collect();
            let (part_name, split_from) = match whole {
                true => (name.to_string(), None),
                false => (format!("{name}_{}", side.name()), Some(name.to_string())),
            };
            let ball = Head::compacted(&part_name, &mesh.positions, &triangles);
            let (centre, radius) = fit_sphere(&ball.positions).ok_or_else(|| EyeballError::NotRound {
                name: part_name.clone(),
            })?;
            let profile = RadialProfile::of(&ball.positions, centre, forward);
            eyes.push(Eyeball {
                name: part_name,
                side,
                mesh: ball,
                split_from,
                centre,
                centre_mask: to_mask.transform_point3(centre),
                forward,
                radius,
                profile,
            });
        }
        Ok(eyes)
    }
}

/// The least-squares sphere through `points`: centre and radius, `None` when they do not
/// determine one (fewer than four, or all on a plane).
pub fn fit_sphere(points: &[Vec3]) -> Option<(Vec3, f32)> {
    if points.len() < 4 {
        return None;
    }
    // About the centroid, in f64, for conditioning.
    let mean = points.iter().map(|p| p.as_dvec3()).sum::<DVec3>() / points.len() as f64;
    let mut normal = glam::DMat4::ZERO;
    let mut rhs = DVec4::ZERO;
    for p in points {
        let q = p.as_dvec3() - mean;
        let row = DVec4::new(2.0 * q.x, 2.0 * q.y, 2.0 * q.z, 1.0);
        normal += glam::DMat4::from_cols(row * row.x, row * row.y, row * row.z, row * row.w);
        rhs += row * q.length_squared();
    }
    // Hadamard: |det| <= the product of the diagonal; far below it, the points lie on a
    // plane (or a line) and no sphere is determined.
    let diagonal = (0..4).map(|k| normal.col(k)[k]).product::<f64>();
    let determinant = normal.determinant().abs();
    if determinant.is_nan() || determinant <= 1e-12 * diagonal {
        return None;
    }
    let solution = normal.inverse() * rhs;
    let centre = solution.truncate();
    let radius_squared = solution.w + centre.length_squared();
    (radius_squared > 0.0 && radius_squared.is_finite())
        .then(|| ((centre + mean).as_vec3(), radius_squared.sqrt() as f32))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::fit::Fit;
    use crate::mask::{Mask, MaskPose};

    /// A UV sphere of `radius` about `centre`, with a cap pushed out by `bulge` within 30
    /// degrees of +z (a cornea).
    pub(crate) fn eyeball(centre: Vec3, radius: f32, bulge: f32, base: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let (rings, segments) = (24u32, 32u32);
        let mut positions = vec![centre + Vec3::Z * (radius + bulge)];
        for ring in 1..rings {
            let theta = ring as f32 / rings as f32 * std::f32::consts::PI;
            let r = if theta < std::f32::consts::FRAC_PI_6 {
                radius + bulge * (1.0 - theta / std::f32::consts::FRAC_PI_6)
            } else {
                radius
            };
            for s in 0..segments {
                let phi = s as f32 / segments as f32 * std::f32::consts::TAU;
                let dir = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
                positions.push(centre + dir * r);
            }
        }
        positions.push(centre - Vec3::Z * radius);
        let last = positions.len() as u32 - 1;
        let at = |ring: u32, s: u32| 1 + (ring - 1) * segments + s % segments;
        let mut triangles = Vec::new();
        for s in 0..segments {
            triangles.push([0, at(1, s), at(1, s + 1)]);
            triangles.push([last, at(rings - 1, s + 1), at(rings - 1, s)]);
        }
        for ring in 1..rings - 1 {
            for s in 0..segments {
                triangles.push([at(ring, s), at(ring + 1, s), at(ring + 1, s + 1)]);
                triangles.push([at(ring, s), at(ring + 1, s + 1), at(ring, s + 1)]);
            }
        }
        (
            positions,
            triangles.into_iter().map(|t| t.map(|v| v + base)).collect(),
        )
    }

    pub(crate) fn identity_fit() -> FittedMask {
        let mask = Mask::candide3();
        let fit = Fit {
            pose: MaskPose::IDENTITY,
            shape: vec![0.0; mask.shape_units.len()],
            nudges: Vec::new(),
            mm_per_unit: 100.0,
        };
        FittedMask::new(mask, fit)
    }

    #[test]
    fn a_sphere_is_fitted_exactly_and_a_plane_is_refused() {
        let (points, _) = eyeball(Vec3::new(0.3, -0.2, 0.1), 0.12, 0.0, 0);
        let (centre, radius) = fit_sphere(&points).unwrap();
        assert!(centre.abs_diff_eq(Vec3::new(0.3, -0.2, 0.1), 1e-5), "{centre}");
        assert!((radius - 0.12).abs() < 1e-5, "{radius}");
        let flat: Vec<Vec3> = (0..20)
            .map(|k| Vec3::new(k as f32, (k * k) as f32 % 7.0, 0.0))
            .collect();
        assert_eq!(fit_sphere(&flat), None);
    }

    #[test]
    fn two_eyeballs_split_by_side_each_about_its_own_centre() {
        let fitted = identity_fit();
        // Mask units here (the identity fit): the left eye at +x.
        let (mut p, mut t) = eyeball(Vec3::new(0.3, 0.2, -0.1), 0.12, 0.015, 0);
        let (p2, t2) = eyeball(Vec3::new(-0.3, 0.2, -0.1), 0.12, 0.015, p.len() as u32);
        p.extend(p2);
        t.extend(t2);
        let eyes = Eyeball::of_part(&Head::new("eyes", p, t), "eyes", &fitted).unwrap();
        assert_eq!(eyes.len(), 2);
        assert_eq!((eyes[0].name.as_str(), eyes[0].side), ("eyes_left", Side::Left));
        assert_eq!((eyes[1].name.as_str(), eyes[1].side), ("eyes_right", Side::Right));
        assert_eq!(eyes[0].split_from.as_deref(), Some("eyes"));
        for (eye, x) in eyes.iter().zip([0.3, -0.3]) {
            // The cornea pulls the fitted centre forward by a little of its bulge.
            let expected = Vec3::new(x, 0.2, -0.1);
            assert!(
                eye.centre.distance(expected) < 0.004,
                "{} {}",
                eye.name,
                eye.centre
            );
            assert!(eye.forward.abs_diff_eq(Vec3::Z, 1e-6));
            // The profile: the sclera's radius behind, the cornea's in front.
            let about_true = RadialProfile::of(&eye.mesh.positions, expected, Vec3::Z);
            assert!((about_true.radius_at(-1.0) - 0.12).abs() < 1e-4);
            assert!((about_true.radius_at(0.0) - 0.12).abs() < 1e-4);
            assert!(
                (about_true.radius_at(1.0) - 0.135).abs() < 1e-3,
                "{}",
                about_true.radius_at(1.0)
            );
            assert_eq!(eye.mesh.positions.len(), 2 + 23 * 32);
        }

        // One eyeball alone keeps its name and finds its side.
        let (p, t) = eyeball(Vec3::new(-0.3, 0.2, -0.1), 0.12, 0.0, 0);
        let one = Eyeball::of_part(&Head::new("eye_r", p, t), "eye_r", &fitted).unwrap();
        assert_eq!(
            (one.len(), one[0].name.as_str(), one[0].side),
            (1, "eye_r", Side::Right)
        );
        assert_eq!(one[0].split_from, None);
    }
}
