//! `facewire load`: a load generator for a running service. It produces S streams (the
//! syllable stream, looped, through real producer sockets) on one head and spreads V
//! viewers over them, all in this process, then reports what the viewers saw (frames,
//! skips, stalls, frames older than one already shown, producer-to-viewer latency, bytes
//! per frame), with `--audio` what the listeners heard (chunks, gaps, latency, bytes per
//! second), and what the server spent (CPU and memory from its `/metrics`).
//!
//! Counts and duration are bounded, and only loopback targets are accepted unless
//! `--allow-remote` is given: the tool opens thousands of sockets. The server and the
//! generator share the machine's cores on loopback; reports say so.

mod latency;
mod pauses;
mod producer;
mod send_times;
mod server_metrics;
mod viewer;

use std::net::ToSocketAddrs;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant as StdInstant};

use serde::Serialize;
use tokio::time::Instant;

use super::{CliResult, FilePath};
use crate::mask::Mask;
use crate::server::process::cpu_seconds;
use crate::stream::{syllables, JsonlWriter};
use latency::Latencies;
use pauses::{explained_by_host, MachineTime, Pause, PauseWatch};
use producer::{produce, ProducerPlan, Sent, VoicePlan};
use send_times::SendTimes;
use server_metrics::ServerSample;
use viewer::{ViewerOutcome, ViewerPlan};

/// Most streams one run produces.
pub const MAX_STREAMS: usize = 10_000;
/// Most viewers one run opens.
pub const MAX_VIEWERS: usize = 100_000;
/// Longest run, seconds.
pub const MAX_SECONDS: f64 = 3_600.0;
/// Most nodes a run spreads its viewers over.
pub const MAX_NODES: usize = 64;
/// A viewer stalls when no frame comes for this many frame periods.
pub const STALL_PERIODS: f64 = 3.0;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// The service, e.g. http://127.0.0.1:8480: the producers connect here (and the head
    /// is registered here).
    #[arg(long)]
    url: String,
    /// Nodes of a cluster the viewers connect to instead, each stream's viewers spread over
    /// them in turn (repeat the flag) [default: --url].
    #[arg(long = "view-url")]
    view_urls: Vec<String>,
    /// Streams to produce (1 to 10,000).
    #[arg(long, default_value_t = 10)]
    streams: usize,
    /// Viewers, spread evenly over the streams (1 to 100,000).
    #[arg(long, default_value_t = 40)]
    viewers: usize,
    /// How long to produce, seconds (up to 3,600).
    #[arg(long, default_value_t = 10.0)]
    seconds: f64,
    /// Frames per second of every producer.
    #[arg(long, default_value_t = 30.0)]
    fps: f64,
    /// Algorithm spec the viewers ask for [default: the server's].
    #[arg(long)]
    algo: Option<String>,
    /// Viewer frames: `fwf1` (quantized binary deltas, the frozen layout the tables in
    /// docs/PERFORMANCE.md were measured with), `fwf2` (the same in sections) or `json`
    /// (every position as JSON text, the naive baseline).
    #[arg(long, value_enum, default_value_t = WireFormat::Fwf1)]
    format: WireFormat,
    /// Audio on every stream: the producers send the syllable stream's voice (16 kHz PCM,
    /// looped) in 20 ms chunks on their frames' clock, and the viewers ask for it in this
    /// codec (the server encodes Opus once per stream).
    #[arg(long, value_enum)]
    audio: Option<AudioCodec>,
    /// The producers send their voice alone (`produce?derive=visemes`, needs --audio): the
    /// server derives each stream's face from it at --fps. A frame's latency then counts
    /// from the send of the audio chunk holding the frame's instant.
    #[arg(long)]
    derive: bool,
    /// A registered head to use; without it the MakeHuman head is registered for the run
    /// and deleted after.
    #[arg(long)]
    head: Option<String>,
    /// Also write the report as JSON to this file.
    #[arg(long)]
    json: Option<FilePath>,
    /// Token for every request, if the server wants one (admin, or one that may produce,
    /// view and register).
    #[arg(long)]
    token: Option<String>,
    /// Accept a target that is not on this machine's loopback.
    #[arg(long)]
    allow_remote: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum WireFormat {
    Fwf1,
    Fwf2,
    Json,
}

impl WireFormat {
    pub fn name(self) -> &'static str {
        match self {
            WireFormat::Fwf1 => "fwf1",
            WireFormat::Fwf2 => "fwf2",
            WireFormat::Json => "json",
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum AudioCodec {
    Opus,
    Pcm,
}

impl AudioCodec {
    pub fn name(self) -> &'static str {
        match self {
            AudioCodec::Opus => "opus",
            AudioCodec::Pcm => "pcm",
        }
    }
}

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
    fn of(latencies: &Latencies) -> LatencySummary {
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

pub fn run(args: Args) -> CliResult {
    check(&args)?;
    let base = args.url.trim_end_matches('/').to_string();
    let view_bases: Vec<String> = match args.view_urls.is_empty() {
        true => vec![base.clone()],
        false => args
            .view_urls
            .iter()
            .map(|u| u.trim_end_matches('/').to_string())
            .collect(),
    };
    // One worker thread: on a machine the server shares, a second one mostly competes with
    // the server for the same cores (measured: docs/PERFORMANCE.md, "Load").
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()?;
    let report = runtime.block_on(load(&args, &base, &view_bases))?;
    print(&report);
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&report)?;
        crate::atomic::write_atomic(path, text.as_bytes())
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    Ok(())
}

/// Refuses counts, durations and targets out of bounds, naming the flag.
fn check(args: &Args) -> Result<(), String> {
    if !(1..=MAX_STREAMS).contains(&args.streams) {
        return Err(format!("--streams {}: must be 1 to {MAX_STREAMS}", args.streams));
    }
    if !(1..=MAX_VIEWERS).contains(&args.viewers) {
        return Err(format!("--viewers {}: must be 1 to {MAX_VIEWERS}", args.viewers));
    }
    if !(args.seconds > 0.0 && args.seconds <= MAX_SECONDS) {
        return Err(format!(
            "--seconds {}: must be above 0 and at most {MAX_SECONDS}",
            args.seconds
        ));
    }
    if !(args.fps > 0.0 && args.fps <= crate::stream::MAX_FPS) {
        return Err(format!(
            "--fps {}: must be above 0 and at most {}",
            args.fps,
            crate::stream::MAX_FPS
        ));
    }
    if args.derive && args.audio.is_none() {
        return Err("--derive: the face is derived from the voice, so give --audio too".to_string());
    }
    if args.view_urls.len() > MAX_NODES {
        return Err(format!(
            "--view-url given {} times: at most {MAX_NODES}",
            args.view_urls.len()
        ));
    }
    check_url("--url", &args.url, args.allow_remote)?;
    for url in &args.view_urls {
        check_url("--view-url", url, args.allow_remote)?;
    }
    Ok(())
}

/// Refuses a URL that is not `http://HOST:PORT`, or not on loopback without `allow_remote`.
fn check_url(flag: &str, url: &str, allow_remote: bool) -> Result<(), String> {
    let Some(authority) = url.strip_prefix("http://") else {
        return Err(format!("{flag} {url:?}: expected http://HOST:PORT"));
    };
    let host_port = authority.trim_end_matches('/');
    let addrs: Vec<_> = host_port
        .to_socket_addrs()
        .map_err(|e| format!("{flag} {url:?}: {e}"))?
        .collect();
    if !allow_remote && (addrs.is_empty() || addrs.iter().any(|a| !a.ip().is_loopback())) {
        return Err(format!(
            "{flag} {url:?}: not a loopback address; a load run opens thousands of sockets, so give --allow-remote to aim it at another machine"
        ));
    }
    Ok(())
}

async fn load(
    args: &Args,
    base: &str,
    view_bases: &[String],
) -> Result<LoadReport, Box<dyn std::error::Error + Send + Sync>> {
    let http = reqwest::Client::new();
    let token_query = args
        .token
        .as_deref()
        .map_or(String::new(), |t| format!("token={t}"));
    let with_token = |path: &str| -> String {
        match (&token_query, path.contains('?')) {
            (t, _) if t.is_empty() => path.to_string(),
            (t, true) => format!("{path}&{t}"),
            (t, false) => format!("{path}?{t}"),
        }
    };
    let (head, registered) = match &args.head {
        Some(head) => (head.clone(), false),
        None => (register(&http, base, &with_token).await?, true),
    };
    // Every node registers a cluster's head itself: wait until the viewers' nodes have it.
    for node in view_bases {
        wait_ready(&http, node, &head, &with_token).await?;
    }
    let mut nodes = vec![base.to_string()];
    nodes.extend(view_bases.iter().filter(|n| n.as_str() != base).cloned());
    let frames = Arc::new(syllable_frames(args.fps)?);
    let ws_base = base.replacen("http://", "ws://", 1);
    let view_ws: Vec<String> = view_bases
        .iter()
        .map(|b| b.replacen("http://", "ws://", 1))
        .collect();
    let run_id = std::process::id();
    let stream_name = |s: usize| format!("load-{run_id}-{s}");
    let format = args.format.name();
    let mut query = format!("?format={format}");
    if let Some(a) = args.algo.as_deref() {
        query.push_str(&format!("&algo={a}"));
    }
    if let Some(codec) = args.audio {
        query.push_str(&format!("&audio={}", codec.name()));
    }
    let voice = match args.audio {
        Some(_) => Some(Arc::new(crate::voice::syllable_voice()?)),
        None => None,
    };

    let before = server_metrics::sample_nodes(&http, &nodes, &with_token).await;
    let clock = StdInstant::now();
    let times: Vec<Arc<SendTimes>> = (0..args.streams)
        .map(|_| Arc::new(SendTimes::new(clock)))
        .collect();
    let audio_times: Vec<Arc<SendTimes>> = match voice {
        Some(_) => (0..args.streams)
            .map(|_| Arc::new(SendTimes::new(clock)))
            .collect(),
        None => Vec::new(),
    };
    let chunks_sent = Arc::new(AtomicU64::new(0));
    let (sent, received) = (Arc::new(AtomicU64::new(0)), Arc::new(AtomicU64::new(0)));
    let period = Duration::from_secs_f64(1.0 / args.fps);
    // Viewers first, so that every one sees the first frame; streams come to life with them.
    let run_length = Duration::from_secs_f64(args.seconds);
    let mut failures: Vec<String> = Vec::new();
    eprint!("facewire load: connecting {} viewers", args.viewers);
    let mut connected = Vec::with_capacity(args.viewers);
    for v in 0..args.viewers {
        let s = v % args.streams;
        let node = &view_ws[(v / args.streams) % view_ws.len()];
        let url = with_token(&format!(
            "{node}/v1/heads/{head}/streams/{}/view{query}",
            stream_name(s)
        ));
        match viewer::connect(&url).await {
            Ok((socket, algorithm)) => connected.push((s, socket, algorithm)),
            Err(e) => failures.push(format!("viewer: {e}")),
        }
    }
    eprintln!(", {} connected", connected.len());
    let start = Instant::now() + Duration::from_millis(200);
    let generator_cpu_before = cpu_seconds();
    let pause_watch = PauseWatch::start(start.into_std())?;
    let deadline = start + run_length + Duration::from_secs(3);
    let viewers: Vec<_> = connected
        .into_iter()
        .map(|(s, socket, algorithm)| {
            let plan = ViewerPlan {
                times: times[s].clone(),
                audio_times: audio_times.get(s).cloned(),
                received: received.clone(),
                stall_after: period.mul_f64(STALL_PERIODS),
                start,
                deadline,
            };
            tokio::spawn(viewer::watch(plan, socket, algorithm))
        })
        .collect();
    let count = (args.seconds * args.fps).round() as u64;
    let produce_query = match args.derive {
        true => format!("?derive=visemes&fps={}", args.fps),
        false => String::new(),
    };
    let producers: Vec<_> = (0..args.streams)
        .map(|s| {
            tokio::spawn(produce(ProducerPlan {
                url: with_token(&format!(
                    "{ws_base}/v1/heads/{head}/streams/{}/produce{produce_query}",
                    stream_name(s)
                )),
                derive: args.derive,
                frames: frames.clone(),
                fps: args.fps,
                count,
                // Spread the streams' frames over one period, as independent producers are.
                start: start + period.mul_f64(s as f64 / args.streams as f64),
                times: times[s].clone(),
                sent: sent.clone(),
                voice: voice.as_ref().map(|voice| VoicePlan {
                    voice: voice.clone(),
                    times: audio_times[s].clone(),
                    sent: chunks_sent.clone(),
                }),
            }))
        })
        .collect();
    let progress = tokio::spawn(progress_line(start, run_length, sent.clone(), received.clone()));

    let mut sent_per_stream = Vec::with_capacity(args.streams);
    for producer in producers {
        match producer.await? {
            Ok(sent) => sent_per_stream.push(sent),
            Err(e) => {
                failures.push(format!("producer: {e}"));
                sent_per_stream.push(Sent::default());
            }
        }
    }
    let mut outcomes: Vec<ViewerOutcome> = Vec::with_capacity(viewers.len());
    for viewer in viewers {
        outcomes.push(viewer.await?);
    }
    progress.abort();
    eprintln!();
    let machine = pause_watch.finish();
    let stall_after_us = period.mul_f64(STALL_PERIODS).as_micros() as u64;
    let host_pause_stalls = outcomes
        .iter()
        .flat_map(|o| &o.stall_windows)
        .filter(|&&(from, to)| explained_by_host(from, to, stall_after_us, &machine.pauses))
        .count() as u64;
    let after = server_metrics::sample_nodes(&http, &nodes, &with_token).await;
    let elapsed = start.elapsed().as_secs_f64();
    if registered {
        let _ = http
            .delete(with_token(&format!("{base}/v1/heads/{head}")))
            .send()
            .await;
    }
    failures.extend(outcomes.iter().filter_map(|o| o.failure.clone()));
    let viewers_of = |s: usize| (0..args.viewers).filter(|v| v % args.streams == s).count() as u64;
    let frames_expected = sent_per_stream
        .iter()
        .enumerate()
        .map(|(s, n)| n.frames * viewers_of(s))
        .sum();
    let audio = args.audio.map(|codec| {
        let mut latencies = Latencies::default();
        for outcome in &outcomes {
            latencies.merge(&outcome.audio.latencies);
        }
        let heard = |f: fn(&ViewerOutcome) -> u64| outcomes.iter().map(f).sum::<u64>();
        AudioReport {
            codec,
            chunks_sent: sent_per_stream.iter().map(|n| n.chunks).sum(),
            seconds_expected: sent_per_stream
                .iter()
                .enumerate()
                .map(|(s, n)| (n.chunks * viewers_of(s)) as f64 * crate::voice::CHUNK_S)
                .sum(),
            seconds_received: outcomes.iter().map(|o| o.audio.seconds).sum(),
            messages_received: heard(|o| o.audio.chunks),
            regressions: heard(|o| o.audio.regressions),
            gaps: heard(|o| o.audio.gaps),
            latency_ms: LatencySummary::of(&latencies),
            bytes_per_viewer_second: heard(|o| o.audio.bytes) as f64
                / outcomes.len().max(1) as f64
                / args.seconds,
        }
    });
    let mut latencies = Latencies::default();
    for outcome in &outcomes {
        latencies.merge(&outcome.latencies);
    }
    let frames_received: u64 = outcomes.iter().map(|o| o.frames).sum();
    let bytes: u64 = outcomes.iter().map(|o| o.bytes).sum();
    Ok(LoadReport {
        url: base.to_string(),
        view_urls: args.view_urls.clone(),
        head,
        algorithm: outcomes.iter().find_map(|o| o.algorithm.clone()),
        format: args.format,
        streams: args.streams,
        viewers: args.viewers,
        seconds: args.seconds,
        fps: args.fps,
        frames_sent: sent_per_stream.iter().map(|n| n.frames).sum(),
        frames_expected,
        frames_received,
        frames_skipped: outcomes.iter().map(|o| o.skipped).sum(),
        regressions: outcomes.iter().map(|o| o.regressions).sum(),
        stalls: outcomes.iter().map(|o| o.stalls).sum(),
        producer_stalls: outcomes.iter().map(|o| o.producer_stalls).sum(),
        publish_stalls: outcomes.iter().map(|o| o.publish_stalls).sum(),
        host_pause_stalls,
        stall_seconds: busiest_seconds(&outcomes, &machine),
        pauses: summarize(&machine.pauses),
        viewers_without_frames: outcomes.iter().filter(|o| o.frames == 0).count() + args.viewers
            - outcomes.len(),
        latency_ms: LatencySummary::of(&latencies),
        bytes_per_frame: bytes as f64 / frames_received.max(1) as f64,
        audio,
        failures: tally(failures),
        server: ServerSample::usage(before, after, elapsed),
        generator_cpu_percent: 100.0 * (cpu_seconds() - generator_cpu_before) / elapsed.max(1e-9),
        note: "generator and server on one machine share its cores; latency is from the producer's send to the viewer's receipt, on the generator's clock",
    })
}

/// Registers the MakeHuman head (embedded) for the run and waits until it is ready.
async fn register(
    http: &reqwest::Client,
    base: &str,
    with_token: &impl Fn(&str) -> String,
) -> Result<String, Box<dyn std::error::Error + Send + Sync>> {
    let head = crate::server::demo::DEMO_HEADS
        .iter()
        .find(|h| h.id == "makehuman")
        .ok_or("the embedded MakeHuman head is missing")?;
    let (obj, fit) = (head.obj, head.fit);
    let id = format!("load-{}", std::process::id());
    let body = serde_json::json!({
        "id": id,
        "obj": String::from_utf8_lossy(obj),
        "fit": fit,
    });
    let response = http
        .post(with_token(&format!("{base}/v1/heads")))
        .json(&body)
        .send()
        .await
        .map_err(|e| format!("cannot reach {base}: {e}"))?;
    if !response.status().is_success() {
        return Err(format!(
            "registering the MakeHuman head: {} {}",
            response.status(),
            response.text().await?
        )
        .into());
    }
    wait_ready(http, base, &id, with_token).await?;
    Ok(id)
}

/// Waits (30 s at most) until the node at `base` has head `id` ready; a node of a cluster
/// may not know it yet (404) while it follows the registry.
async fn wait_ready(
    http: &reqwest::Client,
    base: &str,
    id: &str,
    with_token: &impl Fn(&str) -> String,
) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    for _ in 0..600 {
        let info: serde_json::Value = http
            .get(with_token(&format!("{base}/v1/heads/{id}")))
            .send()
            .await
            .map_err(|e| format!("cannot reach {base}: {e}"))?
            .json()
            .await?;
        match info["status"].as_str() {
            Some("ready") => return Ok(()),
            Some("failed") => return Err(format!("head {id} failed on {base}: {}", info["error"]).into()),
            _ => tokio::time::sleep(Duration::from_millis(50)).await,
        }
    }
    Err(format!("head {id} was not ready on {base} within 30 s").into())
}

/// The syllable stream at `fps` as JSONL objects.
fn syllable_frames(fps: f64) -> Result<Vec<serde_json::Value>, Box<dyn std::error::Error + Send + Sync>> {
    let mask = Mask::candide3();
    let mut frames = Vec::new();
    for frame in syllables::generate(fps)? {
        let mut writer = JsonlWriter::new(Vec::new(), &mask);
        writer.write_frame(&frame)?;
        frames.push(serde_json::from_slice(&writer.into_inner()?)?);
    }
    Ok(frames)
}

/// `[4.0/10 s] sent 1200, received 4790` on stderr once a second.
async fn progress_line(start: Instant, length: Duration, sent: Arc<AtomicU64>, received: Arc<AtomicU64>) {
    tokio::time::sleep_until(start).await;
    let mut tick = tokio::time::interval(Duration::from_secs(1));
    loop {
        tick.tick().await;
        eprint!(
            "\r[{:.0}/{:.0} s] sent {}, received {}   ",
            start.elapsed().as_secs_f64().min(length.as_secs_f64()),
            length.as_secs_f64(),
            sent.load(Ordering::Relaxed),
            received.load(Ordering::Relaxed)
        );
    }
}

/// The seconds with the most stalls over every viewer, at most 10, most first, with the
/// steal around each.
fn busiest_seconds(outcomes: &[ViewerOutcome], machine: &MachineTime) -> Vec<StallSecond> {
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

fn summarize(pauses: &[Pause]) -> PauseSummary {
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
fn tally(messages: Vec<String>) -> Vec<(String, usize)> {
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

fn print(r: &LoadReport) {
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
