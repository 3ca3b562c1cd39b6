//! A voice slowed down or sped up without changing its pitch, for a replay played at a
//! viewer's pace (0.25x for someone learning to read a syllable): WSOLA (waveform
//! similarity overlap-add, through the `wsola` crate) lays the voice's own 30 ms pieces
//! down further apart or closer together, each joined where its waveform best continues
//! the last, so the voice keeps its pitch and only its tempo changes.

use std::num::{NonZeroU16, NonZeroU32};

use super::Voice;

/// The slowest and fastest a voice is played, times its own pace.
pub const STRETCH_SPEEDS: [f64; 2] = [wsola::MIN_TEMPO as f64, wsola::MAX_TEMPO as f64];

/// Why a voice was not stretched.
#[derive(Debug, thiserror::Error)]
pub enum StretchError {
    #[error("a voice plays at {min} to {max} times its pace, not {speed}", min = STRETCH_SPEEDS[0], max = STRETCH_SPEEDS[1])]
    Speed { speed: f64 },
    #[error("stretching the voice: {0}")]
    Wsola(#[from] wsola::Error),
}

impl Voice {
    /// The samples from `from_s` to `to_s` (seconds on the voice's timeline, clamped to
    /// it; empty when `to_s <= from_s`).
    pub fn between(&self, from_s: f64, to_s: f64) -> Voice {
        let rate = f64::from(self.sample_rate);
        let index = |t: f64| ((t * rate).round().max(0.0) as usize).min(self.samples.len());
        let (from, to) = (index(from_s), index(to_s));
        Voice {
            sample_rate: self.sample_rate,
            samples: self.samples[from..to.max(from)].to_vec(),
        }
    }

    /// The voice played at `speed` times its pace (0.25 is four times as long) with its
    /// pitch kept; exactly `len / speed` samples long (rounded), so that a replay's voice
    /// stays on its frames' timeline however long it plays.
    pub fn at_speed(&self, speed: f64) -> Result<Voice, StretchError> {
        if !(STRETCH_SPEEDS[0]..=STRETCH_SPEEDS[1]).contains(&speed) {
            return Err(StretchError::Speed { speed });
        }
        let length = (self.samples.len() as f64 / speed).round() as usize;
        if self.samples.is_empty() || speed == 1.0 {
            return Ok(self.clone());
        }
        let floats: Vec<f32> = self.samples.iter().map(|&s| f32::from(s) / 32_768.0).collect();
        let rate = NonZeroU32::new(self.sample_rate).expect("a voice's rate is not 0");
        let stretched = wsola::stretch(&floats, rate, NonZeroU16::MIN, speed as f32)?;
        let mut samples: Vec<i16> = stretched
            .iter()
            .map(|&x| (x * 32_768.0).round().clamp(-32_768.0, 32_767.0) as i16)
            .collect();
        samples.resize(length, 0);
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
    fn a_speed_out_of_range_is_refused_and_between_clamps() {
        let voice = tone(220.0, 0.5);
        assert!(matches!(voice.at_speed(0.1), Err(StretchError::Speed { .. })));
        assert_eq!(voice.at_speed(1.0).unwrap(), voice);
        assert_eq!(voice.between(0.25, 9.0).samples.len(), 4_000);
        assert!(voice.between(0.4, 0.2).samples.is_empty());
    }
}
