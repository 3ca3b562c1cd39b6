//! Bytes on the wire: every frame of the syllable stream, deformed on the scan and
//! encoded as a viewer frame, against raw f32 deltas (12 bytes per vertex). The default
//! algorithm is checked; `FACEWIRE_WIRE_ALL=1 cargo test --release --test wire --
//! --nocapture` prints every preset (docs/PERFORMANCE.md).

mod common;

use common::{data, register};

use std::sync::Arc;

use facewire::animate::{AnimatedHead, FrameJob, FrameTimes, Heat};
use facewire::deform::{bind, AlgoSpec};
use facewire::stream::{open_stream, ArkitBasis};
use facewire_proto::frame::decode;
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
        let encoded = job.encode(frame, FrameTimes::default()).unwrap();
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
        let still_bytes = still.encode(&frame, FrameTimes::default()).unwrap().to_vec();
        let deformed = turning.deform(&moving).to_vec();
        let motion = turning.head_motion();
        let turning_bytes = turning.encode(&moving, FrameTimes::default()).unwrap();
        // The same deltas, byte for byte; 28 bytes of motion beside them.
        assert_eq!(turning_bytes.len(), still_bytes.len() + 28, "frame {}", frame.seq);
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
