//! Speech in, visemes out, causally: [`VisemeTracker`] takes 16 kHz samples as they arrive
//! and decides the viseme of each 10 ms frame as soon as the model's look-ahead has been
//! heard (docs/SPEECH.md, "Latency"). Each frame is normalized against the speech heard so
//! far, a window of frames goes through the [`VisemeModel`], and a forward filter over the
//! visemes (the model's posteriors over its training priors, times the training
//! transitions) keeps one stray frame from flipping the mouth.
//!
//! A tracker allocates once, when made; per frame it only computes.

use std::sync::Arc;

use super::log_mel::{frame_centre_s, LogMel, MELS};
use super::model::{Dense, VisemeModel, FEATURES, VISEME_COUNT};

/// One decided 10 ms frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decision {
    /// Frame index from the stream's first sample (10 ms steps).
    pub frame: usize,
    /// The frame's centre, seconds from the stream's first sample.
    pub time_s: f64,
    /// The viseme shown: MPEG-4 / Oculus number, 0 (`sil`) to 14 (`ou`).
    pub viseme: u8,
    /// The filtered probability of each viseme (sums to 1).
    pub probability: [f32; VISEME_COUNT],
}

/// The running state of one speech stream.
pub struct VisemeTracker {
    model: Arc<VisemeModel>,
    log_mel: LogMel,
    mean: [f32; MELS],
    peak: Option<f32>,
    /// The last `history_len` normalized frames, frame `k` at `k % history_len`.
    history: Vec<f32>,
    history_len: usize,
    /// Frames normalized so far.
    frames: usize,
    /// Frames decided so far.
    decided: usize,
    input: Vec<f32>,
    hidden: [Vec<f32>; 2],
    filter: Option<[f32; VISEME_COUNT]>,
}

impl VisemeTracker {
    pub fn new(model: Arc<VisemeModel>) -> Self {
        let history_len = model.lookback_frames() + model.lookahead_frames() + 1;
        let width = model.widest_layer();
        VisemeTracker {
            log_mel: LogMel::new(),
            mean: model.normalization.mean_init,
            peak: None,
            history: vec![0.0; history_len * FEATURES],
            history_len,
            frames: 0,
            decided: 0,
            input: vec![0.0; model.context.len() * FEATURES],
            hidden: [vec![0.0; width], vec![0.0; width]],
            filter: None,
            model,
        }
    }

    /// Takes samples at 16 kHz (full scale -1..1) and calls `on_decision` for each frame
    /// they let the tracker decide, in order.
    pub fn push(&mut self, samples: &[f32], mut on_decision: impl FnMut(&Decision)) {
        let mut log_mel = std::mem::take(&mut self.log_mel);
        log_mel.push(samples, |frame| self.push_log_mel(frame, &mut on_decision));
        self.log_mel = log_mel;
    }

    /// Takes the next log-mel frame (what [`LogMel`] makes of the samples).
    fn push_log_mel(&mut self, frame: &[f32; MELS], on_decision: &mut impl FnMut(&Decision)) {
        self.normalize(frame);
        let lookahead = self.model.lookahead_frames();
        if self.frames > lookahead {
            let decision = self.decide(self.frames - 1 - lookahead);
            on_decision(&decision);
        }
    }

    /// The stream has ended: decides the frames still waiting for their look-ahead, with
    /// the last frame heard standing in for the future.
    pub fn finish(&mut self, mut on_decision: impl FnMut(&Decision)) {
        while self.decided < self.frames {
            let decision = self.decide(self.decided);
            on_decision(&decision);
        }
    }

    fn normalize(&mut self, frame: &[f32; MELS]) {
        let n = &self.model.normalization;
        let level = frame.iter().sum::<f32>() / MELS as f32;
        let peak = self.peak.map_or(level, |p| level.max(p - n.peak_decay));
        self.peak = Some(peak);
        if level > peak - n.gate {
            for (m, &x) in self.mean.iter_mut().zip(frame) {
                *m += n.mean_rate * (x - *m);
            }
        }
        let slot = (self.frames % self.history_len) * FEATURES;
        let out = &mut self.history[slot..slot + FEATURES];
        for (((o, &x), &m), &s) in out.iter_mut().zip(frame).zip(&self.mean).zip(&n.inv_std) {
            *o = (x - m) * s;
        }
        out[MELS] = (level - peak) * n.loudness_scale;
        self.frames += 1;
    }

    fn decide(&mut self, frame: usize) -> Decision {
        let last = self.frames - 1;
        for (k, &offset) in self.model.context.iter().enumerate() {
            let at = (frame as i64 + i64::from(offset)).clamp(0, last as i64) as usize;
            let slot = (at % self.history_len) * FEATURES;
            self.input[k * FEATURES..(k + 1) * FEATURES]
                .copy_from_slice(&self.history[slot..slot + FEATURES]);
        }
        let logits = forward(&self.model.layers, &self.input, &mut self.hidden);
        let probability = self.filter_step(&softmax(&logits));
        let viseme = (0..VISEME_COUNT)
            .max_by(|&x, &y| probability[x].total_cmp(&probability[y]))
            .unwrap_or(0) as u8;
        self.decided = frame + 1;
        Decision {
            frame,
            time_s: frame_centre_s(frame),
            viseme,
            probability,
        }
    }

    /// One step of the forward filter: the model's posterior over the prior is each
    /// viseme's scaled likelihood, times the chance of reaching it from the last state.
    fn filter_step(&mut self, posterior: &[f32; VISEME_COUNT]) -> [f32; VISEME_COUNT] {
        let decoder = &self.model.decoder;
        let mut next = [0.0f32; VISEME_COUNT];
        for (to, out) in next.iter_mut().enumerate() {
            let reach = match &self.filter {
                Some(state) => (0..VISEME_COUNT)
                    .map(|from| state[from] * decoder.transition[from * VISEME_COUNT + to])
                    .sum(),
                None => decoder.prior[to],
            };
            *out = posterior[to] / decoder.prior[to].max(1e-6) * reach;
        }
        let total: f32 = next.iter().sum();
        if total > 0.0 && total.is_finite() {
            next.iter_mut().for_each(|p| *p /= total);
        } else {
            next = *posterior;
        }
        self.filter = Some(next);
        next
    }
}

/// The model's logits for `input`, hidden layers alternating between the two buffers.
fn forward(layers: &[Dense], input: &[f32], hidden: &mut [Vec<f32>; 2]) -> [f32; VISEME_COUNT] {
    let mut logits = [0.0f32; VISEME_COUNT];
    let [a, b] = hidden;
    let (mut from, mut to) = (a, b);
    for (i, layer) in layers.iter().enumerate() {
        let source: &[f32] = if i == 0 { input } else { &from[..layer.inputs] };
        if i + 1 == layers.len() {
            layer.apply(source, &mut logits, false);
        } else {
            layer.apply(source, &mut to[..layer.outputs], true);
            std::mem::swap(&mut from, &mut to);
        }
    }
    logits
}

fn softmax(logits: &[f32; VISEME_COUNT]) -> [f32; VISEME_COUNT] {
    let top = logits.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let mut out = logits.map(|x| (x - top).exp());
    let total: f32 = out.iter().sum();
    out.iter_mut().for_each(|p| *p /= total);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use safetensors::SafeTensors;

    fn floats(tensors: &SafeTensors, name: &str) -> (Vec<usize>, Vec<f32>) {
        let view = tensors.tensor(name).unwrap();
        let data = view
            .data()
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        (view.shape().to_vec(), data)
    }

    /// The shipped model holds a validation file's log-mel frames and the probabilities
    /// its trainer computed for them (data/speech/train.py): the tracker must agree.
    #[test]
    fn the_tracker_computes_what_the_trainer_computed() {
        let bytes = include_bytes!("../../../data/speech/visemes.safetensors");
        let tensors = SafeTensors::deserialize(bytes).unwrap();
        let (shape, log_mel) = floats(&tensors, "check.log_mel");
        let (_, expected) = floats(&tensors, "check.probability");
        assert_eq!(shape[1], MELS);
        let mut tracker = VisemeTracker::new(Arc::new(VisemeModel::embedded().unwrap()));
        let mut decided = Vec::new();
        for frame in log_mel.chunks_exact(MELS) {
            tracker.push_log_mel(frame.try_into().unwrap(), &mut |d: &Decision| decided.push(*d));
        }
        tracker.finish(|d| decided.push(*d));
        assert_eq!(decided.len(), shape[0]);
        let mut worst = 0.0f32;
        for (d, want) in decided.iter().zip(expected.chunks_exact(VISEME_COUNT)) {
            for (p, w) in d.probability.iter().zip(want) {
                worst = worst.max((p - w).abs());
            }
        }
        assert!(worst < 2e-3, "largest probability difference {worst}");
        let argmax_agree = decided
            .iter()
            .zip(expected.chunks_exact(VISEME_COUNT))
            .filter(|(d, want)| {
                let top = (0..VISEME_COUNT)
                    .max_by(|&a, &b| want[a].total_cmp(&want[b]))
                    .unwrap();
                usize::from(d.viseme) == top
            })
            .count();
        assert!(
            argmax_agree + 2 >= decided.len(),
            "{argmax_agree} of {} frames agree",
            decided.len()
        );
    }

    #[test]
    fn the_look_ahead_is_four_frames_and_half_a_window() {
        let tracker = VisemeTracker::new(Arc::new(VisemeModel::embedded().unwrap()));
        assert_eq!(tracker.model.lookahead_frames(), 4);
        assert!((tracker.model.lookahead_s() - 0.0525).abs() < 1e-12);
    }

    #[test]
    fn each_frame_is_decided_once_in_order_and_silence_is_sil() {
        let mut tracker = VisemeTracker::new(Arc::new(VisemeModel::embedded().unwrap()));
        let mut frames = Vec::new();
        // 1 s of digital silence in pieces of odd sizes: 98 frames of 25 ms every 10 ms.
        for piece in [0.0f32; 16_000].chunks(777) {
            tracker.push(piece, |d| frames.push((d.frame, d.viseme)));
        }
        tracker.finish(|d| frames.push((d.frame, d.viseme)));
        assert_eq!(frames.len(), 98);
        assert!(
            frames.iter().enumerate().all(|(i, &(f, v))| f == i && v == 0),
            "{frames:?}"
        );
    }
}
