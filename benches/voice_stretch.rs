//! What a replay's voice costs when it is slowed down (`src/server/replay_voice.rs`,
//! `core/src/voice/stretch.rs`): stretched chunk by chunk as it is sent, each 20 ms chunk
//! costs only its own samples' work, against stretching a whole run before its first
//! chunk (how replays began, with runs of 30 s). At 16 kHz (the syllable stream's voice)
//! and 48 kHz (an Opus producer's voice, decoded): the first chunk of a 30 s run (the
//! delay before a replay is heard after a play control), the run stretched whole, and one
//! chunk in the middle of a run. Tables in docs/PERFORMANCE.md "Audio".
//!
//! `cargo bench --bench voice_stretch`

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use facewire::voice::{syllable_voice, Stretching, Voice};

const RUN_S: f64 = 30.0;
const SPEED: f64 = 0.25;

/// `seconds` of the syllables' voice at `rate` (repeated, and for 48 kHz each sample
/// interpolated to three: what matters here is the count of samples, not their sound).
fn voice_at(rate: u32, seconds: f64) -> Voice {
    let syllables = syllable_voice().expect("the shipped voice reads");
    let factor = (rate / syllables.sample_rate) as usize;
    let wanted = (seconds * f64::from(rate)) as usize;
    let mut samples = Vec::with_capacity(wanted);
    'fill: loop {
        for pair in syllables.samples.windows(2) {
            for k in 0..factor {
                let (a, b) = (f64::from(pair[0]), f64::from(pair[1]));
                samples.push((a + (b - a) * k as f64 / factor as f64) as i16);
                if samples.len() == wanted {
                    break 'fill;
                }
            }
        }
    }
    Voice {
        sample_rate: rate,
        samples,
    }
}

fn voice_stretch(c: &mut Criterion) {
    let mut group = c.benchmark_group("voice_stretch");
    group.sample_size(10).measurement_time(Duration::from_secs(8));
    for rate in [16_000, 48_000] {
        let voice = voice_at(rate, RUN_S);
        let chunk = rate as usize / 50;
        let mut out = vec![0i16; chunk];
        group.bench_function(
            format!("{rate} Hz, first 20 ms chunk of a {RUN_S} s run at {SPEED}x"),
            |b| {
                b.iter(|| {
                    let mut stretching = Stretching::new(rate, SPEED, 0, 0..voice.samples.len()).unwrap();
                    black_box(stretching.fill(&voice.samples, &mut out))
                })
            },
        );
        let mut stretching = Stretching::new(rate, SPEED, 0, 0..voice.samples.len()).unwrap();
        group.bench_function(format!("{rate} Hz, one 20 ms chunk in a run at {SPEED}x"), |b| {
            b.iter(|| {
                if stretching.fill(&voice.samples, &mut out) == 0 {
                    stretching = Stretching::new(rate, SPEED, 0, 0..voice.samples.len()).unwrap();
                }
                black_box(out[0])
            })
        });
        // The whole run, as replays stretched it before their first chunk: 16 kHz only at
        // full length (48 kHz takes seconds an iteration), 48 kHz over 3 s (it scales with
        // the length).
        let whole_s = if rate == 16_000 { RUN_S } else { 3.0 };
        let whole = voice.between(0.0, whole_s);
        group.bench_function(
            format!("{rate} Hz, a {whole_s} s run stretched whole at {SPEED}x"),
            |b| b.iter(|| black_box(whole.at_speed(SPEED).unwrap().samples.len())),
        );
    }
    group.finish();
}

criterion_group!(benches, voice_stretch);
criterion_main!(benches);
