//! A fit with no landmarks, for heads nobody has marked up: find the plane the head is
//! mirror-symmetric about, which way the face looks and where its nose may be on range
//! images of the head from every direction across that plane, up along the nose's ridge;
//! place the mask on each of the few likeliest noses at a few scales guessed from the
//! face's width there, lay it on the surface by iterated closest points (pose, then shape
//! units), keep the start that lies closest, then pin its nose, mouth and its corners,
//! chin, pupils and eye corners to what the face shows in front of it and lay it again;
//! read them again in front of that fit and lay it once more; hold sunken outer eye
//! corners to the skin, and nudge the free vertices onto the surface.
//!
//! Assumes nothing of the file's axes; assumes the face is close to mirror-symmetric and
//! not hidden (one nose, in front). Works in head units; the physical scale comes from the
//! caller or, as for landmark fits, from 63 mm pupils.
//!
//! The steps, each a module: [`mirror_plane`]; [`nose_search`] (views across the plane,
//! nose candidates); [`starts`] (the mask placed on each, screened, the closest laid);
//! [`reading`] with [`pins`] (the face read in front of a fit and the mask pinned to it,
//! twice); then sunken eye corners held to the skin and [`nudges`]. What each constant
//! was checked on is in docs/FITTING.md, "The automatic fit's constants".

mod closest_points;
mod conv_net;
pub(crate) mod depth_map;
mod eyes;
mod face_marks;
mod face_model;
mod fissure;
pub(crate) mod front_image;
mod learned_reading;
mod mirror_plane;
mod nose_search;
mod nudges;
mod onnx_file;
mod pins;
mod profile;
mod reading;
mod starts;

use glam::{DVec3, Vec3};

use super::limits::{check_head_extent, in_range, RangeError, MM_PER_UNIT_RANGE};
use super::{Fit, FittedMask, SolveError};
use crate::cancel::Cancel;
use crate::head::{raster_cost, Head, RasterCostError};
use crate::mask::Mask;
use closest_points::{lay_mask, Laid, Pin, Surface};
pub use eyes::EyeKind;
pub use face_model::FaceModelError;
use learned_reading::read_learned_face;
use nose_search::{find_nose, MIN_NOSE_PROMINENCE};
use pins::{midline_pins, sunken_corner_pins, with_midline};
use reading::{read_features, FRONT_IMAGE_CELLS};

/// A fit whose score (mean capped distance, mask units; 0.045 is about 4.5 mm on a head of
/// the usual size) is worse than this did not find a face.
const MAX_SCORE: f64 = 0.045;
/// A rule-read pin further than this (mask units, about 6 mm; the learned marks lie 1.5-3.5
/// mm from the vertices people mark, on average by vertex) from the learned mark for its
/// vertex gives way to the mark.
const PIN_TOLERANCE: f64 = 0.06;
/// The rules' fit is kept when its marked vertices lie this close to the learned marks on
/// average (mask units, about 10 mm). On the population, with one face-mesh point a mark,
/// the fits the rules got right lay 0.02-0.09 from the marks, those they got wrong (the
/// mouth found on the fold under the lower lip, the chin on the neck) 0.3-0.5: the bound
/// sits in the gap.
const MAX_MARKS_DISAGREEMENT: f64 = 0.1;

#[derive(Debug, thiserror::Error)]
pub enum AutomaticFitError {
    #[error(
        "{head}: no face found: looked for a nose from every direction across the head's plane of \
         mirror symmetry; the best stood out {prominence:.2} of the surface beside it, a nose \
         stands out at least {MIN_NOSE_PROMINENCE}. Give landmarks"
    )]
    NoNose { head: String, prominence: f32 },
    #[error(
        "{head}: found a nose at ({x:.3}, {y:.3}, {z:.3}) but the learned face reader saw no face in front \
         of any fit laid on it. Give landmarks",
        x = nose_tip.x, y = nose_tip.y, z = nose_tip.z
    )]
    NoMouth { head: String, nose_tip: Vec3 },
    #[error(
        "{head}: the mask does not lie on this mesh: its vertices are {mean_mask_units:.3} mask units \
         (about {about_mm:.1} mm) from the surface on average after the best start. Give landmarks"
    )]
    NoFit {
        head: String,
        mean_mask_units: f64,
        about_mm: f64,
    },
    #[error("{head}: {source}")]
    Solve { head: String, source: SolveError },
    #[error("{head}: out of range: {source}")]
    Range { head: String, source: RangeError },
    #[error("{head}: not fitted: {source}")]
    RasterCost { head: String, source: RasterCostError },
    #[error("{head}: the fit was cancelled")]
    Cancelled { head: String },
    #[error("{head}: {source}")]
    FaceModel { head: String, source: FaceModelError },
}

/// A fit found without landmarks, with what was assumed and found on the way.
#[derive(Debug, Clone, PartialEq)]
pub struct AutomaticFit {
    pub fit: Fit,
    /// The direction the face looks (the fitted mask's +z), head frame.
    pub forward: Vec3,
    /// The nose tip found on the range image, head units.
    pub nose_tip: Vec3,
    /// Mean distance of the fitted mask's vertices to the surface (each capped near 5 mm),
    /// mask units.
    pub score: f64,
    /// No `mm_per_unit` was given; it comes from 63 mm pupils, taken as the standard unit
    /// near it ([`STANDARD_UNITS`]) when there is one.
    pub mm_per_unit_from_pupils: bool,
    /// What 63 mm pupils gave (mm per head unit) when no `mm_per_unit` was given, before it
    /// was taken as a standard unit.
    pub pupils_mm_per_unit: Option<f32>,
    /// What the face showed in front of the fit (its second reading), and so what was pinned.
    pub found: FoundFeatures,
    /// How the fit agrees with the learned reading of the face.
    pub reading: FaceReading,
    /// What a person should check before using the fit.
    pub warnings: Vec<AutomaticFitWarning>,
}

/// Something about an automatic fit that a person should check: the fit disagrees with
/// itself. On the population (docs/FITTING.md, "On a population") 5 of 82 fits warned,
/// among them the one more than 5 mm from its reference.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum AutomaticFitWarning {
    /// The face's shape (profile, lips, eyes) was read in front of the learned reader's fit
    /// but put the marked vertices more than [`MAX_MARKS_DISAGREEMENT`] from its marks on
    /// average: the fit follows the learned reader alone.
    ShapeDisagreesWithReader,
    /// The face's shape could not be read in front of the learned reader's fit (no profile,
    /// lips or eyes where it put them): the fit follows the learned reader alone.
    ShapeNotRead,
}

impl AutomaticFitWarning {
    /// The warning as a sentence.
    pub fn message(&self) -> String {
        let why = match self {
            AutomaticFitWarning::ShapeDisagreesWithReader => format!(
                "the face's shape (its profile, lips and eyes) put the marked points more than about {:.0} mm \
                 from where the learned face reader saw them",
                MAX_MARKS_DISAGREEMENT * 100.0
            ),
            AutomaticFitWarning::ShapeNotRead => {
                "the face's shape (its profile, lips and eyes) could not be read where the learned face \
                 reader saw the face"
                    .to_string()
            }
        };
        format!("automatic fit: {why}, so the fit follows the reader alone: check it, or give landmarks")
    }
}

/// The learned reading the fit was checked against: how sure the model was that it saw a
/// face, and how far the fitted mask's marked vertices lie from its marks (mm at the fit's
/// scale). Not a confidence yet: on the population neither ranks the fits by their error
/// (docs/FITTING.md, "On a population").
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FaceReading {
    pub face_probability: f32,
    pub marks_mean_mm: f32,
    /// Each mark's offset from its mask vertex: (mask vertex, mark minus vertex in the
    /// mask's own axes, mm at the fit's scale).
    pub mark_offsets_mm: Vec<(u32, [f32; 3])>,
    /// The learned reading's face-mesh points (head units; `None` where a point was not seen
    /// on the surface), in MediaPipe's order.
    #[serde(skip)]
    pub points: Vec<Option<Vec3>>,
}

/// The features the automatic fit found and pinned the mask to, besides the nose tip and
/// the mouth's height: when one is missing the surface alone places that part of the mask.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct FoundFeatures {
    /// How the left and right eyes showed (their pupils pinned), or `None` when either did
    /// not.
    pub eyes: Option<[EyeKind; 2]>,
    /// The eyes' corners were seen and agreed, and were pinned.
    pub eye_corners_pinned: bool,
    /// The outer eye corners had sunk into openings between the lids and were held to the
    /// skin where the lids meet.
    pub outer_eye_corners_on_skin: bool,
    pub mouth_corners: MouthCorners,
}

/// Where the mouth's corners were pinned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MouthCorners {
    /// At the mean distance of the lips' fissure's two ends from the midline.
    AtBothEnds,
    /// Both at the farther end, mirrored: the fissure faded early on one side.
    Mirrored,
    /// Not pinned: no fissure at the mouth's height, or too short.
    NotFound,
}

/// The units meshes are written in (name, mm per unit): scanners write mm or m, game
/// engines cm or m, MakeHuman dm, some tools inches.
pub const STANDARD_UNITS: [(&str, f32); 5] = [
    ("millimetres", 1.0),
    ("centimetres", 10.0),
    ("inches", 25.4),
    ("decimetres", 100.0),
    ("metres", 1000.0),
];
/// How far a unit guessed from 63 mm pupils may be from the true one (1 sd, as a share of
/// it): people's pupils differ. Measured on the population's development members
/// (`tools/unit_guess/measure.py`; docs/FITTING.md, "Units"): 6.1 % rms, 7.7 % on the
/// held-out ones. Lengths across the whole face do no better: faces large in one length
/// are large in the others.
pub const PUPILS_RELATIVE_SD: f32 = 0.061;
/// A unit guessed from the pupils is taken as the standard unit it lies within this share
/// of (about 2.5 [`PUPILS_RELATIVE_SD`]): on the population the guess lay within 15 % of
/// the true unit on 81 of 82 heads, and the standard units lie at least 2.5 times apart,
/// so no guess is within 15 % of two.
pub const UNIT_SNAP: f32 = 0.15;

/// The standard unit `mm_per_unit` lies within [`UNIT_SNAP`] of, if any.
pub fn standard_unit(mm_per_unit: f32) -> Option<(&'static str, f32)> {
    STANDARD_UNITS
        .iter()
        .find(|(_, size)| (mm_per_unit / size - 1.0).abs() <= UNIT_SNAP)
        .copied()
}

impl AutomaticFit {
    /// The standard unit the head's unit is (or is near), if any: the guess put in words.
    pub fn unit_name(&self) -> Option<&'static str> {
        standard_unit(self.fit.mm_per_unit).map(|(name, _)| name)
    }
}

/// Fits `mask` to `head` with no landmarks. `mm_per_unit`, when given, is kept; otherwise
/// it comes from 63 mm pupils like a landmark fit's.
pub fn fit_automatically(
    head: &Head,
    mask: &Mask,
    mm_per_unit: Option<f32>,
) -> Result<AutomaticFit, AutomaticFitError> {
    fit_automatically_unless(head, mask, mm_per_unit, &Cancel::new())
}

/// [`fit_automatically`], stopping with [`AutomaticFitError::Cancelled`] at the next step
/// once `cancel` is set (steps take a fraction of a second: the head's raster cost is
/// checked first, [`raster_cost`]).
pub fn fit_automatically_unless(
    head: &Head,
    mask: &Mask,
    mm_per_unit: Option<f32>,
    cancel: &Cancel,
) -> Result<AutomaticFit, AutomaticFitError> {
    let name = || head.name.clone();
    let go_on = || match cancel.is_cancelled() {
        true => Err(AutomaticFitError::Cancelled { head: name() }),
        false => Ok(()),
    };
    go_on()?;
    check_head_extent(&head.positions).map_err(|source| AutomaticFitError::Range { head: name(), source })?;
    raster_cost::check(&head.positions, &head.triangles)
        .map_err(|source| AutomaticFitError::RasterCost { head: name(), source })?;
    let winding = depth_map::outward_winding(&head.positions, &head.triangles);
    let no_nose = |prominence| AutomaticFitError::NoNose {
        head: name(),
        prominence,
    };
    let plane = mirror_plane::mirror_plane(head).ok_or_else(|| no_nose(0.0))?;
    go_on()?;
    let views = find_nose(head, winding, &plane);
    go_on()?;
    let Some(nose) = views.first().map(|(_, noses)| noses[0]) else {
        return Err(no_nose(0.0));
    };
    if nose.prominence < MIN_NOSE_PROMINENCE {
        return Err(no_nose(nose.prominence));
    }
    let used: Vec<u32> = mask
        .used_vertices()
        .iter()
        .enumerate()
        .filter(|(_, &u)| u)
        .map(|(j, _)| j as u32)
        .collect();
    let surface = Surface::new(head, mask);
    let midline = midline_pins(mask, &used, &plane);
    let solve_error = |source| AutomaticFitError::Solve { head: name(), source };
    let starts = starts::lay_starts(&surface, mask, &used, &midline, &views, &go_on, &solve_error)?;
    // The closest start in front of which the learned model sees a face (the back of a
    // head can stand out and be as symmetric as a face): the mask is pinned to the model's
    // marks, then read by the rules in front of that fit, and the rules' pins kept where they
    // agree with the marks. The rules' fit is kept when it lies on the marks; otherwise the
    // marks' own.
    let model_error = |source| AutomaticFitError::FaceModel { head: name(), source };
    let mut chosen = None;
    for (laid, _, candidate) in starts {
        go_on()?;
        let Some(LearnedRead {
            laid: marked,
            seen_from: marked_from,
            marks,
            face_probability,
            points,
        }) = read_learned(head, mask, &surface, &used, &midline, laid, winding).map_err(|e| match e {
            LearnedError::Model(source) => model_error(source),
            LearnedError::Solve(source) => solve_error(source),
        })?
        else {
            continue;
        };
        let mut reading = Reading {
            marks,
            face_probability,
            points,
            rules_read: false,
            rules_kept: false,
        };
        if let Some((_, seen_from, image, rule_pins, found)) =
            read_features(head, mask, &surface, &used, &midline, marked.clone(), winding)
                .map_err(solve_error)?
        {
            reading.rules_read = true;
            let merged = pins::agreeing_pins(
                mask,
                &rule_pins,
                &found,
                &reading.marks,
                PIN_TOLERANCE * seen_from.similarity.scale,
            );
            let laid = lay_mask(
                &surface,
                mask,
                &used,
                seen_from.similarity,
                &with_midline(&merged, &midline),
            )
            .map_err(solve_error)?;
            if marks_disagreement(mask, &laid.solution, &reading.marks) <= MAX_MARKS_DISAGREEMENT {
                reading.rules_kept = true;
                chosen = Some(((laid, seen_from, image, merged, found), reading, candidate));
                break;
            }
        }
        let image =
            front_image::FrontImage::render(head, &marked_from.similarity, winding, FRONT_IMAGE_CELLS);
        let found = FoundFeatures {
            eyes: None,
            eye_corners_pinned: true,
            outer_eye_corners_on_skin: false,
            mouth_corners: MouthCorners::AtBothEnds,
        };
        let marks = reading.marks.clone();
        chosen = Some(((marked, marked_from, image, marks, found), reading, candidate));
        break;
    }
    let Some(((mut best, seen_from, image, mut pins, mut found), reading, nose)) = chosen else {
        return Err(AutomaticFitError::NoMouth {
            head: name(),
            nose_tip: nose.tip,
        });
    };
    go_on()?;
    let sunken = sunken_corner_pins(&image, mask, &seen_from.similarity, &best.solution);
    if !sunken.is_empty() {
        found.outer_eye_corners_on_skin = true;
        pins.extend(sunken);
        best = lay_mask(
            &surface,
            mask,
            &used,
            seen_from.similarity,
            &with_midline(&pins, &midline),
        )
        .map_err(solve_error)?;
    }
    let held: Vec<u32> = pins.iter().map(|pin| pin.vertex).collect();
    let nudges = nudges::onto_surface(&surface, mask, &best.solution, &used, &held);
    let pose = best.solution.pose;
    let shape = best.solution.shape;
    let range = |source| AutomaticFitError::Range { head: name(), source };
    let (mm_per_unit, pupils_mm_per_unit) = match mm_per_unit {
        Some(mm) => (
            in_range("mm_per_unit", mm, MM_PER_UNIT_RANGE).map_err(range)?,
            None,
        ),
        None => {
            let measured = in_range(
                "mm_per_unit (from 63 mm pupils)",
                Fit::mm_per_unit_from_pupils(mask, &shape, &pose),
                MM_PER_UNIT_RANGE,
            )
            .map_err(range)?;
            let unit = standard_unit(measured).map_or(measured, |(_, size)| size);
            (unit, Some(measured))
        }
    };
    if best.score > MAX_SCORE {
        let mm_per_mask_unit = f64::from(mm_per_unit) * best.solution.similarity.scale;
        return Err(AutomaticFitError::NoFit {
            head: name(),
            mean_mask_units: best.score,
            about_mm: best.score * mm_per_mask_unit,
        });
    }
    let fit = Fit {
        pose,
        shape,
        nudges,
        mm_per_unit,
    };
    fit.check_ranges().map_err(range)?;
    let warnings = match (reading.rules_kept, reading.rules_read) {
        (true, _) => Vec::new(),
        (false, true) => vec![AutomaticFitWarning::ShapeDisagreesWithReader],
        (false, false) => vec![AutomaticFitWarning::ShapeNotRead],
    };
    let reading = face_reading(mask, &fit, reading);
    Ok(AutomaticFit {
        fit,
        forward: (best.solution.similarity.rotation * DVec3::Z).as_vec3(),
        nose_tip: nose.tip,
        score: best.score,
        mm_per_unit_from_pupils: pupils_mm_per_unit.is_some(),
        pupils_mm_per_unit,
        found,
        reading,
        warnings,
    })
}

enum LearnedError {
    Model(FaceModelError),
    Solve(crate::fit::SolveError),
}

/// A start laid again on the learned model's marks.
struct LearnedRead {
    /// The mask laid with the marks pinned.
    laid: Laid,
    /// The fit the face was seen from.
    seen_from: crate::fit::FitSolution,
    marks: Vec<Pin>,
    face_probability: f32,
    points: Vec<Option<Vec3>>,
}

/// The face read by the learned model in front of a laid start, the mask pinned to its
/// marks and laid again, twice. `None` when the model sees no face there.
fn read_learned(
    head: &Head,
    mask: &Mask,
    surface: &Surface,
    used: &[u32],
    midline: &[Pin],
    mut laid: Laid,
    winding: f32,
) -> Result<Option<LearnedRead>, LearnedError> {
    let mut last = None;
    for _ in 0..2 {
        let seen_from = laid.solution.clone();
        let shaped = mask.shaped(&seen_from.shape);
        let face_points: Vec<Vec3> = used
            .iter()
            .map(|&v| {
                seen_from
                    .similarity
                    .apply(shaped[v as usize].as_dvec3())
                    .as_vec3()
            })
            .collect();
        let view = depth_map::View::of_rotation(seen_from.similarity.rotation.as_mat3());
        let Some(face) = read_learned_face(head, winding, view, &face_points).map_err(LearnedError::Model)?
        else {
            return Ok(None);
        };
        if face.face_probability < 0.5 {
            return Ok(None);
        }
        let model = face_marks::FaceMarks::shipped()
            .map_err(|e| LearnedError::Model(FaceModelError::Marks(e.to_string())))?;
        let pins = pins::learned_pins(model, &face, &seen_from.similarity);
        laid = lay_mask(
            surface,
            mask,
            used,
            seen_from.similarity,
            &with_midline(&pins, midline),
        )
        .map_err(LearnedError::Solve)?;
        let points = face.points.iter().map(|p| p.map(|p| p.as_vec3())).collect();
        last = Some((seen_from, pins, face.face_probability, points));
    }
    Ok(
        last.map(|(seen_from, marks, face_probability, points)| LearnedRead {
            laid,
            seen_from,
            marks,
            face_probability,
            points,
        }),
    )
}

/// What the learned reading gave for the chosen start, and how the rules' reading agreed.
struct Reading {
    marks: Vec<Pin>,
    face_probability: f32,
    points: Vec<Option<Vec3>>,
    /// The rules read the face in front of the marks' fit.
    rules_read: bool,
    /// The fit with the rules' pins lay on the marks and was kept.
    rules_kept: bool,
}

/// How far `fit`'s marked vertices lie from the learned marks (mm at the fit's scale).
fn face_reading(mask: &Mask, fit: &Fit, reading: Reading) -> FaceReading {
    let neutral = FittedMask::new(mask.clone(), fit.clone()).neutral;
    let to_mask_axes = fit.pose.rotation().transpose();
    let mark_offsets_mm: Vec<(u32, [f32; 3])> = reading
        .marks
        .iter()
        .map(|pin| {
            let offset = (pin.point - neutral[pin.vertex as usize].as_dvec3()).as_vec3();
            (pin.vertex, (to_mask_axes * offset * fit.mm_per_unit).to_array())
        })
        .collect();
    let total_mm: f32 = mark_offsets_mm
        .iter()
        .map(|(_, offset)| glam::Vec3::from(*offset).length())
        .sum();
    FaceReading {
        face_probability: reading.face_probability,
        marks_mean_mm: total_mm / reading.marks.len().max(1) as f32,
        mark_offsets_mm,
        points: reading.points,
    }
}

/// The mean distance (mask units) of the fitted mask's vertices from the learned marks'
/// pins for them.
fn marks_disagreement(mask: &Mask, solution: &crate::fit::FitSolution, marks: &[Pin]) -> f64 {
    let shaped = mask.shaped(&solution.shape);
    let total: f64 = marks
        .iter()
        .map(|pin| {
            solution
                .similarity
                .apply(shaped[pin.vertex as usize].as_dvec3())
                .distance(pin.point)
        })
        .sum();
    total / marks.len().max(1) as f64 / solution.similarity.scale
}
