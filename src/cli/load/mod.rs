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

mod client;
mod latency;
mod pauses;
mod plan;
mod producer;
mod report;
mod run;
mod send_times;
mod server_metrics;
mod viewer;

use serde::Serialize;

use super::{CliResult, FilePath};
use plan::check;
use report::print;
use run::load;

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
