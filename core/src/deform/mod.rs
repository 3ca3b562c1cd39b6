//! Deforming a dense head from the moved CANDIDE-3 mask, with every interpolation
//! variant of the thesis plus Kshirsagar as published and RBF.
//!
//! Each algorithm is split into **bind** (once per head, fit and spec; sees the neutral
//! geometry; may be slow and runs in parallel) and **deform** (every frame; one pass over
//! the bound terms, no allocation). See docs/ALGORITHMS.md for each variant.

mod anchor_system;
mod bary1;
mod bary2;
mod biharmonic;
mod binding;
mod bones;
mod geometric;
mod kshirsagar;
mod lip_seam;
mod lip_smoothing;
mod mouth_calibration;
mod needles;
mod normalize;
pub mod planar_bones;
mod point_distance;
pub mod projection;
mod rbf;
mod registration;
mod renato1;
mod renato2;
mod renato3;
mod row_merge;
pub mod spec;
mod triangle_basis;
mod weights;

pub use binding::{Binding, Csr, DeformScratch, LinearTerm, SourceMap, TriangleTerm};
pub use mouth_calibration::{close_rest_mouth, MouthCalibrationError};
pub use projection::Projection;
pub use registration::{Registration, RegistrationError, HEAD_SIZE_MM, MASK_TO_HEAD_SIZE};
pub use spec::{AlgoSpec, Kernel, Metric, RbfParams, SpecError, Weights};
pub use triangle_basis::TriangleBasis;
pub use weights::triangle_weights;

/// Binds `spec` to a registered head.
pub fn bind(reg: &Registration, spec: &AlgoSpec) -> Binding {
    match *spec {
        AlgoSpec::Bary1(p) => bary1::bind(reg, *spec, p.alpha),
        AlgoSpec::Bary2(p) => bary2::bind(reg, *spec, &p.weights),
        AlgoSpec::Geometric(p) => geometric::bind(reg, *spec, &p.weights),
        AlgoSpec::PointDistance(p) => point_distance::bind(reg, *spec, p.k, p.local, p.interpolate),
        AlgoSpec::PlanarBones(p) => planar_bones::bind(reg, *spec, &p.weights),
        AlgoSpec::Renato1(_) => renato1::bind(reg, *spec),
        AlgoSpec::Renato2(p) => renato2::bind(reg, *spec, p.alpha),
        AlgoSpec::Renato3(p) => renato3::bind(reg, *spec, &p.weights),
        AlgoSpec::Kshirsagar(_) => kshirsagar::bind(reg, *spec),
        AlgoSpec::Rbf(params) => rbf::bind(reg, *spec, &params),
        AlgoSpec::Biharmonic(p) => {
            let reach = biharmonic::Reach {
                eyes_mm: p.eyes_hold_mm,
                other_mm: p.hold_mm,
            };
            biharmonic::bind(reg, *spec, reach, p.k, p.smooth_lips)
        }
    }
}

/// `exp(-|P - C| / alpha^2)`: the legacy falloff of eq. 1.2, `distance` in mask units.
pub(crate) fn legacy_falloff(distance_mask_units: f32, alpha: f32) -> f32 {
    (-distance_mask_units / (alpha * alpha)).exp()
}
