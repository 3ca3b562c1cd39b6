//! Bytes on the wire: every frame of the syllable stream, deformed on the scan and
//! encoded as a viewer frame, against raw f32 deltas (12 bytes per vertex). The default
//! algorithm is checked; `FACEWIRE_WIRE_ALL=1 cargo test --release --test wire --
//! --nocapture` prints every preset (docs/PERFORMANCE.md).

use std::path::{Path, PathBuf};

use facewire::deform::{bind, AlgoSpec, Registration};
use facewire::fit::{FitFile, FittedMask};
use facewire::head::Head;
use facewire::mask::Mask;
use facewire::server::STEP_MM;
use facewire::stream::open_stream;
use facewire_proto::frame::{decode, FrameContent, FrameEncoder, FrameHeader, LipRoughness};
use glam::Vec3;

fn data(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(path)
}

/// (mean bytes per frame, worst quantization error in mm) over the syllable stream.
fn measure(reg: &Registration, spec: &AlgoSpec) -> (f64, f32) {
    let frames: Vec<_> = open_stream(&data("streams/syllables.jsonl"), &reg.fitted.mask)
        .unwrap()
        .map(Result::unwrap)
        .collect();
    let binding = bind(reg, spec);
    let mut scratch = binding.scratch(113, reg.mask_triangles().len());
    let (mut weights, mut mask_now) = (vec![0.0; 65], vec![Vec3::ZERO; 113]);
    let mut deformed = vec![Vec3::ZERO; reg.vertex_count()];
    let mut deltas = vec![[0.0f32; 3]; reg.vertex_count()];
    let mut encoder = FrameEncoder::default();
    let step = STEP_MM / reg.mm_per_unit();
    let lip = LipRoughness {
        per_vertex: vec![0.0; 18],
        ..LipRoughness::default()
    };
    let rest: Vec<f32> = reg.head.positions.iter().flat_map(|p| p.to_array()).collect();
    let (mut bytes, mut worst) = (0usize, 0.0f32);
    let mut decoded = Vec::new();
    for frame in &frames {
        frame.animation_weights(&reg.fitted.mask, &reg.fitted.fapu, &mut weights);
        reg.fitted.pose_into(&weights, &mut mask_now);
        binding.deform(
            &reg.head.positions,
            reg.mask_rest(),
            &mask_now,
            reg.mask_triangles(),
            &mut scratch,
            &mut deformed,
        );
        for ((d, now), was) in deltas.iter_mut().zip(&deformed).zip(&reg.head.positions) {
            *d = (*now - *was).to_array();
        }
        let header = FrameHeader {
            seq: frame.seq,
            producer_time_s: frame.time_s,
            server_receive_us: 0,
            server_send_us: 0,
        };
        let encoded = encoder.encode(
            &header,
            &FrameContent {
                step,
                deltas: &deltas,
                lip: &lip,
                label: frame.label.as_deref(),
                face: None,
                deflate: true,
            },
        );
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
    let mask = Mask::candide3();
    let head = Head::load(&data("heads/lee_perry_smith_head.obj")).unwrap();
    let fit = FitFile::load(&data("heads/lee_perry_smith_head.fit.toml"))
        .unwrap()
        .resolve("fit", &mask)
        .unwrap();
    let reg = Registration::new(head, FittedMask::new(mask, fit));
    let raw = reg.vertex_count() as f64 * 12.0;
    let default: AlgoSpec = facewire::server::Config::default()
        .default_algorithm
        .parse()
        .unwrap();
    let mut specs: Vec<AlgoSpec> = AlgoSpec::presets().into_iter().map(|(_, s, _)| s).collect();
    if std::env::var_os("FACEWIRE_WIRE_ALL").is_none() {
        specs = vec![default];
    }
    for spec in specs {
        let (mean, worst) = measure(&reg, &spec);
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
