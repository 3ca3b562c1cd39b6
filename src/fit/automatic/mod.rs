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
//! not hidden (one nose, in front). Works in head units; the physical scale comes from the caller or,
//! as for landmark fits, from 63 mm pupils.

mod closest_points;
pub(crate) mod depth_map;
mod eyes;
mod fissure;
pub(crate) mod front_image;
mod mirror_plane;
mod nudges;
mod profile;

use glam::{DMat3, DVec3, Vec3};

use super::limits::{check_head_extent, in_range, RangeError, MM_PER_UNIT_RANGE};
use super::umeyama::Similarity;
use super::{Fit, FitSolution, SolveError};
use crate::cancel::Cancel;
use crate::head::{raster_cost, Head, RasterCostError};
use crate::mask::{fap, Mask};
use closest_points::{lay_mask, screen_start, Pin, Surface};
use depth_map::{DepthMap, NoseCandidate, View};
pub use eyes::EyeKind;
use mirror_plane::MirrorPlane;

/// CANDIDE-3's nose tip (FP 9.3).
const MASK_NOSE_TIP: u32 = 5;
/// CANDIDE-3's mouth middle: the inner lips, upper and lower, which meet at rest.
const MASK_MOUTH_MIDDLE: [u32; 2] = [40, 87];
/// The eye corners are pinned only when the two eyes are as wide, corner to corner,
/// within this factor (1.04 at most on the shipped heads' openings, 1.08 on the scan's
/// closed lids); a first fit that sat aside reads them askew (a head with its mouth open,
/// 1.39; read again in front of the pinned fit they agree).
const EYE_WIDTHS_RATIO: f64 = 1.15;
/// CANDIDE-3's chin (FP 2.1), at the bottom of the chin.
const MASK_CHIN: u32 = 10;
/// CANDIDE-3's mouth corners, left (FP 8.3) and right (FP 8.4).
const MASK_MOUTH_CORNERS: [u32; 2] = [31, 64];
/// The lips' fissure is looked for this far above and below the mouth's height (mask
/// units) ...
const MOUTH_CREASE_WINDOW: f64 = 0.03;
/// ... and followed at most this far to each side.
const MOUTH_CREASE_REACH: f64 = 0.45;
/// The mouth's corners are pinned only when the fissure reaches at least this far from
/// the midline (CANDIDE's corners are 0.246 from it) ...
const MIN_MOUTH_HALF_WIDTH: f64 = 0.1;
/// ... at the two ends' mean distance from it when those agree within this factor, and
/// otherwise both at the farther end's, mirrored: a crease fades early rather than late.
/// Followed on 0.5 mm cells, a fissure's ends fade within 2 mm of each other on
/// MakeHuman, a mirror-symmetric head (each at its own end, the mask's mouth sat 0.5 mm
/// aside); the shipped heads' ends agree within 1.11, their faces' within 1.13.
const MOUTH_SIDES_RATIO: f64 = 1.25;
/// CANDIDE-3's outer eye corners (FP 3.7, 3.12) ...
const MASK_OUTER_EYE_CORNERS: [u32; 2] = [MASK_LEFT_EYE_CORNERS[1], MASK_RIGHT_EYE_CORNERS[1]];
/// ... lie inside an opening between the lids when they are this far (mask units, about
/// 5 mm) behind the frontmost surface within [`CORNER_SKIN_REACH`] of them (MakeHuman's:
/// 6.0-6.7 mm; 0.3-3.6 mm on the other shipped heads, 1.5-3.4 on the ICT ones) ...
const MAX_CORNER_BEHIND_SKIN: f64 = 0.05;
const CORNER_SKIN_REACH: f64 = 0.01;
/// ... and are then held in depth to the frontmost surface within this distance.
const CORNER_SKIN_HOLD: f64 = 0.02;
/// CANDIDE-3's eye corners, inner then outer: left (FP 3.11, 3.7) and right (FP 3.8, 3.12).
const MASK_LEFT_EYE_CORNERS: [u32; 2] = [23, 20];
const MASK_RIGHT_EYE_CORNERS: [u32; 2] = [56, 53];
/// Cells along the longer side of the range image the face's features are read on (about
/// 0.5 mm on the shipped heads: closed lids step 1-2 mm, and a feature's place jitters by
/// about a cell as the fit it is read in front of turns).
const FRONT_IMAGE_CELLS: usize = 512;
/// The face's features are read in front of the first fit, then again in front of the mask
/// laid on them: on ICT's face cut the first fit lay 10 % small and tilted, and the chin
/// and mouth read in its frame 2.5 and 0.9 mm high.
const FEATURE_READINGS: usize = 2;
/// Directions the head is looked at from, evenly around the normal of its mirror plane.
const VIEWS: usize = 72;
/// Views whose noses are tried: the likeliest, and the next likeliest looking at least
/// [`FACING_VIEWS_APART_DEG`] away from it.
const FACING_VIEWS: usize = 4;
const FACING_VIEWS_APART_DEG: f32 = 20.0;
/// A nose tip lies this close to the mirror plane, as a fraction of the nose's radius
/// (three cells of the range image: the tip is read to a cell, and faces are not exactly
/// symmetric).
const NOSE_OFF_PLANE: f32 = 0.3;
/// Starts laid in full after the screening, the closest first.
const LAID_STARTS: usize = 6;
/// A nose stands out of the surface beside it by at most this fraction of that radius: its
/// ridge rises to the brow at less than 45 degrees. A cell standing out more is the rim
/// of a hole (a neck's cut, seen from below, with the inside of the head behind it).
const MAX_NOSE_PROMINENCE: f32 = 1.0;
/// Cells along the longer side of each range image.
const DEPTH_MAP_CELLS: usize = 96;
/// The sides of a nose are compared this far from the tip, as a fraction of the head's size.
const NOSE_RADIUS: f32 = 0.1;
/// A nose must stand out of the surface beside it by at least this fraction of that radius.
const MIN_NOSE_PROMINENCE: f32 = 0.15;
/// Places tried as the nose tip in the chosen view, the most prominent first: a chin
/// lowered by a mouth open at rest can stand out more than the nose.
const NOSE_CANDIDATES: usize = 3;
/// The width of the head across the nose tip, in mask units (1.65 to 1.97 on the shipped
/// heads' landmark fits); the starting scale is the measured width over this, and
/// [`START_SCALES`] cover the spread.
const HEAD_WIDTH_AT_NOSE: f64 = 1.7;
/// Starting scales, as factors of the one guessed from the width.
const START_SCALES: [f64; 3] = [0.8, 1.0, 1.25];
/// A fit whose score (mean capped distance, mask units; 0.045 is about 4.5 mm) is worse
/// than this did not find a face.
const MAX_SCORE: f64 = 0.045;

#[derive(Debug, thiserror::Error)]
pub enum AutomaticFitError {
    #[error(
        "{head}: no face found: looked for a nose from every direction across the head's plane of \
         mirror symmetry; the best stood out {prominence:.2} of the surface beside it, a nose \
         stands out at least {MIN_NOSE_PROMINENCE}. Give landmarks"
    )]
    NoNose { head: String, prominence: f32 },
    #[error(
        "{head}: found a nose at ({x:.3}, {y:.3}, {z:.3}) but no mouth below it (a notch between two lips) \
         in front of any fit laid on it. Give landmarks",
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
    /// No `mm_per_unit` was given; it comes from 63 mm pupils.
    pub mm_per_unit_from_pupils: bool,
    /// What the face showed in front of the fit (its second reading), and so what was pinned.
    pub found: FoundFeatures,
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

impl AutomaticFit {
    /// A unit `mm_per_unit` is close to (within 15 %), if any: the guess put in words.
    pub fn unit_name(&self) -> Option<&'static str> {
        const UNITS: [(&str, f32); 5] = [
            ("millimetres", 1.0),
            ("centimetres", 10.0),
            ("inches", 25.4),
            ("decimetres", 100.0),
            ("metres", 1000.0),
        ];
        let mm = self.fit.mm_per_unit;
        UNITS
            .iter()
            .find(|(_, size)| (mm / size - 1.0).abs() <= 0.15)
            .map(|(name, _)| *name)
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
    let mask_tip = mask.vertices[MASK_NOSE_TIP as usize].as_dvec3();
    let solve_error = |source| AutomaticFitError::Solve { head: name(), source };
    // Every candidate nose of each view, upright and upside down (which way is up shows in
    // how the mask lies), at every starting scale: screened by the similarity alone, the
    // closest few laid in full, the closest of those first.
    let mut screened: Vec<(closest_points::Laid, View, NoseCandidate)> = Vec::new();
    for (view, noses) in &views {
        go_on()?;
        for view in [*view, view.upside_down()] {
            let rotation = DMat3::from_cols(
                view.lateral.as_dvec3(),
                view.up.as_dvec3(),
                view.forward.as_dvec3(),
            );
            for candidate in noses.iter().filter(|n| n.prominence >= MIN_NOSE_PROMINENCE) {
                let tip = candidate.tip.as_dvec3();
                let guessed_scale = f64::from(candidate.width_at_tip) / HEAD_WIDTH_AT_NOSE;
                for factor in START_SCALES {
                    let scale = guessed_scale * factor;
                    let start = Similarity {
                        rotation,
                        scale,
                        translation: tip - scale * (rotation * mask_tip),
                    };
                    let pins = with_midline(&[Pin::at(MASK_NOSE_TIP, tip)], &midline);
                    let laid = screen_start(&surface, mask, &used, start, &pins).map_err(solve_error)?;
                    screened.push((laid, view, *candidate));
                }
            }
        }
    }
    screened.sort_by(|a, b| a.0.score.total_cmp(&b.0.score));
    let mut starts = Vec::with_capacity(LAID_STARTS);
    for (screen, view, candidate) in screened.into_iter().take(LAID_STARTS) {
        go_on()?;
        let tip = candidate.tip.as_dvec3();
        let pins = with_midline(&[Pin::at(MASK_NOSE_TIP, tip)], &midline);
        let laid = lay_mask(&surface, mask, &used, screen.solution.similarity, &pins).map_err(solve_error)?;
        starts.push((laid, view, candidate));
    }
    starts.sort_by(|a, b| a.0.score.total_cmp(&b.0.score));
    // The closest start whose face shows a mouth below its nose: the back of a head can
    // stand out and be as symmetric as a face, but shows none.
    let mut chosen = None;
    for (laid, view, candidate) in starts {
        go_on()?;
        if let Some(read) =
            read_features(head, mask, &surface, &used, &midline, laid, winding).map_err(solve_error)?
        {
            chosen = Some((read, view, candidate));
            break;
        }
    }
    let Some(((mut best, seen_from, image, mut pins, mut found), _, nose)) = chosen else {
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
    let (mm_per_unit, from_pupils) = match mm_per_unit {
        Some(mm) => (
            in_range("mm_per_unit", mm, MM_PER_UNIT_RANGE).map_err(range)?,
            false,
        ),
        None => (
            in_range(
                "mm_per_unit (from 63 mm pupils)",
                Fit::mm_per_unit_from_pupils(mask, &shape, &pose),
                MM_PER_UNIT_RANGE,
            )
            .map_err(range)?,
            true,
        ),
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
    Ok(AutomaticFit {
        fit,
        forward: (best.solution.similarity.rotation * DVec3::Z).as_vec3(),
        nose_tip: nose.tip,
        score: best.score,
        mm_per_unit_from_pupils: from_pupils,
        found,
    })
}

/// Pins for what the face shows in front of a fit: the nose tip at the profile's, the
/// mouth's middle at the profile's mouth height and its corners at the ends of the lips'
/// fissure, the chin at the height of the chin's bottom, and the pupils and eye corners on
/// the eyes (the corners when both sides agree). `None` when the profile shows no mouth.
fn face_pins(
    mask: &Mask,
    fit: &FitSolution,
    image: &front_image::FrontImage,
) -> Option<(Vec<Pin>, FoundFeatures)> {
    let shaped = mask.shaped(&fit.shape);
    let features = profile::midline_features(image)?;
    let mut pins = vec![Pin::at(MASK_NOSE_TIP, features.nose_tip)];
    for vertex in MASK_MOUTH_MIDDLE {
        let lips = shaped[vertex as usize].as_dvec3();
        pins.push(Pin::at(
            vertex,
            image.head_point(DVec3::new(features.midline_x, features.mouth_height, lips.z)),
        ));
    }
    // Held up and down only: left to the surface, the jaw's edge shrank onto the chin's
    // front, 5-7 mm above the landmark fits' chin on four of the five shipped heads.
    if let Some(height) = features.chin_height {
        let up = fit.similarity.rotation * DVec3::Y;
        pins.push(Pin::along(
            MASK_CHIN,
            image.head_point(DVec3::new(0.0, height, 0.0)),
            up,
        ));
    }
    let (mouth_pins, mouth_corners) =
        mouth_corner_pins(image, features.midline_x, features.mouth_height, &fit.similarity);
    pins.extend(mouth_pins);
    let mut found = FoundFeatures {
        eyes: None,
        eye_corners_pinned: false,
        outer_eye_corners_on_skin: false,
        mouth_corners,
    };
    if let Some(centres) = eyes::eye_centres(image) {
        found.eyes = Some(centres.map(|centre| centre.kind));
        if eyes::eye_widths_agree(&centres, EYE_WIDTHS_RATIO) {
            found.eye_corners_pinned = true;
            for (centre, corners) in centres
                .iter()
                .zip([MASK_LEFT_EYE_CORNERS, MASK_RIGHT_EYE_CORNERS])
            {
                pins.extend(eye_corner_pins(image, centre, corners, &fit.similarity));
            }
        }
        // Sideways and up only: the surface sets the eyes' depth (an opening has no
        // surface where the pupil is, closed lids stand in front of it).
        let (across, up) = (
            fit.similarity.rotation * DVec3::X,
            fit.similarity.rotation * DVec3::Y,
        );
        for (centre, pupil) in centres.iter().zip([&fap::LEFT_PUPIL, &fap::RIGHT_PUPIL]) {
            let middle = fap::centroid(&shaped, pupil).as_dvec3();
            for &vertex in pupil {
                let offset = shaped[vertex].as_dvec3() - middle;
                let target = image.head_point(DVec3::new(centre.x + offset.x, centre.y + offset.y, 0.0));
                pins.push(Pin::along(vertex as u32, target, across));
                pins.push(Pin::along(vertex as u32, target, up));
            }
        }
    }
    Some((pins, found))
}

/// Pins (sideways only) for the mouth's corners from the ends of the lips' fissure, when it
/// is found at the mouth's height, mirrored about the midline at `midline_x`: at the ends'
/// mean distance from it when they agree, else both at the farther one's. Left to the
/// surface, the scan's corners sat 3.8 and 5.1 mm from its marked ones and V folded its
/// lips.
fn mouth_corner_pins(
    image: &front_image::FrontImage,
    midline_x: f64,
    mouth_height: f64,
    seen_from: &Similarity,
) -> (Vec<Pin>, MouthCorners) {
    let Some(y) = fissure::crease_height(image, 0.0, mouth_height, MOUTH_CREASE_WINDOW) else {
        return (Vec::new(), MouthCorners::NotFound);
    };
    let left = fissure::fissure_end(image, (0.0, y), 1.0, MOUTH_CREASE_REACH);
    let right = fissure::fissure_end(image, (0.0, y), -1.0, MOUTH_CREASE_REACH);
    let (to_left, to_right) = (left.0 - midline_x, midline_x - right.0);
    let (long, short) = (to_left.max(to_right), to_left.min(to_right));
    if long < MIN_MOUTH_HALF_WIDTH {
        return (Vec::new(), MouthCorners::NotFound);
    }
    let (left, right, corners) = if long / short > MOUTH_SIDES_RATIO {
        let y = if to_left >= to_right { left.1 } else { right.1 };
        (
            (midline_x + long, y),
            (midline_x - long, y),
            MouthCorners::Mirrored,
        )
    } else {
        let half_width = (to_left + to_right) / 2.0;
        (
            (midline_x + half_width, left.1),
            (midline_x - half_width, right.1),
            MouthCorners::AtBothEnds,
        )
    };
    let across = seen_from.rotation * DVec3::X;
    let pins = [(MASK_MOUTH_CORNERS[0], left), (MASK_MOUTH_CORNERS[1], right)]
        .into_iter()
        .map(|(vertex, (x, y))| Pin::along(vertex, image.head_point(DVec3::new(x, y, 0.0)), across))
        .collect();
    (pins, corners)
}

/// Pins (sideways only) for an eye's corners, when they are seen ([`eyes`]). The lids
/// around an eye are nearly flat across, so the surface alone hardly sets the eye's width.
/// Held sideways only, the surface sets their height and depth: held to the surface point
/// past an opening's outer end instead, MakeHuman's landmark vertices came 0.6 mm closer
/// to the landmark fit's but its lips folded (40 triangle-frames over 60 degrees on the
/// syllable stream with V, against none).
fn eye_corner_pins(
    image: &front_image::FrontImage,
    eye: &eyes::EyeCentre,
    [inner_vertex, outer_vertex]: [u32; 2],
    first: &Similarity,
) -> Vec<Pin> {
    let Some(corners) = eye.corners else {
        return Vec::new();
    };
    let across = first.rotation * DVec3::X;
    [inner_vertex, outer_vertex]
        .into_iter()
        .zip(corners)
        .map(|(vertex, (x, y))| Pin::along(vertex, image.head_point(DVec3::new(x, y, 0.0)), across))
        .collect()
}

/// Pins (in depth only) for outer eye corners the laid mask sank into an opening between
/// the lids: more than [`MAX_CORNER_BEHIND_SKIN`] behind the frontmost surface within
/// [`CORNER_SKIN_REACH`] of them, held to the frontmost surface within
/// [`CORNER_SKIN_HOLD`]. The corner is where the lids meet, on the skin; on MakeHuman, whose
/// openings have nothing behind them, the surface had laid CANDIDE's corners 6-7 mm behind
/// it, against the sockets' walls.
fn sunken_corner_pins(
    image: &front_image::FrontImage,
    mask: &Mask,
    seen_from: &Similarity,
    laid: &FitSolution,
) -> Vec<Pin> {
    let shaped = mask.shaped(&laid.shape);
    let forward = seen_from.rotation * DVec3::Z;
    MASK_OUTER_EYE_CORNERS
        .into_iter()
        .filter_map(|vertex| {
            let corner = seen_from.invert_point(laid.similarity.apply(shaped[vertex as usize].as_dvec3()));
            let skin = image.frontmost_near(corner.x, corner.y, CORNER_SKIN_REACH)?;
            if skin - corner.z <= MAX_CORNER_BEHIND_SKIN {
                return None;
            }
            let hold = image.frontmost_near(corner.x, corner.y, CORNER_SKIN_HOLD)?;
            Some(Pin::along(
                vertex,
                image.head_point(DVec3::new(corner.x, corner.y, hold)),
                forward,
            ))
        })
        .collect()
}

/// Pins (across the plane only) holding every used mask vertex on CANDIDE's midline to the
/// head's mirror plane: a face is laid symmetric about the plane it is symmetric about.
/// Left to the surface, a start's roll stayed (1.4 degrees on the scan).
fn midline_pins(mask: &Mask, used: &[u32], plane: &MirrorPlane) -> Vec<Pin> {
    used.iter()
        .filter(|&&j| mask.vertices[j as usize].x == 0.0)
        .map(|&j| Pin::along(j, plane.point.as_dvec3(), plane.normal.as_dvec3()))
        .collect()
}

/// `pins` and the midline's.
fn with_midline(pins: &[Pin], midline: &[Pin]) -> Vec<Pin> {
    pins.iter().chain(midline).copied().collect()
}

/// A start laid again on what the face shows in front of it, read twice: the laid mask,
/// the fit it was read in front of, that image, the pins and what they hold.
type FeaturesRead = (
    closest_points::Laid,
    FitSolution,
    front_image::FrontImage,
    Vec<Pin>,
    FoundFeatures,
);

/// Pins the laid mask's nose tip, mouth, chin, pupils and eye corners to what the face
/// shows in front of it and lays it again, then reads them again in front of that fit and
/// lays it once more. `None` when the profile in front of it shows no mouth below the nose.
fn read_features(
    head: &Head,
    mask: &Mask,
    surface: &Surface,
    used: &[u32],
    midline: &[Pin],
    mut laid: closest_points::Laid,
    winding: f32,
) -> Result<Option<FeaturesRead>, SolveError> {
    let mut pinned = None;
    for _ in 0..FEATURE_READINGS {
        let seen_from = laid.solution.clone();
        let image = front_image::FrontImage::render(head, &seen_from.similarity, winding, FRONT_IMAGE_CELLS);
        let Some((pins, found)) = face_pins(mask, &seen_from, &image) else {
            return Ok(None);
        };
        laid = lay_mask(
            surface,
            mask,
            used,
            seen_from.similarity,
            &with_midline(&pins, midline),
        )?;
        pinned = Some((seen_from, image, pins, found));
    }
    Ok(pinned.map(|(seen_from, image, pins, found)| (laid, seen_from, image, pins, found)))
}

/// The views that may look at the face, each with the places in it that could be the nose
/// tip ([`DepthMap::noses`]; never empty), the likeliest first: of [`VIEWS`] directions
/// across the head's mirror plane (from the head's longest axis in it, so that a head
/// turned is seen from the same directions, turned), those whose most prominent place stands out like a nose
/// (within [`MIN_NOSE_PROMINENCE`] and [`MAX_NOSE_PROMINENCE`]) and lies on the plane
/// (within [`NOSE_OFF_PLANE`] of the nose's radius: a brow or a cheekbone seen aslant can
/// stand out as much, but off the plane), the most prominent first, each at least
/// [`FACING_VIEWS_APART_DEG`] from those before. The back of a head can stand out on the
/// plane too: the fit that follows tells them apart. Which way is up is left to the fit.
fn find_nose(head: &Head, winding: f32, plane: &MirrorPlane) -> Vec<(View, Vec<NoseCandidate>)> {
    let lateral = plane.normal;
    let across = mirror_plane::principal_axis_in(&head.positions, plane);
    let look = |forward: Vec3| {
        let view = View::with_lateral(forward, lateral);
        let map = DepthMap::render(&head.positions, &head.triangles, view, DEPTH_MAP_CELLS, winding);
        let radius = NOSE_RADIUS * map.extent();
        let noses: Vec<NoseCandidate> = map
            .noses(radius, NOSE_CANDIDATES)
            .into_iter()
            .filter(|n| {
                n.prominence <= MAX_NOSE_PROMINENCE
                    && (n.tip - plane.point).dot(lateral).abs() < NOSE_OFF_PLANE * radius
            })
            .collect();
        (!noses.is_empty()).then_some((view, noses))
    };
    let mut scored: Vec<(View, Vec<NoseCandidate>)> = Vec::new();
    let mut most_prominent: Option<(View, NoseCandidate)> = None;
    for k in 0..VIEWS {
        let angle = k as f32 * std::f32::consts::TAU / VIEWS as f32;
        let Some((view, noses)) = look(across * angle.cos() + lateral.cross(across) * angle.sin()) else {
            continue;
        };
        let nose = noses[0];
        if most_prominent.is_none_or(|(_, m)| nose.prominence > m.prominence) {
            most_prominent = Some((view, nose));
        }
        if nose.prominence >= MIN_NOSE_PROMINENCE {
            scored.push((view, noses));
        }
    }
    // The file's own axes, as far as they lie across the plane: a head written upright is
    // seen straight from the front, where the most prominent view of its nose can be
    // pitched by a few degrees, and the fit keeps a start's pitch.
    let file_views: Vec<(View, Vec<NoseCandidate>)> = [Vec3::X, Vec3::Y, Vec3::Z]
        .into_iter()
        .flat_map(|axis| [axis, -axis])
        .filter_map(|axis| (axis - lateral * axis.dot(lateral)).try_normalize())
        .filter_map(look)
        .filter(|(_, noses)| noses[0].prominence >= MIN_NOSE_PROMINENCE)
        .collect();
    scored.sort_by(|a, b| b.1[0].prominence.total_cmp(&a.1[0].prominence));
    let min_cos = FACING_VIEWS_APART_DEG.to_radians().cos();
    let mut views: Vec<(View, Vec<NoseCandidate>)> = Vec::new();
    for (view, noses) in scored {
        if views.iter().all(|(v, _)| v.forward.dot(view.forward) < min_cos) {
            let nearest_file_view = file_views
                .iter()
                .filter(|(v, _)| v.forward.dot(view.forward) >= min_cos)
                .max_by(|a, b| {
                    a.0.forward
                        .dot(view.forward)
                        .total_cmp(&b.0.forward.dot(view.forward))
                });
            views.push(nearest_file_view.cloned().unwrap_or((view, noses)));
        }
        if views.len() == FACING_VIEWS {
            break;
        }
    }
    if views.is_empty() {
        views.extend(most_prominent.map(|(view, nose)| (view, vec![nose])));
    }
    views
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::automatic::depth_map::tests::grid_plate;
    use crate::fit::automatic::front_image::tests::seen_from_the_front;
    use glam::{DMat3, Vec2};

    /// The mouth-corner pins' x on a plate facing +z (mask units) with a crease 0.02 deep
    /// along y = -0.5 from x = `ends[0]` to `ends[1]`, the midline at x = 0.
    fn corner_pins_on_crease(ends: [f32; 2]) -> (Vec<f64>, MouthCorners) {
        let crease = move |x: f32, y: f32| {
            if (ends[0]..=ends[1]).contains(&x) {
                -0.02 * (1.0 - (y + 0.5).abs() / 0.015).max(0.0)
            } else {
                0.0
            }
        };
        let (positions, triangles) = grid_plate([201, 121], Vec2::new(-0.5, -0.8), 0.005, crease);
        let image = seen_from_the_front(&Head::new("creased plate", positions, triangles), 256);
        let seen_from = Similarity {
            rotation: DMat3::IDENTITY,
            scale: 1.0,
            translation: DVec3::ZERO,
        };
        let (pins, corners) = mouth_corner_pins(&image, 0.0, -0.5, &seen_from);
        for pin in &pins {
            assert_eq!(pin.along, Some(DVec3::X), "held sideways only");
        }
        (pins.iter().map(|pin| pin.point.x).collect(), corners)
    }

    #[test]
    fn mouth_corners_are_pinned_mirrored_about_the_midline() {
        // Ends 0.2 and 0.22 from the midline agree (1.1): both at their mean, 0.21. Ends
        // 0.12 and 0.24 do not (2.0): both at the farther one's distance.
        for (ends, expected, half_width) in [
            ([-0.2, 0.22], MouthCorners::AtBothEnds, 0.21),
            ([-0.12, 0.24], MouthCorners::Mirrored, 0.24),
        ] {
            let (x, corners) = corner_pins_on_crease(ends);
            assert_eq!(corners, expected, "{ends:?}");
            assert!(
                (x[0] - half_width).abs() < 0.008 && (x[1] + half_width).abs() < 0.008,
                "{ends:?}: {x:?}"
            );
        }
    }

    #[test]
    fn a_fissure_too_short_pins_no_corner() {
        let (x, corners) = corner_pins_on_crease([-0.05, 0.05]);
        assert_eq!(corners, MouthCorners::NotFound);
        assert!(x.is_empty());
    }
}
