//! A recording's voice (`super::recordings`): the producer's audio kept as mono PCM on
//! the recording's own timeline, for a replay to play with its frames and the shelf to
//! keep on disk.

use crate::voice::{StretchError, Stretching, Voice};

/// A recording's voice: mono PCM whose first sample plays at `start_t_s` on the
/// recording's timeline (the producer's seconds, as its frames' `t`).
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedVoice {
    pub start_t_s: f64,
    pub voice: Voice,
}

impl RecordedVoice {
    /// The voice from `from_s` to `to_s` on the recording's timeline, its first sample at
    /// `from_s`: silence where the voice had not started, nothing past its end.
    pub fn between(&self, from_s: f64, to_s: f64) -> Voice {
        let (before, range) = self.span(from_s, to_s);
        let mut samples = vec![0; before];
        samples.extend_from_slice(&self.voice.samples[range]);
        Voice {
            sample_rate: self.voice.sample_rate,
            samples,
        }
    }

    /// From `from_s` to `to_s`: how many samples of silence come before the voice, and the
    /// indices of its samples.
    fn span(&self, from_s: f64, to_s: f64) -> (usize, std::ops::Range<usize>) {
        let rate = f64::from(self.voice.sample_rate);
        let before = ((self.start_t_s - from_s) * rate).round().max(0.0) as usize;
        let before = before.min(((to_s - from_s) * rate).round().max(0.0) as usize);
        let range = self
            .voice
            .range_between(from_s - self.start_t_s, to_s - self.start_t_s);
        (before, range)
    }

    /// The voice from `from_s` to `to_s`, as [`Self::between`] has it, played at `speed`
    /// piece by piece ([`Stretching::fill`] with this voice's samples).
    pub fn stretching(&self, from_s: f64, to_s: f64, speed: f64) -> Result<Stretching, StretchError> {
        let (before, range) = self.span(from_s, to_s);
        Stretching::new(self.voice.sample_rate, speed, before, range)
    }

    /// Where the voice ends on the recording's timeline, seconds.
    pub fn end_t_s(&self) -> f64 {
        self.start_t_s + self.voice.duration_s()
    }
}
