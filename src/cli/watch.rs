//! `facewire watch`: a headless viewer. Connects to a viewer WebSocket, decodes every
//! frame and prints frames per second, latency per hop and bytes per frame.

use std::time::{Duration, Instant};

use futures_util::StreamExt;
use serde::Serialize;
use tokio_tungstenite::tungstenite::Message;

use super::play::with_token;
use super::serve::runtime;
use super::{print_json, CliResult};
use crate::server::config::Limits;
use crate::server::now_us;
use facewire_proto::messages::ServerMessage;
use facewire_proto::viewer_frame::decode;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Viewer URL, e.g. ws://127.0.0.1:8480/v1/heads/scan/streams/main/view?algo=C
    url: String,
    /// Stop after this many frames.
    #[arg(long)]
    frames: Option<u64>,
    /// Stop after this many seconds.
    #[arg(long)]
    seconds: Option<f64>,
    /// Print one JSON summary at the end instead of a line per second.
    #[arg(long)]
    json: bool,
    /// Viewer token, if the server wants one.
    #[arg(long)]
    token: Option<String>,
}

/// Latency statistics of one hop, milliseconds.
#[derive(Debug, Default, Serialize)]
struct Hop {
    mean_ms: f64,
    p99_ms: f64,
    max_ms: f64,
}

impl Hop {
    fn of(mut samples: Vec<f64>) -> Hop {
        if samples.is_empty() {
            return Hop::default();
        }
        samples.sort_by(f64::total_cmp);
        let p99 = samples[((samples.len() as f64 * 0.99).ceil() as usize).clamp(1, samples.len()) - 1];
        Hop {
            mean_ms: samples.iter().sum::<f64>() / samples.len() as f64,
            p99_ms: p99,
            max_ms: *samples.last().expect("not empty"),
        }
    }
}

#[derive(Debug, Serialize)]
struct Summary {
    algorithm: String,
    frames: u64,
    skipped: u64,
    seconds: f64,
    fps: f64,
    bytes_per_frame: f64,
    /// Parameters received to frame published (deform, roughness, encode).
    server: Hop,
    /// Frame published to received here.
    delivery: Hop,
    /// Parameters received by the server to frame received here.
    total: Hop,
    ended: Option<String>,
}

pub fn run(args: Args) -> CliResult {
    let url = with_token(&args.url, args.token.as_deref());
    runtime(&Limits::default())?.block_on(async move {
        let (mut socket, _) = tokio_tungstenite::connect_async(url.as_str())
            .await
            .map_err(|e| format!("cannot connect to {}: {e}", args.url))?;
        let started = Instant::now();
        let deadline = args.seconds.map(Duration::from_secs_f64);
        let (mut algorithm, mut ended) = (String::new(), None);
        let (mut frames, mut skipped, mut bytes, mut last_seq) = (0u64, 0u64, 0u64, None::<u64>);
        let (mut server, mut delivery, mut total) = (Vec::new(), Vec::new(), Vec::new());
        let mut last_print = Instant::now();
        let mut printed_frames = 0u64;
        loop {
            if args.frames.is_some_and(|n| frames >= n) || deadline.is_some_and(|d| started.elapsed() >= d) {
                break;
            }
            let next = tokio::time::timeout(Duration::from_millis(250), socket.next()).await;
            let message = match next {
                Err(_) => continue,
                Ok(None) => break,
                Ok(Some(message)) => message.map_err(|e| format!("connection failed: {e}"))?,
            };
            match message {
                Message::Text(text) => match serde_json::from_str::<ServerMessage>(text.as_str())? {
                    ServerMessage::Snapshot(s) => {
                        algorithm = s.algorithm.clone();
                        if !args.json {
                            println!("watching {} / {} with {} ({} vertices)", s.head, s.stream, s.algorithm, s.vertices);
                        }
                    }
                    ServerMessage::Error { code, message, .. } => return Err(format!("server refused: {code}: {message}").into()),
                    ServerMessage::End { reason, .. } => ended = Some(reason.to_string()),
                    ServerMessage::Ack { .. } | ServerMessage::Derived { .. } | ServerMessage::Replay { .. } => {}
                },
                Message::Binary(data) => {
                    let now = now_us();
                    let frame = decode(&data)?;
                    if let Some(previous) = last_seq.filter(|&p| frame.header.seq > p + 1) {
                        skipped += frame.header.seq - previous - 1;
                    }
                    last_seq = Some(frame.header.seq);
                    frames += 1;
                    bytes += data.len() as u64;
                    let h = frame.header;
                    server.push(h.server_send_us.saturating_sub(h.server_receive_us) as f64 / 1e3);
                    delivery.push(now.saturating_sub(h.server_send_us) as f64 / 1e3);
                    total.push(now.saturating_sub(h.server_receive_us) as f64 / 1e3);
                }
                Message::Close(_) => break,
                _ => {}
            }
            if !args.json && last_print.elapsed() >= Duration::from_secs(1) {
                let window = (frames - printed_frames) as f64 / last_print.elapsed().as_secs_f64();
                let recent = total.iter().rev().take((frames - printed_frames) as usize).copied().collect();
                let hop = Hop::of(recent);
                println!(
                    "{window:5.1} fps  total latency mean {:.2} ms p99 {:.2} ms  {:.0} bytes/frame  {skipped} skipped",
                    hop.mean_ms,
                    hop.p99_ms,
                    bytes as f64 / frames.max(1) as f64
                );
                last_print = Instant::now();
                printed_frames = frames;
            }
        }
        let seconds = started.elapsed().as_secs_f64();
        let summary = Summary {
            algorithm,
            frames,
            skipped,
            seconds,
            fps: frames as f64 / seconds.max(1e-9),
            bytes_per_frame: bytes as f64 / frames.max(1) as f64,
            server: Hop::of(server),
            delivery: Hop::of(delivery),
            total: Hop::of(total),
            ended,
        };
        if args.json {
            print_json(&summary)?;
        } else {
            println!(
                "{} frames in {:.1} s ({:.1} fps), {:.0} bytes/frame, latency ms (mean/p99): server {:.2}/{:.2}, delivery {:.2}/{:.2}, total {:.2}/{:.2}",
                summary.frames, summary.seconds, summary.fps, summary.bytes_per_frame,
                summary.server.mean_ms, summary.server.p99_ms, summary.delivery.mean_ms,
                summary.delivery.p99_ms, summary.total.mean_ms, summary.total.p99_ms
            );
        }
        Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
    })
}
