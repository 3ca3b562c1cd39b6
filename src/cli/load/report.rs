//! What a load run measured, as the report it prints and writes as JSON: frames, stalls and
//! their causes, latency, the voice heard, the server's and the generator's CPU.

use serde::Serialize;

use super::latency::Latencies;
use super::pauses::{MachineTime, Pause};
use super::viewer::ViewerOutcome;
use super::{AudioCodec, WireFormat};

/// What the listeners heard, with `--audio`.
#[derive(Debug, Serialize)]
pub struct AudioReport {
    pub codec: AudioCodec,
    /// Chunks (20 ms) the producers sent.
    pub chunks_sent: u64,
    /// Seconds of sound the viewers would hear if none were lost: each stream's sent
    /// sound times its viewers.
    pub seconds_expected: f64,
    /// Seconds of sound in what they received (the server's Opus packets are 40 ms).
    pub seconds_received: f64,
    pub messages_received: u64,
    /// Chunks at or before one the viewer had already heard (must be 0).
    pub regressions: u64,
    /// Gaps between two chunks' arrivals longer than a frame stall's limit.
    pub gaps: u64,
    /// Producer-to-viewer latency of the chunks, milliseconds.
    pub latency_ms: LatencySummary,
    /// Audio bytes (whole `FWA1` messages) a viewer received per second of the run.
    pub bytes_per_viewer_second: f64,
}

/// What one run measured.
#[derive(Debug, Serialize)]
pub struct LoadReport {
    pub url: String,
    /// Where the viewers connected, when not `url`.
    pub view_urls: Vec<String>,
    pub head: String,
    pub algorithm: Option<String>,
    pub format: WireFormat,
    pub streams: usize,
    pub viewers: usize,
    pub seconds: f64,
    pub fps: f64,
    /// Frames the producers sent.
    pub frames_sent: u64,
    /// Frames the viewers would get if none were skipped: each stream's sent frames times
    /// its viewers.
    pub frames_expected: u64,
    pub frames_received: u64,
    pub frames_skipped: u64,
    /// Frames older than one the viewer had already received (must be 0).
    pub regressions: u64,
    /// Gaps of more than `STALL_PERIODS` frame periods between two frames of one viewer.
    pub stalls: u64,
    /// Those of `stalls` where the producer's sends of the two frames were as far apart:
    /// the generator fell behind, not the server.
    pub producer_stalls: u64,
    /// Those of `stalls` where the server published the two frames as far apart: its
    /// pipeline was late. The rest were published in time and delivered late (fan-out,
    /// kernel, or this generator). Binary frames only (the JSON baseline's frames do not
    /// carry the time).
    pub publish_stalls: u64,
    /// Those of `stalls` that a pause of the whole machine by its host explains: without
    /// the pause the gap would have stayed under the stall limit (checked for each viewer's
    /// first 64 stalls).
    pub host_pause_stalls: u64,
    /// The seconds of the run with the most stalls (at most 10, most first): a burst shows
    /// as one second with many.
    pub stall_seconds: Vec<StallSecond>,
    /// Pauses of this machine seen by the generator (a thread late to wake by more than
    /// 20 ms), with the steal the kernel counted in them.
    pub pauses: PauseSummary,
    /// Viewers that received no frame at all.
    pub viewers_without_frames: usize,
    /// Producer-to-viewer latency, milliseconds.
    pub latency_ms: LatencySummary,
    pub bytes_per_frame: f64,
    pub audio: Option<AudioReport>,
    /// Refusals and failures, by message, with counts (at most 20 kinds).
    pub failures: Vec<(String, usize)>,
    /// The server's CPU use over the run (percent of one core) and memory, when its
    /// `/metrics` could be read; with `view_urls`, the sum over every node.
    pub server: Option<ServerUse>,
    /// This generator's own CPU use over the run, percent of one core.
    pub generator_cpu_percent: f64,
    /// Where the numbers come from.
    pub note: &'static str,
}

#[derive(Debug, Serialize)]
pub struct StallSecond {
    /// Whole seconds since the producers started.
    pub second: u64,
    pub stalls: u64,
    /// CPU time the host took from this machine (all CPUs) in that second and the next, ms.
    pub steal_ms: f64,
}

#[derive(Debug, Serialize)]
pub struct PauseSummary {
    pub count: usize,
    /// Those where the host took the time (steal of at least half the pause).
    pub host: usize,
    /// The longest, most first (at most 5).
    pub longest: Vec<Pause>,
}

#[derive(Debug, Serialize)]
pub struct LatencySummary {
    /// Frames whose send time was still known when they arrived.
    pub samples: u64,
    pub p50: f64,
    pub p90: f64,
    pub p99: f64,
    pub max: f64,
}

impl LatencySummary {
    pub(super) fn of(latencies: &Latencies) -> LatencySummary {
        LatencySummary {
            samples: latencies.samples(),
            p50: latencies.quantile(0.5),
            p90: latencies.quantile(0.9),
            p99: latencies.quantile(0.99),
            max: latencies.max_ms(),
        }
    }
}

#[derive(Debug, Serialize)]
pub struct ServerUse {
    pub cpu_percent: f64,
    pub resident_mib_before: f64,
    pub resident_mib_after: f64,
}

/// The seconds with the most stalls over every viewer, at most 10, most first, with the
/// steal around each.
pub(super) fn busiest_seconds(outcomes: &[ViewerOutcome], machine: &MachineTime) -> Vec<StallSecond> {
    let mut by_second = std::collections::BTreeMap::<u64, u64>::new();
    for outcome in outcomes {
        for (&second, &stalls) in &outcome.stall_seconds {
            *by_second.entry(second).or_default() += stalls;
        }
    }
    let mut seconds: Vec<StallSecond> = by_second
        .into_iter()
        .map(|(second, stalls)| StallSecond {
            second,
            stalls,
            steal_ms: machine.steal_around(second),
        })
        .collect();
    seconds.sort_by_key(|s| (std::cmp::Reverse(s.stalls), s.second));
    seconds.truncate(10);
    seconds
}

pub(super) fn summarize(pauses: &[Pause]) -> PauseSummary {
    let mut longest = pauses.to_vec();
    longest.sort_by(|a, b| b.length_ms().total_cmp(&a.length_ms()));
    longest.truncate(5);
    PauseSummary {
        count: pauses.len(),
        host: pauses.iter().filter(|p| p.is_host()).count(),
        longest,
    }
}

/// Distinct messages with their counts, most frequent first, at most 20.
pub(super) fn tally(messages: Vec<String>) -> Vec<(String, usize)> {
    let mut counts: Vec<(String, usize)> = Vec::new();
    for message in messages {
        match counts.iter_mut().find(|(m, _)| *m == message) {
            Some((_, n)) => *n += 1,
            None => counts.push((message, 1)),
        }
    }
    counts.sort_by_key(|c| std::cmp::Reverse(c.1));
    counts.truncate(20);
    counts
}

pub(super) fn print(r: &LoadReport) {
    println!(
        "{} streams x {} viewers at {} fps for {} s ({}, {} frames), head {}",
        r.streams,
        r.viewers,
        r.fps,
        r.seconds,
        r.algorithm
            .as_deref()
            .unwrap_or("no algorithm: no viewer connected"),
        r.format.name(),
        r.head
    );
    println!(
        "  frames: sent {}, received {} of {} expected ({:.1} %), skipped {}, stalls {} ({} with the producer paused, {} published late by the server, {} explained by the host pausing the machine), older than shown {}, viewers with none {}",
        r.frames_sent,
        r.frames_received,
        r.frames_expected,
        100.0 * r.frames_received as f64 / r.frames_expected.max(1) as f64,
        r.frames_skipped,
        r.stalls,
        r.producer_stalls,
        r.publish_stalls,
        r.host_pause_stalls,
        r.regressions,
        r.viewers_without_frames
    );
    if !r.stall_seconds.is_empty() {
        let seconds: Vec<String> = r
            .stall_seconds
            .iter()
            .map(|s| format!("{} s: {} (steal {:.0} ms)", s.second, s.stalls, s.steal_ms))
            .collect();
        println!(
            "  stalls by second of the run (busiest first): {}",
            seconds.join(", ")
        );
    }
    if r.pauses.count > 0 {
        let longest: Vec<String> = r
            .pauses
            .longest
            .iter()
            .map(|p| {
                format!(
                    "{:.0} ms at {:.1} s (steal {:.0} ms)",
                    p.length_ms(),
                    p.from_us as f64 / 1e6,
                    p.steal_ms
                )
            })
            .collect();
        println!(
            "  machine pauses: {} ({} by the host), longest {}",
            r.pauses.count,
            r.pauses.host,
            longest.join(", ")
        );
    }
    println!(
        "  producer-to-viewer latency ms: p50 {:.2}  p90 {:.2}  p99 {:.2}  max {:.2}; {:.0} bytes/frame",
        r.latency_ms.p50, r.latency_ms.p90, r.latency_ms.p99, r.latency_ms.max, r.bytes_per_frame
    );
    if let Some(a) = &r.audio {
        println!(
            "  audio ({}): sent {} chunks, heard {:.0} of {:.0} s expected ({:.1} %) in {} messages, gaps {}, older than heard {}; latency ms p50 {:.2}  p99 {:.2}  max {:.2}; {:.0} bytes/s a viewer",
            a.codec.name(),
            a.chunks_sent,
            a.seconds_received,
            a.seconds_expected,
            100.0 * a.seconds_received / a.seconds_expected.max(1e-9),
            a.messages_received,
            a.gaps,
            a.regressions,
            a.latency_ms.p50,
            a.latency_ms.p99,
            a.latency_ms.max,
            a.bytes_per_viewer_second
        );
    }
    match &r.server {
        Some(s) => println!(
            "  server: {:.0} % of one core, resident {:.1} -> {:.1} MiB",
            s.cpu_percent, s.resident_mib_before, s.resident_mib_after
        ),
        None => println!("  server: /metrics not readable"),
    }
    println!("  generator: {:.0} % of one core", r.generator_cpu_percent);
    if !r.view_urls.is_empty() {
        println!("  viewers on {}; producers on {}", r.view_urls.join(", "), r.url);
    }
    for (failure, count) in &r.failures {
        println!("  {count} x {failure}");
    }
}
