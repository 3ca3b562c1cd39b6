//! Contact inside the ICT head's mouth over the whole syllable stream, as `facewire
//! compare` measures it after the contact constraint: no lip vertex ends inside a tooth,
//! the tongue at most grazes them, the lower lip comes within 2 mm of the upper teeth in
//! every f syllable, the tongue tip reaches the ridge behind the upper teeth for t and d
//! and never comes out past the teeth.

use crate::common::{data, ict_head};

use std::path::Path;

use facewire::report::{compare, parse_algorithms, CompareInput, Comparison};
use facewire::stream::ArkitBasis;

/// `algorithms` over `stream` on the ICT head with its parts, as `facewire compare`.
fn compare_on_ict(algorithms: &str, stream: &Path) -> Comparison {
    let head = std::sync::Arc::new(ict_head());
    let basis = ArkitBasis::shipped();
    let algorithms = parse_algorithms(algorithms).unwrap();
    let input = CompareInput {
        head: &head,
        stream,
        basis: &basis,
        algorithms: &algorithms,
        targets: &[],
    };
    compare(&input, &mut |_| {}).unwrap()
}

#[test]
fn the_syllables_touch_the_teeth_without_going_into_them() {
    let comparison = compare_on_ict("U,biharmonic", &data("streams/syllables.jsonl"));
    let rest = comparison.rest_contact.expect("the ICT head has teeth");
    assert_eq!(rest.lips_in_teeth, 0);
    for a in &comparison.algorithms {
        let s = &a.summary;
        assert_eq!(a.contact.len(), comparison.frames, "{}", s.spec);
        // No lip vertex inside a tooth, in any frame.
        assert_eq!(s.lips_in_teeth, Some(0), "{}", s.spec);
        // Every f syllable brings the lower lip to the upper teeth (the labiodental
        // contact leaves it at most its 0.2 mm margin from them; 1.0 mm without it)...
        let fv = s.fv_gap_mm.unwrap();
        eprintln!("{}: widest f/v gap {fv:.2} mm", s.spec);
        assert!(fv <= 0.201, "{}: {fv} mm", s.spec);
        // ... and the lips stay off the teeth where the mouth opens for a vowel.
        for row in a
            .contact
            .iter()
            .filter(|r| r.label == "pa" && (10..=12).contains(&r.frame))
        {
            assert!(row.contact.lower_lip_to_upper_teeth_mm > 2.0, "{row:?}");
        }
    }

    // The tongue moves alike under every algorithm.
    let rows = &comparison.algorithms[0].contact;
    let closest = |syllable: &str| {
        rows.iter()
            .filter(|r| r.label == syllable)
            .map(|r| r.contact.tongue_tip_to_gums_mm)
            .fold(f32::INFINITY, f32::min)
    };
    let widest = |syllable: &str| {
        rows.iter()
            .filter(|r| r.label == syllable)
            .map(|r| r.contact.tongue_tip_to_gums_mm)
            .fold(0.0f32, f32::max)
    };
    for syllable in ["ta", "ti", "tu", "da", "di", "du"] {
        let tip = closest(syllable);
        eprintln!("{syllable}: tongue tip {tip:.2} mm from the ridge at its closest");
        assert!(tip < 1.0, "{syllable}: {tip} mm");
    }
    // Open for a: the tip drops well away from the ridge.
    assert!(widest("pa") > 5.0, "{}", widest("pa"));
    let tongue = comparison.tongue.expect("the ICT head has a tongue");
    eprintln!("tongue: {tongue:?}");
    // Behind the teeth in every frame (no sound of the stream puts it between them)...
    assert!(tongue.max_past_teeth_mm < -1.0, "{tongue:?}");
    // ... and out of them: the contact constraint puts every tongue vertex that was
    // outside the teeth at rest back outside them, the last round's neighbours alone
    // (before they went out alone, 23 frames kept them up to 0.14 mm deep).
    for row in rows {
        assert_eq!(row.contact.tongue_depth_mm, 0.0, "{row:?}");
    }
}

#[test]
fn a_th_puts_the_tongue_between_the_teeth() {
    // TH (Oculus 3): the one viseme whose tongue comes out past the upper teeth.
    let dir = tempfile::tempdir().unwrap();
    let stream = dir.path().join("th.jsonl");
    std::fs::write(
        &stream,
        "{\"seq\":0,\"t\":0,\"label\":\"sil\"}\n{\"seq\":1,\"t\":0.1,\"label\":\"th\",\"viseme\":{\"oculus\":\"TH\"}}\n",
    )
    .unwrap();
    let comparison = compare_on_ict("U", &stream);
    let rows = &comparison.algorithms[0].contact;
    assert!(rows[0].contact.tongue_past_teeth_mm < -3.0, "{:?}", rows[0]);
    assert!(rows[1].contact.tongue_past_teeth_mm > 0.0, "{:?}", rows[1]);
}
