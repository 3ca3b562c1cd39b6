//! Visemes as input: MPEG-4's visemes (FAP 1: two of them and a blend), which are also
//! Oculus/Meta's 15 (the same list in the same order, `sil` first), and Microsoft's 22
//! viseme IDs (each mapped onto one of them), so a text-to-speech engine's viseme track
//! drives a head directly. Each viseme is a mouth shape in the channels of the syllable
//! generator ([`CHANNELS`]); the shapes the generator has (p, f, t, k, s and the vowels
//! a, i, u) are taken from its table, so a viseme and a syllable of the same sound look
//! alike. docs/STREAMS.md, "Visemes", has the tables.

use super::frame::VisemeFap;
use super::mouth_shapes::{Consonant, CHANNELS, CONSONANTS, TONGUE_FAPS, VOWELS};

/// One MPEG-4 viseme: its number (also Oculus/Meta's index), Oculus/Meta's name, the
/// sounds it stands for, and its mouth shape as weights of [`CHANNELS`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Viseme {
    pub number: u8,
    pub oculus: &'static str,
    pub sounds: &'static str,
    pub shape: [f32; 8],
    /// The tongue's FAP counts ([`TONGUE_FAPS`]).
    pub tongue: [f32; 3],
}

/// A consonant of the syllable table alone: the channels it leaves to the vowel at rest.
const fn alone(consonant: &Consonant) -> [f32; 8] {
    let mut shape = [0.0; 8];
    let mut k = 0;
    while k < 8 {
        if let Some(x) = consonant.targets[k] {
            shape[k] = x;
        }
        k += 1;
    }
    shape
}

/// A consonant's tongue alone: at rest where it leaves the tongue to the vowel.
const fn tongue_of(consonant: &Consonant) -> [f32; 3] {
    match consonant.tongue {
        Some(tongue) => tongue,
        None => [0.0; 3],
    }
}

/// Channels: upper_lip_raiser, jaw_drop, lip_stretcher, lip_corner_depressor,
/// lip_presser, fap5_raise_b_midlip, fap16_push_b_lip, fap17_push_t_lip; tongue: FAPs
/// 44 raise_tongue_tip, 45 thrust_tongue_tip, 46 raise_tongue (counts). TH puts the tip
/// between the teeth (past the upper teeth's front).
#[rustfmt::skip]
pub const VISEMES: [Viseme; 15] = [
    Viseme { number: 0,  oculus: "sil", sounds: "silence", shape: [0.0; 8], tongue: [0.0; 3] },
    Viseme { number: 1,  oculus: "PP",  sounds: "p b m", shape: alone(&CONSONANTS[0]) , tongue: tongue_of(&CONSONANTS[0]) },
    Viseme { number: 2,  oculus: "FF",  sounds: "f v", shape: alone(&CONSONANTS[5]) , tongue: tongue_of(&CONSONANTS[5]) },
    Viseme { number: 3,  oculus: "TH",  sounds: "th (thin, this)", shape: [0.08, 0.12, 0.05, 0.0, 0.0, 0.0, 0.0, 0.0], tongue: [200.0, 300.0, 0.0] },
    Viseme { number: 4,  oculus: "DD",  sounds: "t d", shape: alone(&CONSONANTS[1]) , tongue: tongue_of(&CONSONANTS[1]) },
    Viseme { number: 5,  oculus: "kk",  sounds: "k g", shape: alone(&CONSONANTS[2]) , tongue: tongue_of(&CONSONANTS[2]) },
    Viseme { number: 6,  oculus: "CH",  sounds: "ch j sh zh", shape: [0.1, 0.1, -0.25, 0.0, 0.0, 0.0, 0.025, 0.03], tongue: [400.0, 0.0, 400.0] },
    Viseme { number: 7,  oculus: "SS",  sounds: "s z", shape: alone(&CONSONANTS[6]) , tongue: tongue_of(&CONSONANTS[6]) },
    Viseme { number: 8,  oculus: "nn",  sounds: "n l", shape: [0.05, 0.12, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0], tongue: [900.0, 75.0, 0.0] },
    Viseme { number: 9,  oculus: "RR",  sounds: "r", shape: [0.05, 0.12, -0.2, 0.0, 0.0, 0.0, 0.015, 0.02], tongue: [500.0, -100.0, 0.0] },
    Viseme { number: 10, oculus: "aa",  sounds: "a (car)", shape: VOWELS[0].targets , tongue: VOWELS[0].tongue },
    Viseme { number: 11, oculus: "E",   sounds: "e (bed)", shape: [0.12, 0.35, 0.35, 0.05, 0.0, 0.0, 0.0, 0.0], tongue: [0.0, 0.0, 150.0] },
    Viseme { number: 12, oculus: "ih",  sounds: "i (tip, see)", shape: VOWELS[1].targets , tongue: VOWELS[1].tongue },
    Viseme { number: 13, oculus: "oh",  sounds: "o (top, go)", shape: [0.05, 0.35, -0.35, 0.0, 0.0, 0.0, 0.03, 0.03], tongue: [0.0, -100.0, 0.0] },
    Viseme { number: 14, oculus: "ou",  sounds: "u (book, you)", shape: VOWELS[2].targets , tongue: VOWELS[2].tongue },
];

/// Microsoft's viseme ID (0..=21, Azure text-to-speech) -> MPEG-4 viseme number.
/// Diphthongs (9 `aʊ`, 10 `ɔɪ`, 11 `aɪ`) take their first vowel.
#[rustfmt::skip]
pub const MICROSOFT_TO_MPEG4: [u8; 22] = [
    0,  // 0 silence
    10, // 1 æ ə ʌ
    10, // 2 ɑ
    13, // 3 ɔ
    11, // 4 ɛ ʊ
    9,  // 5 ɝ
    12, // 6 j i ɪ
    14, // 7 w u
    13, // 8 o
    10, // 9 aʊ
    13, // 10 ɔɪ
    10, // 11 aɪ
    11, // 12 h
    9,  // 13 ɹ
    8,  // 14 l
    7,  // 15 s z
    6,  // 16 ʃ tʃ dʒ ʒ
    3,  // 17 ð
    2,  // 18 f v
    4,  // 19 d t n θ
    5,  // 20 k g ŋ
    1,  // 21 p b m
];

/// Where a text-to-speech viseme ID comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VisemeScheme {
    /// Oculus/Meta's 15 (`sil`, `PP`, ..., `ou`): MPEG-4's numbers.
    Oculus,
    /// Microsoft's 22.
    Microsoft,
}

impl VisemeScheme {
    /// The MPEG-4 viseme of `id` in this scheme, if it has one.
    pub fn to_mpeg4(self, id: i64) -> Option<u8> {
        let id = usize::try_from(id).ok()?;
        match self {
            VisemeScheme::Oculus => VISEMES.get(id).map(|v| v.number),
            VisemeScheme::Microsoft => MICROSOFT_TO_MPEG4.get(id).copied(),
        }
    }

    /// Its key in a JSONL `viseme` object.
    pub fn key(self) -> &'static str {
        match self {
            VisemeScheme::Oculus => "oculus",
            VisemeScheme::Microsoft => "microsoft",
        }
    }

    /// The highest ID.
    pub fn last(self) -> usize {
        match self {
            VisemeScheme::Oculus => VISEMES.len() - 1,
            VisemeScheme::Microsoft => MICROSOFT_TO_MPEG4.len() - 1,
        }
    }

    /// FAP 1 holding the viseme `id` names, or what to tell a producer whose `id` (as
    /// written) names none.
    pub fn fap1(self, id: i64, written: &str) -> Result<VisemeFap, String> {
        self.to_mpeg4(id).map(single).ok_or_else(|| {
            let names = match self {
                VisemeScheme::Oculus => {
                    " or a name (sil, PP, FF, TH, DD, kk, CH, SS, nn, RR, aa, E, ih, oh, ou)"
                }
                VisemeScheme::Microsoft => "",
            };
            format!("{written} is not a viseme: expected 0..={}{names}", self.last())
        })
    }
}

/// One viseme held fully, as FAP 1 says it: both selects the viseme, blend 63.
pub fn single(number: u8) -> VisemeFap {
    VisemeFap {
        select1: i32::from(number),
        select2: i32::from(number),
        blend: 63,
        definition: 0,
    }
}

/// Adds FAP 1's mouth shape to the animation-unit weights `out` (one slot per unit):
/// `blend / 63` of viseme `select1` and the rest of `select2`, channel by channel. A frame
/// that defines a viseme (`definition` 1) rather than using it, and selects outside 0..=14,
/// add nothing. Allocates nothing.
pub fn add_viseme(viseme: &VisemeFap, out: &mut [f32]) {
    let (Some(first), Some(second)) = (
        usize::try_from(viseme.select1).ok().and_then(|i| VISEMES.get(i)),
        usize::try_from(viseme.select2).ok().and_then(|i| VISEMES.get(i)),
    ) else {
        return;
    };
    if viseme.definition != 0 {
        return;
    }
    let share = viseme.blend.clamp(0, 63) as f32 / 63.0;
    for (k, channel) in CHANNELS.iter().enumerate() {
        if let Some(slot) = out.get_mut(usize::from(channel.unit)) {
            *slot += share * first.shape[k] + (1.0 - share) * second.shape[k];
        }
    }
}

/// FAP 1's tongue: `(fap, counts)` for each of [`TONGUE_FAPS`], blended as
/// [`add_viseme`] blends the mouth; nothing for a frame that defines a viseme or selects
/// outside 0..=14.
pub fn viseme_tongue(viseme: &VisemeFap) -> impl Iterator<Item = (u8, f32)> {
    let pair = (viseme.definition == 0)
        .then(|| {
            let first = VISEMES.get(usize::try_from(viseme.select1).ok()?)?;
            let second = VISEMES.get(usize::try_from(viseme.select2).ok()?)?;
            Some((first, second))
        })
        .flatten();
    let share = viseme.blend.clamp(0, 63) as f32 / 63.0;
    TONGUE_FAPS.iter().enumerate().filter_map(move |(k, &fap)| {
        let (first, second) = pair?;
        Some((fap, share * first.tongue[k] + (1.0 - share) * second.tongue[k]))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_viseme_blend_blends_the_tongue() {
        let dd_and_aa = VisemeFap {
            select1: 4,
            select2: 10,
            blend: 21,
            definition: 0,
        };
        let tongue: Vec<(u8, f32)> = viseme_tongue(&dd_and_aa).collect();
        let third = 21.0 / 63.0;
        assert_eq!(tongue.len(), 3);
        assert_eq!(tongue[0], (44, third * 900.0));
        assert!((tongue[2].1 - (1.0 - third) * -150.0).abs() < 1e-3, "{tongue:?}");
        let defining = VisemeFap {
            definition: 1,
            ..dd_and_aa
        };
        assert_eq!(viseme_tongue(&defining).count(), 0);
    }

    #[test]
    fn the_numbers_are_the_positions_and_shapes_stay_in_range() {
        for (i, viseme) in VISEMES.iter().enumerate() {
            assert_eq!(usize::from(viseme.number), i);
            for (k, channel) in CHANNELS.iter().enumerate() {
                let x = viseme.shape[k];
                assert!(
                    (channel.min..=channel.max).contains(&x),
                    "{} {}: {x}",
                    viseme.oculus,
                    channel.key
                );
            }
        }
        assert!(MICROSOFT_TO_MPEG4.iter().all(|&v| usize::from(v) < VISEMES.len()));
    }

    #[test]
    fn the_syllable_sounds_keep_their_shapes() {
        // p closes and presses the lips, as the syllable generator's p does.
        assert_eq!(VISEMES[1].shape, [0.0, 0.0, 0.0, 0.0, 0.6, 0.0, 0.0, 0.0]);
        // f lifts the upper lip and draws the lower lip back under the teeth.
        assert_eq!(VISEMES[2].shape, [0.30, 0.08, 0.0, 0.0, 0.0, 0.01, -0.015, 0.0]);
        assert_eq!(VISEMES[10].shape, VOWELS[0].targets);
        // t d: the tongue tip to the ridge, as the generator's t; th: out between the teeth.
        assert_eq!(VISEMES[4].tongue, [900.0, 75.0, 0.0]);
        assert!(VISEMES[3].tongue[1] > 0.0);
        assert_eq!(VISEMES[1].tongue, [0.0; 3]);
    }

    #[test]
    fn schemes_map_onto_mpeg4() {
        assert_eq!(VisemeScheme::Oculus.to_mpeg4(10), Some(10));
        assert_eq!(VisemeScheme::Oculus.to_mpeg4(15), None);
        assert_eq!(VisemeScheme::Microsoft.to_mpeg4(21), Some(1)); // p b m
        assert_eq!(VisemeScheme::Microsoft.to_mpeg4(18), Some(2)); // f v
        assert_eq!(VisemeScheme::Microsoft.to_mpeg4(-1), None);
        assert_eq!(VisemeScheme::Microsoft.last(), 21);
    }

    #[test]
    fn fap1_blends_two_shapes_into_the_unit_weights() {
        let mut out = [0.0f32; 65];
        // 21/63 of aa and 42/63 of ih.
        add_viseme(
            &VisemeFap {
                select1: 10,
                select2: 12,
                blend: 21,
                definition: 0,
            },
            &mut out,
        );
        let jaw = (VOWELS[0].targets[1] + 2.0 * VOWELS[1].targets[1]) / 3.0;
        assert!((out[1] - jaw).abs() < 1e-6, "{}", out[1]);
        // A definition, or a select out of range, adds nothing.
        let mut still = [0.0f32; 65];
        add_viseme(
            &VisemeFap {
                select1: 10,
                select2: 10,
                blend: 63,
                definition: 1,
            },
            &mut still,
        );
        add_viseme(
            &VisemeFap {
                select1: 15,
                select2: 1,
                blend: 63,
                definition: 0,
            },
            &mut still,
        );
        assert_eq!(still, [0.0; 65]);
    }
}
