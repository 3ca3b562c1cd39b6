//! Audio at the wire's rates (16, 24 or 48 kHz, `PCM_RATES`; Opus decodes at 48 kHz)
//! brought to the model's 16 kHz as it arrives: a windowed-sinc (Blackman) low-pass at
//! [`CUTOFF_HZ`] evaluated at each output instant, `TAPS_HALF` input samples either side,
//! with the kernels for the rate's few phases computed once. 16 kHz passes through.
//!
//! Per chunk nothing is allocated once the buffer has grown to a chunk's size.

use super::log_mel::SAMPLE_RATE_HZ;

/// The low-pass cut-off, Hz: below 16 kHz's Nyquist frequency with a transition band.
pub const CUTOFF_HZ: f64 = 7_200.0;
/// Input samples each side of an output instant, at the input rate per 16 kHz sample.
const TAPS_HALF: usize = 24;

/// Why a rate cannot be resampled.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{rate} Hz audio cannot be brought to 16 kHz: expected 16000, 24000 or 48000 Hz")]
pub struct RateError {
    pub rate: u32,
}

/// A streaming resampler from one input rate to 16 kHz.
pub struct ToModelRate {
    /// Output instant `n` is at input position `n * down / up`.
    up: usize,
    down: usize,
    /// Per phase `(n * down) % up`: the `2 * half` weights from input `base - half + 1`.
    kernels: Vec<Vec<f32>>,
    half: usize,
    /// Input samples from absolute index `first`.
    buffer: Vec<f32>,
    first: usize,
    /// The next output sample's index.
    next: usize,
}

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

impl ToModelRate {
    pub fn new(rate: u32) -> Result<Self, RateError> {
        if !facewire_proto::audio_chunk::PCM_RATES.contains(&rate) {
            return Err(RateError { rate });
        }
        let (rate, out) = (rate as usize, SAMPLE_RATE_HZ as usize);
        let g = gcd(rate, out);
        let (up, down) = (out / g, rate / g);
        // Passing through needs no filter; otherwise the kernel spans TAPS_HALF output
        // samples' worth of input either side.
        let half = if up == down { 0 } else { TAPS_HALF * down / up };
        let cutoff = CUTOFF_HZ / rate as f64;
        let kernels = (0..up)
            .map(|phase| {
                let offset = phase as f64 / up as f64;
                (0..2 * half)
                    .map(|j| {
                        let x = j as f64 - half as f64 + 1.0 - offset;
                        let sinc = if x == 0.0 {
                            2.0 * cutoff
                        } else {
                            (2.0 * std::f64::consts::PI * cutoff * x).sin() / (std::f64::consts::PI * x)
                        };
                        let w = x / (2.0 * half as f64) + 0.5;
                        let tau = 2.0 * std::f64::consts::PI;
                        let window = 0.42 - 0.5 * (tau * w).cos() + 0.08 * (2.0 * tau * w).cos();
                        (sinc * window.max(0.0)) as f32
                    })
                    .collect()
            })
            .collect();
        Ok(ToModelRate {
            up,
            down,
            kernels,
            half,
            buffer: Vec::new(),
            first: 0,
            next: 0,
        })
    }

    /// Takes input samples (full scale -1..1) and appends the 16 kHz samples they
    /// complete to `out`.
    pub fn push(&mut self, samples: &[f32], out: &mut Vec<f32>) {
        if self.half == 0 {
            out.extend_from_slice(samples);
            return;
        }
        self.buffer.extend_from_slice(samples);
        let end = self.first + self.buffer.len();
        loop {
            let position = self.next * self.down;
            let base = position / self.up;
            if base + self.half >= end {
                break;
            }
            let kernel = &self.kernels[position % self.up];
            let start = base as i64 - self.half as i64 + 1;
            let mut sum = 0.0f32;
            for (j, &w) in kernel.iter().enumerate() {
                let at = start + j as i64 - self.first as i64;
                if at >= 0 {
                    sum += w * self.buffer[at as usize];
                }
            }
            out.push(sum);
            self.next += 1;
        }
        // Keep what the next output still reaches back to.
        let needed = (self.next * self.down / self.up + 1).saturating_sub(self.half);
        if needed > self.first {
            let drop = (needed - self.first).min(self.buffer.len());
            self.buffer.drain(..drop);
            self.first += drop;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tone(rate: u32, hz: f64, seconds: f64) -> Vec<f32> {
        let n = (f64::from(rate) * seconds) as usize;
        (0..n)
            .map(|i| (0.5 * (2.0 * std::f64::consts::PI * hz * i as f64 / f64::from(rate)).sin()) as f32)
            .collect()
    }

    #[test]
    fn a_tone_keeps_its_level_and_phase_and_a_tone_above_8_khz_is_removed() {
        for rate in [24_000, 48_000] {
            let mut resampler = ToModelRate::new(rate).unwrap();
            let mut out = Vec::new();
            resampler.push(&tone(rate, 1000.0, 0.5), &mut out);
            // Output sample n is at time n / 16 kHz: compare with the tone there.
            let expected = tone(16_000, 1000.0, 0.5);
            let worst = out[100..out.len() - 100]
                .iter()
                .zip(&expected[100..])
                .map(|(a, b)| (a - b).abs())
                .fold(0.0f32, f32::max);
            assert!(worst < 0.01, "{rate} Hz: worst error {worst}");
            let mut out = Vec::new();
            ToModelRate::new(rate)
                .unwrap()
                .push(&tone(rate, 10_000.0, 0.5), &mut out);
            let peak = out[100..].iter().fold(0.0f32, |m, x| m.max(x.abs()));
            assert!(peak < 0.005, "{rate} Hz: 10 kHz left at {peak}");
        }
    }

    #[test]
    fn chunks_give_what_the_whole_gives_and_16_khz_passes_through() {
        let input = tone(48_000, 440.0, 0.3);
        let mut whole = Vec::new();
        ToModelRate::new(48_000).unwrap().push(&input, &mut whole);
        let mut pieces = Vec::new();
        let mut resampler = ToModelRate::new(48_000).unwrap();
        for chunk in input.chunks(960) {
            resampler.push(chunk, &mut pieces);
        }
        assert_eq!(whole, pieces);
        assert!(resampler.buffer.len() < 960 + 2 * resampler.half);
        let mut same = Vec::new();
        ToModelRate::new(16_000).unwrap().push(&[0.25, -0.5], &mut same);
        assert_eq!(same, [0.25, -0.5]);
        assert_eq!(ToModelRate::new(44_100).err(), Some(RateError { rate: 44_100 }));
    }
}
