//! Quality metrics of a deformed head (ALGORITHMS.md section 3, docs/METRICS.md):
//! dihedral roughness, restricted to the lips and tabulated per frame like the thesis's
//! `dataMetrics.txt`, aggregated per syllable and per algorithm; and fidelity (control
//! error at the anchors, mouth opening, error against artist-made expression targets).
//!
//! Regions and evaluators are built once per head and fit; per-frame calls allocate
//! nothing. Lengths are in head units going in and millimetres coming out.

mod aggregate;
mod contact;
mod face_crease;
mod face_region;
mod fidelity;
mod folds;
mod lip_region;
mod lip_roughness;
mod region;
mod roughness;
mod table;

pub use aggregate::{algorithm_score, AlgorithmScore, SyllableScore, SyllableScores};
pub use contact::{ContactFrame, MouthContact};
pub use face_crease::FaceCrease;
pub use face_region::{FaceVertices, FACE_RADIUS_MM};
pub use fidelity::{
    control_error, ground_truth_error, mouth_opening, ControlError, FidelityError, GroundTruthError,
    MouthOpening, MIN_MASK_OPENING_MM, MOVING_CONTROL_MM,
};
pub use folds::{FoldMeter, Folds, FLIP_DEG, FOLDS_TSV_HEADER, FOLD_DEG};
pub use lip_region::{LipRegion, LIP_RADIUS_MM};
pub use lip_roughness::{LipRoughness, LipRoughnessRow, LIP_ROWS, SUMMARY_MASK_VERTEX};
pub use region::RegionError;
pub use roughness::{Roughness, RoughnessError, VARIANCE_FLOOR};
pub use table::{RoughnessTsvWriter, TsvError, TSV_HEADER};
