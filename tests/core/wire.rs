//! Bytes on the wire: every frame of the syllable stream, deformed on the scan and
//! encoded as a viewer frame, against raw f32 deltas (12 bytes per vertex). The default
//! algorithm is checked; `FACEWIRE_WIRE_ALL=1 cargo test --release --test core wire:: --
//! --nocapture` prints every preset (docs/PERFORMANCE.md).

use crate::common::{data, register};

use std::sync::Arc;

use facewire::animate::{AnimatedHead, FrameJob, FrameTimes, Heat};
use facewire::deform::{bind, AlgoSpec};
use facewire::stream::{open_stream, ArkitBasis};
use facewire_proto::viewer_frame::{decode, FrameLayout};
use glam::Vec3;

/// (mean bytes per frame, worst quantization error in mm) over the syllable stream, as
/// the service's per-frame job encodes it.
fn measure(head: &Arc<AnimatedHead>, spec: &AlgoSpec) -> (f64, f32) {
    let reg = &head.registration;
    let frames: Vec<_> = open_stream(&data("streams/syllables.jsonl"), &reg.fitted.mask)
        .unwrap()
        .map(Result::unwrap)
        .collect();
    let binding = Arc::new(bind(reg, spec));
    let mut job = FrameJob::new(head.clone(), binding, Arc::new(ArkitBasis::shipped()), Heat::None).unwrap();
    let rest: Vec<f32> = reg.head.positions.iter().flat_map(|p| p.to_array()).collect();
    let (mut bytes, mut worst) = (0usize, 0.0f32);
    let mut decoded = Vec::new();
    for frame in &frames {
        let deformed = job.deform(frame).to_vec();
        job.measure(frame).unwrap();
        let encoded = job
            .encode(frame, FrameTimes::default(), FrameLayout::Fwf2)
            .unwrap();
        bytes += encoded.len();
        decode(encoded).unwrap().apply(&rest, &mut decoded);
        for (v, p) in deformed.iter().enumerate() {
            let got = Vec3::from_slice(&decoded[v * 3..v * 3 + 3]);
            worst = worst.max((got - *p).abs().max_element() * reg.mm_per_unit());
        }
    }
    (bytes as f64 / frames.len() as f64, worst)
}

#[test]
fn default_algorithm_frames_are_a_tenth_of_raw_deltas() {
    let head = Arc::new(AnimatedHead::new(register("lee_perry_smith_head")).unwrap());
    let raw = head.registration.vertex_count() as f64 * 12.0;
    let default: AlgoSpec = facewire::server::Config::default()
        .default_algorithm
        .parse()
        .unwrap();
    let mut specs: Vec<AlgoSpec> = AlgoSpec::presets().into_iter().map(|(_, s, _)| s).collect();
    if std::env::var_os("FACEWIRE_WIRE_ALL").is_none() {
        specs = vec![default];
    }
    for spec in specs {
        let (mean, worst) = measure(&head, &spec);
        eprintln!(
            "{:<58} {:>8.0} bytes/frame = {:>5.1} % of raw f32 ({raw:.0}), worst error {worst:.4} mm",
            spec.to_string(),
            mean,
            100.0 * mean / raw
        );
        assert!(worst < 0.05, "{spec}: quantization error {worst} mm");
        if spec == default {
            assert!(
                mean <= raw / 10.0,
                "{spec}: {mean} bytes per frame against {raw} raw"
            );
        }
    }
}

#[test]
fn a_turning_head_compresses_like_a_still_one() {
    let head = Arc::new(AnimatedHead::new(register("lee_perry_smith_head")).unwrap());
    let reg = &head.registration;
    let spec: AlgoSpec = facewire::server::config::DEFAULT_ALGORITHM.parse().unwrap();
    let binding = Arc::new(bind(reg, &spec));
    let basis = Arc::new(ArkitBasis::shipped());
    let mut still = FrameJob::new(head.clone(), binding.clone(), basis.clone(), Heat::None).unwrap();
    let mut turning = FrameJob::new(head.clone(), binding, basis, Heat::None).unwrap();
    let rest: Vec<f32> = reg.head.positions.iter().flat_map(|p| p.to_array()).collect();
    let mut placed = Vec::new();
    let frames = open_stream(&data("streams/syllables.jsonl"), &reg.fitted.mask).unwrap();
    for frame in frames.map(Result::unwrap) {
        let t = frame.time_s as f32;
        let moving = facewire::stream::Frame {
            head_rotation_rad: Some([0.1 * (2.0 * t).sin(), 0.4 * t.sin(), 0.05]),
            head_translation: Some([0.0, 0.02 * t.cos(), 0.0]),
            ..frame.clone()
        };
        still.deform(&frame);
        still.measure(&frame).unwrap();
        let deformed = turning.deform(&moving).to_vec();
        turning.measure(&moving).unwrap();
        let motion = turning.head_motion();
        // The same deltas, byte for byte; 28 bytes of motion beside them (and, in FWF2, its
        // section's kind and length).
        for (layout, section) in [(FrameLayout::Fwf1, 0), (FrameLayout::Fwf2, 5)] {
            let still_bytes = still.encode(&frame, FrameTimes::default(), layout).unwrap().len();
            let turning_bytes = turning.encode(&moving, FrameTimes::default(), layout).unwrap();
            assert_eq!(
                turning_bytes.len(),
                still_bytes + 28 + section,
                "frame {}",
                frame.seq
            );
        }
        let still_bytes = still
            .encode(&frame, FrameTimes::default(), FrameLayout::Fwf2)
            .unwrap()
            .to_vec();
        let turning_bytes = turning
            .encode(&moving, FrameTimes::default(), FrameLayout::Fwf2)
            .unwrap();
        let decoded = decode(turning_bytes).unwrap();
        assert_eq!(
            decoded.moved,
            decode(&still_bytes).unwrap().moved,
            "frame {}",
            frame.seq
        );
        decoded.place(&rest, &mut placed);
        for (v, p) in deformed.iter().enumerate() {
            let error = Vec3::from_slice(&placed[v * 3..v * 3 + 3]).distance(motion.apply(*p));
            assert!(
                error * reg.mm_per_unit() < 0.07,
                "frame {} vertex {v}: {error}",
                frame.seq
            );
        }
    }
}

/// A moved-vertex digest (proto/fixtures/README.md): count, sums, first and last entries.
fn moved_digest(moved: &[(u32, [i32; 3])]) -> serde_json::Value {
    let entry = |m: &(u32, [i32; 3])| serde_json::json!([m.0, m.1[0], m.1[1], m.1[2]]);
    let sum = |k: usize, f: fn(i64) -> i64| moved.iter().map(|m| f(i64::from(m.1[k]))).sum::<i64>();
    serde_json::json!({
        "count": moved.len(),
        "index_sum": moved.iter().map(|m| u64::from(m.0)).sum::<u64>(),
        "sum": ([0, 1, 2].map(|k| sum(k, |x| x))),
        "abs_sum": ([0, 1, 2].map(|k| sum(k, i64::abs))),
        "first": moved.first().map(entry),
        "last": moved.last().map(entry),
    })
}

/// A frame's digest as proto/fixtures/README.md defines it.
fn digest(frame: &facewire_proto::viewer_frame::ViewerFrame) -> serde_json::Value {
    let wide = |xs: &[f32]| xs.iter().map(|&x| f64::from(x)).collect::<Vec<_>>();
    let motion = |m: &facewire_proto::viewer_frame::RigidMotion| serde_json::json!({"rotation": wide(&m.rotation), "translation": wide(&m.translation)});
    let heat = frame.heat.as_ref().map(|values| {
        let max = values.iter().copied().fold(0.0f32, f32::max);
        let bytes: Vec<u64> = values
            .iter()
            .map(|&v| {
                if max > 0.0 {
                    (v / max * 255.0).round() as u64
                } else {
                    0
                }
            })
            .collect();
        serde_json::json!({
            "count": values.len(),
            "max": f64::from(max),
            "byte_sum": bytes.iter().sum::<u64>(),
            "weighted_byte_sum": bytes.iter().enumerate().map(|(i, b)| i as u64 * b).sum::<u64>(),
        })
    });
    let h = frame.header;
    serde_json::json!({
        "seq": h.seq,
        "t": h.producer_time_s,
        "server_receive_us": h.server_receive_us,
        "server_send_us": h.server_send_us,
        "step": f64::from(frame.step),
        "vertex_count": frame.vertex_count,
        "moved": moved_digest(&frame.moved),
        "lip": {
            "min": f64::from(frame.lip.min),
            "max": f64::from(frame.lip.max),
            "mean": f64::from(frame.lip.mean),
            "per_vertex": wide(&frame.lip.per_vertex),
        },
        "label": frame.label,
        "head": motion(&frame.head),
        "jaw": motion(&frame.jaw),
        "folds": frame.folds.map(|f| serde_json::json!({
            "turned_over_60": f.turned_over_60,
            "turned_over_90": f.turned_over_90,
            "max_dihedral_increase_deg": f64::from(f.max_dihedral_increase_deg),
        })),
        "parts": frame.parts.iter().map(|p| serde_json::json!({
            "part": p.part,
            "vertex_count": p.vertex_count,
            "moved": moved_digest(&p.moved),
        })).collect::<Vec<_>>(),
        "heat": heat,
    })
}

#[test]
fn every_captured_frame_decodes_to_its_digest() {
    // Frames captured from the server in every layout it has sent (proto/fixtures/): a
    // decoder must keep reading them, FWF2's including one from a "later server" with a
    // section kind and section fields no decoder knows.
    let fixtures = crate::common::repo_path("proto/fixtures");
    let mut checked = Vec::new();
    for layout in ["fwf1", "fwf2"] {
        let dir = fixtures.join(layout);
        let expected: serde_json::Map<String, serde_json::Value> =
            serde_json::from_slice(&std::fs::read(dir.join("expected.json")).unwrap()).unwrap();
        assert!(expected.len() >= 9, "{layout}: {} frames", expected.len());
        for (file, want) in &expected {
            let bytes = std::fs::read(dir.join(file)).unwrap();
            let frame = decode(&bytes).unwrap_or_else(|e| panic!("{layout}/{file}: {e}"));
            assert_eq!(frame.layout.name(), layout, "{file}");
            assert_eq!(&digest(&frame), want, "{layout}/{file}");
        }
        checked.push((layout, expected.len()));
    }
    eprintln!("fixtures decoded: {checked:?}");
}
