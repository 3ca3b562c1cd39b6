//! The service's per-frame job on the MakeHuman head (4,352 vertices) with the default
//! algorithm, stage by stage: deform, lip roughness, lip folds, and the viewer frame's
//! encoding with and without deflate, over the frames of the shipped syllable stream.
//! At the load budget (50 streams at 30 fps) this job runs 1,500 times a second.
//!
//! `cargo bench --bench frame_job`; numbers in docs/PERFORMANCE.md ("The frame job").

use std::hint::black_box;
use std::path::Path;
use std::sync::Arc;

use criterion::{criterion_group, criterion_main, Criterion};
use facewire::animate::{AnimatedHead, FrameJob, FrameTimes, Heat};
use facewire::deform::{bind, AlgoSpec, Registration};
use facewire::fit::{FitFile, FittedMask};
use facewire::head::Head;
use facewire::mask::Mask;
use facewire::metrics::{FoldMeter, LipRoughness};
use facewire::stream::{open_stream, ArkitBasis, Frame};
use facewire_proto::viewer_frame::{
    FrameContent, FrameEncoder, FrameHeader, FrameLayout, LipRoughness as WireLip,
};

fn makehuman() -> AnimatedHead {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
    let head = Head::load(&root.join("heads/makehuman_head.obj")).expect("shipped head");
    let mask = Mask::candide3();
    let fit = FitFile::load(&root.join("heads/makehuman_head.fit.toml"))
        .expect("shipped fit")
        .resolve("makehuman_head", &mask)
        .expect("valid fit");
    AnimatedHead::new(Registration::new(head, FittedMask::new(mask, fit))).expect("lip region")
}

fn syllables(mask: &Mask) -> Vec<Frame> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/streams/syllables.jsonl");
    open_stream(&path, mask)
        .expect("shipped stream")
        .map(|f| f.expect("valid frame"))
        .collect()
}

fn frame_job(c: &mut Criterion) {
    let head = Arc::new(makehuman());
    let reg = &head.registration;
    let frames = syllables(&reg.fitted.mask);
    let spec: AlgoSpec = facewire::server::config::DEFAULT_ALGORITHM
        .parse()
        .expect("default spec");
    let binding = Arc::new(bind(reg, &spec));
    let mut job = FrameJob::new(head.clone(), binding, Arc::new(ArkitBasis::shipped()), Heat::None)
        .expect("job builds");
    let mut group = c.benchmark_group("frame_job/makehuman_4k");

    let mut next = frames.iter().cycle();
    group.bench_function("deform and encode", |b| {
        b.iter(|| {
            let frame = next.next().expect("cycled");
            job.deform(frame);
            job.measure(frame).expect("finite");
            black_box(
                job.encode(frame, FrameTimes::default(), FrameLayout::Fwf2)
                    .expect("finite")
                    .len(),
            )
        })
    });
    group.bench_function("deform", |b| {
        b.iter(|| black_box(job.deform(next.next().expect("cycled")).len()))
    });

    // One frame mid-stream (mid-syllable) for the stages below.
    let deformed = job.deform(&frames[frames.len() / 2]).to_vec();
    let mut lips = LipRoughness::new(&reg.head, &head.lip_region).expect("lip roughness");
    group.bench_function("lip roughness", |b| {
        b.iter(|| black_box(lips.rows(black_box(&deformed), 0, 0.0).expect("sizes").len()))
    });
    let mut folds = FoldMeter::new(&reg.head, head.lip_region.union()).expect("fold meter");
    group.bench_function("lip folds", |b| {
        b.iter(|| black_box(folds.measure(black_box(&deformed)).expect("sizes")))
    });

    let deltas: Vec<[f32; 3]> = deformed
        .iter()
        .zip(&reg.head.positions)
        .map(|(now, rest)| (*now - *rest).to_array())
        .collect();
    let lip = WireLip {
        per_vertex: vec![0.0; facewire::mask::LIP_VERTICES.len()],
        ..WireLip::default()
    };
    let header = FrameHeader {
        seq: 1,
        producer_time_s: 0.0,
        server_receive_us: 0,
        server_send_us: 0,
    };
    let mut encoder = FrameEncoder::for_head(deltas.len(), lip.per_vertex.len());
    for (name, layout, deflate) in [
        ("encode FWF2, deflated", FrameLayout::Fwf2, true),
        ("encode FWF2, not deflated", FrameLayout::Fwf2, false),
        ("encode FWF1, deflated", FrameLayout::Fwf1, true),
    ] {
        let content = FrameContent {
            step: head.step,
            deltas: &deltas,
            lip: &lip,
            label: None,
            heat: None,
            deflate,
            head: None,
            jaw: None,
            tongue: None,
            folds: None,
            eyes: &[],
            viseme: None,
        };
        group.bench_function(name, |b| {
            b.iter(|| black_box(encoder.encode(layout, &header, black_box(&content)).len()))
        });
    }
    group.finish();
}

criterion_group!(benches, frame_job);
criterion_main!(benches);
