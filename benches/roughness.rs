//! Per-frame roughness on the 8838-vertex scan (`lee_perry_smith_head`): the lip table
//! (18 patches and the summary, about 700 triangles) and the whole-face heat-map values.
//! DESIGN.md's budget: lip roughness under the cost of the deform itself (10-50 us).
//!
//! `cargo bench --bench roughness`; numbers in docs/METRICS.md.

use std::hint::black_box;
use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};
use facewire::fit::{anchor_mask, FitFile, FittedMask};
use facewire::head::Head;
use facewire::mask::Mask;
use facewire::metrics::{LipRegion, LipRoughness, Roughness};
use glam::Vec3;

fn scan() -> (Head, LipRegion) {
    let heads = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/heads");
    let head = Head::load(&heads.join("lee_perry_smith_head.obj")).expect("the shipped scan loads");
    let mask = Mask::candide3();
    let fit = FitFile::load(&heads.join("lee_perry_smith_head.fit.toml"))
        .and_then(|f| f.resolve("fit", &mask))
        .expect("the shipped fit loads");
    let fitted = FittedMask::new(mask, fit);
    let mm = fitted.fit.mm_per_unit;
    let anchors = anchor_mask(&head, &fitted.neutral, mm);
    let region = LipRegion::new(&head, &anchors, mm).expect("the lip region builds");
    (head, region)
}

/// The scan with a smooth ripple, so the frame is not the rest pose.
fn deformed(head: &Head) -> Vec<Vec3> {
    head.positions
        .iter()
        .map(|p| *p + Vec3::new(0.0, 0.0, 0.02 * (7.0 * p.x).sin() * (5.0 * p.y).cos()))
        .collect()
}

fn roughness(c: &mut Criterion) {
    let (head, region) = scan();
    let frame = deformed(&head);

    let mut lips = LipRoughness::new(&head, &region).expect("lip roughness builds");
    c.bench_function("lip_rows_scan_8838", |b| {
        b.iter(|| lips.rows(black_box(&frame), 0, 0.0).expect("sizes match"))
    });

    let mut whole = Roughness::whole_mesh(&head).expect("whole-mesh roughness builds");
    let mut heat = vec![0.0f32; head.positions.len()];
    c.bench_function("face_vertex_roughness_scan_8838", |b| {
        b.iter(|| {
            whole
                .face_vertex_roughness(black_box(&frame), &mut heat)
                .expect("sizes match");
            black_box(&heat);
        })
    });
}

criterion_group!(benches, roughness);
criterion_main!(benches);
