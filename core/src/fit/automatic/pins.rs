//! Step 3 of the automatic fit: pins, the mask vertices held to what the face shows in
//! front of a fit (its profile, the lips' fissure, the eyes, the mirror plane), each
//! along the directions the image sets and no others, so the surface sets the rest. What
//! each constant was checked on: docs/FITTING.md, "The automatic fit's constants".

use glam::DVec3;

use super::closest_points::Pin;
use super::face_marks::FaceMarks;
use super::learned_reading::LearnedFace;
use super::mirror_plane::MirrorPlane;
use super::{eyes, fissure, front_image, profile, FoundFeatures, MouthCorners};
use crate::fit::umeyama::Similarity;
use crate::fit::FitSolution;
use crate::mask::{fap, Mask, OUTER_LIP_CORNERS};

/// CANDIDE-3's nose tip (FP 9.3).
pub(super) const MASK_NOSE_TIP: u32 = 5;
/// CANDIDE-3's mouth middle: the inner lips, upper and lower, which meet at rest.
const MASK_MOUTH_MIDDLE: [u32; 2] = [40, 87];
/// CANDIDE-3's chin (FP 2.1), at the bottom of the chin.
const MASK_CHIN: u32 = 10;
/// CANDIDE-3's mouth corners, left (FP 8.3) and right (FP 8.4).
const MASK_MOUTH_CORNERS: [u32; 2] = [OUTER_LIP_CORNERS[0] as u32, OUTER_LIP_CORNERS[1] as u32];
/// CANDIDE-3's eye corners, inner then outer: left (FP 3.11, 3.7) and right (FP 3.8, 3.12).
const MASK_LEFT_EYE_CORNERS: [u32; 2] = [23, 20];
const MASK_RIGHT_EYE_CORNERS: [u32; 2] = [56, 53];
/// CANDIDE-3's outer eye corners (FP 3.7, 3.12).
const MASK_OUTER_EYE_CORNERS: [u32; 2] = [MASK_LEFT_EYE_CORNERS[1], MASK_RIGHT_EYE_CORNERS[1]];
/// The eye corners are pinned only when the two eyes are as wide, corner to corner,
/// within this factor: a first fit that sat aside reads them askew.
const EYE_WIDTHS_RATIO: f64 = 1.15;
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
const MOUTH_SIDES_RATIO: f64 = 1.25;
/// Outer eye corners lie inside an opening between the lids when they are this far (mask
/// units, about 5 mm) behind the frontmost surface within [`CORNER_SKIN_REACH`] of them ...
const MAX_CORNER_BEHIND_SKIN: f64 = 0.05;
const CORNER_SKIN_REACH: f64 = 0.01;
/// ... and are then held in depth to the frontmost surface within this distance.
const CORNER_SKIN_HOLD: f64 = 0.02;

/// Pins for what the face shows in front of a fit: the nose tip at the profile's, the
/// mouth's middle at the profile's mouth height and its corners at the ends of the lips'
/// fissure, the chin at the height of the chin's bottom, and the pupils and eye corners on
/// the eyes (the corners when both sides agree). `None` when the profile shows no mouth.
pub(super) fn face_pins(
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
    // Held up and down only: left to the surface, the jaw's edge shrinks onto the chin's
    // front, above the chin's bottom.
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
/// surface, the corners sit off the lips' ends and the lips fold (docs/FITTING.md).
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
/// Held sideways only, the surface sets their height and depth (held to the surface point
/// past an opening's outer end instead, the landmark vertices come closer but the lips
/// fold: docs/FITTING.md).
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
/// [`CORNER_SKIN_HOLD`]. The corner is where the lids meet, on the skin; where openings
/// have nothing behind them, the surface alone lays CANDIDE's corners against the
/// sockets' walls.
pub(super) fn sunken_corner_pins(
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
/// Left to the surface, a start's roll stays.
pub(super) fn midline_pins(mask: &Mask, used: &[u32], plane: &MirrorPlane) -> Vec<Pin> {
    used.iter()
        .filter(|&&j| mask.vertices[j as usize].x == 0.0)
        .map(|&j| Pin::along(j, plane.point.as_dvec3(), plane.normal.as_dvec3()))
        .collect()
}

/// `pins` and the midline's.
pub(super) fn with_midline(pins: &[Pin], midline: &[Pin]) -> Vec<Pin> {
    pins.iter().chain(midline).copied().collect()
}

/// Pins for the marks the learned reading places ([`FaceMarks`]: each marked vertex from
/// several face-mesh points and an offset), read in front of a fit posed by `similarity`.
/// Held in all three directions: held across the picture only, leaving depth to the
/// surface, 7 of the population's 82 heads were fitted over 5 mm from their marks against 1
/// (docs/FITTING.md, "The learned reading").
pub(super) fn learned_pins(model: &FaceMarks, face: &LearnedFace, similarity: &Similarity) -> Vec<Pin> {
    model
        .marks
        .iter()
        .filter_map(|mark| {
            mark.predict(&face.points, similarity)
                .map(|p| Pin::at(mark.mask_vertex, p))
        })
        .collect()
}

/// The rule-read `pins` and the `learned` marks together: a vertex both pin is held by
/// both, and lies between them (on the population of `facewire population`, the rules'
/// pins alone, with the marks only where the rules failed, left 20 of 82 heads within 2 mm
/// of their references; both together, 60: docs/FITTING.md, "The learned reading").
/// A vertex whose rule pins disagree with its mark by more than `tolerance` (head units,
/// along each rule pin's direction) keeps only the mark when its mirror image on the mask
/// disagrees too: a pair is read one way or the other, never half and half (one eye corner
/// replaced, the other just inside the tolerance, turned the mirror-symmetric MakeHuman
/// head's fit by a degree). Features the rules only guessed or did not find
/// ([`guessed_vertices`]) keep only their marks. Where no lips' fissure was found at the
/// profile's mouth height, that height is doubted too: the mouth's middle is not pinned to
/// it and the marks' corners hold the mouth (on the population 5 fits came closer, none
/// further; ICT seed 13's from 2.53 to 1.42 mm, its lips from 4,879 folded triangle-frames
/// on the syllable stream to 60).
pub(super) fn agreeing_pins(
    mask: &Mask,
    pins: &[Pin],
    found: &FoundFeatures,
    learned: &[Pin],
    tolerance: f64,
) -> Vec<Pin> {
    let guessed = guessed_vertices(found);
    let disagrees = |vertex: u32| {
        learned.iter().filter(|l| l.vertex == vertex).any(|l| {
            pins.iter()
                .filter(|p| p.vertex == vertex)
                .any(|p| along_distance(p, l.point) > tolerance)
        })
    };
    let replaced = |vertex: u32| {
        learned.iter().any(|l| l.vertex == vertex)
            && (guessed.contains(&vertex) || disagrees(vertex) && disagrees(mask.mirror_partner(vertex)))
    };
    let doubted_middle = found.mouth_corners == MouthCorners::NotFound
        && learned.iter().any(|l| MASK_MOUTH_CORNERS.contains(&l.vertex));
    pins.iter()
        .filter(|p| !(replaced(p.vertex) || doubted_middle && MASK_MOUTH_MIDDLE.contains(&p.vertex)))
        .chain(learned)
        .copied()
        .collect()
}

/// How far `point` lies from `pin` along the pin's direction (everywhere, when it has none).
fn along_distance(pin: &Pin, point: DVec3) -> f64 {
    let off = point - pin.point;
    pin.along.map_or(off.length(), |d| off.dot(d).abs())
}

/// The vertices the rules pinned from a guess or not at all although their feature has a
/// learned mark: the mouth's corners when the fissure was not followed to both ends, the
/// eye corners when the eyes' widths disagreed or no eyes were found.
fn guessed_vertices(found: &FoundFeatures) -> Vec<u32> {
    let mut guessed = Vec::new();
    if found.mouth_corners != MouthCorners::AtBothEnds {
        guessed.extend(MASK_MOUTH_CORNERS);
    }
    if !found.eye_corners_pinned {
        guessed.extend(MASK_LEFT_EYE_CORNERS);
        guessed.extend(MASK_RIGHT_EYE_CORNERS);
    }
    guessed
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::automatic::depth_map::tests::grid_plate;
    use crate::fit::automatic::front_image::tests::seen_from_the_front;
    use crate::head::Head;
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

    fn found(eye_corners_pinned: bool, mouth_corners: MouthCorners) -> FoundFeatures {
        FoundFeatures {
            eyes: None,
            eye_corners_pinned,
            outer_eye_corners_on_skin: false,
            mouth_corners,
        }
    }

    /// The two mouth corners pinned sideways by the rules, at x = `rules`, and marked by the
    /// learned reading at x = `marks`.
    fn mouth_pins(rules: [f64; 2], marks: [f64; 2]) -> (Vec<Pin>, Vec<Pin>) {
        let at = |x: f64| DVec3::new(x, -0.5, 0.0);
        let rule = MASK_MOUTH_CORNERS
            .iter()
            .zip(rules)
            .map(|(&v, x)| Pin::along(v, at(x), DVec3::X))
            .collect();
        let learned = MASK_MOUTH_CORNERS
            .iter()
            .zip(marks)
            .map(|(&v, x)| Pin::at(v, at(x)))
            .collect();
        (rule, learned)
    }

    fn pinned_x(pins: &[Pin]) -> Vec<(u32, f64, bool)> {
        let mut x: Vec<_> = pins
            .iter()
            .map(|p| (p.vertex, p.point.x, p.along.is_none()))
            .collect();
        x.sort_by_key(|p| p.0);
        x
    }

    #[test]
    fn a_pair_is_replaced_only_when_both_sides_disagree() {
        let mask = Mask::candide3();
        let corners = found(true, MouthCorners::AtBothEnds);
        // One side 0.1 off, the other 0.01: both rule pins kept, each beside its mark.
        let (rule, learned) = mouth_pins([0.25, -0.25], [0.35, -0.26]);
        assert_eq!(
            pinned_x(&agreeing_pins(&mask, &rule, &corners, &learned, 0.05)),
            vec![
                (31, 0.25, false),
                (31, 0.35, true),
                (64, -0.25, false),
                (64, -0.26, true)
            ]
        );
        // Both sides off: both learned marks, held in every direction.
        let (rule, learned) = mouth_pins([0.25, -0.25], [0.35, -0.33]);
        assert_eq!(
            pinned_x(&agreeing_pins(&mask, &rule, &corners, &learned, 0.05)),
            vec![(31, 0.35, true), (64, -0.33, true)]
        );
    }

    #[test]
    fn corners_the_rules_guessed_or_missed_take_the_learned_marks() {
        let mask = Mask::candide3();
        let (rule, learned) = mouth_pins([0.25, -0.25], [0.26, -0.24]);
        let merged = agreeing_pins(&mask, &rule, &found(true, MouthCorners::Mirrored), &learned, 0.05);
        assert_eq!(pinned_x(&merged), vec![(31, 0.26, true), (64, -0.24, true)]);
        let merged = agreeing_pins(&mask, &[], &found(true, MouthCorners::NotFound), &learned, 0.05);
        assert_eq!(pinned_x(&merged), vec![(31, 0.26, true), (64, -0.24, true)]);
        // No fissure at the profile's mouth height: the mouth's middle is not held there.
        let middle: Vec<Pin> = MASK_MOUTH_MIDDLE
            .iter()
            .map(|&v| Pin::at(v, DVec3::new(0.0, -0.6, 0.0)))
            .collect();
        let merged = agreeing_pins(
            &mask,
            &middle,
            &found(true, MouthCorners::NotFound),
            &learned,
            0.05,
        );
        assert_eq!(pinned_x(&merged), vec![(31, 0.26, true), (64, -0.24, true)]);
        let merged = agreeing_pins(
            &mask,
            &middle,
            &found(true, MouthCorners::Mirrored),
            &learned,
            0.05,
        );
        assert_eq!(merged.len(), 4, "{merged:?}");
        // Eye corners not pinned by the rules take no mouth rule pin's place: each mouth
        // corner keeps its rule pin beside its mark.
        let merged = agreeing_pins(
            &mask,
            &rule,
            &found(false, MouthCorners::AtBothEnds),
            &learned,
            0.05,
        );
        assert_eq!(
            pinned_x(&merged),
            vec![
                (31, 0.25, false),
                (31, 0.26, true),
                (64, -0.25, false),
                (64, -0.24, true)
            ]
        );
    }
}
