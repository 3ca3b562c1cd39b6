//! The viseme model: a small multilayer perceptron from a window of normalized log-mel
//! frames to the probabilities of the 15 visemes at the window's centre frame, with the
//! constants of its input normalization and of its decoder. Trained by
//! data/speech/train.py (docs/SPEECH.md is its model card) and shipped embedded in the
//! binary as data/speech/visemes.safetensors; any file of the same layout loads.
//!
//! The file is checked as it loads (layer shapes that chain, finite numbers, a context
//! that ends in the future by at most [`MAX_LOOKAHEAD_FRAMES`]), so a bad file is named
//! at start and never at the first frame.

use std::collections::HashMap;

use safetensors::{Dtype, SafeTensors};

use super::log_mel::{HOP, MELS, SAMPLE_RATE_HZ, WINDOW};

/// Visemes the model tells apart: MPEG-4's (Oculus's) 15, `sil` first.
pub const VISEME_COUNT: usize = 15;
/// Features per frame: the [`MELS`] normalized bands and the frame's loudness below the
/// recent peak.
pub const FEATURES: usize = MELS + 1;
/// No model may wait for more than this many frames after the one it decides (60 ms of
/// look-ahead with the frame's own window).
pub const MAX_LOOKAHEAD_FRAMES: i32 = 4;
/// Earliest frame a model may look back to.
pub const MAX_LOOKBACK_FRAMES: i32 = 100;
/// The format this reader knows, the file's `format` metadata.
pub const FORMAT: &str = "facewire-visemes-1";

const EMBEDDED: &[u8] = include_bytes!("../../../data/speech/visemes.safetensors");

/// Why a viseme model file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    #[error("{origin}: not a safetensors file: {reason}")]
    Format { origin: String, reason: String },
    #[error("{origin}: metadata `{key}`: {reason}")]
    Metadata {
        origin: String,
        key: String,
        reason: String,
    },
    #[error("{origin}: tensor `{name}`: {reason}")]
    Tensor {
        origin: String,
        name: String,
        reason: String,
    },
}

/// One fully connected layer: `out = weight * input + bias`, `weight` row-major
/// (`outputs` rows of `inputs`).
#[derive(Debug, Clone, PartialEq)]
pub struct Dense {
    pub inputs: usize,
    pub outputs: usize,
    pub weight: Vec<f32>,
    pub bias: Vec<f32>,
}

impl Dense {
    /// `out = weight * input + bias`, then ReLU when `relu`.
    pub fn apply(&self, input: &[f32], out: &mut [f32], relu: bool) {
        for ((o, row), b) in out
            .iter_mut()
            .zip(self.weight.chunks_exact(self.inputs))
            .zip(&self.bias)
        {
            let sum = dot(row, input) + b;
            *o = if relu { sum.max(0.0) } else { sum };
        }
    }
}

/// Lanes of [`dot`]'s partial sums: independent accumulators the compiler keeps in one
/// SIMD register (a single running sum would serialize every add).
const LANES: usize = 8;

/// `a . b` over the shorter length, summed in [`LANES`] interleaved partial sums.
fn dot(a: &[f32], b: &[f32]) -> f32 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut lanes = [0.0f32; LANES];
    let (a_body, b_body) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
    let tail: f32 = a_body
        .remainder()
        .iter()
        .zip(b_body.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in a_body.zip(b_body) {
        for k in 0..LANES {
            lanes[k] += x[k] * y[k];
        }
    }
    lanes.iter().sum::<f32>() + tail
}

/// How each log-mel frame becomes the model's input (docs/SPEECH.md, "Features").
#[derive(Debug, Clone, PartialEq)]
pub struct Normalization {
    /// Each band's running mean starts here (log power).
    pub mean_init: [f32; MELS],
    /// 1 / each band's spread in training.
    pub inv_std: [f32; MELS],
    /// The running mean moves this share of the way to each loud frame.
    pub mean_rate: f32,
    /// The recent peak of a frame's mean log power falls this much per frame (nats).
    pub peak_decay: f32,
    /// Frames more than this below the peak (nats) leave the running mean alone.
    pub gate: f32,
    /// The loudness feature: (frame level - peak) times this.
    pub loudness_scale: f32,
}

/// The decoder's constants: a forward filter over the visemes at 10 ms steps.
#[derive(Debug, Clone, PartialEq)]
pub struct Decoder {
    /// How often each viseme is heard in training (sums to 1).
    pub prior: [f32; VISEME_COUNT],
    /// `transition[from * 15 + to]`: probability of `to` 10 ms after `from`.
    pub transition: Vec<f32>,
}

/// A loaded viseme model.
#[derive(Debug, Clone, PartialEq)]
pub struct VisemeModel {
    /// Frames the input window takes, relative to the decided frame, ascending.
    pub context: Vec<i32>,
    pub normalization: Normalization,
    pub layers: Vec<Dense>,
    pub decoder: Decoder,
}

struct Reader<'a> {
    origin: &'a str,
    tensors: SafeTensors<'a>,
    metadata: HashMap<String, String>,
}

impl Reader<'_> {
    fn meta(&self, key: &str) -> Result<&str, ModelError> {
        self.metadata
            .get(key)
            .map(String::as_str)
            .ok_or_else(|| self.meta_error(key, "missing"))
    }

    fn meta_error(&self, key: &str, reason: impl Into<String>) -> ModelError {
        ModelError::Metadata {
            origin: self.origin.to_owned(),
            key: key.to_owned(),
            reason: reason.into(),
        }
    }

    fn number(&self, key: &str) -> Result<f32, ModelError> {
        let text = self.meta(key)?;
        text.parse::<f32>()
            .ok()
            .filter(|x| x.is_finite() && *x >= 0.0)
            .ok_or_else(|| self.meta_error(key, format!("{text:?} is not a finite number >= 0")))
    }

    fn tensor_error(&self, name: &str, reason: impl Into<String>) -> ModelError {
        ModelError::Tensor {
            origin: self.origin.to_owned(),
            name: name.to_owned(),
            reason: reason.into(),
        }
    }

    /// A float32 tensor of exactly `shape`, every value finite.
    fn floats(&self, name: &str, shape: &[usize]) -> Result<Vec<f32>, ModelError> {
        let view = self
            .tensors
            .tensor(name)
            .map_err(|e| self.tensor_error(name, e.to_string()))?;
        if view.dtype() != Dtype::F32 {
            return Err(self.tensor_error(name, format!("{:?}, expected F32", view.dtype())));
        }
        if view.shape() != shape {
            return Err(self.tensor_error(name, format!("shape {:?}, expected {shape:?}", view.shape())));
        }
        let values: Vec<f32> = view
            .data()
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        match values.iter().position(|x| !x.is_finite()) {
            Some(i) => Err(self.tensor_error(name, format!("value {i} is {}", values[i]))),
            None => Ok(values),
        }
    }

    /// The shape of tensor `name`, if the file has it.
    fn shape(&self, name: &str) -> Option<Vec<usize>> {
        self.tensors.tensor(name).ok().map(|v| v.shape().to_vec())
    }

    fn array<const N: usize>(&self, name: &str) -> Result<[f32; N], ModelError> {
        let values = self.floats(name, &[N])?;
        Ok(std::array::from_fn(|i| values[i]))
    }
}

impl VisemeModel {
    /// The model facewire ships (data/speech/visemes.safetensors).
    pub fn embedded() -> Result<Self, ModelError> {
        Self::from_bytes(EMBEDDED, "data/speech/visemes.safetensors")
    }

    /// Reads and checks a model; `origin` names it in errors.
    pub fn from_bytes(bytes: &[u8], origin: &str) -> Result<Self, ModelError> {
        let format_error = |reason: String| ModelError::Format {
            origin: origin.to_owned(),
            reason,
        };
        let (_, header) = SafeTensors::read_metadata(bytes).map_err(|e| format_error(e.to_string()))?;
        let metadata = header.metadata().clone().unwrap_or_default();
        let tensors = SafeTensors::deserialize(bytes).map_err(|e| format_error(e.to_string()))?;
        let reader = Reader {
            origin,
            tensors,
            metadata,
        };
        let format = reader.meta("format")?;
        if format != FORMAT {
            return Err(reader.meta_error("format", format!("{format:?}, this facewire reads {FORMAT:?}")));
        }
        let context = read_context(&reader)?;
        let normalization = Normalization {
            mean_init: reader.array("feature_mean")?,
            inv_std: reader.array("feature_inv_std")?,
            mean_rate: reader.number("mean_rate")?,
            peak_decay: reader.number("peak_decay")?,
            gate: reader.number("gate")?,
            loudness_scale: reader.number("loudness_scale")?,
        };
        if normalization.mean_rate > 1.0 {
            return Err(reader.meta_error("mean_rate", "above 1"));
        }
        let mut layers = Vec::new();
        let mut inputs = context.len() * FEATURES;
        while let Some(shape) = reader.shape(&format!("dense{}.weight", layers.len())) {
            let name = format!("dense{}", layers.len());
            let outputs = shape.first().copied().unwrap_or(0);
            if outputs == 0 || outputs > 4096 {
                return Err(reader.tensor_error(&format!("{name}.weight"), format!("{outputs} outputs")));
            }
            layers.push(Dense {
                inputs,
                outputs,
                weight: reader.floats(&format!("{name}.weight"), &[outputs, inputs])?,
                bias: reader.floats(&format!("{name}.bias"), &[outputs])?,
            });
            inputs = outputs;
        }
        if layers.is_empty() || inputs != VISEME_COUNT {
            return Err(reader.tensor_error(
                &format!("dense{}.weight", layers.len().saturating_sub(1)),
                format!("the last layer has {inputs} outputs, expected one per viseme ({VISEME_COUNT})"),
            ));
        }
        let decoder = Decoder {
            prior: reader.array("viseme_prior")?,
            transition: reader.floats("viseme_transition", &[VISEME_COUNT, VISEME_COUNT])?,
        };
        Ok(VisemeModel {
            context,
            normalization,
            layers,
            decoder,
        })
    }

    /// Frames after the decided one the model needs.
    pub fn lookahead_frames(&self) -> usize {
        self.context.last().map_or(0, |&o| o.max(0) as usize)
    }

    /// Seconds from a sample arriving to the decision of the frame centred on it: the
    /// look-ahead frames and the half window after the centre.
    pub fn lookahead_s(&self) -> f64 {
        let samples = self.lookahead_frames() * HOP + WINDOW / 2;
        samples as f64 / f64::from(SAMPLE_RATE_HZ)
    }

    /// Frames before the decided one the model needs.
    pub fn lookback_frames(&self) -> usize {
        self.context.first().map_or(0, |&o| (-o).max(0) as usize)
    }

    /// The widest layer's width (the scratch a forward pass needs).
    pub fn widest_layer(&self) -> usize {
        self.layers
            .iter()
            .map(|l| l.outputs.max(l.inputs))
            .max()
            .unwrap_or(0)
    }
}

fn read_context(reader: &Reader) -> Result<Vec<i32>, ModelError> {
    let text = reader.meta("context")?;
    let context = text
        .split(',')
        .map(|s| s.trim().parse::<i32>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| reader.meta_error("context", format!("{text:?}: {e}")))?;
    let ascending = context.windows(2).all(|w| w[0] < w[1]);
    match (context.first(), context.last()) {
        (Some(&first), Some(&last)) if ascending && first >= -MAX_LOOKBACK_FRAMES && last <= MAX_LOOKAHEAD_FRAMES => {
            Ok(context)
        }
        _ => Err(reader.meta_error(
            "context",
            format!(
                "{text:?}: expected ascending frame offsets from -{MAX_LOOKBACK_FRAMES} to {MAX_LOOKAHEAD_FRAMES}"
            ),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_model_loads_and_looks_ahead_at_most_four_frames() {
        let model = VisemeModel::embedded().unwrap();
        assert!(model.lookahead_frames() <= 4);
        assert_eq!(model.layers.last().unwrap().outputs, VISEME_COUNT);
        let prior_sum: f32 = model.decoder.prior.iter().sum();
        assert!((prior_sum - 1.0).abs() < 1e-4, "{prior_sum}");
        for row in model.decoder.transition.chunks(VISEME_COUNT) {
            assert!((row.iter().sum::<f32>() - 1.0).abs() < 1e-4);
        }
    }

    #[test]
    fn a_file_that_is_not_a_model_is_named() {
        let error = VisemeModel::from_bytes(b"not a model", "x.safetensors").unwrap_err();
        assert!(
            error
                .to_string()
                .starts_with("x.safetensors: not a safetensors file"),
            "{error}"
        );
    }

    #[test]
    fn a_dense_layer_is_hand_computable() {
        let layer = Dense {
            inputs: 2,
            outputs: 2,
            weight: vec![1.0, 2.0, -3.0, 0.5],
            bias: vec![0.5, 0.0],
        };
        let mut out = [0.0; 2];
        layer.apply(&[1.0, 1.0], &mut out, false);
        assert_eq!(out, [3.5, -2.5]);
        layer.apply(&[1.0, 1.0], &mut out, true);
        assert_eq!(out, [3.5, 0.0]);
    }

    #[test]
    fn the_dot_product_counts_the_body_and_the_tail() {
        let a: Vec<f32> = (1..=19).map(|i| i as f32).collect();
        assert_eq!(dot(&a, &[1.0; 19]), 190.0);
        assert_eq!(dot(&a, &[2.0; 3]), 12.0);
        assert_eq!(dot(&[], &[]), 0.0);
    }
}
