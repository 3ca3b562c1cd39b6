//! A recording's voice (`super::recordings`): the producer's audio kept as mono PCM on
//! the recording's own timeline, for a replay to play with its frames and the shelf to
//! keep on disk.

use crate::voice::Voice;

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
        let rate = f64::from(self.voice.sample_rate);
        let before = ((self.start_t_s - from_s) * rate).round().max(0.0) as usize;
        let voiced = self.voice.between(from_s - self.start_t_s, to_s - self.start_t_s);
        let before = before.min(((to_s - from_s) * rate).round().max(0.0) as usize);
        let mut samples = vec![0; before];
        samples.extend_from_slice(&voiced.samples);
        Voice {
            sample_rate: self.voice.sample_rate,
            samples,
        }
    }

    /// Where the voice ends on the recording's timeline, seconds.
    pub fn end_t_s(&self) -> f64 {
        self.start_t_s + self.voice.duration_s()
    }
}
