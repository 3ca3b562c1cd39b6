//! What deriving the mouth from a voice costs per stream: the viseme tracker
//! (`core/src/speech/tracker.rs`: log-mel, normalization, the model, the forward filter) over the
//! syllable stream's 16 kHz voice pushed in 20 ms chunks, as a producer's audio arrives.
//! One iteration is the whole 16.2 s voice; its real-time factor is 16.2 s over the time
//! (docs/SPEECH.md "Speed").
//!
//! `cargo bench --bench speech_tracker`

use std::hint::black_box;
use std::sync::Arc;

use criterion::{criterion_group, criterion_main, Criterion};
use facewire::speech::{VisemeModel, VisemeTracker};
use facewire::voice::syllable_voice;

fn tracker(c: &mut Criterion) {
    let voice = syllable_voice().unwrap();
    let samples: Vec<f32> = voice.samples.iter().map(|&s| f32::from(s) / 32768.0).collect();
    let model = Arc::new(VisemeModel::embedded().unwrap());
    let chunk = (voice.sample_rate / 50) as usize;
    c.bench_function("speech_tracker/syllable_voice_16.2s_in_20ms_chunks", |b| {
        b.iter(|| {
            let mut tracker = VisemeTracker::new(model.clone());
            let mut last = 0u8;
            for piece in samples.chunks(chunk) {
                tracker.push(black_box(piece), |d| last = d.viseme);
            }
            tracker.finish(|d| last = d.viseme);
            black_box(last)
        })
    });
}

criterion_group!(benches, tracker);
criterion_main!(benches);
