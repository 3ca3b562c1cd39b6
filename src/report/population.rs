//! The animation on the population: each whole head of [`crate::population`], with its
//! teeth, gums and tongue as users have them, registered from its landmark fit and from its
//! automatic fit, and driven through a stream by one algorithm (the default): lip folds,
//! lips in the teeth beyond rest, the tongue in the teeth, the f/v gap, the ground truth
//! against the head's expression targets, and the deform time; for heads with eyes, the
//! lids in the eyeballs over [`EYES_S`] of blinks and glances ([`IdleEyes`]) with and
//! without the lid constraint. `facewire population --animate` prints the table
//! (docs/METRICS.md, "On a population").

use std::path::Path;
use std::time::Instant;

use serde::Serialize;

use std::sync::Arc;

use super::{compare, Candidate, CompareInput};
use crate::animate::{AnimatedHead, FrameJob, Heat, PartInput};
use crate::deform::Registration;
use crate::fit::{fit_automatically, FittedMask};
use crate::head::PartRole;
use crate::mask::Mask;
use crate::population::Member;
use crate::stream::{ArkitBasis, Frame, IdleEyes};
use crate::targets::ExpressionTarget;

/// Which fit of a member's head the animation starts from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FitSource {
    /// The landmark fit the member's reference comes from.
    Landmarks,
    /// `fit_automatically`, scale guessed.
    Automatic,
}

impl FitSource {
    pub fn name(self) -> &'static str {
        match self {
            FitSource::Landmarks => "landmarks",
            FitSource::Automatic => "automatic",
        }
    }
}

/// One member animated from one fit.
#[derive(Debug, Clone, Serialize)]
pub struct AnimationOutcome {
    pub member: String,
    pub held_out: bool,
    pub fit: FitSource,
    /// Wall time of fit, registration, binding and the run, s.
    pub seconds: f64,
    /// The measures, or why the head could not be animated.
    pub result: Result<AnimationMeasures, String>,
}

/// What one algorithm did to one head over the stream.
#[derive(Debug, Clone, Serialize)]
pub struct AnimationMeasures {
    /// Lip triangle-frames turned more than 60 degrees from rest.
    pub lip_folds: u64,
    /// The sharpest new fold anywhere on the face, degrees.
    pub fold_deg: f64,
    /// Lip vertices inside a tooth at rest; `None` without teeth.
    pub lips_in_teeth_at_rest: Option<u32>,
    /// Lip vertex-frames inside a tooth beyond the rest count (per frame, the count minus
    /// the rest count when above it, summed); `None` without teeth.
    pub lips_in_teeth: Option<u64>,
    /// Frames with the tongue in a tooth, and the deepest it went (mm); `None` without a
    /// tongue and teeth.
    pub tongue_frames_in_teeth: Option<usize>,
    pub tongue_depth_mm: Option<f32>,
    /// The widest closest approach of the lower lip to the upper teeth over the f and v
    /// syllables, mm.
    pub fv_gap_mm: Option<f64>,
    /// Mean RMS error over the expression targets, mm; `None` without targets.
    pub ground_truth_rms_mm: Option<f64>,
    /// Over the expression targets, each asked for at weight 1 (`None` without targets):
    /// lip triangles turned more than 60 degrees by the algorithm, by the targets
    /// themselves, and by the algorithm where its target does not turn them (summed).
    pub target_lip_folds: Option<TargetLipFolds>,
    /// Median deform call, microseconds (this machine).
    pub deform_us: f64,
    /// Parts given whole that were split into upper and lower rows (`teeth`).
    pub split_parts: Vec<String>,
    /// Eyeballs found (0 for a head without an eyes part).
    pub eyes: usize,
    /// Over [`EYES_S`] of blinks and glances: skin vertex-frames deeper in an eyeball than
    /// at rest, without the lid constraint and with it; `None` without eyes.
    pub lids_in_eyes_unconstrained: Option<u64>,
    pub lids_in_eyes: Option<u64>,
}

/// Lip folds on the expression targets, summed over them.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct TargetLipFolds {
    pub algorithm: u64,
    pub targets: u64,
    pub algorithm_not_in_target: u64,
}

/// Seconds of blinks and glances the eyes are measured over (25 frames a second; five or
/// six blinks).
pub const EYES_S: f64 = 20.0;

/// The blinks and glances of the eyes' measure.
const EYES: IdleEyes = IdleEyes { seed: 11 };

/// Lid vertex-frames in the eyes of `animated` over [`EYES_S`] of [`EYES`] by `algorithm`,
/// with the lid constraint and (from `bare`, the same head without eyes) without it.
fn lids_in_eyes(
    animated: &Arc<AnimatedHead>,
    bare: &Arc<AnimatedHead>,
    algorithm: &Candidate,
) -> Option<(u64, u64)> {
    let lids = animated.eyelids.as_ref()?;
    let binding = Arc::new(crate::deform::bind(&animated.registration, &algorithm.spec));
    let basis = Arc::new(ArkitBasis::shipped());
    let mut with = FrameJob::new(animated.clone(), binding.clone(), basis.clone(), Heat::None).ok()?;
    let mut without = FrameJob::new(bare.clone(), binding, basis, Heat::None).ok()?;
    let rest = &animated.registration.head.positions;
    let (mut constrained, mut unconstrained) = (0u64, 0u64);
    for k in 0..(EYES_S * 25.0) as u64 {
        let mut frame = Frame::at(k, k as f64 / 25.0);
        EYES.add_to(frame.time_s, &mut frame.arkit);
        with.deform(&frame);
        constrained += u64::from(lids.measure(rest, with.deformed(), with.eye_motions()).vertices);
        without.deform(&frame);
        unconstrained += u64::from(
            lids.measure(rest, without.deformed(), with.eye_motions())
                .vertices,
        );
    }
    Some((unconstrained, constrained))
}

/// Animates `member` from `fit` through `stream` with `algorithm`, scoring the ground
/// truth on `targets` (empty for none).
pub fn animate(
    member: &Member,
    fit: FitSource,
    mask: &Mask,
    stream: &Path,
    algorithm: &Candidate,
    targets: &[ExpressionTarget],
) -> AnimationOutcome {
    let started = Instant::now();
    let result = measure(member, fit, mask, stream, algorithm, targets);
    AnimationOutcome {
        member: member.spec.name(),
        held_out: member.spec.held_out,
        fit,
        seconds: started.elapsed().as_secs_f64(),
        result,
    }
}

/// What [`animate`] measures, or why it could not.
fn measure(
    member: &Member,
    source: FitSource,
    mask: &Mask,
    stream: &Path,
    algorithm: &Candidate,
    targets: &[ExpressionTarget],
) -> Result<AnimationMeasures, String> {
    let fit = match source {
        FitSource::Landmarks => member
            .landmark_fit
            .clone()
            .ok_or("no landmark fit: the member's head is not its source's")?,
        FitSource::Automatic => {
            fit_automatically(&member.head, mask, None)
                .map_err(|e| format!("automatic fit: {e}"))?
                .fit
        }
    };
    let registration = Registration::try_new(member.head.clone(), FittedMask::new(mask.clone(), fit))
        .map_err(|e| format!("registration: {e}"))?;
    let without_eyes: Vec<PartInput> = member
        .parts
        .iter()
        .filter(|p| p.role != Some(PartRole::Eyes))
        .cloned()
        .collect();
    let bare = AnimatedHead::with_parts(registration.clone(), without_eyes).map_err(|e| e.to_string())?;
    let animated = AnimatedHead::with_parts(registration, member.parts.clone()).map_err(|e| e.to_string())?;
    let (animated, bare) = (Arc::new(animated), Arc::new(bare));
    let lids = lids_in_eyes(&animated, &bare, algorithm);
    let basis = ArkitBasis::shipped();
    let input = CompareInput {
        head: &animated,
        stream,
        basis: &basis,
        algorithms: std::slice::from_ref(algorithm),
        targets,
    };
    let comparison = compare(&input, &mut |_| {}).map_err(|e| e.to_string())?;
    let result = comparison.algorithms.first().ok_or("no algorithm ran")?;
    let rest = comparison.rest_contact.map(|c| c.lips_in_teeth);
    let beyond_rest = rest.map(|rest| {
        result
            .contact
            .iter()
            .map(|r| u64::from(r.contact.lips_in_teeth.saturating_sub(rest)))
            .sum()
    });
    Ok(AnimationMeasures {
        lip_folds: result.summary.lip_folds,
        fold_deg: result.summary.fold_deg,
        lips_in_teeth_at_rest: rest,
        lips_in_teeth: beyond_rest,
        tongue_frames_in_teeth: comparison.tongue.map(|t| t.frames_in_teeth),
        tongue_depth_mm: comparison.tongue.map(|t| t.max_depth_mm),
        fv_gap_mm: result.summary.fv_gap_mm,
        ground_truth_rms_mm: result.summary.ground_truth_rms_mm,
        target_lip_folds: (!result.ground_truth.is_empty()).then(|| TargetLipFolds {
            algorithm: result.ground_truth.iter().map(|r| u64::from(r.lip_folds)).sum(),
            targets: result
                .ground_truth
                .iter()
                .map(|r| u64::from(r.target_lip_folds))
                .sum(),
            algorithm_not_in_target: result
                .ground_truth
                .iter()
                .map(|r| u64::from(r.lip_folds_not_in_target))
                .sum(),
        }),
        deform_us: result.summary.deform_us,
        split_parts: animated.splits.iter().map(|s| s.name.clone()).collect(),
        eyes: animated.eyes.len(),
        lids_in_eyes_unconstrained: lids.map(|l| l.0),
        lids_in_eyes: lids.map(|l| l.1),
    })
}
