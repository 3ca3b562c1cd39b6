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
//! jumps. Co-articulation: a consonant only fixes the channels its
//! articulation needs; every other channel anticipates the coming vowel at
//! [`ANTICIPATION`] of the vowel's value (the lips round during the `p` of `pu` and
//! spread during the `p` of `pi`).

use super::error::StreamError;
use super::frame::Frame;
use super::syllable_phonemes::{read_timings, SyllableTiming, PHONEMES_TSV};

/// One animation unit the visemes use, with the range the table keeps it in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VisemeChannel {
    /// The unit's key in CANDIDE-3.1.6.
    pub key: &'static str,
    /// Its index among the mask's animation units.
    pub unit: u16,
    /// Weights stay within `min..=max` (mask units along the unit's direction).
    pub min: f32,
    pub max: f32,
}

/// The channels of the viseme table, in unit order. AUV weights scale the unit's stored
/// displacements (jaw_drop 1.0 lowers the lower lip 0.26 mask units, about 27 mm); FAP
/// unit weights are distances in mask units (0.04 is about 4 mm).
#[rustfmt::skip]
pub const CHANNELS: [VisemeChannel; 8] = [
    VisemeChannel { key: "upper_lip_raiser",     unit: 0,  min: 0.0,   max: 0.35 },
    VisemeChannel { key: "jaw_drop",             unit: 1,  min: 0.0,   max: 0.6 },
    VisemeChannel { key: "lip_stretcher",        unit: 2,  min: -0.5,  max: 0.55 },
    VisemeChannel { key: "lip_corner_depressor", unit: 4,  min: 0.0,   max: 0.2 },
    VisemeChannel { key: "lip_presser",          unit: 9,  min: 0.0,   max: 0.7 },
    VisemeChannel { key: "fap5_raise_b_midlip",  unit: 13, min: 0.0,   max: 0.05 },
    VisemeChannel { key: "fap16_push_b_lip",     unit: 24, min: -0.04, max: 0.05 },
    VisemeChannel { key: "fap17_push_t_lip",     unit: 25, min: 0.0,   max: 0.05 },
];

/// The tongue's FAPs the syllables move, in this order: 44 raise_tongue_tip (counts of
/// MNS / 1024, up), 45 thrust_tongue_tip (MW / 1024, forward), 46 raise_tongue (the body,
/// MNS / 1024, up). On the ICT head a count of MNS is about 0.018 mm, of MW 0.047 mm.
pub const TONGUE_FAPS: [u8; 3] = [44, 45, 46];

/// A vowel's target weight for every channel of [`CHANNELS`], and the tongue's FAP
/// counts ([`TONGUE_FAPS`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vowel {
    pub name: &'static str,
    pub targets: [f32; 8],
    pub tongue: [f32; 3],
}

/// A consonant's target per channel; `None` leaves the channel to the vowel
/// (co-articulation: it takes [`ANTICIPATION`] times the vowel's target).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Consonant {
    pub name: &'static str,
    /// How it is articulated, in words.
    pub articulation: &'static str,
    pub targets: [Option<f32>; 8],
    /// The tongue's FAP counts ([`TONGUE_FAPS`]); `None` leaves the tongue to the vowel
    /// (at [`ANTICIPATION`] of it), as the lips' free channels.
    pub tongue: Option<[f32; 3]>,
}

/// The vowels: `a` opens the jaw with slightly spread lips and lowers the tongue, `i`
/// spreads the lips over a small jaw opening and raises the tongue's body to the front of
/// the palate, `u` rounds (negative stretcher: corners in and forward), protrudes both
/// lips and draws the tongue back and up.
#[rustfmt::skip]
pub const VOWELS: [Vowel; 3] = [
    Vowel { name: "a", targets: [0.10, 0.55, 0.15, 0.10, 0.0, 0.0, 0.0, 0.0], tongue: [0.0, 0.0, -150.0] },
    Vowel { name: "i", targets: [0.15, 0.15, 0.50, 0.0, 0.0, 0.0, 0.0, 0.0], tongue: [0.0, 0.0, 300.0] },
    Vowel { name: "u", targets: [0.0, 0.12, -0.45, 0.0, 0.0, 0.0, 0.035, 0.04], tongue: [0.0, -100.0, 250.0] },
];

const BILABIAL_CLOSURE: [Option<f32>; 8] = [
    Some(0.0),
    Some(0.0),
    None,
    Some(0.0),
    Some(0.0),
    Some(0.0),
    None,
    None,
];

const fn bilabial(name: &'static str, articulation: &'static str, presser: f32) -> Consonant {
    let mut targets = BILABIAL_CLOSURE;
    targets[4] = Some(presser);
    Consonant {
        name,
        articulation,
        targets,
        tongue: None,
    }
}

/// A consonant made with the tongue against the teeth or palate: the lips stay free,
/// the jaw nearly closed, the tongue where `tongue` puts it.
const fn lingual(
    name: &'static str,
    articulation: &'static str,
    upper_lip_raiser: f32,
    jaw_drop: f32,
    lip_stretcher: Option<f32>,
    tongue: [f32; 3],
) -> Consonant {
    Consonant {
        name,
        articulation,
        targets: [
            Some(upper_lip_raiser),
            Some(jaw_drop),
            lip_stretcher,
            None,
            Some(0.0),
            Some(0.0),
            None,
            None,
        ],
        tongue: Some(tongue),
    }
}

/// The tip raised to the ridge behind the upper incisors (t, d): about 16 mm up and 3.5 mm
/// forward on the ICT head, where it touches the gums.
const TIP_TO_RIDGE: [f32; 3] = [900.0, 75.0, 0.0];

/// The consonants in the thesis's order (the syllables are these times [`VOWELS`]).
pub const CONSONANTS: [Consonant; 9] = [
    bilabial("p", "bilabial stop: lips closed and pressed, jaw closed", 0.6),
    lingual(
        "t",
        "alveolar stop: tongue tip on the ridge behind the upper teeth, small jaw opening",
        0.05,
        0.10,
        None,
        TIP_TO_RIDGE,
    ),
    lingual(
        "k",
        "velar stop: tongue back on the palate, jaw a little open",
        0.03,
        0.18,
        None,
        [0.0, -50.0, 500.0],
    ),
    bilabial(
        "b",
        "voiced bilabial stop: lips closed, pressed less than p",
        0.45,
    ),
    bilabial("m", "bilabial nasal: lips closed, lightly pressed", 0.35),
    Consonant {
        name: "f",
        articulation: "labiodental: lower lip raised and drawn back under the upper teeth, \
                       upper lip lifted off them",
        targets: [
            Some(0.30),
            Some(0.08),
            None,
            Some(0.0),
            Some(0.0),
            Some(0.01),
            Some(-0.015),
            None,
        ],
        tongue: None,
    },
    lingual(
        "s",
        "alveolar fricative: teeth almost together, tongue tip just short of the ridge",
        0.08,
        0.05,
        None,
        [700.0, 40.0, 0.0],
    ),
    lingual(
        "y",
        "palatal approximant: an i-like spread over a small opening, tongue body to the palate",
        0.10,
        0.08,
        Some(0.35),
        [0.0, 0.0, 400.0],
    ),
    lingual(
        "d",
        "voiced alveolar stop: like t, jaw slightly more open",
        0.05,
        0.12,
        None,
        TIP_TO_RIDGE,
    ),
];

/// Share of the vowel's target a consonant takes on the channels it leaves free.
pub const ANTICIPATION: f32 = 0.7;

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

/// The consonant's targets with the free channels filled from the vowel.
pub fn coarticulated(consonant: &Consonant, vowel: &Vowel) -> [f32; 8] {
    let mut out = [0.0; 8];
    for ((slot, target), vowel_target) in out.iter_mut().zip(consonant.targets).zip(vowel.targets) {
        *slot = target.unwrap_or(ANTICIPATION * vowel_target);
    }
    out
}

fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// The consonant's tongue, or the vowel's at [`ANTICIPATION`] where it leaves the tongue
/// free.
pub fn coarticulated_tongue(consonant: &Consonant, vowel: &Vowel) -> [f32; 3] {
    consonant
        .tongue
        .unwrap_or(vowel.tongue.map(|count| ANTICIPATION * count))
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
