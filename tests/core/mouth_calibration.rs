//! Lips that close on a head scanned with its mouth open (docs/FITTING.md, "Lips that
//! close"). The MakeHuman head with its jaw part-open (the neutral head plus a share of its
//! jawOpen target) is closed at registration; its inner lips then meet within 0.5 mm on the
//! midline on every p, b and m frame of the syllable stream, from the syllable's start
//! through the consonant's hold, while the vowels still open the mouth. Heads whose lips
//! meet already are left exactly as they are.

use crate::common::{data, part_open_head};

use std::sync::Arc;

use facewire::animate::{AnimatedHead, FrameJob, Heat};
use facewire::deform::{bind, AlgoSpec, Registration};
use facewire::fit::{fit_from_landmarks, mouth_opening, FitFile, FittedMask, Landmarks};
use facewire::head::Head;
use facewire::mask::Mask;
use facewire::stream::syllables::{self, SYLLABLE_S};
use facewire::stream::{open_stream, ArkitBasis};

/// Lips this far apart or less meet (mm).
const MEET_MM: f64 = 0.5;

/// The open heads: (head, its jawOpen target, the share that opens it about 6 mm).
const OPEN_HEADS: [(&str, &str, f32); 2] = [
    ("makehuman_head", "makehuman_arkit/jawOpen.target", 0.16),
    ("ict_head", "ict_targets/skin/jawOpen.target", 0.2),
];

/// The gap between the lips on the midline, mm.
fn gap_mm(positions: &[glam::Vec3], head: &Head, fitted: &FittedMask) -> f64 {
    mouth_opening(positions, &head.triangles, fitted).height() * f64::from(fitted.mm_per_mask_unit())
}

#[test]
fn a_mouth_open_at_rest_is_closed_and_p_b_m_close_it() {
    for (name, target, share) in OPEN_HEADS {
        eprintln!("{name}:");
        closes(name, target, share);
    }
}

fn closes(name: &str, target: &str, share: f32) {
    let head = part_open_head(name, target, share);
    let mask = Mask::candide3();
    // Fitted from the neutral head's landmarks, as a user would pick them on this head.
    let landmarks = Landmarks::load(&data(&format!("heads/{name}.landmarks.toml"))).unwrap();
    let fit = fit_from_landmarks(&head, &landmarks, "landmarks", &mask)
        .unwrap()
        .fit;
    let fitted = FittedMask::new(mask, fit);
    let before = gap_mm(&head.positions, &head, &fitted);
    let started = std::time::Instant::now();
    assert!((4.0..8.0).contains(&before), "{before} mm apart at rest");

    let reg = Registration::try_new(head, fitted).unwrap();
    let calibration = reg.mouth_calibration.expect("the mouth is closed");
    eprintln!(
        "open {before:.2} mm at rest: {calibration:?}, registered in {:?}",
        started.elapsed()
    );
    assert!((f64::from(calibration.open_mm) - before).abs() < 1e-3);
    assert!(
        calibration.raised_mm >= calibration.open_mm * 0.5,
        "{calibration:?}"
    );
    let rest = gap_mm(&reg.head.positions, &reg.head, &reg.fitted);
    assert!(rest <= MEET_MM, "{rest} mm apart at rest after closing");

    let closed = speak(reg);
    eprintln!("closed: {closed:?}");
    // The 9 bilabial syllables' frames from their slot's start through the consonant's
    // hold at 30 fps, as the voice times them (data/streams/syllables.phonemes.tsv).
    assert_eq!(closed.closing_frames, 54);
    assert!(closed.widest_closing_gap_mm <= MEET_MM, "{closed:?}");
    assert!(closed.widest_a_mm > 10.0, "{closed:?}");

    // The same head registered as it is: p, b and m leave it open.
    let head = part_open_head(name, target, share);
    let fit = fit_from_landmarks(&head, &landmarks, "landmarks", &Mask::candide3())
        .unwrap()
        .fit;
    let open = speak(Registration::new(head, FittedMask::new(Mask::candide3(), fit)));
    eprintln!("not closed: {open:?}");
    assert!(open.widest_closing_gap_mm > 3.0, "{open:?}");
}

/// The lips through the syllable stream.
#[derive(Debug)]
struct Speech {
    /// Frames of p, b and m syllables from their start through the consonant's hold.
    closing_frames: usize,
    /// The widest midline gap on those frames, mm.
    widest_closing_gap_mm: f64,
    /// The widest gap while a vowel a is held, mm.
    widest_a_mm: f64,
}

/// Plays the syllable stream on `reg` with the default algorithm.
fn speak(reg: Registration) -> Speech {
    let animated = Arc::new(AnimatedHead::new(reg).unwrap());
    let reg = &animated.registration;
    let spec: AlgoSpec = facewire::server::config::DEFAULT_ALGORITHM.parse().unwrap();
    let mut job = FrameJob::new(
        animated.clone(),
        Arc::new(bind(reg, &spec)),
        Arc::new(ArkitBasis::shipped()),
        Heat::None,
    )
    .unwrap();
    let keyframes: Vec<_> = syllables::timings()
        .unwrap()
        .iter()
        .map(syllables::keyframes)
        .collect();
    let mut speech = Speech {
        closing_frames: 0,
        widest_closing_gap_mm: 0.0,
        widest_a_mm: 0.0,
    };
    for frame in open_stream(&data("streams/syllables.jsonl"), &reg.fitted.mask).unwrap() {
        let frame = frame.unwrap();
        let label = frame.label.clone().unwrap();
        // Time into the syllable; a frame on a boundary (0.6 s = 18 / 30 s) starts the next.
        let slot = (frame.time_s / SYLLABLE_S + 1e-9).floor();
        let into_syllable = frame.time_s - slot * SYLLABLE_S;
        let timing = &keyframes[(slot as usize).min(keyframes.len() - 1)];
        let (consonant_held_until, vowel_held) = (timing[2].0, timing[3].0..=timing[4].0);
        let gap = gap_mm(job.deform(&frame), &reg.head, &reg.fitted);
        if label.starts_with(['p', 'b', 'm']) && into_syllable <= consonant_held_until + 1e-9 {
            speech.closing_frames += 1;
            speech.widest_closing_gap_mm = speech.widest_closing_gap_mm.max(gap);
        }
        if label.ends_with('a') && vowel_held.contains(&into_syllable) {
            speech.widest_a_mm = speech.widest_a_mm.max(gap);
        }
    }
    speech
}

#[test]
fn heads_whose_lips_meet_are_left_as_they_are() {
    for name in ["makehuman_head", "lee_perry_smith_head", "ict_head"] {
        let mask = Mask::candide3();
        let head = Head::load(&data(&format!("heads/{name}.obj"))).unwrap();
        let fit = FitFile::load(&data(&format!("heads/{name}.fit.toml")))
            .unwrap()
            .resolve(name, &mask)
            .unwrap();
        let fitted = FittedMask::new(mask, fit);
        let reg = Registration::try_new(head.clone(), fitted.clone()).unwrap();
        assert!(reg.mouth_calibration.is_none(), "{name}");
        assert_eq!(reg.head.positions, head.positions, "{name}");
        assert_eq!(reg.fitted.base, fitted.base, "{name}");
    }
}
