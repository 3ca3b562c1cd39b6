//! Runs the comparison: every algorithm bound once to the registered head and driven through
//! every frame of a stream by the service's own per-frame job ([`FrameJob`]: deform, then
//! its [`FrameMeters`]), so the lip roughness and folds reported are those a viewer is
//! sent; beside them fidelity and the face's crease per frame (docs/METRICS.md), and the
//! job's deform stage timed. Then, where the head has artist-made expression targets,
//! each algorithm is driven by each target sampled at the anchors and measured against
//! the target itself.

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;
use serde::Serialize;

use super::{Candidate, CompareError};
use crate::animate::{AnimatedHead, FrameJob, FrameJobError, FrameMeters, Heat};
use crate::deform::{bind, Registration};
use crate::mask::{INNER_LIP_MID_LOWER, INNER_LIP_MID_UPPER};
use crate::metrics::{
    control_error, ground_truth_error, mouth_opening, ContactFrame, FaceCrease, FaceVertices, FoldMeter,
    MouthContact, SyllableScores, LIP_ROWS,
};
use crate::stream::{open_stream, ArkitBasis};
use crate::targets::ExpressionTarget;

/// Syllable label of frames that carry none.
pub const UNLABELLED: &str = "-";

/// What to compare.
#[derive(Clone, Copy)]
pub struct CompareInput<'a> {
    /// The head with its fitted mask (registered once for every algorithm), its parts
    /// (teeth, gums, tongue, eyes, with their roles, for the contact measures) and the
    /// constraints the per-frame job applies after each deform.
    pub head: &'a Arc<AnimatedHead>,
    /// The parameter stream (`.jsonl`, `.fap`, `.fau`); read once to check and count it,
    /// then once per algorithm, so it is never held in memory whole.
    pub stream: &'a Path,
    /// Retargets the frames' ARKit weights onto the mask.
    pub basis: &'a ArkitBasis,
    pub algorithms: &'a [Candidate],
    /// Expression targets of this head for the ground-truth error; empty for none.
    pub targets: &'a [ExpressionTarget],
}

/// Where a running comparison is, for a progress display.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress<'a> {
    /// 0-based index of the algorithm being run, of `algorithms`.
    pub algorithm: usize,
    pub algorithms: usize,
    /// Its label (letter).
    pub label: &'a str,
    pub stage: Stage,
}

/// What the current algorithm is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    Binding,
    /// `done` of `total` stream frames deformed and measured.
    Frames {
        done: usize,
        total: usize,
    },
    /// `done` of `total` expression targets deformed and measured.
    Targets {
        done: usize,
        total: usize,
    },
    Finished,
}

/// One row of the algorithms table (`algorithms.tsv`, `--json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AlgorithmSummary {
    /// The preset letter, or `X1`, `X2`, ... for a spec that is not a preset.
    pub letter: String,
    /// The canonical spec.
    pub spec: String,
    /// Mean over syllables of each syllable's mean lip roughness (dimensionless).
    pub roughness_mean: f64,
    /// Population variance of the syllable means.
    pub roughness_var: f64,
    /// Control error at the anchors, mm: the mean over the frames that move a control of
    /// each frame's mean over its moving controls.
    pub control_err_mm: f64,
    /// Head mouth opening over mask mouth opening, mean over the frames whose mask opening
    /// is at least 1 mm; `None` when no frame opens the mask that far.
    pub mouth_opening_ratio: Option<f64>,
    /// Median wall time of one frame's deform (the algorithm, then the contact constraint
    /// on a head with teeth), microseconds (varies by machine).
    pub deform_us: f64,
    /// Mean over the expression targets of the RMS error over the face vertices, mm;
    /// `None` without targets.
    pub ground_truth_rms_mm: Option<f64>,
    /// Mean over frames of the mean `rho(T)` over the face triangles (dimensionless).
    pub face_roughness_mean: f64,
    /// Median over frames of the largest rise of a face triangle's `rho(T)` over its rest
    /// value: the sharpest new crease of a typical frame (dimensionless).
    pub crease: f64,
    /// Lip triangles turned more than 60 degrees from rest (after the lip region's own
    /// rigid motion), summed over frames: triangle-frames folded near the lips.
    pub lip_folds: u64,
    /// The largest increase of a dihedral angle over rest between two face triangles, in
    /// any frame, degrees: the sharpest fold anywhere on the face.
    pub fold_deg: f64,
    /// Lip vertices inside a tooth, summed over frames (vertex-frames); `None` for a head
    /// without teeth.
    pub lips_in_teeth: Option<u64>,
    /// The widest of the closest approaches of the lower lip to the upper teeth in each
    /// labiodental syllable (a run of frames whose label starts with `f` or `v`), mm:
    /// under 1.5 mm when every f and v brings the lip to the teeth. `None` without teeth or
    /// without such syllables.
    pub fv_gap_mm: Option<f64>,
}

/// One syllable's roughness under one algorithm.
#[derive(Debug, Clone, PartialEq)]
pub struct SyllableRow {
    pub syllable: String,
    pub frames: u64,
    pub roughness_mean: f64,
}

/// One expression target reproduced by one algorithm (or not moved at all).
#[derive(Debug, Clone, PartialEq)]
pub struct TargetRow {
    pub target: String,
    pub rms_mm: f64,
    pub max_mm: f64,
    /// Lip triangles the measured head turned more than 60 degrees (`metrics::FOLD_DEG`)
    /// from rest: the algorithm's when asked for the target, 0 for the head at rest.
    pub lip_folds: u32,
    /// The target's own lip triangles turned more than 60 degrees: what the face itself
    /// does.
    pub target_lip_folds: u32,
    /// Of `lip_folds`, those the target does not turn past 60 degrees itself.
    pub lip_folds_not_in_target: u32,
}

/// Everything measured about one algorithm.
#[derive(Debug, Clone, PartialEq)]
pub struct AlgorithmResult {
    pub summary: AlgorithmSummary,
    /// In order of each syllable's first frame.
    pub syllables: Vec<SyllableRow>,
    /// In target order; empty without targets.
    pub ground_truth: Vec<TargetRow>,
    /// Contact measures of every frame, in stream order; empty for a head without teeth.
    pub contact: Vec<ContactRow>,
}

/// The contact measures of one frame under one algorithm.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactRow {
    pub frame: usize,
    pub label: String,
    pub contact: ContactFrame,
}

/// The outcome of a comparison.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    pub head_vertices: usize,
    pub mm_per_unit: f32,
    pub frames: usize,
    /// Distinct syllable labels of the stream.
    pub syllables: usize,
    /// Frames in which some control moves (those the control error averages over).
    pub moving_frames: usize,
    /// Frames whose mask opening is at least 1 mm (those the opening ratio averages over).
    pub open_frames: usize,
    /// The opening ratio of a head whose anchors move exactly with their controls: what a
    /// faithful algorithm scores. Not 1 where the head's lips are apart at rest while the
    /// mask's touch. `None` when no frame opens the mask 1 mm.
    pub exact_mouth_opening_ratio: Option<f64>,
    /// Head triangles of the lip region (the union).
    pub lip_triangles: usize,
    /// Summary-row mean lip roughness of the head at rest: what an algorithm that moves
    /// nothing would score.
    pub rest_roughness: f64,
    /// Head vertices within 30 mm of a used anchor: the ground-truth error and the face
    /// roughness are measured over them (and the triangles they make).
    pub face_vertices: usize,
    pub face_triangles: usize,
    /// Mean `rho(T)` of the face triangles at rest.
    pub rest_face_roughness: f64,
    /// Each target against the head at rest (not moving), in target order.
    pub rest_ground_truth: Vec<TargetRow>,
    /// In the order asked for.
    pub algorithms: Vec<AlgorithmResult>,
    /// The contact measures of the head at rest; `None` for a head without teeth.
    pub rest_contact: Option<ContactFrame>,
    /// The tongue over the stream (it moves alike under every algorithm); `None` for a
    /// head without teeth or without a tongue.
    pub tongue: Option<TongueContact>,
}

/// What the tongue did over the stream.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TongueContact {
    /// Frames in which some tongue vertex is inside a tooth.
    pub frames_in_teeth: usize,
    /// The most tongue vertices inside teeth in one frame.
    pub max_in_teeth: u32,
    /// The deepest any of them went, mm.
    pub max_depth_mm: f32,
    /// The furthest the tongue came in front of the upper teeth, mm (negative: it stayed
    /// behind them in every frame).
    pub max_past_teeth_mm: f32,
}

/// Runs every algorithm of `input` over the stream (and the targets), reporting progress.
pub fn compare(
    input: &CompareInput<'_>,
    progress: &mut dyn FnMut(Progress<'_>),
) -> Result<Comparison, CompareError> {
    let head = input.head;
    let reg = &head.registration;
    let mask = &reg.fitted.mask;
    let mm = reg.mm_per_unit();
    let rest = &reg.head.positions;

    let region = &head.lip_region;
    let face = FaceVertices::new(&reg.head, mask, &reg.anchors, mm).map_err(CompareError::FaceRegion)?;
    let face_triangles = face.triangles(&reg.head);
    let rest_roughness = report_meters(head, &face_triangles, "rest")?
        .measure(rest, 0, 0.0)
        .map_err(|source| CompareError::Meters {
            algorithm: "rest".into(),
            frame: 0,
            source,
        })?
        .lip_rows[LIP_ROWS - 1]
        .mean;
    let face_crease = FaceCrease::new(&reg.head, face.vertices()).map_err(CompareError::FaceEvaluator)?;
    let survey = survey(input)?;
    let tongue_vertices = head
        .tongue
        .as_ref()
        .map(|(_, t)| (t.landmarks().tip_vertex, t.free_vertices()));
    let mouth = MouthContact::new(
        &reg.head,
        region,
        &reg.fitted.fit.pose,
        mm,
        &head.parts,
        tongue_vertices,
    );
    let rest_contact = mouth
        .as_ref()
        .map(|m| m.measure(rest, glam::Affine3A::IDENTITY, None));

    let mut target_positions = vec![Vec3::ZERO; rest.len()];
    let mut lip_fold_meter =
        FoldMeter::new(&reg.head, region.union()).map_err(|source| CompareError::Meters {
            algorithm: "rest".into(),
            frame: 0,
            source: source.into(),
        })?;
    // Which lip triangles each target turns past 60 degrees itself, measured once.
    let mut target_folds = Vec::with_capacity(input.targets.len());
    let mut rest_ground_truth = Vec::with_capacity(input.targets.len());
    for target in input.targets {
        target.apply_into(rest, 1.0, &mut target_positions)?;
        let error = ground_truth_error(rest, &target_positions, &face, mm).map_err(|source| {
            CompareError::Fidelity {
                algorithm: "rest".into(),
                source,
            }
        })?;
        let target_lip_folds = lip_fold_meter
            .measure(&target_positions)
            .map_err(|source| CompareError::TargetFolds {
                algorithm: "rest".into(),
                target: target.name.clone(),
                source,
            })?
            .turned_over_60;
        target_folds.push(lip_fold_meter.turned_past_fold().collect::<Vec<bool>>());
        rest_ground_truth.push(TargetRow {
            target: target.name.clone(),
            rms_mm: error.rms_mm,
            max_mm: error.max_mm,
            lip_folds: 0,
            target_lip_folds,
            lip_folds_not_in_target: 0,
        });
    }

    let mut run = Run {
        input,
        survey,
        face,
        face_triangles,
        face_crease,
        basis: Arc::new(input.basis.clone()),
        deformed: vec![Vec3::ZERO; rest.len()],
        target_positions,
        lip_fold_meter,
        target_folds,
        controls: vec![Vec3::ZERO; mask.vertices.len()],
        target_mask: vec![Vec3::ZERO; mask.vertices.len()],
        stream: StreamTotals::default(),
        mouth,
    };
    let mut algorithms = Vec::with_capacity(input.algorithms.len());
    for (index, candidate) in input.algorithms.iter().enumerate() {
        let mut report = |stage| {
            progress(Progress {
                algorithm: index,
                algorithms: input.algorithms.len(),
                label: &candidate.label,
                stage,
            })
        };
        algorithms.push(run.algorithm(candidate, &mut report)?);
        report(Stage::Finished);
    }

    Ok(Comparison {
        head_vertices: rest.len(),
        mm_per_unit: mm,
        frames: survey.frames,
        syllables: survey.syllables,
        moving_frames: run.stream.moving_frames,
        open_frames: run.stream.open_frames,
        exact_mouth_opening_ratio: run.stream.exact_ratio(),
        lip_triangles: region.union().len(),
        rest_roughness,
        face_vertices: run.face.vertices().len(),
        face_triangles: run.face_crease.triangles(),
        rest_face_roughness: run.face_crease.rest_mean(),
        rest_ground_truth,
        tongue: head
            .tongue
            .as_ref()
            .and(algorithms.first())
            .map(|a| tongue_contact(&a.contact)),
        algorithms,
        rest_contact,
    })
}

/// The meters a report reads for `algorithm`: a viewer's (lip roughness and folds) and the
/// folds of the face's triangles.
fn report_meters(
    head: &AnimatedHead,
    face_triangles: &[u32],
    algorithm: &str,
) -> Result<FrameMeters, CompareError> {
    FrameMeters::new(head, Heat::None)
        .and_then(|m| m.with_face_folds(head, face_triangles))
        .map_err(|source| CompareError::Meters {
            algorithm: algorithm.into(),
            frame: 0,
            source,
        })
}

/// The tongue's contact over one pass of the stream.
fn tongue_contact(rows: &[ContactRow]) -> TongueContact {
    TongueContact {
        frames_in_teeth: rows.iter().filter(|r| r.contact.tongue_in_teeth > 0).count(),
        max_in_teeth: rows.iter().map(|r| r.contact.tongue_in_teeth).max().unwrap_or(0),
        max_depth_mm: rows.iter().map(|r| r.contact.tongue_depth_mm).fold(0.0, f32::max),
        max_past_teeth_mm: rows
            .iter()
            .map(|r| r.contact.tongue_past_teeth_mm)
            .fold(f32::NEG_INFINITY, f32::max),
    }
}

/// Whether a syllable label is labiodental (f, v): the lower lip meets the upper teeth.
fn is_labiodental(label: &str) -> bool {
    label.starts_with(['f', 'v', 'F', 'V'])
}

/// The widest, over runs of frames with one labiodental label, of the run's closest
/// approach of the lower lip to the upper teeth (mm).
fn fv_gap(rows: &[ContactRow]) -> Option<f64> {
    let mut widest: Option<f64> = None;
    for run in rows.chunk_by(|a, b| a.label == b.label) {
        if is_labiodental(&run[0].label) {
            let closest = run
                .iter()
                .map(|r| f64::from(r.contact.lower_lip_to_upper_teeth_mm))
                .fold(f64::INFINITY, f64::min);
            widest = Some(widest.map_or(closest, |w| w.max(closest)));
        }
    }
    widest
}

/// What the stream asks of every algorithm alike (it depends on the mask only), counted
/// again by each algorithm's pass.
#[derive(Debug, Clone, Copy, Default)]
struct StreamTotals {
    /// Frames in which some control moves.
    moving_frames: usize,
    /// Frames whose mask opening is at least [`crate::metrics::MIN_MASK_OPENING_MM`].
    open_frames: usize,
    /// Sum over the open frames of the opening ratio of a head whose anchors move exactly
    /// with their controls.
    exact_ratio_sum: f64,
}

impl StreamTotals {
    fn exact_ratio(&self) -> Option<f64> {
        (self.open_frames > 0).then(|| self.exact_ratio_sum / self.open_frames as f64)
    }
}

/// The state shared by every algorithm's pass: evaluators and buffers, built once.
struct Run<'i, 'a> {
    input: &'i CompareInput<'a>,
    survey: Survey,
    face: FaceVertices,
    /// The face's triangles, whose folds each job's meters measure.
    face_triangles: Vec<u32>,
    face_crease: FaceCrease,
    basis: Arc<ArkitBasis>,
    /// The head deformed by a target (the stream's frames are the job's).
    deformed: Vec<Vec3>,
    target_positions: Vec<Vec3>,
    /// The lip region's folds of a target's deform.
    lip_fold_meter: FoldMeter,
    /// Per target, which lip triangles it turns past 60 degrees itself.
    target_folds: Vec<Vec<bool>>,
    controls: Vec<Vec3>,
    target_mask: Vec<Vec3>,
    stream: StreamTotals,
    mouth: Option<MouthContact>,
}

impl Run<'_, '_> {
    /// Binds one algorithm and measures it over the stream, then over the targets.
    fn algorithm(
        &mut self,
        candidate: &Candidate,
        report: &mut dyn FnMut(Stage),
    ) -> Result<AlgorithmResult, CompareError> {
        let reg = &self.input.head.registration;
        let mask = &reg.fitted.mask;
        let mm = reg.mm_per_unit();
        let rest = &reg.head.positions;
        let spec = candidate.spec.to_string();
        let fidelity = |source| CompareError::Fidelity {
            algorithm: spec.clone(),
            source,
        };
        report(Stage::Binding);
        let binding = Arc::new(bind(reg, &candidate.spec));
        let mut scratch = binding.scratch(mask.vertices.len(), mask.triangles.len());
        let meters = report_meters(self.input.head, &self.face_triangles, &spec)?;
        let mut job = FrameJob::with_meters(
            self.input.head.clone(),
            binding.clone(),
            self.basis.clone(),
            meters,
        );

        let frames = self.survey.frames;
        let mut syllables = SyllableScores::new();
        let mut durations = Vec::with_capacity(frames);
        let mut creases = Vec::with_capacity(frames);
        let (mut control_sum, mut ratio_sum, mut face_sum) = (0.0f64, 0.0f64, 0.0f64);
        let (mut lip_folds, mut fold_deg) = (0u64, 0.0f64);
        self.stream = StreamTotals::default();
        let upper = reg.anchors.vertex[INNER_LIP_MID_UPPER] as usize;
        let lower = reg.anchors.vertex[INNER_LIP_MID_LOWER] as usize;
        let mut contact = Vec::with_capacity(if self.mouth.is_some() { frames } else { 0 });
        for (f, frame) in open_stream(self.input.stream, mask)?.enumerate() {
            let frame = frame?;
            let started = Instant::now();
            job.deform(&frame);
            durations.push(started.elapsed().as_secs_f64() * 1e6);

            let measures = job.measure(&frame).map_err(|source| match source {
                FrameJobError::Meter(source) => CompareError::Meters {
                    algorithm: spec.clone(),
                    frame: f,
                    source,
                },
                other => CompareError::Job {
                    algorithm: spec.clone(),
                    source: other,
                },
            })?;
            syllables.add(frame.label.as_deref().unwrap_or(UNLABELLED), measures.lip_rows);
            lip_folds += u64::from(measures.lip_folds.turned_over_60);
            if let Some(face) = measures.face_folds {
                fold_deg = fold_deg.max(face.max_dihedral_increase_deg);
            }
            let (deformed, mask_now) = (job.deformed(), job.mask());
            let (face_mean, crease) =
                self.face_crease
                    .measure(deformed)
                    .map_err(|source| CompareError::Roughness {
                        algorithm: spec.clone(),
                        frame: f,
                        source,
                    })?;
            face_sum += face_mean;
            creases.push(crease);

            control_displacements(reg, mask_now, &mut self.controls);
            let control =
                control_error(deformed, rest, &reg.anchors, &self.controls, mm).map_err(fidelity)?;
            if control.moving > 0 {
                self.stream.moving_frames += 1;
                control_sum += control.mean_mm;
            }
            let opening = mouth_opening(deformed, &reg.anchors, mask_now, mm).map_err(fidelity)?;
            if let Some(ratio) = opening.ratio {
                self.stream.open_frames += 1;
                ratio_sum += ratio;
                let exact = (rest[upper] + self.controls[INNER_LIP_MID_UPPER])
                    .as_dvec3()
                    .distance((rest[lower] + self.controls[INNER_LIP_MID_LOWER]).as_dvec3())
                    * f64::from(mm);
                self.stream.exact_ratio_sum += exact / opening.mask_mm;
            }
            if let Some(mouth) = &self.mouth {
                let tongue = job.tongue_shaped().then_some(job.tongue_deltas());
                contact.push(ContactRow {
                    frame: f,
                    label: frame.label.clone().unwrap_or_else(|| UNLABELLED.into()),
                    contact: mouth.measure(deformed, job.jaw_motion().affine(), tongue),
                });
            }
            report(Stage::Frames {
                done: f + 1,
                total: frames,
            });
        }
        // The stream was read once already; a file emptied since shows here.
        let (Some(score), false) = (syllables.algorithm_score(), durations.is_empty()) else {
            return Err(CompareError::EmptyStream {
                path: self.input.stream.display().to_string(),
            });
        };

        let targets = self.input.targets;
        let mut ground_truth = Vec::with_capacity(targets.len());
        for (t, target) in targets.iter().enumerate() {
            target.controls_into(&reg.anchors, 1.0, &mut self.controls)?;
            for ((m, &c), &r) in self
                .target_mask
                .iter_mut()
                .zip(&self.controls)
                .zip(reg.mask_rest())
            {
                *m = r + c;
            }
            binding.deform(
                rest,
                reg.mask_rest(),
                &self.target_mask,
                reg.mask_triangles(),
                &mut scratch,
                &mut self.deformed,
            );
            target.apply_into(rest, 1.0, &mut self.target_positions)?;
            let error = ground_truth_error(&self.deformed, &self.target_positions, &self.face, mm)
                .map_err(fidelity)?;
            let lip_folds = self
                .lip_fold_meter
                .measure(&self.deformed)
                .map_err(|source| CompareError::TargetFolds {
                    algorithm: spec.clone(),
                    target: target.name.clone(),
                    source,
                })?
                .turned_over_60;
            let by_target = &self.target_folds[t];
            let target_lip_folds = by_target.iter().filter(|&&turned| turned).count() as u32;
            let lip_folds_not_in_target = self
                .lip_fold_meter
                .turned_past_fold()
                .zip(by_target)
                .filter(|&(turned, &by_target)| turned && !by_target)
                .count() as u32;
            ground_truth.push(TargetRow {
                target: target.name.clone(),
                rms_mm: error.rms_mm,
                max_mm: error.max_mm,
                lip_folds,
                target_lip_folds,
                lip_folds_not_in_target,
            });
            report(Stage::Targets {
                done: t + 1,
                total: targets.len(),
            });
        }

        let counted = durations.len();
        let ground_truth_rms_mm = (!ground_truth.is_empty())
            .then(|| ground_truth.iter().map(|r| r.rms_mm).sum::<f64>() / ground_truth.len() as f64);
        let moving = self.stream.moving_frames;
        Ok(AlgorithmResult {
            summary: AlgorithmSummary {
                letter: candidate.label.clone(),
                spec,
                roughness_mean: score.mean,
                roughness_var: score.variance,
                control_err_mm: if moving > 0 {
                    control_sum / moving as f64
                } else {
                    0.0
                },
                mouth_opening_ratio: (self.stream.open_frames > 0)
                    .then(|| ratio_sum / self.stream.open_frames as f64),
                deform_us: median(&mut durations),
                ground_truth_rms_mm,
                face_roughness_mean: face_sum / counted as f64,
                crease: median(&mut creases),
                lip_folds,
                fold_deg,
                lips_in_teeth: self
                    .mouth
                    .as_ref()
                    .map(|_| contact.iter().map(|r| u64::from(r.contact.lips_in_teeth)).sum()),
                fv_gap_mm: fv_gap(&contact),
            },
            syllables: syllables
                .scores()
                .map(|s| SyllableRow {
                    syllable: s.label.to_string(),
                    frames: s.frames,
                    roughness_mean: s.mean,
                })
                .collect(),
            ground_truth,
            contact,
        })
    }
}

/// The stream's frame and syllable counts.
#[derive(Debug, Clone, Copy)]
struct Survey {
    frames: usize,
    syllables: usize,
}

/// Reads the whole stream once: checks it and counts its frames and syllables, before any
/// time goes into binding.
fn survey(input: &CompareInput<'_>) -> Result<Survey, CompareError> {
    let mut frames = 0;
    let mut labels: Vec<String> = Vec::new();
    for frame in open_stream(input.stream, &input.head.registration.fitted.mask)? {
        let frame = frame?;
        let label = frame.label.as_deref().unwrap_or(UNLABELLED);
        if !labels.iter().any(|l| l == label) {
            labels.push(label.to_string());
        }
        frames += 1;
    }
    if frames == 0 {
        return Err(CompareError::EmptyStream {
            path: input.stream.display().to_string(),
        });
    }
    Ok(Survey {
        frames,
        syllables: labels.len(),
    })
}

/// `delta_j = c'_j - c_j` for the controls (mask vertices a triangle uses), zero for the
/// loose vertices, which no algorithm follows.
fn control_displacements(reg: &Registration, posed: &[Vec3], out: &mut [Vec3]) {
    for (j, ((o, &now), &was)) in out.iter_mut().zip(posed).zip(reg.mask_rest()).enumerate() {
        *o = if reg.is_control[j] { now - was } else { Vec3::ZERO };
    }
}

/// Median of non-empty `values` (the mean of the middle two for an even count).
fn median(values: &mut [f64]) -> f64 {
    values.sort_unstable_by(f64::total_cmp);
    let mid = values.len() / 2;
    if values.len().is_multiple_of(2) {
        (values[mid - 1] + values[mid]) / 2.0
    } else {
        values[mid]
    }
}
