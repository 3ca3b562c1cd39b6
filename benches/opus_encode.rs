//! What a stream's voice costs the server when producers send PCM and viewers ask for Opus:
//! one libopus encode per 20 ms packet per stream (`src/server/opus_encode.rs`: mono, VoIP
//! mode, 20 kbit/s), at each encoder complexity, over the syllable stream's 16 kHz voice.
//! Beside the time, the quality each complexity keeps: the voice decoded again against the
//! original, as the signal-to-noise ratio over the whole voice and the mean per 20 ms
//! segment of speech (segmental SNR, silent segments left out), so the cost of a lower
//! complexity shows next to what it saves (docs/PERFORMANCE.md "Audio").
//!
//! `cargo bench --bench opus_encode`

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use facewire::voice::syllable_voice;

/// The server's settings (src/server/opus_encode.rs).
const BITRATE: i32 = 20_000;
const COMPLEXITIES: [i32; 4] = [10, 7, 5, 3];

fn encoder(rate: u32, complexity: i32) -> opus::Encoder {
    let mut encoder = opus::Encoder::new(rate, opus::Channels::Mono, opus::Application::Voip).unwrap();
    encoder.set_bitrate(opus::Bitrate::Bits(BITRATE)).unwrap();
    encoder.set_complexity(complexity).unwrap();
    encoder
}

/// (SNR, segmental SNR) in dB of the voice through an encoder of `complexity` and back.
fn quality(samples: &[i16], rate: u32, frame: usize, complexity: i32) -> (f64, f64) {
    let mut encoder = encoder(rate, complexity);
    let lookahead = encoder.get_lookahead().unwrap() as usize;
    let mut decoder = opus::Decoder::new(rate, opus::Channels::Mono).unwrap();
    let (mut packet, mut decoded) = (vec![0u8; 1275], Vec::with_capacity(samples.len() + frame));
    let mut pcm = vec![0i16; frame];
    for chunk in samples.chunks_exact(frame) {
        let length = encoder.encode(chunk, &mut packet).unwrap();
        let n = decoder.decode(&packet[..length], &mut pcm, false).unwrap();
        decoded.extend_from_slice(&pcm[..n]);
    }
    // The decoder's output runs `lookahead` samples behind the input.
    let aligned = &decoded[lookahead.min(decoded.len())..];
    let (mut signal, mut noise, mut segments, mut segmental) = (0.0f64, 0.0f64, 0usize, 0.0f64);
    for (original, got) in samples.chunks(frame).zip(aligned.chunks(frame)) {
        let s: f64 = original.iter().map(|&x| f64::from(x).powi(2)).sum();
        let e: f64 = original
            .iter()
            .zip(got)
            .map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2))
            .sum();
        signal += s;
        noise += e;
        // Speech: a segment's RMS over 1 % of full scale.
        if s / original.len() as f64 > 327.0f64.powi(2) {
            segmental += 10.0 * (s / e.max(1.0)).log10();
            segments += 1;
        }
    }
    (
        10.0 * (signal / noise).log10(),
        segmental / segments.max(1) as f64,
    )
}

fn opus_encode(c: &mut Criterion) {
    let voice = syllable_voice().expect("the shipped voice reads");
    let frame = (voice.sample_rate / 50) as usize;
    let packets: Vec<&[i16]> = voice.samples.chunks_exact(frame).collect();
    println!(
        "{} packets of 20 ms at {} Hz, {} bit/s",
        packets.len(),
        voice.sample_rate,
        BITRATE
    );
    for complexity in COMPLEXITIES {
        let (snr, segmental) = quality(&voice.samples, voice.sample_rate, frame, complexity);
        println!("complexity {complexity:>2}: SNR {snr:.2} dB, segmental SNR over speech {segmental:.2} dB");
    }
    let mut group = c.benchmark_group("opus_encode");
    for complexity in COMPLEXITIES {
        let mut encoder = encoder(voice.sample_rate, complexity);
        let mut packet = vec![0u8; 1275];
        let mut next = 0;
        group.bench_function(format!("one 20 ms packet, complexity {complexity}"), |b| {
            b.iter(|| {
                let length = encoder
                    .encode(black_box(packets[next % packets.len()]), &mut packet)
                    .unwrap();
                next += 1;
                black_box(length)
            })
        });
    }
    group.finish();
}

criterion_group!(benches, opus_encode);
criterion_main!(benches);
