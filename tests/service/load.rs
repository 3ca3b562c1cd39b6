//! `facewire load` against a real `facewire serve`: the smoke run of docs/PERFORMANCE.md's
//! load section, small and short, asserting what a viewer must never see (no frames, a
//! stall, a frame older than one already shown), and the bounds the tool keeps.

use std::process::Command;

use crate::common::service::{connect, jaw_line, memory_config, next_json, next_message, Server};
use facewire_proto::messages::ServerMessage;
use facewire_proto::viewer_frame::decode;
use futures_util::SinkExt;
use tokio_tungstenite::tungstenite::Message;

fn load(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_facewire"))
        .arg("load")
        .args(args)
        .output()
        .expect("facewire runs")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_short_load_run_reaches_every_viewer_in_order_without_stalls() {
    let server = Server::spawn("[limits]\nmax_streams_per_head = 100\n").await;
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("load.json");
    let args: Vec<String> = [
        "--url",
        &server.http(""),
        "--streams",
        "3",
        "--viewers",
        "9",
        "--seconds",
        "2",
        "--fps",
        "20",
        "--json",
        json.to_str().unwrap(),
    ]
    .map(str::to_string)
    .to_vec();
    let out = tokio::task::spawn_blocking(move || load(&args.iter().map(String::as_str).collect::<Vec<_>>()))
        .await
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let count = |key: &str| report[key].as_u64().unwrap_or_else(|| panic!("{key}: {report}"));
    assert_eq!(count("frames_sent"), 3 * 40, "{report}");
    assert_eq!(count("frames_expected"), 9 * 40, "{report}");
    assert_eq!(count("viewers_without_frames"), 0, "{report}");
    assert_eq!(count("stalls"), 0, "{report}");
    assert_eq!(count("regressions"), 0, "{report}");
    assert!(count("frames_received") > 9 * 40 * 9 / 10, "{report}");
    assert_eq!(report["failures"], serde_json::json!([]), "{report}");
    let latency = &report["latency_ms"];
    assert!(latency["samples"].as_u64().unwrap() > 0, "{report}");
    assert!(latency["p50"].as_f64().unwrap() > 0.0, "{report}");
    assert!(
        latency["p99"].as_f64().unwrap() <= latency["max"].as_f64().unwrap(),
        "{report}"
    );
    assert!(report["bytes_per_frame"].as_f64().unwrap() > 100.0, "{report}");
    let usage = &report["server"];
    assert!(usage["cpu_percent"].as_f64().unwrap() > 0.0, "{report}");
    assert!(usage["resident_mib_after"].as_f64().unwrap() > 1.0, "{report}");
    // The head it registered for the run is gone again.
    let heads: serde_json::Value = reqwest::get(server.http("/v1/heads"))
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(heads.as_array().map(Vec::len), Some(0), "{heads}");

    // The naive JSON baseline through the same tool: far more bytes for the same frames.
    let fwf1_bytes = report["bytes_per_frame"].as_f64().unwrap();
    let json_args = [
        "--url",
        &server.http(""),
        "--streams",
        "1",
        "--viewers",
        "2",
        "--seconds",
        "1",
        "--format",
        "json",
        "--json",
        json.to_str().unwrap(),
    ]
    .map(str::to_string);
    let out =
        tokio::task::spawn_blocking(move || load(&json_args.iter().map(String::as_str).collect::<Vec<_>>()))
            .await
            .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(report["format"], "json", "{report}");
    assert_eq!(report["viewers_without_frames"], 0, "{report}");
    assert_eq!(report["regressions"], 0, "{report}");
    // 4,352 vertices of three numbers: at least "0.0," each.
    let json_bytes = report["bytes_per_frame"].as_f64().unwrap();
    assert!(json_bytes > 4352.0 * 3.0 * 4.0, "{report}");
    assert!(
        json_bytes > 10.0 * fwf1_bytes,
        "{json_bytes} against {fwf1_bytes}"
    );

    // With the voice on every stream, heard in the server's Opus: all of it, in order,
    // without gaps, under the 4 kB/s a viewer the protocol budgets.
    let audio_args = [
        "--url",
        &server.http(""),
        "--streams",
        "2",
        "--viewers",
        "4",
        "--seconds",
        "2",
        "--audio",
        "opus",
        "--json",
        json.to_str().unwrap(),
    ]
    .map(str::to_string);
    let out =
        tokio::task::spawn_blocking(move || load(&audio_args.iter().map(String::as_str).collect::<Vec<_>>()))
            .await
            .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let audio = &report["audio"];
    assert_eq!(audio["codec"], "opus", "{report}");
    // 2 s of 20 ms chunks on each of 2 streams; 2 viewers each hear 4 s of sound in all
    // but the last 40 ms packet's part, which waits for samples that never come.
    assert_eq!(audio["chunks_sent"], 200, "{report}");
    assert_eq!(audio["seconds_expected"].as_f64(), Some(8.0), "{report}");
    let heard = audio["seconds_received"].as_f64().unwrap();
    assert!((7.8..8.0 + 1e-9).contains(&heard), "{report}");
    assert_eq!(audio["gaps"], 0, "{report}");
    assert_eq!(audio["regressions"], 0, "{report}");
    assert!(audio["latency_ms"]["samples"].as_u64().unwrap() > 0, "{report}");
    let per_second = audio["bytes_per_viewer_second"].as_f64().unwrap();
    assert!((1_000.0..4_000.0).contains(&per_second), "{report}");
    assert_eq!(report["stalls"], 0, "{report}");

    // The voice alone (--derive): the server derives every stream's face, each frame's
    // latency counted from the chunk holding its instant, so at least the look-ahead
    // less the 20 ms a chunk holds (docs/SPEECH.md, "Latency").
    let derive_args = [
        "--url",
        &server.http(""),
        "--streams",
        "2",
        "--viewers",
        "4",
        "--seconds",
        "2",
        "--fps",
        "25",
        "--audio",
        "pcm",
        "--derive",
        "--json",
        json.to_str().unwrap(),
    ]
    .map(str::to_string);
    let out = tokio::task::spawn_blocking(move || {
        load(&derive_args.iter().map(String::as_str).collect::<Vec<_>>())
    })
    .await
    .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    // 2 s at 25 fps on 2 streams.
    assert_eq!(report["frames_sent"], 100, "{report}");
    assert_eq!(report["viewers_without_frames"], 0, "{report}");
    assert_eq!(report["regressions"], 0, "{report}");
    let received = report["frames_received"].as_u64().unwrap();
    assert!(received >= 190, "4 viewers of 50 frames each: {report}");
    let median = report["latency_ms"]["p50"].as_f64().unwrap();
    assert!((30.0..150.0).contains(&median), "{report}");
    server.stop().await;
}

/// The JSON baseline and FWF1 carry the same head: every JSON position is the rest
/// position plus the binary frame's quantized delta, to within half a step.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn json_baseline_frames_hold_the_positions_fwf1_quantizes() {
    let server = Server::start(memory_config()).await;
    server.register("mh", "makehuman_head", "").await;
    let view = |format: &str| server.ws(&format!("/v1/heads/mh/streams/s/view?format={format}"));
    let (mut binary, mut text) = (connect(&view("fwf1")).await, connect(&view("json")).await);
    for socket in [&mut binary, &mut text] {
        assert!(matches!(next_json(socket).await, ServerMessage::Snapshot(_)));
    }
    let mut producer = connect(&server.ws("/v1/heads/mh/streams/s/produce")).await;
    producer
        .send(Message::Text(jaw_line(3, 0.1).into()))
        .await
        .unwrap();
    let frame = match next_message(&mut binary).await {
        Some(Message::Binary(bytes)) => decode(&bytes).unwrap(),
        other => panic!("expected a binary frame, got {other:?}"),
    };
    let json: serde_json::Value = match next_message(&mut text).await {
        Some(Message::Text(text)) => serde_json::from_str(text.as_str()).unwrap(),
        other => panic!("expected a JSON frame, got {other:?}"),
    };
    assert_eq!(
        (json["type"].as_str(), json["seq"].as_u64()),
        (Some("frame"), Some(3))
    );
    let rest = crate::common::obj_positions(&crate::common::data("heads/makehuman_head.obj"));
    let positions = json["positions"].as_array().unwrap();
    assert_eq!(positions.len(), rest.len());
    let mut expected = rest.clone();
    for &(vertex, counts) in &frame.moved {
        for k in 0..3 {
            expected[vertex as usize][k] += counts[k] as f32 * frame.step;
        }
    }
    assert!(
        frame.moved.len() > 100,
        "the jaw moves the chin: {}",
        frame.moved.len()
    );
    for (v, (position, expected)) in positions.iter().zip(&expected).enumerate() {
        for k in 0..3 {
            let got = position[k].as_f64().unwrap() as f32;
            assert!(
                (got - expected[k]).abs() <= frame.step * 0.5 + 1e-5,
                "vertex {v} axis {k}: JSON {got}, FWF1 {}",
                expected[k]
            );
        }
    }
    let bad = server.ws("/v1/heads/mh/streams/s/view?format=xml");
    let mut refused = connect(&bad).await;
    match next_json(&mut refused).await {
        ServerMessage::Error { message, .. } => assert!(message.contains("format=xml"), "{message}"),
        other => panic!("expected an error, got {other:?}"),
    }
    server.stop().await;
}

#[test]
fn counts_durations_and_remote_targets_are_refused_by_name() {
    for (args, wanted) in [
        (vec!["--url", "http://10.1.2.3:8480"], "--allow-remote"),
        (
            vec!["--url", "http://127.0.0.1:1", "--streams", "0"],
            "--streams 0: must be 1 to 10000",
        ),
        (
            vec!["--url", "http://127.0.0.1:1", "--viewers", "100001"],
            "--viewers 100001",
        ),
        (
            vec!["--url", "http://127.0.0.1:1", "--seconds", "4000"],
            "--seconds 4000",
        ),
        (vec!["--url", "http://127.0.0.1:1", "--fps", "0"], "--fps 0"),
        (
            vec!["--url", "http://127.0.0.1:1", "--derive"],
            "--derive: the face is derived from the voice, so give --audio too",
        ),
        (vec!["--url", "ws://127.0.0.1:1"], "expected http://HOST:PORT"),
    ] {
        let out = load(&args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} should fail");
        assert!(stderr.contains(wanted), "{args:?}: {stderr}");
    }
}
