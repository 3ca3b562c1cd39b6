//! Service load: C channels on one head, each with a producer at 30 fps (the syllable
//! stream) and V viewers, all on loopback in this process (so the clients share the
//! machine's cores with the server). Reports producer-to-viewer latency (producer send to
//! viewer receipt) and how many frames viewers skipped.
//!
//! `cargo bench --bench service -- [channels] [viewers_per_channel] [seconds] [algo]`
//! (defaults: 50 channels, 4 viewers each, 10 s, the server's default algorithm).

use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use facewire::mask::Mask;
use facewire::server::{now_us, serve, AppState, Config};
use facewire::stream::{open_stream, JsonlWriter};
use futures_util::{SinkExt, StreamExt};
use tokio_tungstenite::tungstenite::Message;

/// Send time of recent frames per channel, indexed by seq modulo this.
const SLOTS: usize = 1024;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with('-')).collect();
    let arg = |i: usize, default: &str| args.get(i).cloned().unwrap_or_else(|| default.to_string());
    let channels: usize = arg(0, "50").parse().expect("channels");
    let per_channel: usize = arg(1, "4").parse().expect("viewers per channel");
    let seconds: f64 = arg(2, "10").parse().expect("seconds");
    let algo = arg(3, "");
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    runtime.block_on(run(channels, per_channel, seconds, algo));
}

async fn run(channels: usize, per_channel: usize, seconds: f64, algo: String) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
    let state = AppState::new(Config {
        addr: "127.0.0.1:0".parse().unwrap(),
        data_dir: None,
        limits: facewire::server::config::Limits {
            max_viewers: 100_000,
            max_streams_per_head: 10_000,
            max_connections: 100_000,
            ..Default::default()
        },
        ..Config::default()
    })
    .unwrap();
    let (tx, rx) = tokio::sync::oneshot::channel();
    tokio::spawn(serve(state.clone(), move |addr| {
        let _ = tx.send(addr);
    }));
    let addr = rx.await.unwrap();
    let body = serde_json::json!({
        "id": "h",
        "obj": std::fs::read_to_string(root.join("heads/makehuman_head.obj")).unwrap(),
        "fit": std::fs::read_to_string(root.join("heads/makehuman_head.fit.toml")).unwrap(),
    });
    let client = reqwest::Client::new();
    client
        .post(format!("http://{addr}/v1/heads"))
        .json(&body)
        .send()
        .await
        .unwrap();
    while state.registry.get("h").and_then(|h| h.ready().ok()).is_none() {
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let mask = Mask::candide3();
    let lines: Vec<String> = open_stream(&root.join("streams/syllables.jsonl"), &mask)
        .unwrap()
        .map(|f| {
            let mut writer = JsonlWriter::new(Vec::new(), &mask);
            writer.write_frame(&f.unwrap()).unwrap();
            String::from_utf8(writer.into_inner().unwrap()).unwrap()
        })
        .collect();
    let frames: Vec<(f64, serde_json::Value)> = lines
        .iter()
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).unwrap();
            (v["t"].as_f64().unwrap(), v)
        })
        .collect();

    let sent_at: Vec<Arc<Vec<AtomicU64>>> = (0..channels)
        .map(|_| Arc::new((0..SLOTS).map(|_| AtomicU64::new(0)).collect()))
        .collect();
    let query = if algo.is_empty() {
        String::new()
    } else {
        format!("?algo={algo}")
    };
    let mut viewers = Vec::new();
    for (c, channel_sent) in sent_at.iter().enumerate() {
        for _ in 0..per_channel {
            let url = format!("ws://{addr}/v1/heads/h/streams/c{c}/view{query}");
            let (mut socket, _) = tokio_tungstenite::connect_async(url.as_str()).await.unwrap();
            let sent = channel_sent.clone();
            viewers.push(tokio::spawn(async move {
                let (mut latencies, mut received, mut skipped, mut last) =
                    (Vec::new(), 0u64, 0u64, None::<u64>);
                let deadline = tokio::time::Instant::now() + Duration::from_secs_f64(seconds + 2.0);
                while let Ok(Some(Ok(message))) = tokio::time::timeout_at(deadline, socket.next()).await {
                    if let Message::Binary(bytes) = message {
                        let now = now_us();
                        let seq = u64::from_le_bytes(bytes[8..16].try_into().unwrap());
                        let at = sent[seq as usize % SLOTS].load(Ordering::Acquire);
                        if at > 0 && now >= at {
                            latencies.push((now - at) as f64 / 1e3);
                        }
                        if let Some(p) = last.filter(|&p| seq > p + 1) {
                            skipped += seq - p - 1;
                        }
                        last = Some(seq);
                        received += 1;
                    }
                }
                (latencies, received, skipped)
            }));
        }
    }
    let start = tokio::time::Instant::now();
    let total_frames = (seconds * 30.0) as u64;
    let mut producers = Vec::new();
    for (c, sent) in sent_at.iter().enumerate() {
        let url = format!("ws://{addr}/v1/heads/h/streams/c{c}/produce");
        let (socket, _) = tokio_tungstenite::connect_async(url.as_str()).await.unwrap();
        let (mut tx, mut rx) = socket.split();
        tokio::spawn(async move { while rx.next().await.is_some() {} });
        let frames = frames.clone();
        let sent = sent.clone();
        // Spread the channels' frame times over one frame period.
        let offset = Duration::from_secs_f64(c as f64 / channels as f64 / 30.0);
        producers.push(tokio::spawn(async move {
            for seq in 0..total_frames {
                tokio::time::sleep_until(start + offset + Duration::from_secs_f64(seq as f64 / 30.0)).await;
                let mut frame = frames[seq as usize % frames.len()].1.clone();
                frame["seq"] = seq.into();
                frame["t"] = (seq as f64 / 30.0).into();
                let text = frame.to_string();
                sent[seq as usize % SLOTS].store(now_us(), Ordering::Release);
                if tx.send(Message::Text(text.into())).await.is_err() {
                    break;
                }
            }
        }));
    }
    for p in producers {
        p.await.unwrap();
    }
    let (mut all, mut received, mut skipped) = (Vec::new(), 0u64, 0u64);
    for v in viewers {
        let (l, r, s) = v.await.unwrap();
        all.extend(l);
        received += r;
        skipped += s;
    }
    all.sort_by(f64::total_cmp);
    let pct = |p: f64| all[((all.len() as f64 * p).ceil() as usize).clamp(1, all.len()) - 1];
    let expected = total_frames * (channels * per_channel) as u64;
    println!(
        "{channels} channels x {per_channel} viewers, {seconds} s at 30 fps ({} algorithm):",
        if algo.is_empty() { "default" } else { algo.as_str() }
    );
    println!(
        "  frames received {received} of {expected} ({:.1} %), skipped {skipped}",
        100.0 * received as f64 / expected as f64
    );
    println!(
        "  producer-to-viewer latency ms: p50 {:.2}  p90 {:.2}  p99 {:.2}  max {:.2}",
        pct(0.5),
        pct(0.9),
        pct(0.99),
        all.last().copied().unwrap_or(0.0)
    );
    state.shutdown.cancel();
}
