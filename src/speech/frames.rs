//! The frames a voice makes: [`VisemeFrames`] samples the tracker's 10 ms decisions at the
//! stream's frame rate on the stream's clock, each frame holding the viseme decided
//! nearest its time as FAP 1 (both selects, blend 63), which moves the mouth, jaw and
//! tongue through [`crate::stream::visemes::VISEMES`] as a text-to-speech viseme track
//! would.

use std::sync::Arc;

use super::live::{SpeechError, SpeechEvent, SpeechStream};
use super::log_mel::{HOP, SAMPLE_RATE_HZ};
use super::model::VisemeModel;
use super::tracker::Decision;
use crate::stream::visemes::single;
use crate::stream::Frame;
use crate::voice::Voice;

/// Frames at `fps` from decisions, on the stream's clock (seconds).
pub struct VisemeFrames {
    fps: f64,
    /// Frame 0's time; frame `k` is at `origin_s + k / fps`.
    origin_s: f64,
    /// The next frame's number.
    next: u64,
}

impl VisemeFrames {
    pub fn new(fps: f64, origin_s: f64) -> Self {
        VisemeFrames {
            fps,
            origin_s,
            next: 0,
        }
    }

    fn time_s(&self, k: u64) -> f64 {
        self.origin_s + k as f64 / self.fps
    }

    /// The next frame's time, s.
    pub fn next_s(&self) -> f64 {
        self.time_s(self.next)
    }

    /// Takes the next decision, centred at `time_s` on the stream's clock, and calls
    /// `on_frame` for each frame whose nearest decision it is (the frames up to half a
    /// step after its centre).
    pub fn push(&mut self, time_s: f64, viseme: u8, mut on_frame: impl FnMut(Frame)) {
        let half_step_s = HOP as f64 / f64::from(SAMPLE_RATE_HZ) / 2.0;
        while self.next_s() < time_s + half_step_s {
            on_frame(self.frame(viseme));
        }
    }

    /// The voice stops at `end_s`: the frames before it still owed, showing `viseme`.
    pub fn finish(&mut self, viseme: u8, end_s: f64, mut on_frame: impl FnMut(Frame)) {
        while self.next_s() < end_s {
            on_frame(self.frame(viseme));
        }
    }

    /// The next frame only, showing `viseme`.
    pub fn one(&mut self, viseme: u8) -> Frame {
        self.frame(viseme)
    }

    /// No frames until `t_s` (a pause in the voice): the next frame is the first at or
    /// after it.
    pub fn skip_to(&mut self, t_s: f64) {
        // Less than a microsecond early is the same instant (rounding).
        let k = ((t_s - self.origin_s) * self.fps - 1e-6 * self.fps).ceil();
        if k.is_finite() && k > self.next as f64 {
            self.next = k as u64;
        }
    }

    fn frame(&mut self, viseme: u8) -> Frame {
        let frame = Frame {
            seq: self.next,
            time_s: self.next_s(),
            viseme: Some(single(viseme)),
            ..Frame::default()
        };
        self.next += 1;
        frame
    }
}

/// A whole voice's frames at `fps` from its first sample at 0 s, and its 10 ms decisions.
pub fn speech_frames(
    voice: &Voice,
    model: Arc<VisemeModel>,
    fps: f64,
) -> Result<(Vec<Frame>, Vec<Decision>), SpeechError> {
    let mut speech = SpeechStream::new(model, fps);
    let (mut frames, mut decisions) = (Vec::new(), Vec::new());
    let mut on = |event: SpeechEvent| match event {
        SpeechEvent::Frame(frame) => frames.push(frame),
        SpeechEvent::Decided(decision) => decisions.push(decision),
    };
    speech.push(0.0, voice.sample_rate, &voice.samples, &mut on)?;
    speech.finish(&mut on);
    Ok((frames, decisions))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::speech::log_mel::frame_centre_s;

    #[test]
    fn each_frame_takes_the_decision_nearest_its_time() {
        // 25 fps: frames at 0, 40, 80 ms; decisions centred at 12.5, 22.5, ... ms.
        let mut sampler = VisemeFrames::new(25.0, 0.0);
        let mut frames = Vec::new();
        for i in 0..10 {
            sampler.push(frame_centre_s(i), i as u8, |f| frames.push(f));
        }
        sampler.finish(9, 0.2, |f| frames.push(f));
        let visemes: Vec<i32> = frames.iter().map(|f| f.viseme.unwrap().select1).collect();
        // 0 ms -> decision 0 (12.5 ms); 40 -> 3 (42.5); 80 -> 7 (82.5); 120, 160 -> the last.
        assert_eq!(visemes, [0, 3, 7, 9, 9]);
        let times: Vec<f64> = frames.iter().map(|f| f.time_s).collect();
        assert_eq!(times, [0.0, 0.04, 0.08, 0.12, 0.16]);
        assert!(frames.iter().enumerate().all(|(k, f)| f.seq == k as u64));
    }

    /// The shipped syllable voice (eSpeak NG's Spanish voice, which training never heard)
    /// against its own phoneme timing: every p and m closure found near where it sounds,
    /// most b and f (the model reads some of the Spanish voice's prevoiced b and of its
    /// quiet f right after a pause as the pause: docs/SPEECH.md, "Weaknesses"), and the
    /// vowels read: a and i as themselves, u rounded (the Spanish u is read partly as "oh",
    /// the other rounded viseme).
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
        let (mut exact_frames, mut exact_hits) = (0, 0);
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
            // aa, ih; ou, or oh (both rounded).
            let vowel_visemes: &[u8] = match vowel {
                "a" => &[10],
                "i" => &[12],
                _ => &[14, 13],
            };
            let during = shown(slot_s + t.vowel_s + 0.03, slot_s + t.vowel_end_s);
            vowel_frames += during.len();
            vowel_hits += during.iter().filter(|v| vowel_visemes.contains(v)).count();
            if vowel != "u" {
                exact_frames += during.len();
                exact_hits += during.iter().filter(|&&v| v == vowel_visemes[0]).count();
            }
        }
        assert_eq!(closures.len(), 12);
        let (unvoiced, voiced): (Vec<_>, Vec<_>) = closures
            .iter()
            .partition(|(name, _)| name.starts_with('p') || name.starts_with('m'));
        assert!(unvoiced.iter().all(|&&(_, found)| found), "{closures:?}");
        let found = voiced.iter().filter(|&&&(_, found)| found).count();
        assert!(found >= 3, "{found} of the 6 b and f found: {closures:?}");
        assert!(
            vowel_hits as f64 > 0.95 * vowel_frames as f64,
            "{vowel_hits} of {vowel_frames} vowel frames read"
        );
        assert!(
            exact_hits as f64 > 0.95 * exact_frames as f64,
            "{exact_hits} of {exact_frames} a and i frames read as aa and ih"
        );
    }
}
