//! The learned face-mesh model the automatic fit reads faces with: MediaPipe's face landmark
//! network (Apache-2.0; `data/models/face_landmark.onnx`, converted from the TFLite file in
//! MediaPipe's wheel by `tools/face_landmarks/convert.py`, licence and origin in
//! `data/models/LICENSES.md`). Given a 192 x 192 picture of a face it places the 468 points
//! of MediaPipe's face mesh on it and says how sure it is that a face is there. Trained on
//! photographs of many thousands of people, it knows faces the hand-set rules never saw.
//!
//! The model's bytes are part of the binary (so the demo needs no file beside it) and are
//! parsed and checked once per process, on first use, and run by [`super::conv_net`].

use std::sync::OnceLock;

use glam::Vec3;

use super::conv_net::{ConvNet, Shape};
use super::onnx_file::read_onnx;

/// The network's input side, pixels.
pub const CROP_PIXELS: usize = 192;
/// Points of MediaPipe's face mesh.
pub const MESH_POINTS: usize = 468;

const MODEL: &[u8] = include_bytes!("../../../../data/models/face_landmark.onnx");

#[derive(Debug, Clone, thiserror::Error)]
pub enum FaceModelError {
    #[error("the face landmark model (data/models/face_landmark.onnx) could not be loaded: {0}")]
    Load(String),
    #[error("the face landmark model failed on a picture: {0}")]
    Run(String),
    /// The learned marks (`face_marks.rs`) did not load: the message names the file.
    #[error("the learned face marks could not be loaded: {0}")]
    Marks(String),
}

/// What the model sees in one picture.
#[derive(Debug, Clone, PartialEq)]
pub struct FaceMesh {
    /// The face mesh's points: x right and y down in pixels of the picture, z towards the
    /// viewer's far side in the same scale, relative to the face's centre.
    pub points: Vec<Vec3>,
    /// The model's logit that the picture holds a face (above 0: more likely than not).
    pub face_logit: f32,
}

impl FaceMesh {
    /// The probability the picture holds a face.
    pub fn face_probability(&self) -> f32 {
        1.0 / (1.0 + (-self.face_logit).exp())
    }
}

fn model() -> Result<&'static ConvNet, FaceModelError> {
    static LOADED: OnceLock<Result<ConvNet, FaceModelError>> = OnceLock::new();
    LOADED
        .get_or_init(|| {
            let graph = read_onnx(MODEL).map_err(|e| FaceModelError::Load(e.to_string()))?;
            let input = Shape {
                channels: 3,
                rows: CROP_PIXELS,
                columns: CROP_PIXELS,
            };
            ConvNet::from_onnx(&graph, "image", input, &["landmarks", "face_flag"])
                .map_err(|e| FaceModelError::Load(e.to_string()))
        })
        .as_ref()
        .map_err(Clone::clone)
}

/// Runs the model on a grey picture: `grey` holds [`CROP_PIXELS`] rows of [`CROP_PIXELS`]
/// values in [0, 1], top row first.
pub fn read_face(grey: &[f32]) -> Result<FaceMesh, FaceModelError> {
    let pixels = CROP_PIXELS * CROP_PIXELS;
    if grey.len() != pixels {
        return Err(FaceModelError::Run(format!(
            "the picture has {} values, the model takes {pixels}",
            grey.len()
        )));
    }
    // The same grey in the red, green and blue planes.
    let planes = grey.repeat(3);
    let outputs = model()?
        .run(&planes)
        .map_err(|e| FaceModelError::Run(e.to_string()))?;
    let (coordinates, flag) = (&outputs[0], &outputs[1]);
    if coordinates.len() != 3 * MESH_POINTS || flag.len() != 1 {
        return Err(FaceModelError::Run(format!(
            "the model gave {} coordinates and {} flags, not {} and 1",
            coordinates.len(),
            flag.len(),
            3 * MESH_POINTS
        )));
    }
    Ok(FaceMesh {
        points: coordinates
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect(),
        face_logit: flag[0],
    })
}
