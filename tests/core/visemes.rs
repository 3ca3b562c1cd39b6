//! Visemes as input: a text-to-speech viseme track (Oculus/Meta names, Microsoft IDs, MPEG-4
//! FAP 1) drives the ICT head, and each viseme's mouth has its shape: closed for p/b/m,
//! the lower lip within 2 mm of the upper teeth for f/v (never inside them), open for aa.

use crate::common::{data, register};

use std::sync::Arc;

use facewire::animate::{AnimatedHead, FrameJob, Heat, PartInput};
use facewire::deform::{bind, AlgoSpec};
use facewire::head::{Head, PartRole};
use facewire::mask::{INNER_LIP_MID_LOWER, INNER_LIP_MID_UPPER};
use facewire::metrics::MouthContact;
use facewire::stream::{ArkitBasis, Frame, JsonlReader};
use glam::Affine3A;

/// (label, JSONL viseme), as a TTS engine's track would give them.
const TRACK: [(&str, &str); 8] = [
    ("sil", r#"{"oculus":"sil"}"#),
    ("p", r#"{"oculus":"PP"}"#),
    ("a", r#"{"oculus":10}"#),
    ("m", r#"{"microsoft":21}"#),
    ("f", r#"{"microsoft":18}"#),
    ("v", r#"{"oculus":"FF"}"#),
    ("aa", r#"{"microsoft":2}"#),
    ("b", r#"{"select1":1,"select2":1,"blend":63,"definition":0}"#),
];

#[test]
fn a_viseme_track_gives_each_sound_its_mouth() {
    let text: String = TRACK
        .iter()
        .enumerate()
        .map(|(seq, (label, viseme))| {
            format!(
                "{{\"seq\":{seq},\"t\":{},\"label\":\"{label}\",\"viseme\":{viseme}}}\n",
                seq as f64 / 30.0
            )
        })
        .collect();
    let reg = register("ict_head");
    let frames: Vec<Frame> = JsonlReader::new(text.as_bytes(), &reg.fitted.mask)
        .map(Result::unwrap)
        .collect();
    // The upper teeth, so the contact measures see them.
    let teeth = PartInput {
        name: "teeth_upper".into(),
        role: Some(PartRole::Skull),
        mesh: Head::load(&data("heads/ict_head_teeth_upper.obj")).unwrap(),
    };
    let head = Arc::new(AnimatedHead::with_parts(reg, vec![teeth]).unwrap());
    let reg = &head.registration;
    let mm = reg.mm_per_unit();
    let spec: AlgoSpec = "U".parse().unwrap();
    let mut job = FrameJob::new(
        head.clone(),
        Arc::new(bind(reg, &spec)),
        Arc::new(ArkitBasis::shipped()),
        Heat::None,
    )
    .unwrap();
    let contact = MouthContact::new(
        &reg.head,
        &head.lip_region,
        &reg.fitted.fit.pose,
        mm,
        &head.parts,
        None,
    )
    .unwrap();
    for frame in &frames {
        let deformed = job.deform(frame);
        let gap = deformed[reg.anchors.vertex[INNER_LIP_MID_UPPER] as usize]
            .distance(deformed[reg.anchors.vertex[INNER_LIP_MID_LOWER] as usize])
            * mm;
        // The lower lip's closest approach to the upper teeth, as `facewire compare`
        // measures it.
        let measured = contact.measure(deformed, Affine3A::IDENTITY, None);
        let to_teeth = measured.lower_lip_to_upper_teeth_mm;
        assert_eq!(measured.lips_in_teeth, 0, "{measured:?}");
        let label = frame.label.as_deref().unwrap();
        eprintln!("{label:>3}: lips {gap:5.1} mm apart, lower lip {to_teeth:4.1} mm from the upper teeth");
        match label {
            "p" | "b" | "m" | "sil" => assert!(gap < 2.0, "{label}: lips {gap} mm apart"),
            "a" | "aa" => {
                assert!(gap > 10.0, "{label}: lips only {gap} mm apart");
                assert!(
                    to_teeth > 5.0,
                    "{label}: lower lip {to_teeth} mm from the upper teeth"
                );
            }
            // The upper lip lifts off and the lower lip comes to the upper teeth (within
            // the labiodental contact's 0.2 mm margin).
            "f" | "v" => {
                assert!(gap > 3.0, "{label}: lips {gap} mm apart");
                assert!(
                    to_teeth <= 0.201,
                    "{label}: lower lip {to_teeth} mm from the upper teeth"
                );
            }
            _ => unreachable!(),
        }
    }
}

#[test]
fn unknown_viseme_ids_are_refused_naming_the_scheme() {
    let mask = facewire::mask::Mask::candide3();
    for (viseme, field, expected) in [
        (r#"{"oculus":"zz"}"#, "viseme.oculus", "or a name (sil, PP"),
        (r#"{"oculus":15}"#, "viseme.oculus", "expected 0..=14"),
        (r#"{"microsoft":22}"#, "viseme.microsoft", "expected 0..=21"),
        (r#"{"microsoft":-1}"#, "viseme.microsoft", "expected 0..=21"),
    ] {
        let line = format!("{{\"seq\":0,\"t\":0,\"viseme\":{viseme}}}\n");
        let error = JsonlReader::new(line.as_bytes(), &mask)
            .next()
            .unwrap()
            .unwrap_err();
        let message = error.to_string();
        assert!(
            message.contains(field) && message.contains(expected),
            "{viseme}: {message}"
        );
    }
    // The IDs become FAP 1 as MPEG-4 numbers it: Microsoft's 18 (f v) is viseme 2.
    let line = "{\"seq\":0,\"t\":0,\"viseme\":{\"microsoft\":18}}\n";
    let frame = JsonlReader::new(line.as_bytes(), &mask).next().unwrap().unwrap();
    assert_eq!(frame.viseme, Some(facewire::stream::visemes::single(2)));
}

#[test]
fn mpeg4_expressions_move_the_face() {
    // FAP 2 as a JSONL `expression`: full surprise, full anger, full joy.
    let text: String = [(6, "surprise"), (3, "anger"), (1, "joy")]
        .iter()
        .enumerate()
        .map(|(seq, (select, label))| {
            format!(
                "{{\"seq\":{seq},\"t\":{seq},\"label\":\"{label}\",\"expression\":{{\"select1\":{select},\
                 \"intensity1\":63,\"select2\":0,\"intensity2\":0,\"init_face\":0,\"definition\":0}}}}\n"
            )
        })
        .collect();
    let reg = register("ict_head");
    let mask = reg.fitted.mask.clone();
    let frames: Vec<Frame> = JsonlReader::new(text.as_bytes(), &mask)
        .map(Result::unwrap)
        .collect();
    let head = Arc::new(AnimatedHead::new(reg).unwrap());
    let reg = &head.registration;
    let mm = reg.mm_per_unit();
    let mut job = FrameJob::new(
        head.clone(),
        Arc::new(bind(reg, &"U".parse::<AlgoSpec>().unwrap())),
        Arc::new(ArkitBasis::shipped()),
        Heat::None,
    )
    .unwrap();
    // The brows: the mask vertices the outer brow raiser moves, mean height in mm.
    let brows: Vec<usize> = mask.animation_units[mask.animation_unit("outer_brow_raiser").unwrap()]
        .displacements
        .iter()
        .map(|&(v, _)| v as usize)
        .collect();
    let brow_height = |m: &[glam::Vec3]| brows.iter().map(|&v| m[v].y).sum::<f32>() / brows.len() as f32 * mm;
    let rest_brows = brow_height(reg.mask_rest());
    let anchor = |d: &[glam::Vec3], j: usize| d[reg.anchors.vertex[j] as usize];
    let rest = &reg.head.positions;
    let width = |d: &[glam::Vec3]| anchor(d, 31).distance(anchor(d, 64)) * mm;
    for frame in &frames {
        let deformed = job.deform(frame).to_vec();
        let raised = brow_height(job.mask()) - rest_brows;
        let gap =
            anchor(&deformed, INNER_LIP_MID_UPPER).distance(anchor(&deformed, INNER_LIP_MID_LOWER)) * mm;
        let wider = width(&deformed) - width(rest);
        let label = frame.label.as_deref().unwrap();
        eprintln!("{label}: brows {raised:+.1} mm, lips {gap:.1} mm apart, mouth {wider:+.1} mm wider");
        match label {
            "surprise" => assert!(raised > 3.0 && gap > 8.0, "{label}"),
            "anger" => assert!(raised < -2.0 && gap < 2.0, "{label}"),
            "joy" => assert!(wider > 5.0 && raised.abs() < 0.5, "{label}"),
            _ => unreachable!(),
        }
    }
}
