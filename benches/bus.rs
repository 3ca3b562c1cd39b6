//! What a frame costs on the cluster bus beyond deforming it: the producer's node writes
//! each accepted frame as one JSONL line, and every other node parses and checks it
//! (`src/server/cluster/relay.rs`). Over the 487 frames of the syllable stream, per frame.
//! Every node does the parse for every stream of the cluster, watched or not, so this
//! bounds how many streams one cluster carries (docs/PERFORMANCE.md "Cluster").
//!
//! `cargo bench --bench bus`

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use facewire::mask::Mask;
use facewire::stream::jsonl::{parse_message, JsonlWriter};
use facewire::stream::syllables;

fn bus(c: &mut Criterion) {
    let mask = Mask::candide3();
    let frames = syllables::generate(30.0).expect("the syllable stream generates");
    let lines: Vec<String> = frames
        .iter()
        .map(|frame| {
            let mut line = Vec::new();
            JsonlWriter::new(&mut line, &mask).write_frame(frame).unwrap();
            String::from_utf8(line).unwrap().trim_end().to_string()
        })
        .collect();
    let mean_bytes = lines.iter().map(String::len).sum::<usize>() as f64 / lines.len() as f64;
    println!("{} frames, {mean_bytes:.0} bytes per line", lines.len());
    let mut group = c.benchmark_group("bus");
    let mut line = Vec::with_capacity(1024);
    let mut next = 0;
    group.bench_function("write one frame (producer's node)", |b| {
        b.iter(|| {
            line.clear();
            JsonlWriter::new(&mut line, &mask)
                .write_frame(black_box(&frames[next % frames.len()]))
                .unwrap();
            next += 1;
            black_box(line.len())
        })
    });
    let mut next = 0;
    group.bench_function("parse one frame (every other node)", |b| {
        b.iter(|| {
            let frame = parse_message("bus", black_box(&lines[next % lines.len()]), &mask).unwrap();
            next += 1;
            black_box(frame.seq)
        })
    });
    group.finish();
}

criterion_group!(benches, bus);
criterion_main!(benches);
