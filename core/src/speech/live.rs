//! A voice as it arrives, in chunks on a stream's clock, turned into that stream's frames:
//! [`SpeechStream`] brings each chunk to 16 kHz, runs the [`VisemeTracker`] over it and
//! samples the decisions at the stream's frame rate, every frame and decision timed on the
//! stream's clock (seconds, the producer's `t`). Chunks may leave gaps: a short one is
//! silence fed to the tracker, a long one ([`MAX_FILLED_GAP_S`]) ends a run of speech (its
//! last frames decided, then a closed mouth) and the next chunk starts a new run, so a
//! pause of any length costs nothing.
//!
//! What a run needs is allocated when it starts; per chunk nothing is.

use std::sync::Arc;

use super::frames::VisemeFrames;
use super::model::VisemeModel;
use super::resample::{RateError, ToModelRate};
use super::tracker::{Decision, VisemeTracker};
use crate::stream::Frame;
use crate::voice::Voice;

/// The longest gap between chunks fed to the tracker as silence, s; a longer one ends the
/// run of speech.
pub const MAX_FILLED_GAP_S: f64 = 0.5;

/// Input samples converted and resampled at a time: bounds the buffers whatever a chunk's
/// length.
const PIECE: usize = 960;

/// Gaps and overlaps below this are rounding, s.
const SLACK_S: f64 = 1e-3;

/// The viseme of silence (`sil`).
const SILENCE: u8 = 0;

static ZEROS: [i16; PIECE] = [0; PIECE];

/// What the stream makes of its voice, in time order.
#[derive(Debug, Clone, PartialEq)]
pub enum SpeechEvent {
    /// A 10 ms frame decided; its `time_s` is on the stream's clock, its `frame` counts
    /// from the start of its run.
    Decided(Decision),
    /// A frame of the stream, at the stream's frame rate.
    Frame(Frame),
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpeechError {
    #[error(transparent)]
    Rate(#[from] RateError),
    #[error("a chunk at {to} Hz cannot follow this voice's {from} Hz")]
    RateChanged { from: u32, to: u32 },
    #[error("a chunk at t {0} s: expected a finite time of at least 0 s")]
    Time(f64),
}

/// One contiguous run of speech.
struct Run {
    tracker: VisemeTracker,
    resampler: ToModelRate,
    /// The stream time of the run's first sample, s.
    start_s: f64,
    /// Input samples heard in the run.
    samples: u64,
}

pub struct SpeechStream {
    model: Arc<VisemeModel>,
    fps: f64,
    /// The voice's sample rate, from its first chunk.
    rate: Option<u32>,
    run: Option<Run>,
    frames: Option<VisemeFrames>,
    /// The viseme of the last decision.
    shown: u8,
    floats: Vec<f32>,
    at_model_rate: Vec<f32>,
}

impl SpeechStream {
    /// A stream of `fps` frames a second; its first frame is at its first chunk's `t`.
    pub fn new(model: Arc<VisemeModel>, fps: f64) -> Self {
        SpeechStream {
            model,
            fps,
            rate: None,
            run: None,
            frames: None,
            shown: SILENCE,
            floats: Vec::with_capacity(PIECE),
            at_model_rate: Vec::with_capacity(PIECE),
        }
    }

    /// Seconds from a sample arriving to the decision of the frame centred on it.
    pub fn lookahead_s(&self) -> f64 {
        self.model.lookahead_s()
    }

    /// Takes `samples` (16-bit PCM at `rate`: 16, 24 or 48 kHz, one rate per stream) whose
    /// first is at `t_s` on the stream's clock; calls `on` for each decision and frame they
    /// complete. Samples before the end of what was heard already are dropped.
    pub fn push(
        &mut self,
        t_s: f64,
        rate: u32,
        samples: &[i16],
        mut on: impl FnMut(SpeechEvent),
    ) -> Result<(), SpeechError> {
        if !(t_s.is_finite() && t_s >= 0.0) {
            return Err(SpeechError::Time(t_s));
        }
        match self.rate {
            Some(from) if from != rate => return Err(SpeechError::RateChanged { from, to: rate }),
            Some(_) => {}
            None => {
                ToModelRate::new(rate)?;
                self.rate = Some(rate);
            }
        }
        let per_s = f64::from(rate);
        let mut samples = samples;
        if let Some(run) = &self.run {
            let heard_until_s = run.start_s + run.samples as f64 / per_s;
            let gap_s = t_s - heard_until_s;
            if gap_s > MAX_FILLED_GAP_S {
                self.end_run(&mut on);
            } else if gap_s > SLACK_S {
                let mut silence = (gap_s * per_s).round() as usize;
                while silence > 0 {
                    let n = silence.min(PIECE);
                    self.feed(&ZEROS[..n], &mut on);
                    silence -= n;
                }
            } else if gap_s < -SLACK_S {
                let overlap = ((-gap_s * per_s).round() as usize).min(samples.len());
                samples = &samples[overlap..];
            }
        }
        if self.run.is_none() {
            self.start_run(t_s, rate)?;
        }
        for piece in samples.chunks(PIECE) {
            self.feed(piece, &mut on);
        }
        Ok(())
    }

    /// The voice has ended: decides what waits for its look-ahead and gives the frames up
    /// to its last sample, then one with the mouth closed.
    pub fn finish(&mut self, mut on: impl FnMut(SpeechEvent)) {
        self.end_run(&mut on);
    }

    fn start_run(&mut self, t_s: f64, rate: u32) -> Result<(), SpeechError> {
        match &mut self.frames {
            Some(frames) => frames.skip_to(t_s),
            None => self.frames = Some(VisemeFrames::new(self.fps, t_s)),
        }
        self.run = Some(Run {
            tracker: VisemeTracker::new(self.model.clone()),
            resampler: ToModelRate::new(rate)?,
            start_s: t_s,
            samples: 0,
        });
        Ok(())
    }

    fn feed(&mut self, piece: &[i16], on: &mut impl FnMut(SpeechEvent)) {
        let (Some(run), Some(frames)) = (&mut self.run, &mut self.frames) else {
            return;
        };
        self.floats.clear();
        self.floats.extend(piece.iter().map(|&s| f32::from(s) / 32768.0));
        self.at_model_rate.clear();
        run.resampler.push(&self.floats, &mut self.at_model_rate);
        run.samples += piece.len() as u64;
        let start_s = run.start_s;
        let shown = &mut self.shown;
        run.tracker.push(&self.at_model_rate, |d| {
            decided(start_s, d, frames, shown, on);
        });
    }

    fn end_run(&mut self, on: &mut impl FnMut(SpeechEvent)) {
        let (Some(mut run), Some(frames)) = (self.run.take(), &mut self.frames) else {
            return;
        };
        let shown = &mut self.shown;
        run.tracker.finish(|d| decided(run.start_s, d, frames, shown, on));
        let rate = f64::from(self.rate.unwrap_or(1));
        frames.finish(*shown, run.start_s + run.samples as f64 / rate, |f| {
            on(SpeechEvent::Frame(f))
        });
        if *shown != SILENCE {
            *shown = SILENCE;
            on(SpeechEvent::Frame(frames.one(SILENCE)));
        }
    }
}

/// A run's decision `d` on the stream's clock, and the frames it is nearest.
fn decided(
    start_s: f64,
    d: &Decision,
    frames: &mut VisemeFrames,
    shown: &mut u8,
    on: &mut impl FnMut(SpeechEvent),
) {
    let decision = Decision {
        time_s: start_s + d.time_s,
        ..*d
    };
    *shown = decision.viseme;
    on(SpeechEvent::Decided(decision));
    frames.push(decision.time_s, decision.viseme, |f| on(SpeechEvent::Frame(f)));
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
    use crate::voice::syllable_voice;

    fn model() -> Arc<VisemeModel> {
        Arc::new(VisemeModel::embedded().unwrap())
    }

    /// Frames and decisions of `chunks` (each `(t_s, samples)` at 16 kHz).
    fn run(chunks: &[(f64, Vec<i16>)], fps: f64) -> (Vec<Frame>, Vec<Decision>) {
        let mut speech = SpeechStream::new(model(), fps);
        let (mut frames, mut decisions) = (Vec::new(), Vec::new());
        let mut on = |event| match event {
            SpeechEvent::Frame(f) => frames.push(f),
            SpeechEvent::Decided(d) => decisions.push(d),
        };
        for (t_s, samples) in chunks {
            speech.push(*t_s, 16_000, samples, &mut on).unwrap();
        }
        speech.finish(&mut on);
        (frames, decisions)
    }

    fn visemes(frames: &[Frame]) -> Vec<i32> {
        frames.iter().map(|f| f.viseme.unwrap().select1).collect()
    }

    #[test]
    fn chunks_of_any_size_make_the_frames_of_the_whole_voice_on_the_stream_clock() {
        // The syllable voice at 48 kHz (each 16 kHz sample held for three), so that the
        // resampler runs too.
        let voice = syllable_voice().unwrap();
        assert_eq!(voice.sample_rate, 16_000);
        let voice = crate::voice::Voice {
            sample_rate: 48_000,
            samples: voice.samples.iter().flat_map(|&s| [s; 3]).collect(),
        };
        let whole = {
            let mut speech = SpeechStream::new(model(), 30.0);
            let mut frames = Vec::new();
            let mut on = |e| {
                if let SpeechEvent::Frame(f) = e {
                    frames.push(f)
                }
            };
            speech.push(100.0, 48_000, &voice.samples, &mut on).unwrap();
            speech.finish(&mut on);
            frames
        };
        let mut speech = SpeechStream::new(model(), 30.0);
        let mut chunked = Vec::new();
        let mut at = 0;
        for (k, len) in [480usize, 7, 4_799, 960, 1].iter().cycle().enumerate() {
            if at >= voice.samples.len() {
                break;
            }
            let end = (at + len).min(voice.samples.len());
            let t_s = 100.0 + at as f64 / 48_000.0;
            speech
                .push(t_s, 48_000, &voice.samples[at..end], |e| {
                    if let SpeechEvent::Frame(f) = e {
                        chunked.push(f)
                    }
                })
                .unwrap_or_else(|e| panic!("chunk {k}: {e}"));
            at = end;
        }
        speech.finish(|e| {
            if let SpeechEvent::Frame(f) = e {
                chunked.push(f)
            }
        });
        assert_eq!(visemes(&whole), visemes(&chunked));
        let duration_s = voice.duration_s();
        // One frame every 1/30 s from the first chunk's t, up to the voice's end, and a
        // closing frame when the voice ends on an open mouth.
        let expected = (duration_s * 30.0).ceil() as usize;
        assert!(
            (expected..=expected + 1).contains(&whole.len()),
            "{}",
            whole.len()
        );
        for (k, f) in whole.iter().enumerate() {
            assert_eq!(f.seq, k as u64);
            assert!((f.time_s - (100.0 + k as f64 / 30.0)).abs() < 1e-9);
        }
        assert!(visemes(&whole).contains(&1), "closures shown");
    }

    #[test]
    fn a_short_gap_is_silence_and_a_long_one_starts_a_new_run() {
        let tone: Vec<i16> = (0..3_200)
            .map(|i| (8_000.0 * (f64::from(i) * 300.0 * std::f64::consts::TAU / 16_000.0).sin()) as i16)
            .collect();
        // 0.2 s of tone, 0.3 s of gap (filled), 0.2 s more, then 10 s of gap (a new run).
        let (frames, decisions) = run(&[(0.0, tone.clone()), (0.5, tone.clone()), (10.7, tone)], 20.0);
        // The first run holds 0 to 0.7 s of sound: 68 decisions of 25 ms every 10 ms; the
        // second 0.2 s: 18.
        let first = decisions.iter().filter(|d| d.time_s < 1.0).count();
        assert_eq!((first, decisions.len() - first), (68, 18));
        assert!(decisions.iter().all(|d| d.time_s < 0.7 || d.time_s > 10.7));
        // The frames of the first run (0 to 0.7 s at 20 fps), perhaps a closing one, then
        // the second run's from frame 214 (10.7 s).
        let second: Vec<&Frame> = frames.iter().filter(|f| f.time_s >= 10.0).collect();
        assert!(frames.iter().filter(|f| f.time_s < 10.0).count() <= 15);
        assert_eq!(second[0].seq, 214);
        assert!((second[0].time_s - 10.7).abs() < 1e-9);
        assert!(frames
            .windows(2)
            .all(|w| w[0].seq < w[1].seq && w[0].time_s < w[1].time_s));
        assert_eq!(frames.last().unwrap().viseme.unwrap().select1, 0);
    }

    #[test]
    fn a_chunk_may_not_change_the_rate_or_come_at_a_time_that_is_not_one() {
        let mut speech = SpeechStream::new(model(), 30.0);
        speech.push(0.0, 16_000, &[0; 320], |_| {}).unwrap();
        assert_eq!(
            speech.push(0.02, 48_000, &[0; 960], |_| {}),
            Err(SpeechError::RateChanged {
                from: 16_000,
                to: 48_000
            })
        );
        assert_eq!(
            speech
                .push(f64::NAN, 16_000, &[0; 320], |_| {})
                .map_err(|e| e.to_string()),
            Err("a chunk at t NaN s: expected a finite time of at least 0 s".into())
        );
        let mut other = SpeechStream::new(model(), 30.0);
        assert_eq!(
            other.push(0.0, 44_100, &[0; 441], |_| {}),
            Err(SpeechError::Rate(RateError { rate: 44_100 }))
        );
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
