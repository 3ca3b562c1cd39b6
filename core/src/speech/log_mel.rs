//! The log-mel spectrum of speech, frame by frame as samples arrive: what the viseme
//! model hears. Frame `i` is the Hann-windowed [`WINDOW`] samples from sample
//! `i * HOP` (25 ms every 10 ms at 16 kHz), its power spectrum ([`FFT_SIZE`]-point real
//! FFT) summed into [`MELS`] triangular bands evenly spaced on the HTK mel scale from
//! [`LOW_HZ`] to [`HIGH_HZ`], and the natural log of each band's power (samples scaled
//! to -1..1), floored at [`POWER_FLOOR`]. data/speech/train.py reads the same frames
//! through `examples/speech_features.rs`, so training and serving cannot disagree.
//!
//! Per frame nothing is allocated: the window, the FFT plan and its buffers are made once.

use std::sync::Arc;

use realfft::num_complex::Complex32;
use realfft::{RealFftPlanner, RealToComplex};

/// Samples per second the model hears (16 kHz, wide-band speech).
pub const SAMPLE_RATE_HZ: u32 = 16_000;
/// Samples between frames: 10 ms.
pub const HOP: usize = 160;
/// Samples in a frame's window: 25 ms.
pub const WINDOW: usize = 400;
/// FFT length: the window zero-padded to a power of two.
pub const FFT_SIZE: usize = 512;
/// Mel bands per frame.
pub const MELS: usize = 40;
/// The lowest band's lower edge, Hz.
pub const LOW_HZ: f32 = 60.0;
/// The highest band's upper edge, Hz.
pub const HIGH_HZ: f32 = 7_600.0;
/// A band's power is floored here before its log (-100 dB of full scale).
pub const POWER_FLOOR: f32 = 1e-10;

/// Seconds from a stream's first sample to the centre of frame `index`.
pub fn frame_centre_s(index: usize) -> f64 {
    (index * HOP + WINDOW / 2) as f64 / f64::from(SAMPLE_RATE_HZ)
}

/// One band of the filterbank: weights over FFT bins `first..first + weights.len()`.
struct Band {
    first: usize,
    weights: Vec<f32>,
}

/// Streaming log-mel frames of 16 kHz speech.
pub struct LogMel {
    window: Vec<f32>,
    bands: Vec<Band>,
    fft: Arc<dyn RealToComplex<f32>>,
    /// The next frame's samples heard so far (at most [`WINDOW`]).
    pending: Vec<f32>,
    frame_input: Vec<f32>,
    spectrum: Vec<Complex32>,
    scratch: Vec<Complex32>,
    frame: [f32; MELS],
}

fn hz_to_mel(hz: f32) -> f32 {
    2595.0 * (1.0 + hz / 700.0).log10()
}

fn mel_to_hz(mel: f32) -> f32 {
    700.0 * (10f32.powf(mel / 2595.0) - 1.0)
}

/// The triangular mel filterbank over the `FFT_SIZE / 2 + 1` bins.
fn filterbank() -> Vec<Band> {
    let bin_hz = SAMPLE_RATE_HZ as f32 / FFT_SIZE as f32;
    let (low, high) = (hz_to_mel(LOW_HZ), hz_to_mel(HIGH_HZ));
    let edge_hz = |k: usize| mel_to_hz(low + (high - low) * k as f32 / (MELS + 1) as f32);
    (0..MELS)
        .map(|m| {
            let (left, centre, right) = (edge_hz(m), edge_hz(m + 1), edge_hz(m + 2));
            let first = (left / bin_hz).ceil() as usize;
            let last = ((right / bin_hz).floor() as usize).min(FFT_SIZE / 2);
            let weights = (first..=last)
                .map(|bin| {
                    let hz = bin as f32 * bin_hz;
                    if hz <= centre {
                        (hz - left) / (centre - left)
                    } else {
                        (right - hz) / (right - centre)
                    }
                    .max(0.0)
                })
                .collect();
            Band { first, weights }
        })
        .collect()
}

impl Default for LogMel {
    fn default() -> Self {
        Self::new()
    }
}

impl LogMel {
    pub fn new() -> Self {
        let fft = RealFftPlanner::<f32>::new().plan_fft_forward(FFT_SIZE);
        let window = (0..WINDOW)
            .map(|n| 0.5 - 0.5 * (2.0 * std::f32::consts::PI * n as f32 / WINDOW as f32).cos())
            .collect();
        LogMel {
            window,
            bands: filterbank(),
            frame_input: fft.make_input_vec(),
            spectrum: fft.make_output_vec(),
            scratch: fft.make_scratch_vec(),
            fft,
            pending: Vec::with_capacity(WINDOW),
            frame: [0.0; MELS],
        }
    }

    /// Takes `samples` (16 kHz, full scale -1..1) and calls `on_frame` with each frame
    /// they complete, in order.
    pub fn push(&mut self, samples: &[f32], mut on_frame: impl FnMut(&[f32; MELS])) {
        let mut rest = samples;
        while !rest.is_empty() {
            let take = (WINDOW - self.pending.len()).min(rest.len());
            self.pending.extend_from_slice(&rest[..take]);
            rest = &rest[take..];
            if self.pending.len() == WINDOW {
                self.compute_frame();
                on_frame(&self.frame);
                self.pending.drain(..HOP);
            }
        }
    }

    fn compute_frame(&mut self) {
        for ((input, &sample), &w) in self.frame_input.iter_mut().zip(&self.pending).zip(&self.window) {
            *input = sample * w;
        }
        self.frame_input[WINDOW..].fill(0.0);
        // The lengths are the plan's own, so the transform cannot fail.
        self.fft
            .process_with_scratch(&mut self.frame_input, &mut self.spectrum, &mut self.scratch)
            .expect("FFT buffers made by their plan");
        for (out, band) in self.frame.iter_mut().zip(&self.bands) {
            let power: f32 = band
                .weights
                .iter()
                .zip(&self.spectrum[band.first..])
                .map(|(w, bin)| w * bin.norm_sqr())
                .sum();
            *out = power.max(POWER_FLOOR).ln();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frames_of(samples: &[f32]) -> Vec<[f32; MELS]> {
        let mut frames = Vec::new();
        LogMel::new().push(samples, |f| frames.push(*f));
        frames
    }

    #[test]
    fn frames_come_every_hop_once_a_window_is_full() {
        assert_eq!(frames_of(&vec![0.0; WINDOW - 1]).len(), 0);
        assert_eq!(frames_of(&vec![0.0; WINDOW]).len(), 1);
        assert_eq!(frames_of(&vec![0.0; WINDOW + HOP - 1]).len(), 1);
        assert_eq!(frames_of(&vec![0.0; 16_000]).len(), 1 + (16_000 - WINDOW) / HOP);
        assert!((frame_centre_s(0) - 0.0125).abs() < 1e-12);
        assert!((frame_centre_s(10) - 0.1125).abs() < 1e-12);
    }

    #[test]
    fn pushing_in_pieces_gives_the_same_frames() {
        let samples: Vec<f32> = (0..5_000).map(|n| (n as f32 * 0.37).sin() * 0.3).collect();
        let whole = frames_of(&samples);
        let mut pieces = Vec::new();
        let mut log_mel = LogMel::new();
        for chunk in samples.chunks(321) {
            log_mel.push(chunk, |f| pieces.push(*f));
        }
        assert_eq!(whole, pieces);
    }

    #[test]
    fn silence_is_the_floor_and_a_tone_lights_its_band() {
        assert!(frames_of(&vec![0.0; WINDOW])[0]
            .iter()
            .all(|&x| x == POWER_FLOOR.ln()));
        // A 1 kHz tone: the band whose centre is nearest 1 kHz is the loudest.
        let tone: Vec<f32> = (0..WINDOW)
            .map(|n| (2.0 * std::f32::consts::PI * 1000.0 * n as f32 / 16_000.0).sin() * 0.5)
            .collect();
        let frame = frames_of(&tone)[0];
        let loudest = (0..MELS).max_by(|&a, &b| frame[a].total_cmp(&frame[b])).unwrap();
        let (low, high) = (hz_to_mel(LOW_HZ), hz_to_mel(HIGH_HZ));
        let centre = |m: usize| mel_to_hz(low + (high - low) * (m + 1) as f32 / (MELS + 1) as f32);
        let nearest = (0..MELS)
            .min_by(|&a, &b| (centre(a) - 1000.0).abs().total_cmp(&(centre(b) - 1000.0).abs()))
            .unwrap();
        assert_eq!(loudest, nearest);
        // Its power: a sine of amplitude A under a Hann window has |X(k)| = A W / 4 at its bin
        // (W the window length): (0.5 * 400 / 4)^2 = 2500 from that bin alone. All its
        // positive-frequency bins together hold, by Parseval, N/2 * (A^2 / 2) * 3W/8 =
        // 256 * 0.125 * 150 = 4800; the band weighs the bins of the main lobe by at most 1.
        let power = frame[loudest].exp();
        assert!(power > 2500.0 && power < 4800.0, "{power}");
        let far: Vec<usize> = (0..MELS)
            .filter(|&m| (centre(m) - 1000.0).abs() > 500.0)
            .collect();
        let leak = far.iter().map(|&m| frame[m]).fold(f32::NEG_INFINITY, f32::max) - frame[loudest];
        assert!(leak < -7.0, "bands 500 Hz away are {leak} nats under the tone");
    }

    #[test]
    fn every_band_has_weight_and_the_bands_tile_the_range() {
        for (m, band) in filterbank().iter().enumerate() {
            assert!(band.weights.iter().any(|&w| w > 0.0), "band {m}");
            assert!(band.weights.iter().all(|&w| (0.0..=1.0).contains(&w)), "band {m}");
        }
    }
}
