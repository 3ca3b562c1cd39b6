//! A voice slowed down or sped up without changing its pitch, for a replay played at a
//! viewer's pace (0.25x for someone learning to read a syllable): WSOLA (waveform
//! similarity overlap-add, through the `wsola` crate) lays the voice's own 30 ms pieces
//! down further apart or closer together, each joined where its waveform best continues
//! the last, so the voice keeps its pitch and only its tempo changes.

use std::collections::VecDeque;
use std::num::{NonZeroU16, NonZeroU32};
use std::ops::Range;

use wsola::TimeStretch;

use super::Voice;

/// The slowest and fastest a voice is played, times its own pace.
pub const STRETCH_SPEEDS: [f64; 2] = [wsola::MIN_TEMPO as f64, wsola::MAX_TEMPO as f64];

/// Why a voice was not stretched.
#[derive(Debug, thiserror::Error)]
pub enum StretchError {
    #[error("a voice plays at {min} to {max} times its pace, not {speed}", min = STRETCH_SPEEDS[0], max = STRETCH_SPEEDS[1])]
    Speed { speed: f64 },
    #[error("a voice's sample rate is not 0")]
    SampleRate,
    #[error("stretching the voice: {0}")]
    Wsola(#[from] wsola::Error),
}

/// A stretch of a voice played at another speed, given piece by piece ([`Self::fill`]):
/// each piece costs only the work of its own samples, so a replay's voice is stretched as
/// it is sent, never whole (30 s of 48 kHz at 0.25x took 5.5 s at once; a 20 ms piece
/// takes 0.1 ms at 16 kHz, 0.9 ms at 48 kHz: `cargo bench --bench voice_stretch`). The
/// voice is `silence` samples of silence, then `source[range]` of a voice's samples passed to each
/// fill; it is given exactly `(silence + range.len()) / speed` samples long (rounded), so
/// that a replay's voice stays on its frames' timeline however long it plays.
pub struct Stretching {
    /// None at speed 1: the samples as they are.
    stretcher: Option<TimeStretch>,
    feed: Feed,
    /// Output samples still to give.
    remaining: usize,
    /// Stretched samples made but not yet given.
    made: VecDeque<f32>,
    /// One input block and one output hop, reused.
    input: Vec<f32>,
    hop: Vec<f32>,
    /// All input is in and the stretcher told so; `spent`: and its tail is out.
    drained: bool,
    spent: bool,
}

impl Stretching {
    /// `silence` samples then `source[range]` at `speed` (within [`STRETCH_SPEEDS`]).
    pub fn new(
        sample_rate: u32,
        speed: f64,
        silence: usize,
        range: Range<usize>,
    ) -> Result<Stretching, StretchError> {
        if !(STRETCH_SPEEDS[0]..=STRETCH_SPEEDS[1]).contains(&speed) {
            return Err(StretchError::Speed { speed });
        }
        let rate = NonZeroU32::new(sample_rate).ok_or(StretchError::SampleRate)?;
        let remaining = ((silence + range.len()) as f64 / speed).round() as usize;
        let stretcher = if speed == 1.0 {
            None
        } else {
            let mut stretcher = TimeStretch::new(rate, NonZeroU16::MIN)?;
            stretcher.set_tempo(speed as f32);
            Some(stretcher)
        };
        let hop = stretcher.as_ref().map_or(0, TimeStretch::min_output_buff_size);
        Ok(Stretching {
            stretcher,
            feed: Feed { silence, range },
            remaining,
            made: VecDeque::new(),
            input: Vec::with_capacity(hop),
            hop: vec![0.0; hop],
            drained: false,
            spent: false,
        })
    }

    /// Output samples still to give.
    pub fn remaining(&self) -> usize {
        self.remaining
    }

    /// Fills `out` with the next samples (`source`: the voice's samples the range is of),
    /// silence past the end; returns how many of them were still to give (0 once all are).
    pub fn fill(&mut self, source: &[i16], out: &mut [i16]) -> usize {
        let given = out.len().min(self.remaining);
        let Some(stretcher) = self.stretcher.as_mut() else {
            for sample in out.iter_mut().take(given) {
                *sample = self.feed.next(source).unwrap_or(0);
            }
            out[given..].fill(0);
            self.remaining -= given;
            return given;
        };
        while self.made.len() < given && !self.spent {
            match stretcher.pull(&mut self.hop) {
                Ok(written) => self.made.extend(&self.hop[..written]),
                Err(_) if self.drained => self.spent = true,
                Err(_) => {
                    // More input: one hop's worth.
                    self.input.clear();
                    while self.input.len() < self.hop.len() {
                        let Some(sample) = self.feed.next(source) else {
                            break;
                        };
                        self.input.push(f32::from(sample) / 32_768.0);
                    }
                    if self.input.is_empty() {
                        stretcher.set_draining();
                        self.drained = true;
                    }
                    stretcher.push(&self.input);
                }
            }
        }
        for sample in out.iter_mut().take(given) {
            let x = self.made.pop_front().unwrap_or(0.0);
            *sample = (x * 32_768.0).round().clamp(-32_768.0, 32_767.0) as i16;
        }
        out[given..].fill(0);
        self.remaining -= given;
        given
    }
}

/// The input still to stretch: `silence` samples of silence, then `source[range]`.
struct Feed {
    silence: usize,
    range: Range<usize>,
}

impl Feed {
    /// The next input sample, `None` once all are given.
    fn next(&mut self, source: &[i16]) -> Option<i16> {
        if self.silence > 0 {
            self.silence -= 1;
            return Some(0);
        }
        let at = self.range.next()?;
        Some(source.get(at).copied().unwrap_or(0))
    }
}

impl Voice {
    /// The samples from `from_s` to `to_s` (seconds on the voice's timeline, clamped to
    /// it; empty when `to_s <= from_s`).
    pub fn between(&self, from_s: f64, to_s: f64) -> Voice {
        let range = self.range_between(from_s, to_s);
        Voice {
            sample_rate: self.sample_rate,
            samples: self.samples[range].to_vec(),
        }
    }

    /// The indices of the samples from `from_s` to `to_s`, as [`Self::between`] takes them.
    pub fn range_between(&self, from_s: f64, to_s: f64) -> Range<usize> {
        let rate = f64::from(self.sample_rate);
        let index = |t: f64| ((t * rate).round().max(0.0) as usize).min(self.samples.len());
        let (from, to) = (index(from_s), index(to_s));
        from..to.max(from)
    }

    /// The voice played at `speed` times its pace (0.25 is four times as long) with its
    /// pitch kept; exactly `len / speed` samples long (rounded), as [`Stretching`] gives it.
    pub fn at_speed(&self, speed: f64) -> Result<Voice, StretchError> {
        let mut stretching = Stretching::new(self.sample_rate, speed, 0, 0..self.samples.len())?;
        let mut samples = vec![0; stretching.remaining()];
        stretching.fill(&self.samples, &mut samples);
        Ok(Voice {
            sample_rate: self.sample_rate,
            samples,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `seconds` of a `hz` tone at 16 kHz, half full scale.
    fn tone(hz: f64, seconds: f64) -> Voice {
        let rate = 16_000.0;
        Voice {
            sample_rate: 16_000,
            samples: (0..(seconds * rate) as usize)
                .map(|i| (16_000.0 * (i as f64 * hz * std::f64::consts::TAU / rate).sin()) as i16)
                .collect(),
        }
    }

    /// The tone's frequency from its rising zero crossings, Hz.
    fn frequency(voice: &Voice) -> f64 {
        let s = &voice.samples;
        let crossings: Vec<usize> = (1..s.len()).filter(|&i| s[i - 1] < 0 && s[i] >= 0).collect();
        let periods = (crossings.len() - 1) as f64;
        periods * f64::from(voice.sample_rate) / (crossings[crossings.len() - 1] - crossings[0]) as f64
    }

    #[test]
    fn slowed_to_a_quarter_it_lasts_four_times_as_long_at_the_same_pitch() {
        let voice = tone(220.0, 1.0);
        let slow = voice.at_speed(0.25).unwrap();
        assert_eq!(slow.samples.len(), 64_000);
        eprintln!("stretched tone: {:.2} Hz", frequency(&slow.between(0.1, 3.9)));
        assert!((frequency(&slow.between(0.1, 3.9)) - 220.0).abs() < 2.0);
        // Played faster, as long as asked and still the same pitch.
        let fast = voice.at_speed(2.0).unwrap();
        assert_eq!(fast.samples.len(), 8_000);
        assert!((frequency(&fast.between(0.05, 0.45)) - 220.0).abs() < 2.0);
    }

    #[test]
    fn the_voice_keeps_its_place_in_time() {
        // A click at 0.5 s of a silent second is heard at 2 s at a quarter of the pace.
        let mut voice = tone(0.0, 1.0);
        for s in &mut voice.samples[8_000..8_016] {
            *s = 20_000;
        }
        let slow = voice.at_speed(0.25).unwrap();
        let loudest = (0..slow.samples.len())
            .max_by_key(|&i| slow.samples[i].unsigned_abs())
            .unwrap();
        let heard_s = loudest as f64 / 16_000.0;
        eprintln!("click heard at {heard_s:.3} s");
        assert!((heard_s - 2.0).abs() < 0.03, "{heard_s}");
    }

    #[test]
    fn given_piece_by_piece_it_is_the_voice_stretched_whole() {
        let voice = tone(220.0, 1.0);
        for (speed, piece) in [(0.25, 320), (0.5, 1_920), (2.0, 77), (1.0, 320)] {
            let whole = voice.at_speed(speed).unwrap();
            let mut stretching = Stretching::new(16_000, speed, 0, 0..voice.samples.len()).unwrap();
            let mut pieces = Vec::new();
            let mut out = vec![0; piece];
            while stretching.fill(&voice.samples, &mut out) > 0 {
                pieces.extend_from_slice(&out);
                // Each piece is made as it is asked for: no more than a hop is kept ahead.
                assert!(
                    stretching.made.len() < 16_000 * 15 / 1000 + 1,
                    "{}",
                    stretching.made.len()
                );
            }
            pieces.truncate(whole.samples.len());
            assert_eq!(pieces, whole.samples, "speed {speed}, pieces of {piece}");
            assert_eq!(stretching.fill(&voice.samples, &mut out), 0);
            assert!(out.iter().all(|&s| s == 0), "past its end, silence");
        }
    }

    #[test]
    fn silence_first_then_the_voice() {
        // 0.25 s of silence, then a click at 0.5 s of the voice: at half the pace the
        // click is heard at (0.25 + 0.5) * 2 = 1.5 s of 2.5 s.
        let mut voice = tone(0.0, 1.0);
        for s in &mut voice.samples[8_000..8_016] {
            *s = 20_000;
        }
        let mut stretching = Stretching::new(16_000, 0.5, 4_000, 0..16_000).unwrap();
        assert_eq!(stretching.remaining(), 40_000);
        let mut out = vec![0; 40_000];
        assert_eq!(stretching.fill(&voice.samples, &mut out), 40_000);
        let loudest = (0..out.len()).max_by_key(|&i| out[i].unsigned_abs()).unwrap();
        let heard_s = loudest as f64 / 16_000.0;
        assert!((heard_s - 1.5).abs() < 0.03, "{heard_s}");
        assert!(matches!(
            Stretching::new(0, 0.5, 0, 0..1),
            Err(StretchError::SampleRate)
        ));
    }

    #[test]
    fn a_speed_out_of_range_is_refused_and_between_clamps() {
        let voice = tone(220.0, 0.5);
        assert!(matches!(voice.at_speed(0.1), Err(StretchError::Speed { .. })));
        assert_eq!(voice.at_speed(1.0).unwrap(), voice);
        assert_eq!(voice.between(0.25, 9.0).samples.len(), 4_000);
        assert!(voice.between(0.4, 0.2).samples.is_empty());
    }
}
