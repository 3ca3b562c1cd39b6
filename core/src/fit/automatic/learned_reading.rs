//! The face read by the learned model ([`super::face_model`]) on pictures of the head: the
//! head is drawn (shaded from its range image) as seen from in front of a fit, the model
//! places MediaPipe's 468 face-mesh points on the picture, and each point is carried back
//! onto the surface it was seen on. The picture is framed as MediaPipe frames its own
//! tracking crops: a square 1.5 times the points' extent, turned so the eyes are level,
//! read again until the frame holds still. The last picture is read again mirrored, and
//! each point that has a mirror image on the face is placed halfway between its two
//! readings: the network's own lean to one side cancels, and a symmetric face is read
//! symmetric.
//!
//! Positions are head units; the picture's x runs along the view's lateral (the face's
//! left), its y down the view's up.

use glam::{DVec3, Vec2, Vec3};

use super::depth_map::{DepthMap, View};
use super::face_marks::FaceMarks;
use super::face_model::{read_face, FaceMesh, FaceModelError, CROP_PIXELS, MESH_POINTS};
use crate::head::Head;

/// MediaPipe frames a face 1.5 times as wide as its points reach (its
/// `face_landmark_landmarks_to_roi` graph), and the model was trained on such frames.
const FRAME_MARGIN: f32 = 1.5;
/// The head is drawn at this many cells per picture pixel and averaged down, so that edges
/// are smooth as in a photograph.
const SUPERSAMPLING: usize = 2;
/// Readings of one view at most: the first frame comes from the fit, each next one from
/// the points the last reading placed.
const MAX_READINGS: usize = 4;
/// The frame holds still when it moves less than this share of its side between readings.
const STILL_FRAME: f32 = 0.02;
/// The light, in the view's frame (lateral, up, toward the viewer): from the viewer,
/// a little above, as a face is usually lit.
const LIGHT: Vec3 = Vec3::new(0.0, 0.3, 1.0);

/// MediaPipe face-mesh points: the eyes' outer corners (right, left; the picture's left
/// eye is the face's right) level the frame.
const OUTER_EYE_CORNERS: [usize; 2] = [33, 263];

/// The face the model read, on the head.
#[derive(Debug, Clone)]
pub struct LearnedFace {
    /// Each face-mesh point where the picture showed it on the surface, head units; `None`
    /// where its pixel showed nothing of the head.
    pub points: Vec<Option<DVec3>>,
    /// The model's probability that the last picture held a face.
    pub face_probability: f32,
}

/// A square of the view: its lower-left corner (lateral, up) and side, head units.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Frame {
    low: Vec2,
    side: f32,
}

impl Frame {
    fn around(points: impl Iterator<Item = Vec2>) -> Option<Frame> {
        let (mut low, mut high) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
        for p in points {
            low = low.min(p);
            high = high.max(p);
        }
        let side = (high - low).max_element() * FRAME_MARGIN;
        (side.is_finite() && side > 0.0).then(|| Frame {
            low: (low + high) / 2.0 - Vec2::splat(side / 2.0),
            side,
        })
    }

    /// Where picture pixel (x right, y down) lies in the view.
    fn across(&self, pixel: Vec2) -> Vec2 {
        let scale = self.side / CROP_PIXELS as f32;
        self.low + Vec2::new(pixel.x, CROP_PIXELS as f32 - pixel.y) * scale
    }
}

/// Reads the face seen along `view` (its `up` roughly the face's), starting from a frame
/// around `face_points` (head units: where a fit puts the face). `winding` as for
/// [`DepthMap::render`]. `None` when the pictures show nothing of the head.
pub fn read_learned_face(
    head: &Head,
    winding: f32,
    mut view: View,
    face_points: &[Vec3],
) -> Result<Option<LearnedFace>, FaceModelError> {
    let Some(mut frame) = Frame::around(face_points.iter().map(|&p| view.project(p).0)) else {
        return Ok(None);
    };
    let mut last = None;
    for _ in 0..MAX_READINGS {
        let cells = CROP_PIXELS * SUPERSAMPLING;
        let map = DepthMap::render_window(
            &head.positions,
            &head.triangles,
            view,
            (frame.low, frame.side),
            cells,
            winding,
        );
        let Some(picture) = shaded_picture(&map, frame.side / cells as f32) else {
            return Ok(None);
        };
        let mesh = read_face(&picture)?;
        let seen: Vec<Vec2> = mesh.points.iter().map(|p| frame.across(p.truncate())).collect();
        let (next_view, next_frame) = level_frame(view, &seen);
        let moved = (next_frame.low - frame.low).length() / frame.side
            + (next_frame.side / frame.side - 1.0).abs()
            + next_view.lateral.distance(view.lateral);
        last = Some((mesh, picture, map, view, frame));
        view = next_view;
        frame = next_frame;
        if moved < STILL_FRAME {
            break;
        }
    }
    let Some((mesh, picture, map, view, frame)) = last else {
        return Ok(None);
    };
    let mirrored = read_face(&mirrored_picture(&picture))?;
    let mirror = &FaceMarks::shipped()
        .map_err(|e| FaceModelError::Marks(e.to_string()))?
        .mirror;
    Ok(Some(on_the_surface(
        &symmetric_reading(mesh, &mirrored, mirror),
        &map,
        view,
        frame,
    )))
}

/// The view turned about its forward axis so that the eyes' outer corners (`seen`, in the
/// view) lie level, and a frame around the points in that view.
fn level_frame(view: View, seen: &[Vec2]) -> (View, Frame) {
    let [right, left] = OUTER_EYE_CORNERS.map(|k| seen[k]);
    let along = (left - right).normalize_or(Vec2::X);
    let lateral = (view.lateral * along.x + view.up * along.y).normalize();
    let turned = View::with_lateral(view.forward, lateral);
    let in_turned = |p: Vec2| {
        let q = view.lateral * p.x + view.up * p.y;
        Vec2::new(q.dot(turned.lateral), q.dot(turned.up))
    };
    let frame = Frame::around(seen.iter().map(|&p| in_turned(p))).unwrap_or(Frame {
        low: Vec2::ZERO,
        side: 1.0,
    });
    (turned, frame)
}

/// The picture the model reads: the range image shaded by its slopes (Lambert, [`LIGHT`]),
/// black where no surface is, averaged down to [`CROP_PIXELS`] rows, top row first. `None`
/// when no cell shows the head.
fn shaded_picture(map: &DepthMap, cell: f32) -> Option<Vec<f32>> {
    let (columns, rows) = map.cells();
    let light = LIGHT.normalize();
    let mut picture = vec![0.0f32; CROP_PIXELS * CROP_PIXELS];
    let mut any = false;
    let slope = |column: isize, row: isize, step: (isize, isize)| -> f32 {
        let here = map.at(column, row);
        let ahead = map.at(column + step.0, row + step.1);
        let behind = map.at(column - step.0, row - step.1);
        match (behind, here, ahead) {
            (Some(b), _, Some(a)) => (a - b) / (2.0 * cell),
            (None, Some(h), Some(a)) => (a - h) / cell,
            (Some(b), Some(h), None) => (h - b) / cell,
            _ => 0.0,
        }
    };
    for row in 0..rows as isize {
        for column in 0..columns as isize {
            if map.at(column, row).is_none() {
                continue;
            }
            any = true;
            let normal = Vec3::new(-slope(column, row, (1, 0)), -slope(column, row, (0, 1)), 1.0).normalize();
            let shade = 0.15 + 0.8 * normal.dot(light).max(0.0);
            let x = column as usize / SUPERSAMPLING;
            let y = CROP_PIXELS - 1 - (row as usize / SUPERSAMPLING).min(CROP_PIXELS - 1);
            picture[y * CROP_PIXELS + x.min(CROP_PIXELS - 1)] +=
                shade / (SUPERSAMPLING * SUPERSAMPLING) as f32;
        }
    }
    any.then_some(picture)
}

/// The picture turned left for right.
fn mirrored_picture(picture: &[f32]) -> Vec<f32> {
    picture
        .chunks_exact(CROP_PIXELS)
        .flat_map(|row| row.iter().rev().copied())
        .collect()
}

/// `mesh` with each point halfway between where it was read and where its mirror image
/// (`mirror`, [`FaceMarks::mirror`]) was read in the mirrored picture (turned back), and
/// the lesser of the two readings' face logits.
fn symmetric_reading(mut mesh: FaceMesh, mirrored: &FaceMesh, mirror: &[usize]) -> FaceMesh {
    for (k, point) in mesh.points.iter_mut().enumerate().take(MESH_POINTS) {
        let seen = mirrored.points[mirror[k]];
        *point = (*point + Vec3::new(CROP_PIXELS as f32 - seen.x, seen.y, seen.z)) / 2.0;
    }
    mesh.face_logit = mesh.face_logit.min(mirrored.face_logit);
    mesh
}

/// Each face-mesh point carried onto the surface drawn at its pixel (the nearest covered
/// cell within two pixels).
fn on_the_surface(mesh: &FaceMesh, map: &DepthMap, view: View, frame: Frame) -> LearnedFace {
    let cell = frame.side / (CROP_PIXELS * SUPERSAMPLING) as f32;
    let points = mesh
        .points
        .iter()
        .take(MESH_POINTS)
        .map(|p| {
            let across = frame.across(p.truncate());
            let grid = ((across - frame.low) / cell).round();
            let reach = (2 * SUPERSAMPLING) as isize;
            let mut best: Option<(isize, f32)> = None;
            for dy in -reach..=reach {
                for dx in -reach..=reach {
                    if let Some(depth) = map.at(grid.x as isize + dx, grid.y as isize + dy) {
                        let far = dx * dx + dy * dy;
                        if best.is_none_or(|(f, _)| far < f) {
                            best = Some((far, depth));
                        }
                    }
                }
            }
            best.map(|(_, depth)| view.point(across, depth).as_dvec3())
        })
        .collect();
    LearnedFace {
        points,
        face_probability: mesh.face_probability(),
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::fit::Landmarks;

    fn ict() -> (Head, Landmarks) {
        let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/heads");
        (
            Head::load(&data.join("ict_head.obj")).unwrap(),
            Landmarks::load(&data.join("ict_head.landmarks.toml")).unwrap(),
        )
    }

    fn marked(head: &Head, landmarks: &Landmarks, mask_vertex: u32) -> DVec3 {
        let mark = landmarks
            .landmarks
            .iter()
            .find(|l| l.mask_vertex == mask_vertex)
            .unwrap();
        head.positions[mark.head_vertex as usize].as_dvec3()
    }

    fn front() -> View {
        View::with_lateral(Vec3::Z, Vec3::X)
    }

    #[test]
    fn the_face_of_a_head_is_read_where_its_landmarks_are_marked() {
        let (head, landmarks) = ict();
        let marks: Vec<Vec3> = landmarks
            .landmarks
            .iter()
            .map(|l| head.positions[l.head_vertex as usize])
            .collect();
        let face = read_learned_face(&head, 1.0, front(), &marks).unwrap().unwrap();
        assert!(face.face_probability > 0.99, "{}", face.face_probability);
        assert_eq!(face.points.iter().filter(|p| p.is_some()).count(), MESH_POINTS);
        // The ICT head is in centimetres; the mesh's nose tip (4), mouth corners (61
        // right, 291 left) and eyes' inner corners (133 right, 362 left) against the ICT
        // Face Model's own marks for them.
        for (point, mask_vertex, within_mm) in [
            (4, 5, 2.0),
            (291, 31, 4.0),
            (61, 64, 4.0),
            (362, 23, 4.5),
            (133, 56, 4.5),
        ] {
            let off_mm = face.points[point]
                .unwrap()
                .distance(marked(&head, &landmarks, mask_vertex))
                * 10.0;
            assert!(off_mm < within_mm, "point {point}: {off_mm:.2} mm from its mark");
        }
    }

    #[test]
    fn the_back_of_a_head_is_not_read_as_a_face() {
        let (head, landmarks) = ict();
        // Seen from behind, framed where the face would be.
        let behind = View::with_lateral(-Vec3::Z, -Vec3::X);
        let marks: Vec<Vec3> = landmarks
            .landmarks
            .iter()
            .map(|l| head.positions[l.head_vertex as usize] * Vec3::new(1.0, 1.0, -1.0))
            .collect();
        let face = read_learned_face(&head, 1.0, behind, &marks).unwrap().unwrap();
        assert!(face.face_probability < 0.5, "{}", face.face_probability);
    }

    /// Reading a picture and its mirror image gives, for every point, the mirror image of
    /// reading them the other way round: the symmetric reading has no side.
    #[test]
    fn the_symmetric_reading_is_its_own_mirror_image() {
        let mesh = |seed: f32| FaceMesh {
            points: (0..MESH_POINTS)
                .map(|k| Vec3::new((k as f32 * seed).sin() * 90.0 + 96.0, k as f32 * 0.4, seed))
                .collect(),
            face_logit: seed,
        };
        let (a, b) = (mesh(1.3), mesh(2.9));
        let mirror = &FaceMarks::shipped().unwrap().mirror;
        let ab = symmetric_reading(a.clone(), &b, mirror);
        let ba = symmetric_reading(b, &a, mirror);
        for (k, &partner) in mirror.iter().enumerate() {
            let (p, q) = (ab.points[k], ba.points[partner]);
            assert!(
                (p.x - (CROP_PIXELS as f32 - q.x)).abs() < 1e-4,
                "point {k}: {p} and {q}"
            );
            assert!((p.y - q.y).abs() < 1e-4, "point {k}: {p} and {q}");
        }
        assert_eq!(ab.face_logit, 1.3);
        let ramp: Vec<f32> = (0..CROP_PIXELS * CROP_PIXELS)
            .map(|k| (k % CROP_PIXELS) as f32)
            .collect();
        let mirrored = mirrored_picture(&ramp);
        assert_eq!(
            (mirrored[0], mirrored[CROP_PIXELS - 1], mirrored[CROP_PIXELS]),
            (191.0, 0.0, 191.0)
        );
    }

    #[test]
    fn a_picture_of_nothing_is_not_read() {
        let (head, _) = ict();
        let far_away = [Vec3::splat(1e4), Vec3::splat(1e4 + 1.0)];
        assert!(read_learned_face(&head, 1.0, front(), &far_away)
            .unwrap()
            .is_none());
    }
}
