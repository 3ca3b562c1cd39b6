//! Both viewer frame layouts: every field's round trip, the frozen FWF1's byte offsets,
//! and how FWF2 grows (unknown sections and fields skipped) and refuses what is malformed.

use super::*;
use crate::Writer;

const LAYOUTS: [FrameLayout; 2] = [FrameLayout::Fwf1, FrameLayout::Fwf2];

fn header() -> FrameHeader {
    FrameHeader {
        seq: 42,
        producer_time_s: 1.5,
        server_receive_us: 1_000_000,
        server_send_us: 1_000_250,
    }
}

fn content<'a>(deltas: &'a [[f32; 3]], lip: &'a LipRoughness, deflate: bool) -> FrameContent<'a> {
    FrameContent {
        step: 0.5,
        deltas,
        lip,
        label: None,
        heat: None,
        deflate,
        head: None,
        jaw: None,
        tongue: None,
        folds: None,
        eyes: &[],
        viseme: None,
    }
}

fn encode(layout: FrameLayout, content: &FrameContent<'_>) -> Vec<u8> {
    FrameEncoder::default()
        .encode(layout, &header(), content)
        .to_vec()
}

/// A quarter turn about +y (yaw) and a shift.
const QUARTER_YAW: RigidMotion = RigidMotion {
    rotation: [
        0.0,
        std::f32::consts::FRAC_1_SQRT_2,
        0.0,
        std::f32::consts::FRAC_1_SQRT_2,
    ],
    translation: [1.0, 2.0, 3.0],
};

const OPEN_JAW: RigidMotion = RigidMotion {
    rotation: [0.198_669_33, 0.0, 0.0, 0.980_066_6],
    translation: [0.0, -0.5, 0.25],
};

const FOLDS: LipFolds = LipFolds {
    turned_over_60: 12,
    turned_over_90: 3,
    max_dihedral_increase_deg: 97.5,
};

#[test]
fn every_field_travels_in_both_layouts_with_quantization_bounded_by_half_a_step() {
    let deltas = [
        [0.0, 0.0, 0.0],
        [0.011, -0.2, 0.0],
        [0.0, 0.0, 0.0],
        [0.0004, 0.0, 0.0],
        [-1.0, 2.5, 0.3],
    ];
    let lip = LipRoughness {
        min: 0.1,
        max: 0.4,
        mean: 0.2,
        per_vertex: vec![0.1, 0.3],
    };
    let heat = [0.0, 0.5, 1.0, 0.25, 0.0];
    let tongue = [[0.0; 3], [0.0, 0.0026, -0.001], [0.0; 3], [0.001, 0.0, 0.0]];
    let step = 0.001;
    for layout in LAYOUTS {
        for deflate in [false, true] {
            let bytes = encode(
                layout,
                &FrameContent {
                    step,
                    deltas: &deltas,
                    lip: &lip,
                    label: Some("pa"),
                    heat: Some(&heat),
                    deflate,
                    head: Some(QUARTER_YAW),
                    jaw: Some(OPEN_JAW),
                    tongue: Some((3, &tongue)),
                    folds: Some(FOLDS),
                    eyes: &[],
                    viseme: None,
                },
            );
            assert_eq!(&bytes[..4], &layout.magic());
            let frame = decode(&bytes).unwrap();
            assert_eq!(frame.layout, layout);
            assert_eq!(frame.header, header());
            assert_eq!(decode_header(&bytes).unwrap(), header());
            assert_eq!(frame.label.as_deref(), Some("pa"));
            assert_eq!(frame.lip, lip);
            assert_eq!(
                (frame.head, frame.jaw, frame.folds),
                (QUARTER_YAW, OPEN_JAW, Some(FOLDS))
            );
            // vertex 3 moves less than half a step: not sent
            assert_eq!(frame.moved.iter().map(|m| m.0).collect::<Vec<_>>(), vec![1, 4]);
            let rest = vec![0.0f32; 15];
            let mut out = Vec::new();
            frame.apply(&rest, &mut out);
            for (v, d) in deltas.iter().enumerate() {
                for k in 0..3 {
                    assert!((out[v * 3 + k] - d[k]).abs() <= 0.5 * step + 1e-7, "{v} {k}");
                }
            }
            let part = frame.part(3).unwrap();
            assert_eq!((part.step, part.vertex_count), (step, 4));
            // 0.0026 -> 3 counts, -0.001 -> -1, 0.001 -> 1.
            assert_eq!(part.moved, [(1, [0, 3, -1]), (3, [1, 0, 0])]);
            assert_eq!(frame.parts.len(), 1);
            let heat_back = frame.heat.unwrap();
            assert!((heat_back[1] - 0.5).abs() < 1.0 / 255.0);
            assert_eq!(heat_back[2], 1.0);
        }
    }
}

#[test]
fn absent_fields_are_left_out_and_decode_as_rest() {
    let lip = LipRoughness::default();
    for layout in LAYOUTS {
        let plain = encode(layout, &content(&[[0.0; 3]], &lip, true));
        let frame = decode(&plain).unwrap();
        assert_eq!(
            (frame.head, frame.jaw),
            (RigidMotion::IDENTITY, RigidMotion::IDENTITY)
        );
        assert_eq!((frame.label, frame.folds, frame.heat), (None, None, None));
        assert!(frame.parts.is_empty() && frame.moved.is_empty());
        let with_folds = encode(
            layout,
            &FrameContent {
                folds: Some(FOLDS),
                label: Some(""),
                ..content(&[[0.0; 3]], &lip, true)
            },
        );
        // An empty label is not sent; folds are 8 bytes (and a section header in FWF2).
        let section = if layout == FrameLayout::Fwf2 { 5 } else { 0 };
        assert_eq!(with_folds.len(), plain.len() + 8 + section);
        let moving = encode(
            layout,
            &FrameContent {
                head: Some(QUARTER_YAW),
                ..content(&[[0.0; 3]], &lip, true)
            },
        );
        assert_eq!(moving.len(), plain.len() + 28 + section);
    }
}

#[test]
fn bad_motions_and_folds_are_refused_by_name_in_both_layouts() {
    let lip = LipRoughness::default();
    for layout in LAYOUTS {
        let nan = LipFolds {
            max_dihedral_increase_deg: f32::NAN,
            ..FOLDS
        };
        let bytes = encode(
            layout,
            &FrameContent {
                folds: Some(nan),
                ..content(&[[0.0; 3]], &lip, true)
            },
        );
        assert!(matches!(
            decode(&bytes),
            Err(DecodeError::Invalid {
                field: "lip folds",
                ..
            })
        ));
        for (bad, problem) in [(f32::NAN, "not finite"), (2.0, "length")] {
            let mut motion = QUARTER_YAW;
            motion.rotation[0] = bad;
            let bytes = encode(
                layout,
                &FrameContent {
                    jaw: Some(motion),
                    ..content(&[[0.0; 3]], &lip, true)
                },
            );
            match decode(&bytes) {
                Err(DecodeError::Invalid {
                    field: "jaw motion",
                    problem: text,
                    ..
                }) => assert!(text.contains(problem), "{text}"),
                other => panic!("{layout:?}: {other:?}"),
            }
        }
    }
}

#[test]
fn head_motion_rotates_then_translates() {
    let p = QUARTER_YAW.apply([1.0, 0.0, 0.0]);
    // +x turns onto -z about +y, then shifts.
    for (got, want) in p.iter().zip([1.0, 2.0, 2.0]) {
        assert!((got - want).abs() < 1e-6, "{p:?}");
    }
    assert_eq!(RigidMotion::IDENTITY.apply([4.0, 5.0, 6.0]), [4.0, 5.0, 6.0]);
    let lip = LipRoughness::default();
    let frame = decode(&encode(
        FrameLayout::Fwf2,
        &FrameContent {
            head: Some(QUARTER_YAW),
            ..content(&[[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]], &lip, true)
        },
    ))
    .unwrap();
    let (mut local, mut placed) = (Vec::new(), Vec::new());
    let rest = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0];
    frame.apply(&rest, &mut local);
    frame.place(&rest, &mut placed);
    assert_eq!(local, [0.0, 0.0, 0.0, 1.5, 0.0, 0.0]);
    for (got, want) in placed.iter().zip([1.0, 2.0, 3.0, 1.0, 2.0, 1.5]) {
        assert!((got - want).abs() < 1e-6, "{placed:?}");
    }
}

#[test]
fn fwf1_keeps_its_frozen_offsets() {
    let lip = LipRoughness::default();
    let deltas = [[0.0, 0.0, 0.0], [1.0, -0.5, 0.0], [1.0, 0.0, 0.5]];
    let bytes = encode(FrameLayout::Fwf1, &content(&deltas, &lip, false));
    // header 52 + lip 12 + lip_count 1 + block length 4, then
    // vertex 1: gap 1, counts +2 -1 0 -> zigzag 4 1 0
    // vertex 2: gap 0, differences 0 +1 +1 -> zigzag 0 2 2
    assert_eq!(bytes[4], 0);
    assert_eq!(&bytes[44..52], &[3, 0, 0, 0, 2, 0, 0, 0]);
    assert_eq!(&bytes[65..69], &[8, 0, 0, 0]);
    assert_eq!(&bytes[69..], &[1, 4, 1, 0, 0, 0, 2, 2]);
    let moving = encode(
        FrameLayout::Fwf1,
        &FrameContent {
            head: Some(QUARTER_YAW),
            ..content(&deltas, &lip, false)
        },
    );
    // Flag bit 3; the motion starts after the 65 fixed bytes (no lip values, no label).
    assert_eq!(moving[4], 8);
    assert_eq!(&moving[65..69], &0.0f32.to_le_bytes());
    assert_eq!(&moving[69..73], &std::f32::consts::FRAC_1_SQRT_2.to_le_bytes());
    assert!(matches!(
        decode(&moving[..80]),
        Err(DecodeError::Truncated {
            field: "head motion",
            ..
        })
    ));
    assert_eq!(decode_header(&bytes[..40]).unwrap(), header());
    assert!(decode_header(&bytes[..39]).is_err());
}

#[test]
fn fwf2_lays_out_its_header_and_sections() {
    let lip = LipRoughness::default();
    let deltas = [[0.0, 0.0, 0.0], [1.0, -0.5, 0.0], [1.0, 0.0, 0.5]];
    let bytes = encode(FrameLayout::Fwf2, &content(&deltas, &lip, false));
    assert_eq!(&bytes[..4], b"FWF2");
    assert_eq!(&bytes[4..12], &42u64.to_le_bytes());
    assert_eq!(bytes[36], 2);
    // deltas: kind 1, length 4 + 4 + 4 + 1 + 4 + 8, step 0.5, 3 vertices, 2 moved, plain.
    assert_eq!(&bytes[37..42], &[1, 25, 0, 0, 0]);
    assert_eq!(&bytes[42..46], &0.5f32.to_le_bytes());
    assert_eq!(&bytes[46..55], &[3, 0, 0, 0, 2, 0, 0, 0, 0]);
    assert_eq!(&bytes[55..67], &[8, 0, 0, 0, 1, 4, 1, 0, 0, 0, 2, 2]);
    // lip_roughness: kind 2, 13 bytes.
    assert_eq!(&bytes[67..72], &[2, 13, 0, 0, 0]);
    assert_eq!(bytes.len(), 72 + 13);
    assert_eq!(decode_header(&bytes[..36]).unwrap(), header());
    assert!(decode_header(&bytes[..35]).is_err());
}

/// `bytes` (an FWF2 frame) with `extra` bytes appended to the body of every section and a
/// section of `kind` with `body` added: a frame as a later server might send it.
fn from_a_later_server(bytes: &[u8], extra: &[u8], kind: u8, body: &[u8]) -> Vec<u8> {
    let mut out = bytes[..37].to_vec();
    out[36] += 1;
    let mut at = 37;
    // The new kind first: decoders must accept any order.
    out.push(kind);
    out.put_u32(body.len() as u32);
    out.extend_from_slice(body);
    while at < bytes.len() {
        let length = u32::from_le_bytes(bytes[at + 1..at + 5].try_into().unwrap()) as usize;
        out.push(bytes[at]);
        out.put_u32((length + extra.len()) as u32);
        out.extend_from_slice(&bytes[at + 5..at + 5 + length]);
        out.extend_from_slice(extra);
        at += 5 + length;
    }
    out
}

#[test]
fn fwf2_skips_sections_and_fields_it_does_not_know() {
    let lip = LipRoughness {
        per_vertex: vec![0.25; 3],
        ..LipRoughness::default()
    };
    let deltas = [[0.0, 1.0, 0.0], [0.0; 3], [2.0, 0.0, 0.0]];
    let heat = [0.5, 1.0, 0.0];
    let tongue = [[1.0, 0.0, 0.0]];
    for deflate in [false, true] {
        let today = encode(
            FrameLayout::Fwf2,
            &FrameContent {
                label: Some("ka"),
                heat: Some(&heat),
                head: Some(QUARTER_YAW),
                jaw: Some(OPEN_JAW),
                tongue: Some((2, &tongue)),
                folds: Some(FOLDS),
                ..content(&deltas, &lip, deflate)
            },
        );
        let later = from_a_later_server(&today, &[9, 9, 9], 200, &[1, 2, 3, 4]);
        assert_eq!(decode(&later).unwrap(), decode(&today).unwrap());
    }
}

#[test]
fn fwf2_refuses_malformed_sections_by_name() {
    let lip = LipRoughness::default();
    let bytes = encode(FrameLayout::Fwf2, &content(&[[1.0, 0.0, 0.0]], &lip, false));
    let field = |bytes: &[u8]| decode(bytes).unwrap_err().field();
    // A section running past the message.
    let mut overrun = bytes.clone();
    overrun[38] = 200;
    assert_eq!(field(&overrun), Some("section"));
    // One more section announced than there is.
    let mut count = bytes.clone();
    count[36] = 3;
    assert_eq!(field(&count), Some("section"));
    let mut trailing = bytes.clone();
    trailing.push(0);
    assert_eq!(decode(&trailing), Err(DecodeError::Trailing { extra: 1 }));
    // The lip section given twice.
    let lip_section = bytes[bytes.len() - 18..].to_vec();
    let mut twice = bytes.clone();
    twice[36] = 3;
    twice.extend_from_slice(&lip_section);
    assert_eq!(field(&twice), Some("lip_roughness"));
    // No deltas section: only the lip section left.
    let mut missing = bytes[..37].to_vec();
    missing[36] = 1;
    missing.extend_from_slice(&lip_section);
    assert_eq!(field(&missing), Some("deltas"));
    // An encoding that is neither plain nor deflate.
    let mut encoding = bytes.clone();
    encoding[54] = 2;
    assert_eq!(field(&encoding), Some("encoding"));
    // A deltas section cut inside its fields.
    let mut short = bytes[..37].to_vec();
    short[36] = 2;
    short.extend_from_slice(&[1, 6, 0, 0, 0, 0, 0, 0, 63, 1, 0]);
    short.extend_from_slice(&lip_section);
    assert_eq!(field(&short), Some("vertex_count"));
    // More moved than vertices.
    let mut moved = bytes.clone();
    moved[50..54].copy_from_slice(&5u32.to_le_bytes());
    assert_eq!(field(&moved), Some("moved"));
    // The same part twice.
    let tongue = [[1.0, 0.0, 0.0]];
    let with_part = encode(
        FrameLayout::Fwf2,
        &FrameContent {
            tongue: Some((1, &tongue)),
            ..content(&[[1.0, 0.0, 0.0]], &lip, false)
        },
    );
    let part_section = with_part[bytes.len()..].to_vec();
    assert_eq!(part_section[0], 7);
    let mut part_twice = with_part.clone();
    part_twice[36] += 1;
    part_twice.extend_from_slice(&part_section);
    assert_eq!(field(&part_twice), Some("part_deltas"));
    assert!(matches!(decode(b"FWF3...."), Err(DecodeError::Magic { .. })));
}

#[test]
fn eye_motions_travel_in_fwf2_by_eye_and_fwf1_has_no_place_for_them() {
    let lip = LipRoughness::default();
    let down = RigidMotion {
        rotation: [0.258_819, 0.0, 0.0, 0.965_925_8],
        translation: [0.0, 0.93, -0.25],
    };
    // Given out of order, they decode in eye order.
    let eyes = [
        EyeMotion {
            eye: 1,
            motion: QUARTER_YAW,
        },
        EyeMotion { eye: 0, motion: down },
    ];
    let with_eyes = FrameContent {
        eyes: &eyes,
        ..content(&[[1.0, 0.0, 0.0]], &lip, true)
    };
    let frame = decode(&encode(FrameLayout::Fwf2, &with_eyes)).unwrap();
    assert_eq!(frame.eyes, [eyes[1], eyes[0]]);
    // 34 bytes a turned eye: kind, length, eye, seven floats.
    let without = encode(FrameLayout::Fwf2, &content(&[[1.0, 0.0, 0.0]], &lip, true));
    let bytes = encode(FrameLayout::Fwf2, &with_eyes);
    assert_eq!(bytes.len() - without.len(), 2 * 34);
    assert!(decode(&encode(FrameLayout::Fwf1, &with_eyes))
        .unwrap()
        .eyes
        .is_empty());
    assert!(decode(&without).unwrap().eyes.is_empty());

    // One eye twice, a motion that is not a rotation, a section cut short: refused by name.
    let field = |bytes: &[u8]| decode(bytes).unwrap_err().field();
    let one = encode(
        FrameLayout::Fwf2,
        &FrameContent {
            eyes: &eyes[..1],
            ..content(&[[1.0, 0.0, 0.0]], &lip, true)
        },
    );
    let eye_section = one[without.len()..].to_vec();
    assert_eq!((eye_section[0], eye_section.len()), (9, 34));
    let mut twice = one.clone();
    twice[36] += 1;
    twice.extend_from_slice(&eye_section);
    assert_eq!(field(&twice), Some("eye_motion"));
    let mut stretched = one.clone();
    let w = without.len() + 5 + 1 + 12;
    stretched[w..w + 4].copy_from_slice(&2.0f32.to_le_bytes());
    assert_eq!(field(&stretched), Some("eye motion"));
    let mut short = without.clone();
    short[36] += 1;
    short.extend_from_slice(&[9, 5, 0, 0, 0, 1, 0, 0, 0, 0]);
    assert_eq!(field(&short), Some("eye motion"));
}

#[test]
fn a_frame_s_viseme_goes_in_fwf2_and_a_bad_one_is_named() {
    let lip = LipRoughness::default();
    let viseme = FrameViseme {
        select1: 1,
        select2: 10,
        blend: 40,
    };
    let with = FrameContent {
        viseme: Some(viseme),
        ..content(&[[1.0, 0.0, 0.0]], &lip, true)
    };
    let without = encode(FrameLayout::Fwf2, &content(&[[1.0, 0.0, 0.0]], &lip, true));
    let bytes = encode(FrameLayout::Fwf2, &with);
    // Kind, length, three bytes.
    assert_eq!(bytes.len() - without.len(), 8);
    assert_eq!(decode(&bytes).unwrap().viseme, Some(viseme));
    assert_eq!(decode(&without).unwrap().viseme, None);
    assert_eq!(decode(&encode(FrameLayout::Fwf1, &with)).unwrap().viseme, None);
    let mut out_of_range = bytes.clone();
    let at = without.len() + 5;
    out_of_range[at] = 15;
    assert_eq!(decode(&out_of_range).unwrap_err().field(), Some("viseme"));
    let mut short = bytes.clone();
    short.truncate(bytes.len() - 1);
    short[without.len() + 1] = 2;
    assert_eq!(decode(&short).unwrap_err().field(), Some("viseme"));
}
