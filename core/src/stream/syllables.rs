//! The syllable stream the thesis recorded: 27 consonant-vowel syllables, generated from a
//! viseme table in CANDIDE-3 animation-unit terms, so integration tests, benchmarks and
//! demos replay the same speech-like motion. The generated stream at 30 fps ships as
//! `data/streams/syllables.jsonl` (a test keeps the two identical byte for byte).
//!
//! Each syllable has a slot of [`SYLLABLE_S`] and moves on its voice's clock
//! (`data/streams/syllables.wav`, spoken by eSpeak NG; [`super::syllable_phonemes`]): the
//! mouth leaves rest [`APPROACH_S`] before the consonant sounds and reaches it as it does,
//! holds it until the vowel begins, opens to the vowel in [`OPEN_S`], holds it while it
//! sounds and returns to rest in [`CLOSE_S`] ([`keyframes`]). Between keyframes every
//! weight follows a smoothstep, so motion starts and stops with zero speed and never
//! jumps. The mouth shapes and their co-articulation are [`super::mouth_shapes`]'s.

use super::error::StreamError;
use super::frame::Frame;
use super::mouth_shapes::{
    coarticulated, coarticulated_tongue, Consonant, Vowel, CHANNELS, CONSONANTS, TONGUE_FAPS, VOWELS,
};
use super::syllable_phonemes::{read_timings, SyllableTiming, PHONEMES_TSV};

/// The 27 syllables in the thesis's order: each consonant of [`CONSONANTS`] with `a`,
/// `i`, `u`.
pub const SYLLABLES: [&str; 27] = [
    "pa", "pi", "pu", "ta", "ti", "tu", "ka", "ki", "ku", "ba", "bi", "bu", "ma", "mi", "mu", "fa", "fi",
    "fu", "sa", "si", "su", "ya", "yi", "yu", "da", "di", "du",
];

/// A syllable's keyframes ([`keyframes`]): seconds into its slot and the target then.
pub type Keyframes = [(f64, Phase); 6];

/// Which target a keyframe holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    Rest,
    Consonant,
    Vowel,
}

/// The mouth leaves rest this long before the consonant sounds, seconds.
pub const APPROACH_S: f64 = 0.10;
/// From the consonant's release (the vowel's onset) to the vowel's shape, seconds.
pub const OPEN_S: f64 = 0.10;
/// From the end of the voice back to rest, seconds.
pub const CLOSE_S: f64 = 0.15;

/// The keyframes of one syllable: seconds from the start of its slot and the target
/// reached then, from where its phonemes sound.
pub fn keyframes(timing: &SyllableTiming) -> Keyframes {
    let vowel_reached = (timing.vowel_s + OPEN_S).min(timing.vowel_end_s);
    [
        ((timing.consonant_s - APPROACH_S).max(0.0), Phase::Rest),
        (timing.consonant_s, Phase::Consonant),
        (timing.vowel_s, Phase::Consonant),
        (vowel_reached, Phase::Vowel),
        (timing.vowel_end_s, Phase::Vowel),
        ((timing.vowel_end_s + CLOSE_S).min(SYLLABLE_S), Phase::Rest),
    ]
}

/// Length of one syllable, seconds.
pub const SYLLABLE_S: f64 = 0.60;

/// Frame rate of the shipped `data/streams/syllables.jsonl`.
pub const SHIPPED_FPS: f64 = 30.0;

/// Weights are rounded to this step, which keeps the shipped file short and exact.
pub const WEIGHT_STEP: f64 = 1e-4;

const MAX_FPS: f64 = 1000.0;

fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// `from + (to - from) * s`, channel by channel.
fn blend<const N: usize>(from: [f32; N], to: [f32; N], s: f64) -> [f64; N] {
    let mut out = [0.0; N];
    for ((slot, a), b) in out.iter_mut().zip(from).zip(to) {
        let (a, b) = (f64::from(a), f64::from(b));
        *slot = a + (b - a) * s;
    }
    out
}

/// Channel weights and tongue counts `local_s` seconds into a syllable whose keyframes
/// are `keyframes`.
fn pose(consonant: &Consonant, vowel: &Vowel, keyframes: &Keyframes, local_s: f64) -> ([f64; 8], [f64; 3]) {
    let consonant_targets = (
        coarticulated(consonant, vowel),
        coarticulated_tongue(consonant, vowel),
    );
    let target = |phase: Phase| -> ([f32; 8], [f32; 3]) {
        match phase {
            Phase::Rest => ([0.0; 8], [0.0; 3]),
            Phase::Consonant => consonant_targets,
            Phase::Vowel => (vowel.targets, vowel.tongue),
        }
    };
    let segment = keyframes
        .windows(2)
        .find(|pair| local_s < pair[1].0)
        .unwrap_or(&keyframes[keyframes.len() - 2..]);
    let ((start_s, from), (end_s, to)) = (segment[0], segment[1]);
    // A keyframe pair at one instant (a timing clamped to its slot) is a step.
    let s = if end_s > start_s {
        smoothstep((local_s - start_s) / (end_s - start_s))
    } else {
        1.0
    };
    let (from, to) = (target(from), target(to));
    (blend(from.0, to.0, s), blend(from.1, to.1, s))
}

/// Where the shipped voice sounds each syllable's phonemes (checked when read).
pub fn timings() -> Result<Vec<SyllableTiming>, StreamError> {
    read_timings(PHONEMES_TSV, &SYLLABLES, SYLLABLE_S)
}

/// The 27 syllables at `fps` frames per second (at most 1000): frame `i` at `i / fps`
/// seconds, from rest at 0 to rest at `27 * SYLLABLE_S`, every frame labelled with its
/// syllable and timed by the shipped voice ([`timings`]). Deterministic: the same `fps`
/// gives the same frames on every machine.
pub fn generate(fps: f64) -> Result<Vec<Frame>, StreamError> {
    if !(fps.is_finite() && fps > 0.0 && fps <= MAX_FPS) {
        return Err(StreamError::InvalidOption {
            option: "syllable stream fps",
            expected: "a positive number up to 1000",
            found: fps.to_string(),
        });
    }
    let timings = timings()?;
    let syllables: Vec<(&Consonant, &Vowel, Keyframes)> = CONSONANTS
        .iter()
        .flat_map(|c| VOWELS.iter().map(move |v| (c, v)))
        .zip(&timings)
        .map(|((c, v), timing)| (c, v, keyframes(timing)))
        .collect();
    let total_s = SYLLABLE_S * syllables.len() as f64;
    let last_frame = (total_s * fps).round() as u64;
    let frames = (0..=last_frame)
        .map(|seq| {
            let time_s = seq as f64 / fps;
            // The epsilon puts a frame that lands on a boundary in the syllable it starts.
            let index = ((time_s / SYLLABLE_S + 1e-9).floor() as usize).min(syllables.len() - 1);
            let (consonant, vowel, keyframes) = &syllables[index];
            let local_s = (time_s - index as f64 * SYLLABLE_S).max(0.0);
            let (weights, tongue) = pose(consonant, vowel, keyframes, local_s);
            let animation = CHANNELS
                .iter()
                .zip(weights)
                .map(|(channel, w)| (channel.unit, ((w / WEIGHT_STEP).round() * WEIGHT_STEP) as f32))
                .filter(|&(_, w)| w != 0.0)
                .collect();
            // FAP counts are whole numbers.
            let faps = TONGUE_FAPS
                .iter()
                .zip(tongue)
                .map(|(&fap, count)| (fap, count.round() as f32))
                .filter(|&(_, count)| count != 0.0)
                .collect();
            Frame {
                label: Some(format!("{}{}", consonant.name, vowel.name)),
                animation,
                faps,
                ..Frame::at(seq, time_s)
            }
        })
        .collect();
    Ok(frames)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mask::Mask;

    #[test]
    fn channels_name_the_candide_units() {
        let mask = Mask::candide3();
        for channel in CHANNELS {
            assert_eq!(
                mask.animation_unit(channel.key),
                Ok(usize::from(channel.unit)),
                "{}",
                channel.key
            );
            assert_eq!(mask.animation_units[usize::from(channel.unit)].key, channel.key);
            assert!(channel.min <= 0.0 && 0.0 <= channel.max, "{channel:?}");
        }
    }

    #[test]
    fn syllables_are_consonants_times_vowels() {
        let built: Vec<String> = CONSONANTS
            .iter()
            .flat_map(|c| VOWELS.iter().map(move |v| format!("{}{}", c.name, v.name)))
            .collect();
        assert_eq!(built, SYLLABLES);
    }

    #[test]
    fn every_target_is_inside_its_channel_range() {
        let in_range = |k: usize, w: f32| CHANNELS[k].min <= w && w <= CHANNELS[k].max;
        for vowel in VOWELS {
            for (k, w) in vowel.targets.into_iter().enumerate() {
                assert!(in_range(k, w), "{} {}: {w}", vowel.name, CHANNELS[k].key);
            }
            for consonant in CONSONANTS {
                for (k, w) in coarticulated(&consonant, &vowel).into_iter().enumerate() {
                    assert!(
                        in_range(k, w),
                        "{}{} {}",
                        consonant.name,
                        vowel.name,
                        CHANNELS[k].key
                    );
                }
            }
        }
    }

    #[test]
    fn bilabials_close_the_jaw_and_press_the_lips() {
        for consonant in &CONSONANTS[3..5] {
            assert_eq!(consonant.targets[1], Some(0.0), "{}", consonant.name);
            assert!(consonant.targets[4].unwrap() > 0.3, "{}", consonant.name);
        }
        assert_eq!(CONSONANTS[0].name, "p");
        assert_eq!(CONSONANTS[0].targets[4], Some(0.6));
    }

    /// Consonant from 0.10 s, vowel from 0.16 s to 0.42 s into the slot.
    const TIMING: SyllableTiming = SyllableTiming {
        consonant_s: 0.10,
        vowel_s: 0.16,
        vowel_end_s: 0.42,
    };

    #[test]
    fn keyframes_follow_the_phonemes_from_rest_to_rest() {
        let expected = [
            (0.0, Phase::Rest),
            (0.10, Phase::Consonant),
            (0.16, Phase::Consonant),
            (0.26, Phase::Vowel),
            (0.42, Phase::Vowel),
            (0.57, Phase::Rest),
        ];
        let found = keyframes(&TIMING);
        for (k, (f, e)) in found.iter().zip(expected).enumerate() {
            assert!(
                (f.0 - e.0).abs() < 1e-12 && f.1 == e.1,
                "keyframe {k}: {f:?}, expected {e:?}"
            );
        }
        // A short vowel is reached when it ends, and the return to rest stays in the slot.
        let short = keyframes(&SyllableTiming {
            consonant_s: 0.05,
            vowel_s: 0.30,
            vowel_end_s: 0.50,
        });
        assert_eq!(short[0], (0.0, Phase::Rest));
        assert_eq!(short[3], (0.40, Phase::Vowel));
        assert_eq!(short[5], (SYLLABLE_S, Phase::Rest));
    }

    #[test]
    fn the_shipped_voice_times_every_syllable_inside_its_slot() {
        let timings = timings().unwrap();
        assert_eq!(timings.len(), SYLLABLES.len());
        for (name, timing) in SYLLABLES.iter().zip(&timings) {
            let frames = keyframes(timing);
            assert!(
                frames.windows(2).all(|pair| pair[0].0 < pair[1].0),
                "{name}: {frames:?}"
            );
            assert!(frames[5].0 <= SYLLABLE_S, "{name}: {frames:?}");
            // eSpeak NG's consonants last 25-160 ms at 130 words a minute.
            let consonant_ms = (timing.vowel_s - timing.consonant_s) * 1e3;
            assert!((20.0..200.0).contains(&consonant_ms), "{name}: {consonant_ms} ms");
        }
    }

    #[test]
    fn pose_hits_the_keyframe_targets() {
        let (p, u) = (&CONSONANTS[0], &VOWELS[2]);
        let frames = keyframes(&TIMING);
        let at = |t: f64| pose(p, u, &frames, t).0.map(|w| (w * 1e6).round() / 1e6);
        assert_eq!(at(0.0), [0.0; 8]);
        // Consonant hold of "pu": lips closed and pressed, already rounding.
        assert_eq!(at(0.13), [0.0, 0.0, -0.315, 0.0, 0.6, 0.0, 0.0245, 0.028]);
        assert_eq!(at(0.36), [0.0, 0.12, -0.45, 0.0, 0.0, 0.0, 0.035, 0.04]);
        assert_eq!(at(0.57), [0.0; 8]);
        assert_eq!(at(0.60), [0.0; 8]);
        // Halfway between two keyframes smoothstep is halfway too.
        let mid = pose(p, u, &frames, 0.21).0;
        assert!((mid[1] - 0.06).abs() < 1e-7, "{}", mid[1]);
    }

    #[test]
    fn the_tongue_follows_the_consonant_then_the_vowel() {
        let (t, k, p) = (&CONSONANTS[1], &CONSONANTS[2], &CONSONANTS[0]);
        let (a, u) = (&VOWELS[0], &VOWELS[2]);
        let frames = keyframes(&TIMING);
        let tongue = |c, v, at| pose(c, v, &frames, at).1;
        // t: the tip to the ridge at the consonant hold, whatever the vowel.
        assert_eq!(tongue(t, a, 0.13), [900.0, 75.0, 0.0]);
        assert_eq!(tongue(t, u, 0.13), [900.0, 75.0, 0.0]);
        // k: the body raised.
        assert_eq!(tongue(k, a, 0.13)[2], 500.0);
        // p leaves the tongue free: it anticipates the vowel.
        assert_eq!(tongue(p, u, 0.13), [0.0, -70.0, 175.0]);
        assert_eq!(tongue(p, u, 0.36), [0.0, -100.0, 250.0]);
        assert_eq!(tongue(t, a, 0.0), [0.0; 3]);
        // The generated frames carry the counts as FAPs 44-46, whole numbers.
        let frames = generate(30.0).unwrap();
        let hold = frames
            .iter()
            .find(|f| f.label.as_deref() == Some("ta") && f.time_s > 1.9)
            .unwrap();
        assert!(
            hold.faps
                .iter()
                .all(|&(fap, count)| TONGUE_FAPS.contains(&fap) && count.fract() == 0.0),
            "{hold:?}"
        );
    }

    #[test]
    fn bad_rates_are_refused() {
        for fps in [0.0, -30.0, f64::NAN, f64::INFINITY, 1e6] {
            assert!(generate(fps).is_err(), "{fps}");
        }
    }
}
