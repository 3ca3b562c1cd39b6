//! The service under abuse, through real sockets: no frame lost before an end, every end
//! with a reason, nothing a client creates without a limit and an end, no connection held
//! forever, and a shutdown that finishes and reaches every client.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use crate::common::service::{
    close_code, connect, jaw_line, memory_config, next_json, next_message, post, until_end, Server,
};
use facewire::server::config::Limits;
use facewire::server::Config;
use facewire_proto::messages::ServerMessage;
use futures_util::SinkExt;
use tokio_tungstenite::tungstenite::Message;

fn limits(f: impl FnOnce(&mut Limits)) -> Config {
    let mut config = memory_config();
    f(&mut config.limits);
    config
}

fn batch_body(frames: usize, dt: f64) -> String {
    (0..frames)
        .map(|i| jaw_line(i as u64, i as f64 * dt) + "\n")
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_batch_frame_reaches_viewers_before_the_end() {
    let server = Server::start(memory_config()).await;
    server.register("mh", "makehuman_head", "").await;
    for (stream, frames) in [("eight", 8), ("one", 1)] {
        let mut viewer = connect(&server.ws(&format!("/v1/heads/mh/streams/{stream}/view"))).await;
        assert!(matches!(next_json(&mut viewer).await, ServerMessage::Snapshot(_)));
        let path = format!("/v1/heads/mh/streams/{stream}/batch");
        let (status, body) = post(&server, &path, batch_body(frames, 0.01), "application/x-ndjson").await;
        assert_eq!(status, 202, "{body}");
        let (seqs, reason) = until_end(&mut viewer).await;
        assert_eq!(reason, "batch_finished");
        assert_eq!(seqs.last(), Some(&(frames as u64 - 1)), "{stream}: {seqs:?}");
    }
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn back_to_back_frames_then_end_keep_the_last_frame_and_end_is_answered() {
    let server = Server::start(memory_config()).await;
    server.register("mh", "makehuman_head", "").await;
    for trial in 0..5 {
        let stream = format!("t{trial}");
        let mut viewer = connect(&server.ws(&format!("/v1/heads/mh/streams/{stream}/view?algo=K"))).await;
        assert!(matches!(next_json(&mut viewer).await, ServerMessage::Snapshot(_)));
        let mut producer = connect(&server.ws(&format!("/v1/heads/mh/streams/{stream}/produce"))).await;
        for seq in 0..30 {
            producer
                .send(Message::Text(jaw_line(seq, seq as f64 * 0.001).into()))
                .await
                .unwrap();
        }
        producer
            .send(Message::Text(r#"{"type":"end"}"#.into()))
            .await
            .unwrap();
        for seq in 0..30 {
            assert!(matches!(next_json(&mut producer).await, ServerMessage::Ack { seq: s, .. } if s == seq));
        }
        // The producer's end is answered with end, then a normal close.
        match next_json(&mut producer).await {
            ServerMessage::End { reason, .. } => assert_eq!(reason.as_str(), "producer_ended"),
            other => panic!("expected end, got {other:?}"),
        }
        assert_eq!(close_code(&mut producer).await, 1000);
        let (seqs, reason) = until_end(&mut viewer).await;
        assert_eq!(reason, "producer_ended");
        assert_eq!(seqs.last(), Some(&29), "trial {trial}: {seqs:?}");
    }
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn producers_that_vanish_or_idle_end_their_stream_with_a_reason() {
    let server = Server::start(limits(|l| l.producer_idle_s = 0.3)).await;
    server.register("mh", "makehuman_head", "").await;

    let mut viewer = connect(&server.ws("/v1/heads/mh/streams/gone/view")).await;
    next_json(&mut viewer).await;
    let mut producer = connect(&server.ws("/v1/heads/mh/streams/gone/produce")).await;
    producer
        .send(Message::Text(jaw_line(0, 0.0).into()))
        .await
        .unwrap();
    next_json(&mut producer).await;
    drop(producer);
    let (seqs, reason) = until_end(&mut viewer).await;
    assert_eq!(
        (seqs.as_slice(), reason.as_str()),
        (&[0][..], "producer_disconnected")
    );

    let mut viewer = connect(&server.ws("/v1/heads/mh/streams/idle/view")).await;
    next_json(&mut viewer).await;
    let mut producer = connect(&server.ws("/v1/heads/mh/streams/idle/produce")).await;
    producer
        .send(Message::Text(jaw_line(0, 0.0).into()))
        .await
        .unwrap();
    next_json(&mut producer).await;
    match next_json(&mut producer).await {
        ServerMessage::Error { code, .. } => assert_eq!(code.as_str(), "idle"),
        other => panic!("expected idle, got {other:?}"),
    }
    assert_eq!(close_code(&mut producer).await, 4408);
    let (_, reason) = until_end(&mut viewer).await;
    assert_eq!(reason, "producer_idle");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_deleted_head_stops_streaming_and_its_id_can_be_registered_again() {
    let server = Server::start(memory_config()).await;
    let first = server.register("h", "makehuman_head", "").await;
    let mut viewer = connect(&server.ws("/v1/heads/h/streams/s/view")).await;
    next_json(&mut viewer).await;
    let mut producer = connect(&server.ws("/v1/heads/h/streams/s/produce")).await;
    producer
        .send(Message::Text(jaw_line(0, 0.0).into()))
        .await
        .unwrap();
    next_json(&mut producer).await;
    let deleted = reqwest::Client::new()
        .delete(server.http("/v1/heads/h"))
        .send()
        .await
        .unwrap();
    assert_eq!(deleted.status(), 204);
    for socket in [&mut producer, &mut viewer] {
        loop {
            match next_json(socket).await {
                ServerMessage::End { reason, .. } => {
                    assert_eq!(reason.as_str(), "head_deleted");
                    break;
                }
                ServerMessage::Ack { .. } => {}
                other => panic!("expected end, got {other:?}"),
            }
        }
        assert_eq!(close_code(socket).await, 4410);
    }
    // The same id, another head: a new viewer sees the new head.
    let second = server.register("h", "lee_perry_smith_head", "").await;
    assert_ne!(first.vertices, second.vertices);
    let mut viewer = connect(&server.ws("/v1/heads/h/streams/s/view")).await;
    match next_json(&mut viewer).await {
        ServerMessage::Snapshot(s) => assert_eq!(s.vertices, second.vertices),
        other => panic!("expected a snapshot, got {other:?}"),
    }
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn batches_are_bounded_and_can_be_cancelled() {
    let server = Server::start(limits(|l| l.max_batch_duration_s = 60.0)).await;
    server.register("mh", "makehuman_head", "").await;
    let path = "/v1/heads/mh/streams/b/batch";
    // A second frame at t = 1e300, and a valid batch spanning 1e9 s: refused up front.
    let body = format!("{}\n{}\n", jaw_line(0, 0.0), jaw_line(1, 1e300));
    let (status, body) = post(&server, path, body, "application/x-ndjson").await;
    assert!([400, 413].contains(&status), "{status} {body}");
    let body = format!("{}\n{}\n", jaw_line(0, 0.0), jaw_line(1, 1e9));
    let (status, body) = post(&server, path, body, "application/x-ndjson").await;
    assert_eq!(
        (status, body["error"].as_str()),
        (413, Some("too_long")),
        "{body}"
    );
    // A .fap with an absurd frame rate is refused, and the stream is still free.
    let fap = "2.1 xface 1e-300 3\n1 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0\n0\n";
    let (status, body) = post(&server, path, fap.to_string(), "application/x-fap").await;
    assert_eq!(status, 400, "{body}");

    // A 50 s batch, cancelled after its first frames.
    let mut viewer = connect(&server.ws("/v1/heads/mh/streams/b/view")).await;
    next_json(&mut viewer).await;
    let (status, body) = post(&server, path, batch_body(500, 0.1), "application/x-ndjson").await;
    assert_eq!(status, 202, "{body}");
    let (busy, _) = post(&server, path, batch_body(2, 0.1), "application/x-ndjson").await;
    assert_eq!(busy, 409);
    tokio::time::sleep(Duration::from_millis(300)).await;
    let client = reqwest::Client::new();
    let cancelled = client
        .delete(server.http("/v1/heads/mh/streams/b/producer"))
        .send()
        .await
        .unwrap();
    assert_eq!(cancelled.status(), 204);
    let (seqs, reason) = until_end(&mut viewer).await;
    assert_eq!(reason, "producer_cancelled");
    assert!(seqs.len() < 100, "{seqs:?}");
    // The cancel answers once the producer has let go: a second finds none, and the
    // stream takes a new batch at once.
    let again = client
        .delete(server.http("/v1/heads/mh/streams/b/producer"))
        .send()
        .await
        .unwrap();
    assert_eq!(again.status(), 404);
    let (status, body) = post(&server, path, batch_body(2, 0.01), "application/x-ndjson").await;
    assert_eq!(status, 202, "the stream is free again: {body}");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cancelled_producer_that_never_answers_the_close_frees_its_stream_at_once() {
    let server = Server::start(memory_config()).await;
    server.register("mh", "makehuman_head", "").await;
    let produce = server.ws("/v1/heads/mh/streams/c/produce");
    let mut producer = connect(&produce).await;
    producer
        .send(Message::Text(jaw_line(0, 0.0).into()))
        .await
        .unwrap();
    next_json(&mut producer).await;
    // The client stops reading: it will not answer the server's close frame.
    let started = Instant::now();
    let cancelled = reqwest::Client::new()
        .delete(server.http("/v1/heads/mh/streams/c/producer"))
        .send()
        .await
        .unwrap();
    assert_eq!(cancelled.status(), 204);
    assert!(
        started.elapsed() < Duration::from_secs(1),
        "{:?}",
        started.elapsed()
    );
    let mut next = connect(&produce).await;
    next.send(Message::Text(jaw_line(0, 0.0).into())).await.unwrap();
    assert!(
        matches!(next_json(&mut next).await, ServerMessage::Ack { seq: 0, .. }),
        "the stream takes a new producer at once"
    );
    drop(producer);
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn half_open_connections_and_slow_bodies_time_out() {
    let server = Server::start(limits(|l| {
        l.header_timeout_s = 0.5;
        l.request_timeout_s = 1.0;
    }))
    .await;
    let addr = server.addr;
    let closed_within = move |prefix: &'static [u8]| {
        std::thread::spawn(move || {
            let mut tcp = std::net::TcpStream::connect(addr).unwrap();
            tcp.write_all(prefix).unwrap();
            tcp.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
            let started = Instant::now();
            let mut answer = Vec::new();
            let _ = tcp.read_to_end(&mut answer);
            (started.elapsed(), String::from_utf8_lossy(&answer).into_owned())
        })
    };
    // Nothing sent, and half the headers: closed after the header timeout.
    for prefix in [&b""[..], &b"GET /healthz HTTP/1.1\r\nHost: x\r\n"[..]] {
        let (elapsed, _) = closed_within(prefix).join().unwrap();
        assert!(elapsed < Duration::from_secs(3), "{elapsed:?}");
    }
    // A body shorter than its Content-Length: 408 with a JSON error.
    let (elapsed, answer) = closed_within(
        b"POST /v1/heads HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 1000\r\n\r\n{\"id\":",
    )
    .join()
    .unwrap();
    assert!(elapsed < Duration::from_secs(5), "{elapsed:?}");
    assert!(answer.starts_with("HTTP/1.1 408"), "{answer}");
    assert!(answer.contains("\"error\":\"timeout\""), "{answer}");
    // The server still answers.
    assert_eq!(reqwest::get(server.http("/healthz")).await.unwrap().status(), 200);
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn shutdown_closes_every_viewer_with_a_reason_and_finishes_despite_half_sent_requests() {
    for _ in 0..3 {
        let server = Server::start(limits(|l| l.shutdown_grace_s = 2.0)).await;
        server.register("mh", "makehuman_head", "").await;
        let mut viewers = Vec::new();
        for i in 0..10 {
            let mut viewer = connect(&server.ws(&format!("/v1/heads/mh/streams/s{}/view", i % 3))).await;
            next_json(&mut viewer).await;
            viewers.push(viewer);
        }
        // A request that never finishes its body.
        let mut stuck = std::net::TcpStream::connect(server.addr).unwrap();
        stuck
            .write_all(b"POST /v1/heads HTTP/1.1\r\nHost: x\r\nContent-Length: 100\r\n\r\n{")
            .unwrap();
        let started = Instant::now();
        let stopping = tokio::spawn(server.stop());
        for viewer in &mut viewers {
            match next_json(viewer).await {
                ServerMessage::End { reason, .. } => assert_eq!(reason.as_str(), "server_shutdown"),
                other => panic!("expected end, got {other:?}"),
            }
            assert_eq!(close_code(viewer).await, 1001);
            let _ = viewer.close(None).await;
        }
        stopping.await.unwrap();
        assert!(
            started.elapsed() < Duration::from_secs(5),
            "{:?}",
            started.elapsed()
        );
        drop(stuck);
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn streams_and_algorithms_are_bounded_and_end_when_their_viewers_leave() {
    // Memory over thousands of stream names and hundreds of bindings is measured by
    // `benches/stream_churn_memory.py` (docs/PERFORMANCE.md); this holds the limits and the
    // ends.
    let server = Server::spawn(
        "default_algorithm = \"U\"\n[limits]\nmax_streams_per_head = 4\nstream_linger_s = 0.05\nmax_bindings_per_head = 2\n",
    )
    .await;
    server.register("mh", "makehuman_head", "").await;
    // Stream names are validated like head ids.
    let mut bad = connect(&server.ws("/v1/heads/mh/streams/Not%20OK/view")).await;
    match next_json(&mut bad).await {
        ServerMessage::Error { code, .. } => assert_eq!(code.as_str(), "bad_id"),
        other => panic!("expected bad_id, got {other:?}"),
    }
    assert_eq!(close_code(&mut bad).await, 4400);
    // A fifth live stream is refused while four are watched.
    let mut held = Vec::new();
    for i in 0..4 {
        let mut viewer = connect(&server.ws(&format!("/v1/heads/mh/streams/held{i}/view"))).await;
        next_json(&mut viewer).await;
        held.push(viewer);
    }
    let mut fifth = connect(&server.ws("/v1/heads/mh/streams/fifth/view")).await;
    match next_json(&mut fifth).await {
        ServerMessage::Error { code, .. } => assert_eq!(code.as_str(), "limit_reached"),
        other => panic!("expected limit_reached, got {other:?}"),
    }
    assert_eq!(close_code(&mut fifth).await, 4503);
    // Two algorithms in use: a third is refused until one is free.
    let mut algo_c = connect(&server.ws("/v1/heads/mh/streams/held0/view?algo=C")).await;
    next_json(&mut algo_c).await;
    let mut algo_e = connect(&server.ws("/v1/heads/mh/streams/held1/view?algo=E")).await;
    match next_json(&mut algo_e).await {
        ServerMessage::Error { code, .. } => assert_eq!(code.as_str(), "limit_reached"),
        other => panic!("expected limit_reached, got {other:?}"),
    }
    drop(algo_c);
    for viewer in held.drain(..) {
        drop(viewer);
    }
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert!(server.info("mh", "").await.streams.is_empty());

    // Stream names and algorithms come and go: one viewer per name, one in ten asking for
    // another algorithm (each bound, then evicted); nothing is left behind.
    for i in 0..60usize {
        let algo = match i % 10 {
            0 => format!("point_distance:k={}", 2 + i / 10),
            _ => String::new(),
        };
        let url = server.ws(&format!("/v1/heads/mh/streams/n{i}/view?algo={algo}"));
        // Room comes back as soon as the streams before have lingered out.
        let mut tries = 0;
        let mut viewer = loop {
            let mut viewer = connect(&url).await;
            match next_json(&mut viewer).await {
                ServerMessage::Snapshot(_) => break viewer,
                ServerMessage::Error { code, .. } if code.as_str() == "limit_reached" && tries < 200 => {
                    tries += 1;
                    tokio::time::sleep(Duration::from_millis(10)).await;
                }
                other => panic!("viewer {i}: {other:?}"),
            }
        };
        viewer.close(None).await.unwrap();
        while next_message(&mut viewer).await.is_some() {}
    }
    tokio::time::sleep(Duration::from_millis(300)).await;
    let info = server.info("mh", "").await;
    assert!(info.streams.is_empty(), "{:?}", info.streams);
    assert!(info.algorithms.len() <= 2, "{:?}", info.algorithms);
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn broken_stored_heads_are_reported_and_leftovers_cleaned() {
    let dir = tempfile::tempdir().unwrap();
    let heads = dir.path().join("heads");
    for folder in ["Bad Name", "partial", "corrupt"] {
        std::fs::create_dir_all(heads.join(folder)).unwrap();
    }
    std::fs::write(heads.join("partial/head.obj"), "v 0 0 0\n").unwrap();
    std::fs::write(heads.join("corrupt/head.json"), "{").unwrap();
    std::fs::write(heads.join(".tmpLeft"), "half").unwrap();
    let server = Server::start(Config {
        data_dir: Some(dir.path().to_path_buf()),
        ..Config::default()
    })
    .await;
    let listed: Vec<facewire_proto::messages::HeadInfo> = reqwest::get(server.http("/v1/heads"))
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(listed.len(), 1);
    assert_eq!(
        (listed[0].id.as_str(), listed[0].status.as_str()),
        ("corrupt", "failed")
    );
    let health = server.healthz().await;
    assert!(
        health["stored_problems"][0]
            .as_str()
            .unwrap()
            .contains("Bad Name"),
        "{health}"
    );
    assert!(!heads.join("partial").exists() && !heads.join(".tmpLeft").exists());
    let deleted = reqwest::Client::new()
        .delete(server.http("/v1/heads/corrupt"))
        .send()
        .await
        .unwrap();
    assert_eq!(deleted.status(), 204);
    assert!(!heads.join("corrupt").exists());
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn oversized_and_malformed_producer_messages_close_with_the_right_code() {
    let server = Server::start(limits(|l| l.max_message_bytes = 4096)).await;
    server.register("mh", "makehuman_head", "").await;
    // Text that is not UTF-8: close 1007, not a dropped connection.
    let (mut tcp, _) = tokio_tungstenite::connect_async(server.ws("/v1/heads/mh/streams/u/produce"))
        .await
        .unwrap();
    let raw = tokio_tungstenite::tungstenite::protocol::frame::Frame::message(
        vec![0xff, 0xfe, b'{'],
        tokio_tungstenite::tungstenite::protocol::frame::coding::OpCode::Data(
            tokio_tungstenite::tungstenite::protocol::frame::coding::Data::Text,
        ),
        true,
    );
    tcp.send(Message::Frame(raw)).await.unwrap();
    assert_eq!(close_code(&mut tcp).await, 1007);
    // A 65 MiB batch: a JSON 413.
    let (status, body) = post(
        &server,
        "/v1/heads/mh/streams/u/batch",
        "x".repeat(65 << 20),
        "application/x-ndjson",
    )
    .await;
    assert_eq!(
        (status, body["error"].as_str()),
        (413, Some("too_large")),
        "{body}"
    );
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_viewer_that_sends_a_large_message_is_closed_and_others_keep_watching() {
    let server = Server::start(memory_config()).await;
    server.register("mh", "makehuman_head", "").await;
    let view = server.ws("/v1/heads/mh/streams/s/view");
    let mut rude = connect(&view).await;
    let mut polite = connect(&view).await;
    for socket in [&mut rude, &mut polite] {
        assert!(matches!(next_json(socket).await, ServerMessage::Snapshot(_)));
    }
    // Viewers have nothing to say beyond control frames: 64 KiB is refused with 1009.
    rude.send(Message::Binary(vec![0u8; 64 << 10].into()))
        .await
        .unwrap();
    assert_eq!(close_code(&mut rude).await, 1009);
    let mut producer = connect(&server.ws("/v1/heads/mh/streams/s/produce")).await;
    producer
        .send(Message::Text(jaw_line(0, 0.0).into()))
        .await
        .unwrap();
    assert!(matches!(
        next_json(&mut producer).await,
        ServerMessage::Ack { seq: 0, .. }
    ));
    assert_eq!(
        crate::common::service::next_frame(&mut polite).await.header.seq,
        0
    );
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn extreme_values_are_refused_in_both_formats_with_field_and_seq() {
    let server = Server::start(memory_config()).await;
    server.register("mh", "makehuman_head", "").await;
    let mut producer = connect(&server.ws("/v1/heads/mh/streams/x/produce")).await;
    let refused = async |producer: &mut crate::common::service::Socket, message: Message| {
        producer.send(message).await.unwrap();
        match next_json(producer).await {
            ServerMessage::Error { code, field, seq, .. } => (code.as_str().to_string(), field, seq),
            other => panic!("expected a refusal, got {other:?}"),
        }
    };
    let huge_au = facewire_proto::param_frame::ParamFrame {
        seq: 3,
        time_s: 0.1,
        animation: vec![(1, 3.4e38)],
        ..Default::default()
    };
    for message in [
        Message::Text(r#"{"seq":3,"t":0.1,"au":{"jaw_drop":3.4e38}}"#.into()),
        Message::Binary(huge_au.encode().into()),
    ] {
        assert_eq!(
            refused(&mut producer, message).await,
            ("bad_frame".to_string(), Some("au".to_string()), Some(3))
        );
    }
    let controls = format!(
        r#"{{"seq":4,"t":0.2,"controls":[{}]}}"#,
        vec!["[3.4e38,-3.4e38,0]"; 113].join(",")
    );
    assert_eq!(
        refused(&mut producer, Message::Text(controls.into())).await,
        ("bad_frame".to_string(), Some("controls".to_string()), Some(4))
    );
    let twice = r#"{"seq":5,"t":0.3,"t":0.4}"#;
    let (code, field, _) = refused(&mut producer, Message::Text(twice.into())).await;
    assert_eq!((code.as_str(), field.as_deref()), ("bad_frame", Some("t")));
    let mut flags = facewire_proto::param_frame::ParamFrame {
        seq: 6,
        ..Default::default()
    }
    .encode_fwp1()
    .unwrap();
    flags[20] = 0x80;
    let (code, field, _) = refused(&mut producer, Message::Binary(flags.into())).await;
    assert_eq!((code.as_str(), field.as_deref()), ("bad_frame", Some("flags")));
    // The stream still runs, and what reaches the viewer is finite.
    producer
        .send(Message::Text(jaw_line(7, 0.5).into()))
        .await
        .unwrap();
    assert!(matches!(
        next_json(&mut producer).await,
        ServerMessage::Ack { seq: 7, .. }
    ));
    server.stop().await;
}
