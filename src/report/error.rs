//! Why a comparison or its report failed, with the file, algorithm or target at fault.

use crate::animate::{FrameJobError, MeterError};
use crate::deform::SpecError;
use crate::metrics::{FidelityError, RegionError, RoughnessError};
use crate::stream::StreamError;
use crate::targets::TargetError;

/// A failed comparison or report.
#[derive(Debug, thiserror::Error)]
pub enum CompareError {
    #[error("--algos item {item:?}: {source}")]
    Algorithm { item: String, source: SpecError },
    #[error("--algos: parameter {item:?} follows {previous:?}, which has no `name:` part; write {previous}:{item}")]
    DanglingParameter { item: String, previous: String },
    #[error("--algos: {spec} is listed twice ({first} and {second})")]
    Repeated {
        spec: String,
        first: String,
        second: String,
    },
    #[error("--algos: the list is empty; give specs or letters A-V separated by commas")]
    NoAlgorithms,
    #[error(transparent)]
    Stream(#[from] StreamError),
    #[error("{path}: the stream has no frames")]
    EmptyStream { path: String },
    #[error("the face vertices of the head: {0}")]
    FaceRegion(#[source] RegionError),
    #[error("the face roughness evaluator of the head: {0}")]
    FaceEvaluator(#[source] RoughnessError),
    #[error("roughness with {algorithm}, frame {frame}: {source}")]
    Roughness {
        algorithm: String,
        frame: usize,
        source: RoughnessError,
    },
    #[error("lip roughness or folds with {algorithm}, frame {frame}: {source}")]
    Meters {
        algorithm: String,
        frame: usize,
        source: MeterError,
    },
    #[error("lip folds with {algorithm}, target {target}: {source}")]
    TargetFolds {
        algorithm: String,
        target: String,
        source: crate::metrics::RegionError,
    },
    #[error("{algorithm}: {source}")]
    Job {
        algorithm: String,
        source: FrameJobError,
    },
    #[error("fidelity with {algorithm}: {source}")]
    Fidelity {
        algorithm: String,
        source: FidelityError,
    },
    #[error("expression targets: {0}")]
    Target(#[from] TargetError),
    #[error("cannot create {path}: {source}")]
    CreateDir { path: String, source: std::io::Error },
    #[error("cannot write {path}: {source}")]
    Write { path: String, source: std::io::Error },
    #[error("cannot draw {path}: {message}")]
    Chart { path: String, message: String },
}
