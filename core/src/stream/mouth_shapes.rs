//! The mouth shapes the syllable stream and the visemes are made of, in CANDIDE-3
//! animation-unit terms: the channels they move, the three vowels and nine consonants of
//! the thesis's syllables (with the tongue's FAPs), and co-articulation: a consonant only
//! fixes the channels its articulation needs; every other channel anticipates the coming
//! vowel at [`ANTICIPATION`] of the vowel's value (the lips round during the `p` of `pu`
//! and spread during the `p` of `pi`). Tables only: the syllable generator
//! ([`super::syllables`]) and the viseme table ([`super::visemes`]) both read them.

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

/// The consonant's targets with the free channels filled from the vowel.
pub fn coarticulated(consonant: &Consonant, vowel: &Vowel) -> [f32; 8] {
    let mut out = [0.0; 8];
    for ((slot, target), vowel_target) in out.iter_mut().zip(consonant.targets).zip(vowel.targets) {
        *slot = target.unwrap_or(ANTICIPATION * vowel_target);
    }
    out
}

/// The consonant's tongue, or the vowel's at [`ANTICIPATION`] where it leaves the tongue
/// free.
pub fn coarticulated_tongue(consonant: &Consonant, vowel: &Vowel) -> [f32; 3] {
    consonant
        .tongue
        .unwrap_or(vowel.tongue.map(|count| ANTICIPATION * count))
}
