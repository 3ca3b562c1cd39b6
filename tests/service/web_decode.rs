//! The browser's decoder (`web/decode.js`) against the server's own encoder: frames encoded
//! by `facewire_proto::viewer_frame::FrameEncoder` in both layouts, FWF2 and the frozen FWF1
//! (with and without label, heat values, head
//! and jaw motion, tongue deltas, lip folds and deflate; negative and large deltas;
//! malformed ones) and a `mesh.bin`, written with the values the Rust decoder reads from
//! them to a JSON file that `node web/decode.test.mjs` checks; the page's node list
//! (`node web/nodes.test.mjs`), its fit report (`node web/fit.test.mjs`) and a view's look
//! (`node web/look.test.mjs`), a head's registration from the page (`node
//! web/upload.test.mjs`), the voice's jitter buffer (`node web/playout.test.mjs`), its
//! wait for the face (`node web/sound.test.mjs`), a view's socket off the main thread
//! (`node web/socket-pump.test.mjs`) and the pixels drawn while the voice plays (`node
//! web/draw-scale.test.mjs`).

use crate::common::repo_path;

use std::process::Command;

use facewire_proto::audio_chunk::{AudioBody, AudioChunk};
use facewire_proto::texture_coords::TextureCoords;
use facewire_proto::vertex_weights::VertexWeights;
use facewire_proto::viewer_frame::{
    decode, EyeMotion, FrameContent, FrameEncoder, FrameHeader, FrameLayout, FrameViseme, LipFolds,
    LipRoughness, RigidMotion,
};
use facewire_proto::DecodeError;
use serde_json::{json, Value};

/// f32 values travel as their exact f64, so the script compares with `===`.
fn exact(values: &[f32]) -> Vec<f64> {
    values.iter().map(|&x| f64::from(x)).collect()
}

struct Case<'a> {
    name: &'a str,
    header: FrameHeader,
    step: f32,
    deltas: Vec<[f32; 3]>,
    lip: LipRoughness,
    label: Option<&'a str>,
    face: Option<Vec<f32>>,
    head: Option<RigidMotion>,
    jaw: Option<RigidMotion>,
    /// The tongue's part index and its deltas.
    tongue: Option<(u8, Vec<[f32; 3]>)>,
    folds: Option<LipFolds>,
    /// Turned eyeballs (FWF2 carries them, FWF1 cannot).
    eyes: Vec<EyeMotion>,
    /// The frame's viseme (FWF2 only).
    viseme: Option<FrameViseme>,
}

fn frame_case(
    encoder: &mut FrameEncoder,
    case: &Case,
    layout: FrameLayout,
    deflate: bool,
) -> (Vec<u8>, Value) {
    let bytes = encoder
        .encode(
            layout,
            &case.header,
            &FrameContent {
                step: case.step,
                deltas: &case.deltas,
                lip: &case.lip,
                label: case.label,
                heat: case.face.as_deref(),
                deflate,
                head: case.head,
                jaw: case.jaw,
                tongue: case.tongue.as_ref().map(|(p, d)| (*p, d.as_slice())),
                folds: case.folds,
                eyes: &case.eyes,
                viseme: case.viseme,
            },
        )
        .to_vec();
    let frame = decode(&bytes).expect("the Rust decoder reads its own frames");
    let rest: Vec<f32> = (0..case.deltas.len() * 3)
        .map(|i| i as f32 * 0.37 - 5.0)
        .collect();
    let (mut positions, mut placed) = (Vec::new(), Vec::new());
    frame.apply(&rest, &mut positions);
    frame.place(&rest, &mut placed);
    // The tongue as a client draws it: rest + counts x step (in f32, as `apply`), then the
    // jaw's motion, then the head's.
    let tongue = frame.parts.first();
    let tongue_rest: Vec<f32> = (0..tongue.map_or(0, |t| t.vertex_count as usize * 3))
        .map(|i| 2.0 - i as f32 * 0.21)
        .collect();
    let mut tongue_positions = tongue_rest.clone();
    if let Some(t) = tongue {
        for &(v, q) in &t.moved {
            for k in 0..3 {
                tongue_positions[v as usize * 3 + k] += q[k] as f32 * t.step;
            }
        }
    }
    let tongue_placed: Vec<f32> = tongue_positions
        .chunks_exact(3)
        .flat_map(|p| frame.head.apply(frame.jaw.apply([p[0], p[1], p[2]])))
        .collect();
    let h = frame.header;
    let value = json!({
        "name": format!("{} ({}){}", case.name, layout.name(), if deflate { ", deflated" } else { "" }),
        "bytes": bytes,
        "header": {
            "seq": h.seq,
            "producerTimeS": h.producer_time_s,
            "serverReceiveUs": h.server_receive_us,
            "serverSendUs": h.server_send_us,
            "step": f64::from(frame.step),
            "vertexCount": frame.vertex_count,
            "moved": frame.moved.len(),
            "lip": {
                "min": f64::from(frame.lip.min),
                "max": f64::from(frame.lip.max),
                "mean": f64::from(frame.lip.mean),
            },
        },
        "lipPerVertex": exact(&frame.lip.per_vertex),
        "label": frame.label,
        "movedIndices": frame.moved.iter().map(|m| m.0).collect::<Vec<_>>(),
        "movedCounts": frame.moved.iter().flat_map(|m| m.1).collect::<Vec<_>>(),
        "face": frame.heat.as_deref().map(exact),
        "head": {
            "rotation": exact(&frame.head.rotation),
            "translation": exact(&frame.head.translation),
        },
        "jaw": {
            "rotation": exact(&frame.jaw.rotation),
            "translation": exact(&frame.jaw.translation),
        },
        "tongue": tongue.map(|t| json!({
            "part": t.part,
            "vertexCount": t.vertex_count,
            "movedIndices": t.moved.iter().map(|m| m.0).collect::<Vec<_>>(),
            "movedCounts": t.moved.iter().flat_map(|m| m.1).collect::<Vec<_>>(),
        })),
        "eyes": frame.eyes.iter().map(|e| json!({
            "eye": e.eye,
            "motion": {
                "rotation": exact(&e.motion.rotation),
                "translation": exact(&e.motion.translation),
            },
        })).collect::<Vec<_>>(),
        "viseme": frame.viseme.map(|v| json!({
            "select1": v.select1,
            "select2": v.select2,
            "blend": v.blend,
        })),
        "folds": frame.folds.map(|f| json!({
            "turnedOver60": f.turned_over_60,
            "turnedOver90": f.turned_over_90,
            "maxDihedralIncreaseDeg": f64::from(f.max_dihedral_increase_deg),
        })),
        "tongueRest": exact(&tongue_rest),
        "tonguePositions": exact(&tongue_positions),
        "tonguePlaced": exact(&tongue_placed),
        "rest": exact(&rest),
        "positions": exact(&positions),
        "placed": exact(&placed),
    });
    (bytes, value)
}

/// The field the Rust decoder names, as decode.js names it (`end` for trailing bytes).
fn failing_field(error: DecodeError) -> &'static str {
    match error {
        DecodeError::Truncated { field, .. } | DecodeError::Invalid { field, .. } => field,
        DecodeError::Magic { .. } => "magic",
        DecodeError::Trailing { .. } => "end",
    }
}

fn malformed(name: &str, bytes: Vec<u8>) -> Value {
    let error = decode(&bytes).expect_err("malformed on purpose");
    json!({ "name": name, "bytes": bytes, "field": failing_field(error) })
}

/// An FWF2 frame with turned eyes (`good`) with one eye given twice, and with an eye's
/// rotation that is not a unit quaternion.
fn fwf2_bad_eyes(good: &[u8]) -> Vec<Value> {
    let mut at = 37;
    let mut eye_at = None;
    while at < good.len() {
        let length = u32::from_le_bytes(good[at + 1..at + 5].try_into().unwrap()) as usize;
        if good[at] == 9 && eye_at.is_none() {
            eye_at = Some((at, length));
        }
        at += 5 + length;
    }
    let (eye_at, length) = eye_at.expect("the case turns its eyes");
    let mut twice = good.to_vec();
    twice[36] += 1;
    twice.extend_from_slice(&good[eye_at..eye_at + 5 + length]);
    let mut stretched = good.to_vec();
    stretched[eye_at + 6..eye_at + 10].copy_from_slice(&2.0f32.to_le_bytes());
    vec![
        malformed("FWF2 eye_motion twice for one eye", twice),
        malformed("FWF2 eye rotation not a unit quaternion", stretched),
    ]
}

/// FWF2 frames broken in their framing (`good` is a frame with a label and heat values):
/// the field names must be the Rust decoder's.
fn fwf2_malformed(good: &[u8]) -> Vec<Value> {
    assert_eq!(&good[..4], b"FWF2");
    // The sections: (start, kind, length).
    let mut sections = Vec::new();
    let mut at = 37;
    while at < good.len() {
        let length = u32::from_le_bytes(good[at + 1..at + 5].try_into().unwrap()) as usize;
        sections.push((at, good[at], length));
        at += 5 + length;
    }
    let (lip_at, _, lip_length) = *sections.iter().find(|s| s.1 == 2).expect("lip section");
    let lip_section = good[lip_at..lip_at + 5 + lip_length].to_vec();
    let mut twice = good.to_vec();
    twice[36] += 1;
    twice.extend_from_slice(&lip_section);
    let mut overrun = good.to_vec();
    overrun[38..42].copy_from_slice(&u32::MAX.to_le_bytes());
    let mut one_more = good.to_vec();
    one_more[36] += 1;
    let mut encoding = good.to_vec();
    encoding[37 + 5 + 12] = 7;
    let mut no_deltas = good[..37].to_vec();
    no_deltas[36] = 1;
    no_deltas.extend_from_slice(&lip_section);
    vec![
        malformed("FWF2 lip_roughness twice", twice),
        malformed("FWF2 section past the message", overrun),
        malformed("FWF2 one section more than there is", one_more),
        malformed("FWF2 unknown delta encoding", encoding),
        malformed("FWF2 without deltas", no_deltas),
        malformed("FWF2 cut inside the header", good[..30].to_vec()),
    ]
}

/// A `mesh.bin` as the registry writes it (PROTOCOL.md): two triangles.
fn mesh_bin(positions: &[[f32; 3]], triangles: &[[u32; 3]], mm_per_unit: f32) -> Vec<u8> {
    let mut out = b"FWM1".to_vec();
    out.extend_from_slice(&(positions.len() as u32).to_le_bytes());
    out.extend_from_slice(&(triangles.len() as u32).to_le_bytes());
    out.extend_from_slice(&mm_per_unit.to_le_bytes());
    for x in positions.iter().flatten() {
        out.extend_from_slice(&x.to_le_bytes());
    }
    for v in triangles.iter().flatten() {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

fn cases() -> Value {
    let header = |seq: u64| FrameHeader {
        seq,
        producer_time_s: seq as f64 / 30.0 + 0.1,
        server_receive_us: 1_750_000_000_123_456 + seq * 33_333,
        server_send_us: 1_750_000_000_125_001 + seq * 33_333,
    };
    let lip = LipRoughness {
        min: 0.01,
        max: 0.63,
        mean: 0.057,
        per_vertex: (0..18).map(|i| 0.02 + i as f32 * 0.003).collect(),
    };
    let mut deltas = vec![[0.0f32; 3]; 300];
    deltas[0] = [0.001, -0.002, 0.0];
    deltas[2] = [-0.25, 0.125, -0.0005];
    deltas[3] = [0.0003, 0.0, 0.0]; // under half a step: not sent
    deltas[130] = [1.5, -2.75, 0.01]; // a gap over 127: a two-byte index varint
    deltas[299] = [-0.02, 0.0, 0.02];
    let face: Vec<f32> = (0..300).map(|v| (v % 17) as f32 * 0.011).collect();
    // 0.7 rad about (1, 2, 2) / 3, and a shift.
    let (sin, cos) = (0.35f32.sin(), 0.35f32.cos());
    let turn = RigidMotion {
        rotation: [sin / 3.0, 2.0 * sin / 3.0, 2.0 * sin / 3.0, cos],
        translation: [0.5, -12.0, 3.25],
    };
    // The tongue (part 3, 200 vertices): some still, some moved, one under half a step.
    let mut tongue_deltas = vec![[0.0f32; 3]; 200];
    tongue_deltas[0] = [0.003, 0.0, -0.004];
    tongue_deltas[1] = [0.0002, -0.0001, 0.0]; // under half a step: not sent
    tongue_deltas[5] = [-0.12, 0.25, 0.031];
    tongue_deltas[6] = [-0.11, 0.26, 0.03];
    tongue_deltas[150] = [0.0, 0.0, 0.5]; // a gap over 127
    tongue_deltas[199] = [0.01, -0.02, 0.0];
    // A jaw opened 0.4 rad about x, and slid.
    let open = RigidMotion {
        rotation: [0.2f32.sin(), 0.0, 0.0, 0.2f32.cos()],
        translation: [0.0, -0.75, 0.5],
    };
    let cases = [
        Case {
            name: "plain",
            header: header(1),
            step: 0.001,
            deltas: deltas.clone(),
            lip: lip.clone(),
            label: None,
            face: None,
            head: None,
            jaw: None,
            tongue: None,
            folds: None,
            eyes: Vec::new(),
            viseme: None,
        },
        Case {
            name: "label and face roughness",
            header: header(2),
            step: 0.001,
            deltas: deltas.clone(),
            lip: lip.clone(),
            label: Some("pa"),
            face: Some(face.clone()),
            head: None,
            jaw: None,
            tongue: None,
            folds: None,
            eyes: Vec::new(),
            viseme: None,
        },
        Case {
            name: "large deltas, a multi-byte label, flat face",
            header: FrameHeader {
                seq: 1 << 40,
                ..header(3)
            },
            step: 0.5,
            deltas: vec![
                [1.0e9, -1.07e9, 3.0],
                [0.0; 3],
                [-64.0, 64.0, -0.5],
                [1.0e6, 0.0, -1.0e6],
            ],
            lip: LipRoughness::default(),
            label: Some("ʃa"),
            face: Some(vec![0.0; 4]),
            head: None,
            jaw: None,
            tongue: None,
            folds: None,
            eyes: Vec::new(),
            viseme: None,
        },
        Case {
            name: "nothing moved, lip folds of a gentle bend",
            header: header(4),
            step: 0.002,
            deltas: vec![[0.0; 3]; 50],
            lip: lip.clone(),
            label: Some("rest"),
            face: None,
            head: None,
            jaw: None,
            tongue: None,
            folds: Some(LipFolds {
                turned_over_60: 0,
                turned_over_90: 0,
                max_dihedral_increase_deg: 4.1,
            }),
            eyes: Vec::new(),
            viseme: None,
        },
        Case {
            name: "every vertex moved",
            header: header(5),
            step: 0.001,
            deltas: (0..300)
                .map(|v| [v as f32 * 0.001, (v as f32 * 0.1).sin() * 0.05, -0.002])
                .collect(),
            lip: lip.clone(),
            label: None,
            face: None,
            head: None,
            jaw: None,
            tongue: None,
            folds: None,
            eyes: Vec::new(),
            viseme: None,
        },
        Case {
            name: "head motion, label and face roughness",
            header: header(6),
            step: 0.001,
            deltas: deltas.clone(),
            lip: lip.clone(),
            label: Some("ta"),
            face: Some(face),
            head: Some(turn),
            jaw: None,
            tongue: None,
            folds: None,
            eyes: Vec::new(),
            viseme: None,
        },
        Case {
            name: "head motion only",
            header: header(7),
            step: 0.001,
            deltas: vec![[0.0; 3]; 20],
            lip: LipRoughness::default(),
            label: None,
            face: None,
            head: Some(turn),
            jaw: Some(open),
            tongue: None,
            folds: None,
            eyes: Vec::new(),
            viseme: None,
        },
        Case {
            name: "tongue shaped, head and jaw motion, lip folds, label and face roughness",
            header: header(8),
            step: 0.001,
            deltas: deltas.clone(),
            lip: lip.clone(),
            label: Some("ta"),
            face: Some((0..300).map(|v| (v % 5) as f32 * 0.02).collect()),
            head: Some(turn),
            jaw: Some(open),
            tongue: Some((3, tongue_deltas)),
            // Counts past i16 and u8 (a signed or one-byte read shows), an inexact f32.
            folds: Some(LipFolds {
                turned_over_60: 40_000,
                turned_over_90: 300,
                max_dihedral_increase_deg: 148.83,
            }),
            eyes: vec![
                EyeMotion { eye: 1, motion: turn },
                EyeMotion { eye: 0, motion: open },
            ],
            viseme: Some(FrameViseme {
                select1: 1,
                select2: 14,
                blend: 40,
            }),
        },
        Case {
            name: "tongue sent with nothing moved",
            header: header(9),
            step: 0.001,
            deltas: vec![[0.0; 3]; 20],
            lip: LipRoughness::default(),
            label: None,
            face: None,
            head: None,
            jaw: Some(open),
            tongue: Some((0, vec![[0.0; 3]; 12])),
            folds: None,
            eyes: Vec::new(),
            viseme: None,
        },
    ];
    let mut encoder = FrameEncoder::default();
    let mut frames = Vec::new();
    let mut encoded = Vec::new();
    // FWF1 first: the malformed cases below edit these by their frozen offsets.
    for layout in [FrameLayout::Fwf1, FrameLayout::Fwf2] {
        for case in &cases {
            for deflate in [false, true] {
                let (bytes, value) = frame_case(&mut encoder, case, layout, deflate);
                frames.push(value);
                encoded.push(bytes);
            }
        }
    }
    let fwf2_good = encoded[encoded.len() / 2 + 2].clone();
    let (plain, deflated) = (&encoded[0], &encoded[1]);
    let (good, good_deflated) = (&encoded[2], &encoded[3]);
    let mut bad_magic = good.clone();
    bad_magic[0] = b'X';
    let mut trailing = good.clone();
    trailing.push(0);
    let mut huge_moved = good.clone();
    huge_moved[48..52].copy_from_slice(&u32::MAX.to_le_bytes());
    // The head-motion case with label: its motion follows the label "ta".
    let with_head = &encoded[10];
    let head_at = 65 + 18 * 4 + 3;
    let mut long_quaternion = with_head.clone();
    long_quaternion[head_at + 12..head_at + 16].copy_from_slice(&2.0f32.to_le_bytes());
    let mut nan_translation = with_head.clone();
    nan_translation[head_at + 16..head_at + 20].copy_from_slice(&f32::NAN.to_le_bytes());
    // The last case carries head and jaw motion; no lip values, no label.
    let with_jaw = &encoded[12];
    let mut long_jaw = with_jaw.clone();
    long_jaw[65 + 28..65 + 32].copy_from_slice(&3.0f32.to_le_bytes());
    let mut bad_label = good.clone();
    let label_at = 65 + 18 * 4 + 1;
    bad_label[label_at] = 0xff;
    // The first two cases have no label or face: the delta block ends the frame.
    let block_length_at = 65 + 18 * 4;
    let with_block = |frame: &[u8], block: &[u8], extra_flags: u8| {
        let mut out = frame[..block_length_at].to_vec();
        out[4] |= extra_flags;
        out.extend_from_slice(&(block.len() as u32).to_le_bytes());
        out.extend_from_slice(block);
        out
    };
    let deflated_block = &deflated[block_length_at + 4..];
    let plain_block = &plain[block_length_at + 4..];
    let mut corrupt_block = deflated_block.to_vec();
    corrupt_block[0] ^= 0xc0; // a reserved block type
    let mut extra_entry = plain_block.to_vec();
    extra_entry.extend_from_slice(&[0, 0, 0, 0]);
    // The tongue case (plain): 18 lip values, the label "ta", head and jaw motion, lip
    // folds, then the head's delta block; the tongue's fields follow it.
    let with_tongue = &encoded[14];
    let folds_at = 65 + 18 * 4 + 3 + 2 * 28;
    assert_eq!(with_tongue[4] & 64, 64, "the tongue case has lip folds");
    assert_eq!(with_tongue[folds_at..folds_at + 2], 40_000u16.to_le_bytes());
    let mut nan_folds = with_tongue.clone();
    nan_folds[folds_at + 4..folds_at + 8].copy_from_slice(&f32::NAN.to_le_bytes());
    let mut negative_folds = with_tongue.clone();
    negative_folds[folds_at + 4..folds_at + 8].copy_from_slice(&(-1.5f32).to_le_bytes());
    let head_block_at = folds_at + 8;
    let head_block_length =
        u32::from_le_bytes(with_tongue[head_block_at..head_block_at + 4].try_into().unwrap());
    let tongue_at = head_block_at + 4 + head_block_length as usize;
    assert_eq!(with_tongue[tongue_at], 3, "the tongue's part index");
    let mut tongue_overmoved = with_tongue.clone();
    tongue_overmoved[tongue_at + 5..tongue_at + 9].copy_from_slice(&201u32.to_le_bytes());
    // Five entries of vertices up to 199, said to be of a 100-vertex part.
    let mut tongue_short_part = with_tongue.clone();
    tongue_short_part[tongue_at + 1..tongue_at + 5].copy_from_slice(&100u32.to_le_bytes());
    let mut tongue_flag_only = plain.clone();
    tongue_flag_only[4] |= 32;
    // Claims one entry (40 bytes at most) but inflates to 300 entries.
    let mut bomb = encoded[9].clone(); // every vertex moved, deflated
    bomb[48..52].copy_from_slice(&1u32.to_le_bytes());
    let folds_frames = [
        malformed("truncated lip folds", with_tongue[..folds_at + 5].to_vec()),
        malformed("lip folds' largest increase NaN", nan_folds),
        malformed("lip folds' largest increase negative", negative_folds),
    ];
    for case in &folds_frames {
        assert_eq!(case["field"], "lip folds", "{}", case["name"]);
    }
    let mut malformed_frames = vec![
        malformed("truncated header", good[..10].to_vec()),
        malformed("truncated deltas", good[..good.len() - 310].to_vec()),
        malformed("truncated face roughness", good[..good.len() - 1].to_vec()),
        malformed("bad magic", bad_magic),
        malformed("trailing byte", trailing),
        malformed("moved count larger than the message", huge_moved),
        malformed("label not UTF-8", bad_label),
        malformed("head rotation not a unit quaternion", long_quaternion),
        malformed("head translation not finite", nan_translation),
        malformed("truncated head motion", with_head[..head_at + 10].to_vec()),
        malformed("jaw rotation not a unit quaternion", long_jaw),
        malformed(
            "truncated deflated face roughness",
            good_deflated[..good_deflated.len() - 1].to_vec(),
        ),
        malformed(
            "truncated deflate stream",
            with_block(deflated, &deflated_block[..deflated_block.len() - 3], 0),
        ),
        malformed("corrupt deflate stream", with_block(deflated, &corrupt_block, 0)),
        malformed("inflates past its entry count", bomb),
        malformed(
            "bytes left in the delta block",
            with_block(plain, &extra_entry, 0),
        ),
        malformed("tongue moved more than its vertices", tongue_overmoved),
        malformed("tongue vertex past its part's vertices", tongue_short_part),
        malformed("tongue flag without a tongue", tongue_flag_only),
        malformed(
            "truncated tongue vertex_count",
            with_tongue[..tongue_at + 3].to_vec(),
        ),
        malformed(
            "truncated tongue delta block",
            with_tongue[..tongue_at + 20].to_vec(),
        ),
    ];
    malformed_frames.extend(folds_frames);
    malformed_frames.extend(fwf2_malformed(&fwf2_good));
    malformed_frames.extend(fwf2_bad_eyes(&encoded[encoded.len() / 2 + 14]));

    let positions = [
        [0.0, 0.0, 0.0],
        [1.5, -2.0, 0.25],
        [0.0, 1.0, -3.0],
        [7.0, 8.0, 9.0],
    ];
    let triangles = [[0, 1, 2], [2, 1, 3]];
    let mesh = mesh_bin(&positions, &triangles, 50.3);
    let out_of_range = mesh_bin(&positions, &[[0, 1, 4]], 50.3);
    let short = mesh[..mesh.len() - 4].to_vec();
    let lips = VertexWeights {
        weights: vec![0, 1, 128, 255],
    };
    // Three coordinates for two triangles, a seam: vertex 1 has two.
    let uv = TextureCoords {
        coords: vec![[0.0, 0.0], [1.0, 0.25], [0.5, 1.0]],
        corners: vec![[0, 1, 2], [2, 1, 0]],
    };
    json!({
        "frames": frames,
        "malformedFrames": malformed_frames,
        "audio": audio_cases(),
        "malformedAudio": malformed_audio(),
        "mesh": {
            "bytes": mesh,
            "expected": {
                "vertexCount": 4,
                "triangleCount": 2,
                "mmPerUnit": f64::from(50.3f32),
                "positions": exact(&positions.concat()),
                "indices": triangles.concat(),
            },
        },
        "malformedMeshes": [
            { "name": "short", "bytes": short, "field": "length" },
            { "name": "vertex out of range", "bytes": out_of_range, "field": "triangles" },
            { "name": "frame, not mesh", "bytes": good, "field": "magic" },
        ],
        "lipTint": {
            "bytes": lips.encode(),
            "vertexCount": 4,
            "expected": lips.weights.iter().map(|&w| f64::from(f32::from(w) / 255.0)).collect::<Vec<_>>(),
        },
        "malformedLipTints": [
            { "name": "short", "bytes": lips.encode()[..10].to_vec(), "field": "vertex count" },
            { "name": "another mesh's", "bytes": VertexWeights { weights: vec![0; 5] }.encode(), "field": "vertex count" },
            { "name": "mesh, not lips", "bytes": mesh, "field": "magic" },
        ],
        "textureCoords": {
            "bytes": uv.encode(),
            "triangleCount": 2,
            "coords": exact(&uv.coords.concat()),
            "corners": uv.corners.concat(),
        },
        "malformedTextureCoords": [
            { "name": "short", "bytes": uv.encode()[..20].to_vec(), "field": "coordinate count" },
            { "name": "another mesh's", "bytes": TextureCoords { corners: vec![[0, 1, 2]], ..uv.clone() }.encode(), "field": "triangle count" },
            { "name": "a corner past the coordinates", "bytes": TextureCoords { corners: vec![[0, 1, 2], [2, 3, 0]], ..uv.clone() }.encode(), "field": "corners" },
            { "name": "lips, not coordinates", "bytes": lips.encode(), "field": "magic" },
        ],
    })
}

/// Audio chunks from the server's own encoder, with what they hold.
fn audio_cases() -> Vec<Value> {
    let pcm = AudioChunk {
        t_s: 12.34,
        server_receive_us: 1_700_000_000_123_456,
        body: AudioBody::Pcm {
            sample_rate: 24_000,
            samples: vec![0, 1, -1, i16::MAX, i16::MIN, 300],
        },
        ignored: Vec::new(),
    };
    // Configuration 12 (SILK, wideband, 20 ms), one frame, then the packet's payload.
    let opus = AudioChunk {
        t_s: 0.02,
        server_receive_us: 5,
        body: AudioBody::Opus {
            packet: vec![12 << 3, 0xde, 0xad, 0xbe, 0xef],
        },
        ignored: Vec::new(),
    };
    let mut grown = pcm.encode();
    // A section of a kind from a later server, after the sound: skipped.
    grown[20] += 1;
    grown.extend_from_slice(&[9, 2, 0, 0, 0, 7, 7]);
    vec![
        json!({"name": "pcm", "bytes": pcm.encode(), "expected": {
            "t": 12.34, "serverReceiveUs": 1_700_000_000_123_456u64, "codec": "pcm",
            "sampleRate": 24_000, "samples": [0, 1, -1, 32767, -32768, 300]}}),
        json!({"name": "opus", "bytes": opus.encode(), "expected": {
            "t": 0.02, "serverReceiveUs": 5, "codec": "opus", "sampleRate": 48_000,
            "packet": [96, 0xde, 0xad, 0xbe, 0xef]}}),
        json!({"name": "pcm with a later section", "bytes": grown, "expected": {
            "t": 12.34, "codec": "pcm", "samples": [0, 1, -1, 32767, -32768, 300]}}),
    ]
}

/// Audio chunks the Rust decoder refuses, with the field it names.
fn malformed_audio() -> Vec<Value> {
    let good = AudioChunk {
        t_s: 1.0,
        server_receive_us: 0,
        body: AudioBody::Pcm {
            sample_rate: 16_000,
            samples: vec![1, 2, 3],
        },
        ignored: Vec::new(),
    }
    .encode();
    let mut bad_rate = good.clone();
    bad_rate[26..30].copy_from_slice(&44_100u32.to_le_bytes());
    let mut no_sound = good[..21].to_vec();
    no_sound[20] = 0;
    let mut both = good.clone();
    both[20] = 2;
    both.extend_from_slice(&[2, 3, 0, 0, 0, 1, 0, 96]);
    let mut not_finite = good.clone();
    not_finite[4..12].copy_from_slice(&f64::NAN.to_le_bytes());
    let cases = [
        ("truncated", good[..good.len() - 1].to_vec()),
        ("44.1 kHz", bad_rate),
        ("no sound", no_sound),
        ("pcm and opus", both),
        ("t not finite", not_finite),
        ("a frame, not audio", b"FWF2".to_vec()),
    ];
    cases
        .into_iter()
        .map(|(name, bytes)| {
            let error = AudioChunk::decode(&bytes).unwrap_err();
            json!({ "name": name, "bytes": bytes, "field": error.field().unwrap_or("magic") })
        })
        .collect()
}

#[test]
fn decode_js_agrees_with_the_rust_encoder() {
    let dir = tempfile::tempdir().unwrap();
    let cases_path = dir.path().join("cases.json");
    std::fs::write(&cases_path, serde_json::to_vec(&cases()).unwrap()).unwrap();
    let script = repo_path("web/decode.test.mjs");
    let output = match Command::new("node").arg(&script).arg(&cases_path).output() {
        Ok(output) => output,
        Err(e) => panic!("cannot run `node` ({e}): the web decoder test needs Node.js 20 or newer on PATH"),
    };
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        output.status.success(),
        "node {} failed ({}):\n{stdout}{stderr}",
        script.display(),
        output.status
    );
    println!("{stdout}");
}

/// Runs `node` on a test script of `web/` with `args` (paths in the repository), failing
/// with its output.
fn run_node_test(script: &str, args: &[&str]) {
    let script = repo_path(script);
    let args = args.iter().map(|a| repo_path(a));
    let output = match Command::new("node").arg(&script).args(args).output() {
        Ok(output) => output,
        Err(e) => panic!("cannot run `node` ({e}): the web tests need Node.js 20 or newer on PATH"),
    };
    assert!(
        output.status.success(),
        "node {} failed ({}):\n{}{}",
        script.display(),
        output.status,
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
}

#[test]
fn fit_js_shows_the_fit_report() {
    // The head's fit report as the page shows it: paths, numbers, every answer of the endpoint.
    run_node_test("web/fit.test.mjs", &[]);
}

#[test]
fn a_view_s_look_turns_its_camera_and_carries_its_cut_with_the_head() {
    // The side and cut-away looks (render.js, camera.js): camera turns, cut planes in view
    // space, the close-up's side target, hand-computed.
    run_node_test("web/look.test.mjs", &[]);
}

#[test]
fn upload_js_builds_a_head_s_registration() {
    // "Your own head": ids from file names, which files make a head (and the words for
    // those that do not), and the requests as PROTOCOL.md has POST /v1/heads.
    run_node_test("web/upload.test.mjs", &[]);
}

#[test]
fn playout_js_places_the_voice_after_a_delay_that_follows_the_jitter() {
    // The voice's jitter buffer (the page's audio thread): placement after the delay, a
    // late chunk raising it, a quiet one lowering it, 16 kHz interpolated with a smooth
    // seam, a replay's rate, the ring's reach, hand-computed.
    run_node_test("web/playout.test.mjs", &[]);
}

#[test]
fn sound_js_lets_the_voice_wait_for_a_face_drawn_late() {
    // The sound's wait for the face: lengthened by half the frames' lateness above the
    // aim, given back when they are in time, never below nothing.
    run_node_test("web/sound.test.mjs", &[]);
}

#[test]
fn draw_scale_js_draws_fewer_pixels_only_while_that_keeps_the_face_in_time() {
    // The pixels drawn while the voice plays: cut while the draws are slow for their
    // pixels, no further than needed, a cut that does not help undone, raises taken back
    // tried ever more rarely, full resolution without a voice; simulated 60 Hz pages.
    run_node_test("web/draw-scale.test.mjs", &[]);
}

#[test]
fn socket_pump_js_reads_a_view_s_socket_and_feeds_the_voice() {
    // A view's socket off the main thread: text and frames handed on, the voice decoded to
    // the audio thread's port, its timeline started over in order with the chunks.
    run_node_test("web/socket-pump.test.mjs", &["proto/fixtures/fwf2"]);
}

#[test]
fn nodes_js_fails_over_round_robin() {
    // The page's node list (`?nodes=`): parsing, URL building and round-robin failover.
    run_node_test("web/nodes.test.mjs", &[]);
}

#[test]
fn decode_js_reads_every_captured_frame_and_skips_what_it_does_not_know() {
    // The frames captured from the server in every layout (proto/fixtures/) decode to their
    // digests; each FWF1 fixture re-encoded as FWF2, reordered and grown as a later server
    // would send it decodes the same, and broken ones are refused by name.
    run_node_test("web/fixtures.test.mjs", &["proto/fixtures"]);
    run_node_test("web/fwf2.test.mjs", &["proto/fixtures/fwf1"]);
}
