//! Where CANDIDE-3's marked vertices lie among MediaPipe's face-mesh points, learned: no
//! face-mesh point is exactly where people mark an eye corner, an alar wing or a chin (the
//! nearest sat 2-11 mm off on the population, each by its own offset), so each marked
//! vertex is predicted from several points and an offset,
//!
//! `mark = sum_k w_k p_k + R s c`, with `sum_k w_k = 1`,
//!
//! `p_k` face-mesh points on the surface (head units), `R` and `s` the rotation and scale of
//! the fit the face was read in front of, `c` an offset in mask units along the mask's axes.
//! The weights are scalars, so the sum turns and scales with the head. The model, with the
//! face-mesh points' own mirror map, is `data/models/face_marks.toml`, written by
//! `tools/face_marks/train.py` from the development members of `facewire population`
//! (origin and licences in `data/models/LICENSES.md`); it is part of the binary and checked
//! once per process, on first use.

use std::sync::OnceLock;

use glam::DVec3;

use super::face_model::MESH_POINTS;
use crate::fit::umeyama::Similarity;

const MODEL: &str = include_str!("../../../../data/models/face_marks.toml");

/// The weights of a mark sum to one within this (the file keeps six decimals).
const WEIGHTS_SUM_TOLERANCE: f64 = 1e-4;

#[derive(Debug, Clone, thiserror::Error)]
pub enum FaceMarksError {
    #[error("data/models/face_marks.toml: {0}")]
    Parse(String),
    #[error(
        "data/models/face_marks.toml: `mirror` has {0} entries, not one per face-mesh point ({MESH_POINTS})"
    )]
    MirrorLength(usize),
    #[error("data/models/face_marks.toml: `mirror` is not its own inverse at face-mesh point {0}")]
    MirrorNotInvolution(usize),
    #[error("data/models/face_marks.toml: the mark for mask vertex {vertex}: {what}")]
    Mark { vertex: u32, what: String },
}

#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelFile {
    mirror: Vec<usize>,
    mark: Vec<MarkFile>,
}

#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct MarkFile {
    mask_vertex: u32,
    points: Vec<usize>,
    weights: Vec<f64>,
    offset: [f64; 3],
}

/// One marked vertex's prediction.
#[derive(Debug, Clone, PartialEq)]
pub struct Mark {
    pub mask_vertex: u32,
    /// (face-mesh point, weight); the weights sum to one.
    terms: Vec<(usize, f64)>,
    /// Mask units, along the mask's axes.
    offset: DVec3,
}

impl Mark {
    /// Where this vertex lies on a face whose face-mesh points are `points` (head units;
    /// `None` where a point was not seen), read in front of a fit posed by `similarity`.
    /// `None` when a point it needs was not seen.
    pub fn predict(&self, points: &[Option<DVec3>], similarity: &Similarity) -> Option<DVec3> {
        let mut sum = DVec3::ZERO;
        for &(point, weight) in &self.terms {
            sum += weight * points.get(point).copied().flatten()?;
        }
        Some(sum + similarity.scale * (similarity.rotation * self.offset))
    }
}

/// The learned model: each marked vertex's prediction and the face-mesh points' mirror map.
#[derive(Debug, Clone, PartialEq)]
pub struct FaceMarks {
    /// Face-mesh point `k`'s mirror image across the face is point `mirror[k]` (points on
    /// the midline are their own).
    pub mirror: Vec<usize>,
    pub marks: Vec<Mark>,
}

impl FaceMarks {
    /// Parses and checks a model file's text.
    pub fn parse(text: &str) -> Result<FaceMarks, FaceMarksError> {
        let file: ModelFile = toml::from_str(text).map_err(|e| FaceMarksError::Parse(e.to_string()))?;
        if file.mirror.len() != MESH_POINTS {
            return Err(FaceMarksError::MirrorLength(file.mirror.len()));
        }
        if let Some(k) = (0..MESH_POINTS).find(|&k| file.mirror.get(file.mirror[k]) != Some(&k)) {
            return Err(FaceMarksError::MirrorNotInvolution(k));
        }
        let marks = file
            .mark
            .into_iter()
            .map(|m| {
                let bad = |what: String| FaceMarksError::Mark {
                    vertex: m.mask_vertex,
                    what,
                };
                if m.points.is_empty() || m.points.len() != m.weights.len() {
                    return Err(bad(format!(
                        "{} points and {} weights",
                        m.points.len(),
                        m.weights.len()
                    )));
                }
                if let Some(p) = m.points.iter().find(|&&p| p >= MESH_POINTS) {
                    return Err(bad(format!(
                        "face-mesh point {p} is past the last ({})",
                        MESH_POINTS - 1
                    )));
                }
                if m.weights.iter().chain(&m.offset).any(|w| !w.is_finite()) {
                    return Err(bad("a weight or the offset is not a finite number".into()));
                }
                let sum: f64 = m.weights.iter().sum();
                if (sum - 1.0).abs() > WEIGHTS_SUM_TOLERANCE {
                    return Err(bad(format!("the weights sum to {sum}, not 1")));
                }
                Ok(Mark {
                    mask_vertex: m.mask_vertex,
                    terms: m.points.into_iter().zip(m.weights).collect(),
                    offset: DVec3::from_array(m.offset),
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(FaceMarks {
            mirror: file.mirror,
            marks,
        })
    }

    /// The shipped model, parsed once.
    pub fn shipped() -> Result<&'static FaceMarks, FaceMarksError> {
        static LOADED: OnceLock<Result<FaceMarks, FaceMarksError>> = OnceLock::new();
        LOADED
            .get_or_init(|| FaceMarks::parse(MODEL))
            .as_ref()
            .map_err(Clone::clone)
    }
}

#[cfg(test)]
mod tests {
    use glam::DMat3;

    use super::*;

    fn identity_mirror() -> String {
        format!(
            "mirror = [{}]\n",
            (0..MESH_POINTS)
                .map(|k| k.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )
    }

    #[test]
    fn the_shipped_model_loads_and_marks_the_ten_vertices_in_mirror_pairs() {
        let model = FaceMarks::shipped().unwrap();
        let mut vertices: Vec<u32> = model.marks.iter().map(|m| m.mask_vertex).collect();
        vertices.sort_unstable();
        assert_eq!(vertices, [5, 10, 20, 23, 26, 31, 53, 56, 59, 64]);
        // MediaPipe's nose tip and its eyes' outer corners (33 right, 263 left).
        assert_eq!(model.mirror[4], 4);
        assert_eq!((model.mirror[33], model.mirror[263]), (263, 33));
        // A pair's models are each other's mirror images: the left alar wing (26) from the
        // mirror images of the right one's (59) points, its offset mirrored across x.
        let find = |v: u32| model.marks.iter().find(|m| m.mask_vertex == v).unwrap();
        let (left, right) = (find(26), find(59));
        for (&(p, w), &(q, u)) in left.terms.iter().zip(&right.terms) {
            assert_eq!((model.mirror[p], w), (q, u));
        }
        assert!((left.offset * DVec3::new(-1.0, 1.0, 1.0) - right.offset).length() < 1e-9);
        // The nose tip and the chin are their own mirror images.
        for vertex in [5, 10] {
            let mark = find(vertex);
            for &(p, w) in &mark.terms {
                let partner = mark.terms.iter().find(|(q, _)| *q == model.mirror[p]);
                assert_eq!(partner.map(|&(_, u)| u), Some(w), "vertex {vertex}, point {p}");
            }
            assert!(mark.offset.x.abs() < 1e-6, "vertex {vertex}: {}", mark.offset);
        }
    }

    /// Hand-computed: two points weighted 0.25 and 0.75, an offset turned a quarter turn
    /// about z and doubled.
    #[test]
    fn a_mark_is_its_points_weighted_plus_its_offset_in_the_fits_frame() {
        let text = format!(
            "{}[[mark]]\nmask_vertex = 5\npoints = [1, 2]\nweights = [0.25, 0.75]\noffset = [0.1, 0.0, 0.0]\n",
            identity_mirror()
        );
        let model = FaceMarks::parse(&text).unwrap();
        let mut points = vec![None; MESH_POINTS];
        points[1] = Some(DVec3::new(4.0, 0.0, 0.0));
        points[2] = Some(DVec3::new(0.0, 4.0, 8.0));
        let similarity = Similarity {
            rotation: DMat3::from_rotation_z(std::f64::consts::FRAC_PI_2),
            scale: 2.0,
            translation: DVec3::new(100.0, 0.0, 0.0),
        };
        let mark = model.marks[0].predict(&points, &similarity).unwrap();
        assert!((mark - DVec3::new(1.0, 3.2, 6.0)).length() < 1e-12, "{mark}");
        points[2] = None;
        assert_eq!(model.marks[0].predict(&points, &similarity), None);
    }

    #[test]
    fn a_broken_model_is_refused_with_what_is_wrong() {
        let mark = |points: &str, weights: &str| {
            format!(
                "{}[[mark]]\nmask_vertex = 26\npoints = {points}\nweights = {weights}\noffset = [0.0, 0.0, 0.0]\n",
                identity_mirror()
            )
        };
        let error = |text: &str| FaceMarks::parse(text).unwrap_err().to_string();
        assert!(
            error(&mark("[1, 468]", "[0.5, 0.5]")).contains("mask vertex 26: face-mesh point 468 is past")
        );
        assert!(error(&mark("[1, 2]", "[0.5, 0.6]")).contains("the weights sum to 1.1"));
        assert!(error(&mark("[1, 2]", "[1.0]")).contains("2 points and 1 weights"));
        assert!(error("mirror = [0, 1]\nmark = []\n").contains("`mirror` has 2 entries"));
        let swapped = identity_mirror().replacen("[0, 1,", "[1, 1,", 1) + "mark = []\n";
        assert!(error(&swapped).contains("not its own inverse at face-mesh point 0"));
    }
}
