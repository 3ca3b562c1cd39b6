//! The stream a voice makes: [`VisemeFrames`] samples the tracker's 10 ms decisions at the
//! stream's frame rate, each frame holding the viseme decided nearest its time as FAP 1
//! (both selects, blend 63), which moves the mouth, jaw and tongue through
//! [`crate::stream::visemes::VISEMES`] as a text-to-speech viseme track would.

use std::sync::Arc;

use super::log_mel::{frame_centre_s, HOP, SAMPLE_RATE_HZ};
use super::model::VisemeModel;
use super::resample::{RateError, ToModelRate};
use super::tracker::{Decision, VisemeTracker};
use crate::stream::visemes::single;
use crate::stream::Frame;
use crate::voice::Voice;

/// Frames at `fps` from 10 ms decisions.
pub struct VisemeFrames {
    fps: f64,
    /// The next frame's number; frame `k` is at `k / fps` s.
    next: u64,
}

impl VisemeFrames {
    pub fn new(fps: f64) -> Self {
        VisemeFrames { fps, next: 0 }
    }

    fn time_s(&self, k: u64) -> f64 {
        k as f64 / self.fps
    }

    /// Takes the next decision and calls `on_frame` for each frame whose nearest decision
    /// it is (the frames up to half a step after its centre).
    pub fn push(&mut self, decision: &Decision, mut on_frame: impl FnMut(Frame)) {
        let half_step_s = HOP as f64 / f64::from(SAMPLE_RATE_HZ) / 2.0;
        while self.time_s(self.next) < decision.time_s + half_step_s {
            on_frame(self.frame(decision.viseme));
        }
    }

    /// The stream ends at `end_s`: the frames before it still owed, from the last decision.
    pub fn finish(&mut self, last: Option<&Decision>, end_s: f64, mut on_frame: impl FnMut(Frame)) {
        let viseme = last.map_or(0, |d| d.viseme);
        while self.time_s(self.next) < end_s {
            on_frame(self.frame(viseme));
        }
    }

    fn frame(&mut self, viseme: u8) -> Frame {
        let frame = Frame {
            seq: self.next,
            time_s: self.time_s(self.next),
            viseme: Some(single(viseme)),
            ..Frame::default()
        };
        self.next += 1;
        frame
    }
}

/// A whole voice's frames at `fps`, and its 10 ms decisions.
pub fn speech_frames(
    voice: &Voice,
    model: Arc<VisemeModel>,
    fps: f64,
) -> Result<(Vec<Frame>, Vec<Decision>), RateError> {
    let mut resampler = ToModelRate::new(voice.sample_rate)?;
    let samples: Vec<f32> = voice.samples.iter().map(|&s| f32::from(s) / 32768.0).collect();
    let mut at_model_rate = Vec::with_capacity(samples.len());
    resampler.push(&samples, &mut at_model_rate);
    let mut tracker = VisemeTracker::new(model);
    let mut decisions = Vec::new();
    tracker.push(&at_model_rate, |d| decisions.push(*d));
    tracker.finish(|d| decisions.push(*d));
    let mut sampler = VisemeFrames::new(fps);
    let mut frames = Vec::new();
    for decision in &decisions {
        sampler.push(decision, |f| frames.push(f));
    }
    sampler.finish(decisions.last(), voice.duration_s(), |f| frames.push(f));
    debug_assert!(decisions
        .iter()
        .enumerate()
        .all(|(i, d)| d.time_s == frame_centre_s(i)));
    Ok((frames, decisions))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decision(frame: usize, viseme: u8) -> Decision {
        Decision {
            frame,
            time_s: frame_centre_s(frame),
            viseme,
            probability: [0.0; 15],
        }
    }

    #[test]
    fn each_frame_takes_the_decision_nearest_its_time() {
        // 25 fps: frames at 0, 40, 80 ms; decisions centred at 12.5, 22.5, ... ms.
        let mut sampler = VisemeFrames::new(25.0);
        let mut frames = Vec::new();
        for i in 0..10 {
            sampler.push(&decision(i, i as u8), |f| frames.push(f));
        }
        sampler.finish(Some(&decision(9, 9)), 0.2, |f| frames.push(f));
        let visemes: Vec<i32> = frames.iter().map(|f| f.viseme.unwrap().select1).collect();
        // 0 ms -> decision 0 (12.5 ms); 40 -> 3 (42.5); 80 -> 7 (82.5); 120, 160 -> the last.
        assert_eq!(visemes, [0, 3, 7, 9, 9]);
        let times: Vec<f64> = frames.iter().map(|f| f.time_s).collect();
        assert_eq!(times, [0.0, 0.04, 0.08, 0.12, 0.16]);
        assert!(frames.iter().enumerate().all(|(k, f)| f.seq == k as u64));
    }

    /// The shipped syllable voice (eSpeak NG's Spanish voice, which training never heard)
    /// against its own phoneme timing: every p/b/m closure and f/v found near where it
    /// sounds, and the vowels read.
    #[test]
    fn the_syllable_voice_shows_its_closures_and_its_vowels() {
        use crate::stream::syllable_phonemes::{read_timings, PHONEMES_TSV};
        use crate::stream::syllables::{SYLLABLES, SYLLABLE_S};
        use crate::voice::syllable_voice;
        let voice = syllable_voice().unwrap();
        let model = Arc::new(VisemeModel::embedded().unwrap());
        let (_, decisions) = speech_frames(&voice, model, 30.0).unwrap();
        let timings = read_timings(PHONEMES_TSV, &SYLLABLES, SYLLABLE_S).unwrap();
        let shown = |from_s: f64, to_s: f64| -> Vec<u8> {
            decisions
                .iter()
                .filter(|d| d.time_s >= from_s && d.time_s < to_s)
                .map(|d| d.viseme)
                .collect()
        };
        let (mut closures, mut vowel_frames, mut vowel_hits) = (Vec::new(), 0, 0);
        for (k, (name, t)) in SYLLABLES.iter().zip(&timings).enumerate() {
            let slot_s = k as f64 * SYLLABLE_S;
            let (consonant, vowel) = name.split_at(1);
            let want = match consonant {
                "p" | "b" | "m" => Some(1),
                "f" => Some(2),
                _ => None,
            };
            if let Some(viseme) = want {
                // Found if shown within 20 ms of the consonant's span.
                let around = shown(slot_s + t.consonant_s - 0.02, slot_s + t.vowel_s + 0.02);
                closures.push((*name, around.contains(&viseme)));
            }
            let vowel_viseme = match vowel {
                "a" => 10,
                "i" => 12,
                _ => 14,
            };
            let during = shown(slot_s + t.vowel_s + 0.03, slot_s + t.vowel_end_s);
            vowel_frames += during.len();
            vowel_hits += during.iter().filter(|&&v| v == vowel_viseme).count();
        }
        assert!(closures.iter().all(|&(_, found)| found), "{closures:?}");
        assert_eq!(closures.len(), 12);
        let vowel_accuracy = vowel_hits as f64 / vowel_frames as f64;
        assert!(
            vowel_accuracy > 0.85,
            "{vowel_hits} of {vowel_frames} vowel frames read"
        );
    }
}
