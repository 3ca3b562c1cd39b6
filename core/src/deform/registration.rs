//! Everything binding needs about one head and its fit, computed once: the anchors, the
//! surface distance (mm) from every control anchor to every head vertex, and each head
//! vertex's projection onto the fitted mask.
//!
//! The distance table is dense (controls x head vertices, f32): 104 x 8,838 is 3.7 MB,
//! 104 x 100k is 42 MB. Its rows are computed in parallel, one Dijkstra per control.
//!
//! [`Registration::try_new`] first refuses what cannot be animated (docs/FITTING.md, "What
//! a fit may hold"): a degenerate head, fit numbers out of range, a head of implausible
//! physical size, a mask that misses the head.

use glam::Vec3;
use rayon::prelude::*;

use super::mouth_calibration::{close_rest_mouth, MouthCalibrationError};
use super::projection::{project, Projection};
use crate::fit::{anchor_mask, Anchors, FittedMask, MouthCalibration, RangeError};
use crate::head::{check_animatable, AnimatableError, Bounds, Head, SurfaceDistance};
use crate::mask::OUTER_LIP_CORNERS;

/// Bounding-box diagonal of a head in mm (the shipped ones: 400 and 643), a doll's head to a
/// statue's. Every radius and tolerance of the deformers is in mm, so a head outside this
/// has a wrong `mm_per_unit`.
pub const HEAD_SIZE_MM: [f32; 2] = [10.0, 10_000.0];

/// Bounding-box diagonal of the fitted neutral mask over the head's: the face is a part
/// of the head (0.36 and 0.58 on the shipped heads), neither a speck on it nor many times it.
pub const MASK_TO_HEAD_SIZE: [f32; 2] = [0.02, 5.0];

/// Why a head and its fit cannot be registered.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RegistrationError {
    #[error(transparent)]
    Head(#[from] AnimatableError),
    #[error("fit: {0}")]
    Fit(#[from] RangeError),
    #[error("closing the mouth open at rest: {0}")]
    MouthCalibration(#[from] MouthCalibrationError),
    #[error("fit: the fitted mask has a non-finite vertex ({vertex})")]
    MaskNotFinite { vertex: usize },
    #[error(
        "{name}: {size_mm} mm across at {mm_per_unit} mm per head unit; a head is {} to {} mm (check mm_per_unit)",
        HEAD_SIZE_MM[0],
        HEAD_SIZE_MM[1]
    )]
    HeadSize {
        name: String,
        size_mm: f32,
        mm_per_unit: f32,
    },
    #[error(
        "{name}: the fitted mask (bounds {mask_min:?} to {mask_max:?}) does not touch the head (bounds {head_min:?} to {head_max:?}), head units"
    )]
    MaskOffHead {
        name: String,
        mask_min: [f32; 3],
        mask_max: [f32; 3],
        head_min: [f32; 3],
        head_max: [f32; 3],
    },
    #[error(
        "{name}: the fitted mask is {ratio} times the head's size; it must be {} to {} (check scale)",
        MASK_TO_HEAD_SIZE[0],
        MASK_TO_HEAD_SIZE[1]
    )]
    MaskSize { name: String, ratio: f32 },
}

/// A head with a fitted mask, ready to bind any algorithm to.
#[derive(Debug, Clone)]
pub struct Registration {
    pub head: Head,
    pub fitted: FittedMask,
    pub anchors: Anchors,
    /// Mask vertices used by a triangle: the control points.
    pub controls: Vec<u32>,
    pub is_control: Vec<bool>,
    /// `distance[j * n + v]`: surface distance in mm from the anchor of mask vertex `j` to
    /// head vertex `v`; infinite for non-controls and unreachable vertices.
    distance: Vec<f32>,
    /// One per head vertex.
    pub projections: Vec<Projection>,
    /// Longest edge of each mask triangle on the fitted neutral mask, mm.
    pub longest_edge_mm: Vec<f32>,
    /// How the head's rest mouth was closed, for a head given with its lips apart
    /// ([`Registration::try_new`]); `head` is then the closed head.
    pub mouth_calibration: Option<MouthCalibration>,
}

impl Registration {
    /// Checks that `head` with `fitted` can be animated, then registers it: the entry
    /// point for heads and fits from outside (files, uploads). Refuses a head that
    /// [`check_animatable`] refuses, fit numbers out of range, a head whose size in mm is
    /// outside [`HEAD_SIZE_MM`], and a fitted mask that misses the head's bounding box or
    /// whose size relative to the head is outside [`MASK_TO_HEAD_SIZE`].
    ///
    /// A head whose lips are apart at rest is closed first ([`close_rest_mouth`]):
    /// [`Registration::mouth_calibration`] says by how much.
    pub fn try_new(head: Head, fitted: FittedMask) -> Result<Registration, RegistrationError> {
        Registration::check(&head, &fitted)?;
        Ok(match close_rest_mouth(&head, &fitted)? {
            Some((closed, fitted, calibration)) => Registration {
                mouth_calibration: Some(calibration),
                ..Registration::new(closed, fitted)
            },
            None => Registration::new(head, fitted),
        })
    }

    /// The checks of [`Registration::try_new`] alone (milliseconds; registering takes
    /// seconds): for `facewire inspect` and for refusing a request before queueing it.
    pub fn check(head: &Head, fitted: &FittedMask) -> Result<(), RegistrationError> {
        check_animatable(head)?;
        fitted.fit.check_ranges()?;
        if let Some(vertex) = fitted.neutral.iter().position(|p| !p.is_finite()) {
            return Err(RegistrationError::MaskNotFinite { vertex });
        }
        let name = || head.name.clone();
        let head_box = head.bounds();
        let mm_per_unit = fitted.fit.mm_per_unit;
        let size_mm = head_box.size().length() * mm_per_unit;
        if !(HEAD_SIZE_MM[0]..=HEAD_SIZE_MM[1]).contains(&size_mm) {
            return Err(RegistrationError::HeadSize {
                name: name(),
                size_mm,
                mm_per_unit,
            });
        }
        let mask_box = Bounds::of(&fitted.neutral);
        let overlaps = mask_box.min.cmple(head_box.max).all() && head_box.min.cmple(mask_box.max).all();
        if !overlaps {
            return Err(RegistrationError::MaskOffHead {
                name: name(),
                mask_min: mask_box.min.to_array(),
                mask_max: mask_box.max.to_array(),
                head_min: head_box.min.to_array(),
                head_max: head_box.max.to_array(),
            });
        }
        let ratio = mask_box.size().length() / head_box.size().length();
        if !(MASK_TO_HEAD_SIZE[0]..=MASK_TO_HEAD_SIZE[1]).contains(&ratio) {
            return Err(RegistrationError::MaskSize { name: name(), ratio });
        }
        Ok(())
    }

    /// Registers without the checks of [`Registration::try_new`]: for heads and fits
    /// already checked, and synthetic ones in tests.
    pub fn new(head: Head, fitted: FittedMask) -> Registration {
        let mm = fitted.fit.mm_per_unit;
        let anchors = anchor_mask(&head, &fitted.neutral, mm);
        let is_control = fitted.mask.used_vertices();
        let controls: Vec<u32> = (0..is_control.len() as u32)
            .filter(|&j| is_control[j as usize])
            .collect();
        let n = head.positions.len();
        let m = fitted.mask.vertices.len();

        let mut distance = vec![f32::INFINITY; m * n];
        distance
            .par_chunks_mut(n)
            .enumerate()
            .filter(|(j, _)| is_control[*j])
            .for_each_init(
                || SurfaceDistance::new(n),
                |search, (j, row)| {
                    search.run(&head.topology, &[(anchors.vertex[j], 0.0)], f32::INFINITY);
                    for &v in search.reached() {
                        row[v as usize] = search.distance(v) * mm;
                    }
                },
            );

        let longest_edge_mm = fitted
            .mask
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| fitted.neutral[v as usize]);
                a.distance(b).max(b.distance(c)).max(c.distance(a)) * mm
            })
            .collect();

        let mut registration = Registration {
            head,
            fitted,
            anchors,
            controls,
            is_control,
            distance,
            projections: Vec::new(),
            longest_edge_mm,
            mouth_calibration: None,
        };
        registration.projections = (0..n as u32)
            .into_par_iter()
            .map(|v| project(&registration, v))
            .collect();
        registration
    }

    pub fn vertex_count(&self) -> usize {
        self.head.positions.len()
    }

    /// Millimetres per head unit.
    pub fn mm_per_unit(&self) -> f32 {
        self.fitted.fit.mm_per_unit
    }

    /// The mouth's width at rest, head units: from one outer lip corner's anchor to the
    /// other's ([`OUTER_LIP_CORNERS`]). The length the mouth's own contacts and smoothing
    /// are measured in, so that they scale with the head.
    pub fn mouth_width(&self) -> f32 {
        let [left, right] = OUTER_LIP_CORNERS.map(|j| self.head.positions[self.anchors.vertex[j] as usize]);
        left.distance(right)
    }

    /// Surface distance (mm) from the anchor of mask vertex `j` to head vertex `v`.
    pub fn distance_to_control(&self, j: u32, v: u32) -> f32 {
        self.distance[j as usize * self.vertex_count() + v as usize]
    }

    /// Surface distance (mm) from head vertex `v` to mask triangle `t`: the distance to
    /// its nearest corner's anchor (the thesis's rule), and that corner.
    pub fn distance_to_triangle(&self, t: usize, v: u32) -> (f32, u32) {
        self.fitted.mask.triangles[t]
            .iter()
            .map(|&j| (self.distance_to_control(j, v), j))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .expect("triangles have three corners")
    }

    /// The fitted neutral mask (head units).
    pub fn mask_rest(&self) -> &[Vec3] {
        &self.fitted.neutral
    }

    pub fn mask_triangles(&self) -> &[[u32; 3]] {
        &self.fitted.mask.triangles
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::fit::{Fit, FitFile};
    use crate::mask::{Mask, MaskPose};

    fn shipped(name: &str) -> (Head, Fit) {
        let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/heads");
        let head = Head::load(&data.join(format!("{name}.obj"))).unwrap();
        let fit = FitFile::load(&data.join(format!("{name}.fit.toml")))
            .unwrap()
            .resolve(name, &Mask::candide3())
            .unwrap();
        (head, fit)
    }

    fn check(head: &Head, fit: Fit) -> Result<(), RegistrationError> {
        Registration::check(head, &FittedMask::new(Mask::candide3(), fit))
    }

    #[test]
    fn shipped_heads_pass_and_wild_fits_are_refused() {
        let (head, fit) = shipped("lee_perry_smith_head");
        assert_eq!(check(&head, fit.clone()), Ok(()));
        let (makehuman, makehuman_fit) = shipped("makehuman_head");
        assert_eq!(check(&makehuman, makehuman_fit), Ok(()));

        let with_pose = |scale: f32, translation: Vec3| Fit {
            pose: MaskPose::similarity(fit.pose.rotation_rad, scale, translation),
            ..fit.clone()
        };
        let err = check(&head, with_pose(1e30, fit.pose.translation)).unwrap_err();
        assert!(
            matches!(&err, RegistrationError::Fit(e) if e.field == "scale"),
            "{err}"
        );
        let err = check(
            &head,
            Fit {
                mm_per_unit: 1e-30,
                ..fit.clone()
            },
        )
        .unwrap_err();
        assert!(
            matches!(&err, RegistrationError::Fit(e) if e.field == "mm_per_unit"),
            "{err}"
        );
        let err = check(
            &head,
            Fit {
                mm_per_unit: 1e-3,
                ..fit.clone()
            },
        )
        .unwrap_err();
        assert!(matches!(err, RegistrationError::HeadSize { .. }), "{err}");
        let err = check(&head, with_pose(fit.pose.scale.x, Vec3::new(1e4, 0.0, 0.0))).unwrap_err();
        assert!(matches!(err, RegistrationError::MaskOffHead { .. }), "{err}");
        let err = check(&head, with_pose(1e-4, fit.pose.translation)).unwrap_err();
        assert!(matches!(err, RegistrationError::MaskSize { .. }), "{err}");
        let err = check(&head, with_pose(1e3, fit.pose.translation)).unwrap_err();
        assert!(matches!(err, RegistrationError::MaskSize { .. }), "{err}");
    }

    #[test]
    fn a_lone_triangle_is_not_registered() {
        let (_, fit) = shipped("lee_perry_smith_head");
        let head = Head::new("one.obj", vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
        let err = Registration::try_new(head, FittedMask::new(Mask::candide3(), fit)).unwrap_err();
        assert_eq!(err.to_string(), "one.obj: 3 vertices; a face needs at least 100");
    }
}
