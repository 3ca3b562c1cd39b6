//! One load run: viewers connected first (so every one sees the first frame), producers
//! started at their spread times, every outcome gathered, and the report made of them.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant as StdInstant};

use tokio::time::Instant;

use super::client::{register, READY_WITHIN};
use super::latency::Latencies;
use super::pauses::{explained_by_host, PauseWatch};
use super::plan::syllable_frames;
use super::producer::{produce, ProducerPlan, Sent, VoicePlan};
use super::report::{busiest_seconds, summarize, tally, AudioReport, LatencySummary, LoadReport};
use super::send_times::SendTimes;
use super::server_metrics::{self, ServerSample};
use super::viewer::{self, ViewerOutcome, ViewerPlan};
use super::{Args, STALL_PERIODS};
use crate::cli::head_client::HeadClient;
use crate::server::process::cpu_seconds;

pub(super) async fn load(
    args: &Args,
    base: &str,
    view_bases: &[String],
) -> Result<LoadReport, Box<dyn std::error::Error + Send + Sync>> {
    let http = reqwest::Client::new();
    let client = HeadClient::new(base, args.token.as_deref());
    let with_token = |url: &str| client.with_token(url);
    let (head, registered) = match &args.head {
        Some(head) => (head.clone(), false),
        None => (register(&client).await?, true),
    };
    // Every node registers a cluster's head itself: wait until the viewers' nodes have it.
    for node in view_bases {
        HeadClient::new(node, args.token.as_deref())
            .wait_ready(&head, READY_WITHIN)
            .await?;
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
