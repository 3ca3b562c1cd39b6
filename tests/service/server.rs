//! The service through real sockets on ephemeral ports: registration over HTTP, producers
//! and viewers over WebSocket, malformed input, slow viewers, restarts and tokens.

use crate::common::service::{
    connect, jaw_line, memory_config, next_frame, next_json, next_message, pcm_chunk, post, Server, Socket,
    OPUS_LOOKAHEAD_S,
};
use crate::common::{data, register};

use std::time::Duration;

use facewire::deform::{bind, AlgoSpec, Registration};
use facewire::mask::Mask;
use facewire::metrics::{FoldMeter, LipRegion};
use facewire::server::Config;
use facewire::stream::{open_stream, Frame, JsonlWriter};
use facewire_proto::messages::{HeadInfo, ServerMessage};
use facewire_proto::param_frame::ParamFrame;
use facewire_proto::viewer_frame::ViewerFrame;
use futures_util::{SinkExt, StreamExt};
use glam::Vec3;
use tokio_tungstenite::tungstenite::Message;

fn json_line(frame: &Frame, mask: &Mask) -> String {
    let mut writer = JsonlWriter::new(Vec::new(), mask);
    writer.write_frame(frame).unwrap();
    String::from_utf8(writer.into_inner().unwrap())
        .unwrap()
        .trim_end()
        .to_string()
}

fn syllables() -> Vec<Frame> {
    open_stream(&data("streams/syllables.jsonl"), &Mask::candide3())
        .unwrap()
        .map(Result::unwrap)
        .collect()
}

fn rest_positions(viewer: &ViewerFrame, reg: &Registration) -> Vec<f32> {
    let rest: Vec<f32> = reg.head.positions.iter().flat_map(|p| p.to_array()).collect();
    let mut out = Vec::new();
    viewer.apply(&rest, &mut out);
    out
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn viewers_see_what_facewire_deform_computes() {
    let server = Server::start(memory_config()).await;
    server.register("scan", "lee_perry_smith_head", "").await;

    // The same computation offline, as `facewire deform` does it.
    let reg = register("lee_perry_smith_head");
    let mask = reg.fitted.mask.clone();
    let specs: Vec<AlgoSpec> = ["O", "C", "kshirsagar"]
        .iter()
        .map(|s| s.parse().unwrap())
        .collect();

    let mut viewers = Vec::new();
    for spec in &specs {
        let mut socket = connect(&server.ws(&format!("/v1/heads/scan/streams/main/view?algo={spec}"))).await;
        match next_json(&mut socket).await {
            ServerMessage::Snapshot(s) => {
                assert_eq!(s.algorithm, spec.to_string());
                assert_eq!(s.vertices, 8838);
            }
            other => panic!("expected a snapshot, got {other:?}"),
        }
        viewers.push(socket);
    }
    // The whole recorded syllable stream, at about 60 frames per second.
    let frames: Vec<Frame> = syllables();
    let last = frames.last().unwrap().seq;
    let readers: Vec<_> = viewers
        .into_iter()
        .map(|mut socket| {
            tokio::spawn(async move {
                let mut received = Vec::new();
                while received.last().is_none_or(|f: &ViewerFrame| f.header.seq != last) {
                    received.push(next_frame(&mut socket).await);
                }
                received
            })
        })
        .collect();
    let mut producer = connect(&server.ws("/v1/heads/scan/streams/main/produce")).await;
    for frame in &frames {
        producer
            .send(Message::Text(json_line(frame, &mask).into()))
            .await
            .unwrap();
        match next_json(&mut producer).await {
            ServerMessage::Ack { seq, .. } => assert_eq!(seq, frame.seq),
            other => panic!("expected an ack, got {other:?}"),
        }
        tokio::time::sleep(Duration::from_millis(15)).await;
    }

    let step_slack = |frame: &ViewerFrame| 0.5 * frame.step * 1.001 + 1e-6;
    let lips = LipRegion::new(&reg.head, &reg.anchors, reg.mm_per_unit()).unwrap();
    let mut fold_meter = FoldMeter::new(&reg.head, lips.union()).unwrap();
    let mut folded_frames = 0;
    for (spec, reader) in specs.iter().zip(readers) {
        let received = reader.await.unwrap();
        let binding = bind(&reg, spec);
        let mut scratch = binding.scratch(113, reg.mask_triangles().len());
        let (mut weights, mut mask_now) = (vec![0.0; 65], vec![Vec3::ZERO; 113]);
        let mut expected = vec![Vec3::ZERO; reg.vertex_count()];
        let mut compared = 0;
        for viewer in &received {
            let frame = &frames[viewer.header.seq as usize];
            facewire::stream::animation_weights(frame, &reg.fitted.mask, &reg.fitted.fapu, &mut weights);
            reg.fitted.pose_into(&weights, &mut mask_now);
            binding.deform(
                &reg.head.positions,
                reg.mask_rest(),
                &mask_now,
                reg.mask_triangles(),
                &mut scratch,
                &mut expected,
            );
            let got = rest_positions(viewer, &reg);
            let worst = expected
                .iter()
                .enumerate()
                .map(|(v, e)| {
                    (Vec3::from_slice(&got[v * 3..v * 3 + 3]) - *e)
                        .abs()
                        .max_element()
                })
                .fold(0.0f32, f32::max);
            assert!(
                worst <= step_slack(viewer),
                "{spec} frame {}: off by {worst} (step {})",
                viewer.header.seq,
                viewer.step
            );
            assert_eq!(viewer.label, frame.label, "{spec}");
            assert_eq!(viewer.lip.per_vertex.len(), 18);
            assert!(viewer.lip.mean.is_finite() && viewer.lip.mean >= 0.0);
            // The lip folds are the library's, on the unquantized head.
            let folds = fold_meter.measure(&expected).unwrap();
            let sent = viewer.folds.expect("every frame carries the lip folds");
            assert_eq!(u32::from(sent.turned_over_60), folds.turned_over_60, "{spec}");
            assert_eq!(u32::from(sent.turned_over_90), folds.turned_over_90, "{spec}");
            assert!(
                (f64::from(sent.max_dihedral_increase_deg) - folds.max_dihedral_increase_deg).abs() < 1e-3
            );
            folded_frames += usize::from(folds.turned_over_60 > 0);
            compared += 1;
        }
        assert!(
            compared >= frames.len() / 2,
            "{spec}: only {compared} of {} frames arrived",
            frames.len()
        );
    }
    // O, C and S fold lip triangles on this stream (docs/reports/scan): the counts are live.
    assert!(folded_frames > 0, "no frame carried a lip fold");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_slow_viewer_skips_frames_and_holds_nobody_up() {
    // Its own process, so that its memory is the server's alone.
    let server = Server::spawn("").await;
    server.register("mh", "makehuman_head", "").await;
    let url = server.ws("/v1/heads/mh/streams/s/view?algo=O");
    let mut fast: Vec<Socket> = Vec::new();
    for _ in 0..3 {
        let mut socket = connect(&url).await;
        assert!(matches!(next_json(&mut socket).await, ServerMessage::Snapshot(_)));
        fast.push(socket);
    }
    // The slow viewer's socket buffers little, as a phone on a bad network would.
    let slow_socket = tokio::net::TcpSocket::new_v4().unwrap();
    slow_socket.set_recv_buffer_size(8 << 10).unwrap();
    let stream = slow_socket.connect(server.addr).await.unwrap();
    let mut slow =
        tokio_tungstenite::client_async(url.as_str(), tokio_tungstenite::MaybeTlsStream::Plain(stream))
            .await
            .unwrap()
            .0;
    assert!(matches!(next_json(&mut slow).await, ServerMessage::Snapshot(_)));

    let mask = Mask::candide3();
    let frames = syllables();
    let mut producer = connect(&server.ws("/v1/heads/mh/streams/s/produce")).await;
    let memory_before = server.resident_kib();
    let count = 240;
    let readers: Vec<_> = fast
        .into_iter()
        .map(|mut socket| {
            tokio::spawn(async move {
                let mut seqs = Vec::new();
                while seqs.last() != Some(&(count as u64 - 1)) {
                    seqs.push(next_frame(&mut socket).await.header.seq);
                }
                seqs
            })
        })
        .collect();
    for frame in frames.iter().cycle().take(count).enumerate().map(|(i, f)| {
        let mut f = f.clone();
        f.seq = i as u64;
        f.time_s = i as f64 / 60.0;
        f
    }) {
        producer
            .send(Message::Text(json_line(&frame, &mask).into()))
            .await
            .unwrap();
        assert!(matches!(
            next_json(&mut producer).await,
            ServerMessage::Ack { .. }
        ));
        tokio::time::sleep(Duration::from_millis(12)).await;
    }
    let memory_after = server.resident_kib();
    for reader in readers {
        let seqs = tokio::time::timeout(Duration::from_secs(20), reader)
            .await
            .unwrap()
            .unwrap();
        // Fast viewers keep up: they miss at most a few frames to coalescing.
        assert!(
            seqs.len() >= count * 9 / 10,
            "a fast viewer got {} of {count}",
            seqs.len()
        );
    }
    // The slow viewer (which read nothing meanwhile) catches up with the newest frames.
    let mut slow_seqs = Vec::new();
    while slow_seqs.last() != Some(&(count as u64 - 1)) {
        slow_seqs.push(next_frame(&mut slow).await.header.seq);
    }
    assert!(
        slow_seqs.len() < count,
        "the slow viewer got every frame ({})",
        slow_seqs.len()
    );
    assert!(
        slow_seqs.windows(2).any(|w| w[1] > w[0] + 1),
        "the slow viewer skipped nothing: {slow_seqs:?}"
    );
    assert!(
        memory_after < memory_before + 64 * 1024,
        "memory grew from {memory_before} KiB to {memory_after} KiB"
    );
    let metrics = server.metrics().await;
    assert!(
        metrics.contains("facewire_frames_skipped_total{stage=\"viewer\"}"),
        "{metrics}"
    );
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn malformed_input_is_refused_and_the_stream_keeps_running() {
    let server = Server::start(Config {
        limits: facewire::server::config::Limits {
            max_message_bytes: 4096,
            ..Default::default()
        },
        ..memory_config()
    })
    .await;
    server.register("mh", "makehuman_head", "").await;
    let mut viewer = connect(&server.ws("/v1/heads/mh/streams/s/view?algo=P")).await;
    assert!(matches!(next_json(&mut viewer).await, ServerMessage::Snapshot(_)));
    let mut producer = connect(&server.ws("/v1/heads/mh/streams/s/produce")).await;

    let expect_error = |code: &'static str| {
        let code = code.to_string();
        move |message: ServerMessage| match message {
            ServerMessage::Error {
                code: got, message, ..
            } => {
                assert_eq!(got.as_str(), code, "{message}");
                message
            }
            other => panic!("expected error {code}, got {other:?}"),
        }
    };
    let send = async |producer: &mut Socket, message: Message| {
        producer.send(message).await.unwrap();
        next_json(producer).await
    };

    let ok = |seq: u64| {
        Message::Text(
            format!(
                r#"{{"seq":{seq},"t":{},"au":{{"jaw_drop":0.4}}}}"#,
                seq as f64 * 0.1
            )
            .into(),
        )
    };
    assert!(matches!(
        send(&mut producer, ok(0)).await,
        ServerMessage::Ack { seq: 0, .. }
    ));

    let message = expect_error("bad_frame")(send(&mut producer, Message::Text("{not json".into())).await);
    assert!(message.contains("invalid JSON"), "{message}");
    let message = expect_error("bad_frame")(
        send(
            &mut producer,
            Message::Text(r#"{"seq":1,"t":0.1,"au":{"smile":1}}"#.into()),
        )
        .await,
    );
    assert!(message.contains("smile"), "{message}");
    let good = ParamFrame {
        seq: 1,
        time_s: 0.1,
        animation: vec![(1, 0.3)],
        ..ParamFrame::default()
    };
    let fwp1 = good.encode_fwp1().unwrap();
    let message = expect_error("bad_frame")(
        send(
            &mut producer,
            Message::Binary(fwp1[..fwp1.len() - 2].to_vec().into()),
        )
        .await,
    );
    assert!(message.contains("message too short: arkit_count"), "{message}");
    let fwp2 = good.encode();
    match send(
        &mut producer,
        Message::Binary(fwp2[..fwp2.len() - 2].to_vec().into()),
    )
    .await
    {
        ServerMessage::Error { code, field, .. } => {
            assert_eq!(code.as_str(), "bad_frame");
            assert_eq!(field.as_deref(), Some("section"));
        }
        other => panic!("expected an error, got {other:?}"),
    }
    let nan = ParamFrame {
        seq: 1,
        time_s: 0.1,
        animation: vec![(1, f32::NAN)],
        ..ParamFrame::default()
    }
    .encode();
    match send(&mut producer, Message::Binary(nan.into())).await {
        ServerMessage::Error { code, field, .. } => {
            assert_eq!(code.as_str(), "bad_frame");
            assert_eq!(field.as_deref(), Some("au"));
        }
        other => panic!("expected an error, got {other:?}"),
    }
    match send(&mut producer, ok(0)).await {
        ServerMessage::Error { code, seq, field, .. } => {
            assert_eq!(code.as_str(), "out_of_order");
            assert_eq!(seq, Some(0));
            assert_eq!(field.as_deref(), Some("seq"));
        }
        other => panic!("expected out_of_order, got {other:?}"),
    }

    // A second producer is refused and closed; the first keeps going.
    let mut second = connect(&server.ws("/v1/heads/mh/streams/s/produce")).await;
    expect_error("producer_busy")(next_json(&mut second).await);
    // An FWP2 frame with a section from a later producer: accepted, and the ack names it.
    let mut later = good.encode();
    later[20] += 1;
    later.extend_from_slice(&[99, 2, 0, 0, 0, 1, 2]);
    match send(&mut producer, Message::Binary(later.into())).await {
        ServerMessage::Ack { seq: 1, ignored, .. } => assert_eq!(ignored, [99]),
        other => panic!("expected an ack, got {other:?}"),
    }
    assert!(matches!(
        send(&mut producer, ok(2)).await,
        ServerMessage::Ack { seq: 2, .. }
    ));

    // The viewer saw the good frames only.
    let mut seqs = Vec::new();
    while seqs.last() != Some(&2) {
        seqs.push(next_frame(&mut viewer).await.header.seq);
    }
    assert!(seqs.iter().all(|s| [0, 1, 2].contains(s)), "{seqs:?}");

    // A message over the limit is refused at the socket: close 1009, and the stream ends.
    producer
        .send(Message::Text("x".repeat(10_000).into()))
        .await
        .unwrap();
    match producer.next().await {
        Some(Ok(Message::Close(Some(frame)))) => {
            assert_eq!(u16::from(frame.code), 1009);
            assert!(frame.reason.contains("message_too_large"), "{}", frame.reason);
        }
        other => panic!("expected a 1009 close, got {other:?}"),
    }
    match next_json(&mut viewer).await {
        ServerMessage::End { reason, .. } => assert_eq!(reason.as_str(), "producer_disconnected"),
        other => panic!("expected end, got {other:?}"),
    }

    // Unknown heads: a viewer gets an error and a 4404 close; a producer is refused.
    let mut lost = connect(&server.ws("/v1/heads/nosuch/streams/s/view")).await;
    expect_error("unknown_head")(next_json(&mut lost).await);
    match lost.next().await {
        Some(Ok(Message::Close(Some(frame)))) => assert_eq!(u16::from(frame.code), 4404),
        other => panic!("expected a close, got {other:?}"),
    }
    assert!(
        tokio_tungstenite::connect_async(server.ws("/v1/heads/nosuch/streams/s/produce"))
            .await
            .is_err()
    );
    let response = reqwest::get(server.http("/v1/heads/nosuch")).await.unwrap();
    assert_eq!(response.status(), 404);
    let body: serde_json::Value = response.json().await.unwrap();
    assert_eq!(body["error"], "unknown_head");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn heads_survive_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    let config = Config {
        data_dir: Some(dir.path().to_path_buf()),
        ..Config::default()
    };
    let server = Server::start(config.clone()).await;
    server.register("mh", "makehuman_head", "").await;
    let mut viewer = connect(&server.ws("/v1/heads/mh/streams/s/view")).await;
    let ServerMessage::Snapshot(snapshot) = next_json(&mut viewer).await else {
        panic!("expected a snapshot");
    };
    // Where the lips are, for drawing them: one weight per vertex, some of them lip.
    assert_eq!(snapshot.lip_tint.as_deref(), Some("/v1/heads/mh/lips.bin"));
    let lips = reqwest::get(server.http("/v1/heads/mh/lips.bin"))
        .await
        .unwrap()
        .bytes()
        .await
        .unwrap();
    let lips = facewire_proto::vertex_weights::VertexWeights::decode(&lips).unwrap();
    assert_eq!(lips.weights.len(), 4352);
    let lip = lips.weights.iter().filter(|&&w| w == 255).count();
    assert!((50..1000).contains(&lip), "{lip} vertices are all lip");
    server.stop().await;
    // Viewers are told why they are closed.
    match next_json(&mut viewer).await {
        ServerMessage::End { reason, .. } => assert_eq!(reason.as_str(), "server_shutdown"),
        other => panic!("expected end, got {other:?}"),
    }

    let server = Server::start(config).await;
    let info = server.wait_ready("mh", "").await;
    assert_eq!(info.vertices, 4352);
    let mesh = reqwest::get(server.http("/v1/heads/mh/mesh.bin"))
        .await
        .unwrap()
        .bytes()
        .await
        .unwrap();
    assert_eq!(&mesh[..4], b"FWM1");
    assert_eq!(mesh.len(), 16 + 4352 * 12 + 8652 * 12);
    // Deleting removes it for good.
    let response = reqwest::Client::new()
        .delete(server.http("/v1/heads/mh"))
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 204);
    server.stop().await;
    let server = Server::start(Config {
        data_dir: Some(dir.path().to_path_buf()),
        ..Config::default()
    })
    .await;
    let heads: Vec<HeadInfo> = reqwest::get(server.http("/v1/heads"))
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert!(heads.is_empty());
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tokens_are_required_when_configured() {
    let server = Server::start(Config {
        auth: facewire::server::config::Auth {
            producer_token: Some("prod".into()),
            viewer_token: Some("view".into()),
            admin_token: Some("admin".into()),
        },
        ..memory_config()
    })
    .await;
    let body = serde_json::json!({"id": "x", "obj": "v 0 0 0", "fit": ""});
    let refused = reqwest::Client::new()
        .post(server.http("/v1/heads"))
        .json(&body)
        .send()
        .await
        .unwrap();
    assert_eq!(refused.status(), 401);
    server.register("mh", "makehuman_head", "?token=admin").await;
    for (path, token) in [("produce", "prod"), ("view", "view")] {
        let url = server.ws(&format!("/v1/heads/mh/streams/s/{path}"));
        for bad in [url.clone(), format!("{url}?token=wrong")] {
            match tokio_tungstenite::connect_async(bad.as_str()).await {
                Err(tokio_tungstenite::tungstenite::Error::Http(response)) => {
                    assert_eq!(response.status(), 401)
                }
                other => panic!("{bad}: expected 401, got {:?}", other.map(|_| ())),
            }
        }
        let mut socket = connect(&format!("{url}?token={token}")).await;
        if path == "view" {
            assert!(matches!(next_json(&mut socket).await, ServerMessage::Snapshot(_)));
        } else {
            socket
                .send(Message::Text(r#"{"seq":0,"t":0}"#.into()))
                .await
                .unwrap();
            assert!(matches!(
                next_json(&mut socket).await,
                ServerMessage::Ack { seq: 0, .. }
            ));
        }
    }
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fast_and_idle_producers_are_told_why() {
    let server = Server::start(Config {
        limits: facewire::server::config::Limits {
            max_fps: 8.0,
            producer_idle_s: 0.5,
            ..Default::default()
        },
        ..memory_config()
    })
    .await;
    server.register("mh", "makehuman_head", "").await;
    let mut producer = connect(&server.ws("/v1/heads/mh/streams/s/produce")).await;
    let (mut acks, mut limited) = (0, 0);
    for seq in 0..10u64 {
        let line = format!(r#"{{"seq":{seq},"t":{}}}"#, seq as f64 / 30.0);
        producer.send(Message::Text(line.into())).await.unwrap();
        match next_json(&mut producer).await {
            ServerMessage::Ack { .. } => acks += 1,
            ServerMessage::Error {
                code, seq: Some(_), ..
            } if code.as_str() == "rate_limited" => limited += 1,
            other => panic!("unexpected {other:?}"),
        }
    }
    // a burst of max_fps / 4 (at least 2) passes, the rest of an instant burst does not
    assert!((2..=3).contains(&acks), "{acks} acked");
    assert_eq!(acks + limited, 10);
    match next_json(&mut producer).await {
        ServerMessage::Error { code, .. } => assert_eq!(code.as_str(), "idle"),
        other => panic!("expected idle, got {other:?}"),
    }
    match producer.next().await {
        Some(Ok(Message::Close(Some(frame)))) => assert_eq!(u16::from(frame.code), 4408),
        other => panic!("expected a close, got {other:?}"),
    }
    // An upload over the limit is refused with 413.
    let small = Server::start(Config {
        limits: facewire::server::config::Limits {
            max_upload_bytes: 1024,
            ..Default::default()
        },
        ..memory_config()
    })
    .await;
    let body = serde_json::json!({"id": "big", "obj": "v 0 0 0\n".repeat(1000), "fit": ""});
    let response = reqwest::Client::new()
        .post(small.http("/v1/heads"))
        .json(&body)
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 413);
    small.stop().await;
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn viewers_can_colour_by_folds() {
    let server = Server::start(memory_config()).await;
    server.register("mh", "makehuman_head", "").await;
    // A heat the server does not know is refused, naming it.
    let mut bad = connect(&server.ws("/v1/heads/mh/streams/main/view?heat=wobble")).await;
    match next_json(&mut bad).await {
        ServerMessage::Error { code, message, .. } => {
            assert_eq!(code.as_str(), "bad_request");
            assert!(message.contains("heat=wobble"), "{message}");
        }
        other => panic!("{other:?}"),
    }
    // O (renato2) folds the lips when the jaw drops.
    let mut viewer = connect(&server.ws("/v1/heads/mh/streams/main/view?algo=O&heat=folds")).await;
    match next_json(&mut viewer).await {
        ServerMessage::Snapshot(s) => {
            assert_eq!(s.heat.as_deref(), Some("folds"));
            assert!(!s.face_roughness);
        }
        other => panic!("{other:?}"),
    }
    let mut producer = connect(&server.ws("/v1/heads/mh/streams/main/produce")).await;
    let line = r#"{"seq":0,"t":0,"au":{"jaw_drop":0.6}}"#;
    producer.send(Message::Text(line.into())).await.unwrap();
    let frame = next_frame(&mut viewer).await;
    let sent = frame.heat.expect("per-vertex folds");

    // The library's: the largest turn of each vertex's triangles over the whole head.
    let reg = register("makehuman_head");
    let mut weights = vec![0.0; 65];
    weights[1] = 0.6;
    let mask_now = crate::common::posed(&reg, &weights);
    let binding = bind(&reg, &"O".parse().unwrap());
    let deformed = crate::common::deform_with(&reg, &binding, &mask_now);
    let all: Vec<u32> = (0..reg.head.triangles.len() as u32).collect();
    let mut meter = FoldMeter::new(&reg.head, &all).unwrap();
    meter.measure(&deformed).unwrap();
    let mut expected = vec![0.0f32; reg.vertex_count()];
    meter.vertex_turns_deg(&mut expected);
    let max = expected.iter().copied().fold(0.0f32, f32::max);
    assert!(max > 60.0, "O should fold something: {max}");
    for (v, (got, want)) in sent.iter().zip(&expected).enumerate() {
        // Sent as a byte of the frame's largest value.
        assert!(
            (got - want).abs() <= max / 255.0 * 0.51 + 1e-3,
            "vertex {v}: {got} vs {want}"
        );
    }
    drop((viewer, producer, bad));
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_producer_s_audio_reaches_the_viewers_that_ask_for_it() {
    use facewire_proto::audio_chunk::{AudioBody, AudioChunk};
    let server = Server::start(memory_config()).await;
    server.register("mh", "makehuman_head", "").await;
    let mut listener = connect(&server.ws("/v1/heads/mh/streams/s/view?format=fwf2&audio=pcm")).await;
    match next_json(&mut listener).await {
        ServerMessage::Snapshot(snapshot) => {
            assert_eq!(snapshot.audio.as_deref(), Some("pcm"));
            assert_eq!(snapshot.messages, ["frame", "end", "audio"]);
        }
        other => panic!("{other:?}"),
    }
    let mut deaf = connect(&server.ws("/v1/heads/mh/streams/s/view?format=fwf2")).await;
    match next_json(&mut deaf).await {
        ServerMessage::Snapshot(snapshot) => {
            assert_eq!(snapshot.audio, None);
            assert_eq!(snapshot.messages, ["frame", "end"]);
        }
        other => panic!("{other:?}"),
    }
    let mut opus = connect(&server.ws("/v1/heads/mh/streams/s/view?format=fwf2&audio=opus")).await;
    assert!(matches!(next_json(&mut opus).await, ServerMessage::Snapshot(_)));
    let mut producer = connect(&server.ws("/v1/heads/mh/streams/s/produce")).await;
    producer
        .send(Message::Text(jaw_line(0, 0.0).into()))
        .await
        .unwrap();
    assert!(matches!(
        next_json(&mut producer).await,
        ServerMessage::Ack { seq: 0, .. }
    ));

    // Five chunks back to back: accepted without an answer.
    let sent: Vec<AudioChunk> = (0..5).map(|i| pcm_chunk(0.02 * f64::from(i), i as i16)).collect();
    for chunk in &sent {
        producer
            .send(Message::Binary(chunk.encode().into()))
            .await
            .unwrap();
    }
    // Refused, each by code and field, and the stream runs on: a chunk overlapping the
    // last, another sample rate, another codec, a broken message.
    let overlapping = pcm_chunk(0.09, 9);
    let other_rate = AudioChunk {
        body: AudioBody::Pcm {
            sample_rate: 48_000,
            samples: vec![0; 960],
        },
        ..pcm_chunk(0.2, 0)
    };
    let other_codec = AudioChunk {
        body: AudioBody::Opus {
            packet: vec![31 << 3, 1, 2],
        },
        ..pcm_chunk(0.2, 0)
    };
    let mut broken = pcm_chunk(0.2, 0).encode();
    broken[26..30].copy_from_slice(&44_100u32.to_le_bytes());
    for (message, code, field) in [
        (overlapping.encode(), "out_of_order", "t"),
        (other_rate.encode(), "bad_frame", "sound"),
        (other_codec.encode(), "bad_frame", "sound"),
        (broken, "bad_frame", "sample_rate"),
    ] {
        producer.send(Message::Binary(message.into())).await.unwrap();
        match next_json(&mut producer).await {
            ServerMessage::Error {
                code: got, field: f, ..
            } => assert_eq!((got.as_str(), f.as_deref()), (code, Some(field))),
            other => panic!("expected {code}, got {other:?}"),
        }
    }
    producer
        .send(Message::Text(jaw_line(1, 0.1).into()))
        .await
        .unwrap();
    assert!(matches!(
        next_json(&mut producer).await,
        ServerMessage::Ack { seq: 1, .. }
    ));

    // The listener hears every chunk, in order, as sent and stamped with its receipt.
    let mut heard = Vec::new();
    while heard.len() < sent.len() {
        match next_message(&mut listener).await {
            Some(Message::Binary(bytes)) if bytes.starts_with(b"FWA1") => {
                heard.push(AudioChunk::decode(&bytes).unwrap())
            }
            Some(Message::Binary(_) | Message::Text(_)) => {}
            other => panic!("expected audio, got {other:?}"),
        }
    }
    for (got, want) in heard.iter().zip(&sent) {
        assert_eq!((got.t_s, &got.body), (want.t_s, &want.body));
        assert!(
            got.server_receive_us > 1_700_000_000_000_000,
            "{}",
            got.server_receive_us
        );
    }
    // The viewer that asked for Opus hears the same voice encoded once by the server: the
    // 100 ms as two 40 ms packets starting where the PCM chunks did (the last 20 ms wait
    // for more, or for the voice's end). The one that asked for none gets frames and no audio.
    let packets_due = 2;
    let (mut packets, mut deaf_heard) = (Vec::new(), 0);
    for (viewer, heard) in [(&mut opus, Some(&mut packets)), (&mut deaf, None)] {
        let mut heard = heard;
        let mut seen_last_frame = false;
        while !seen_last_frame || heard.as_ref().is_some_and(|h| h.len() < packets_due) {
            match next_message(viewer).await {
                Some(Message::Binary(bytes)) if bytes.starts_with(b"FWA1") => match heard.as_mut() {
                    Some(heard) => heard.push(AudioChunk::decode(&bytes).unwrap()),
                    None => deaf_heard += 1,
                },
                Some(Message::Binary(bytes)) => {
                    seen_last_frame |= facewire_proto::viewer_frame::decode(&bytes).unwrap().header.seq == 1;
                }
                Some(Message::Text(_)) => {}
                other => panic!("{other:?}"),
            }
        }
    }
    assert_eq!(deaf_heard, 0, "audio to a viewer that did not ask");
    assert_eq!(packets.len(), packets_due);
    // Each packet at its first decoded sample: the encoder's 6.5 ms look-ahead before the
    // first sample it was given.
    for (i, packet) in packets.iter().enumerate() {
        assert!(
            (packet.t_s - (0.04 * i as f64 - OPUS_LOOKAHEAD_S)).abs() < 1e-9,
            "packet {i} at {}",
            packet.t_s
        );
        match &packet.body {
            AudioBody::Opus { packet } => {
                assert_eq!(
                    facewire_proto::audio_chunk::opus_packet_samples(packet, 0),
                    Ok(1920)
                )
            }
            other => panic!("an Opus viewer got {other:?}"),
        }
    }
    // The voice ends with the stream: its last 20 ms are heard as a third packet, closed
    // with silence, before the stream's end.
    producer
        .send(Message::Text(r#"{"type":"end"}"#.into()))
        .await
        .unwrap();
    let mut tail = Vec::new();
    loop {
        match next_message(&mut opus).await {
            Some(Message::Binary(bytes)) if bytes.starts_with(b"FWA1") => {
                tail.push(AudioChunk::decode(&bytes).unwrap().t_s)
            }
            Some(Message::Text(text)) if text.contains(r#""type":"end""#) => break,
            Some(_) => {}
            None => panic!("the Opus viewer's socket closed before the stream's end"),
        }
    }
    assert_eq!(tail.len(), 1, "packets after the end: {tail:?}");
    assert!(
        (tail[0] - (0.08 - OPUS_LOOKAHEAD_S)).abs() < 1e-9,
        "the last packet at {}",
        tail[0]
    );
    // An Opus producer is heard by a PCM viewer: each packet decoded once, at its own t.
    let mut pcm_viewer = connect(&server.ws("/v1/heads/mh/streams/o/view?format=fwf2&audio=pcm")).await;
    assert!(matches!(
        next_json(&mut pcm_viewer).await,
        ServerMessage::Snapshot(_)
    ));
    let mut opus_producer = connect(&server.ws("/v1/heads/mh/streams/o/produce")).await;
    let mut encoder = opus::Encoder::new(48_000, opus::Channels::Mono, opus::Application::Voip).unwrap();
    for i in 0..3 {
        let tone: Vec<i16> = (0..960)
            .map(|k| (6_000.0 * (f64::from(i * 960 + k) * 0.06).sin()) as i16)
            .collect();
        let chunk = AudioChunk {
            body: AudioBody::Opus {
                packet: encoder.encode_vec(&tone, 1275).unwrap(),
            },
            ..pcm_chunk(0.02 * f64::from(i), 0)
        };
        opus_producer
            .send(Message::Binary(chunk.encode().into()))
            .await
            .unwrap();
    }
    let mut decoded = Vec::new();
    while decoded.len() < 3 {
        if let Some(Message::Binary(bytes)) = next_message(&mut pcm_viewer).await {
            if bytes.starts_with(b"FWA1") {
                decoded.push(AudioChunk::decode(&bytes).unwrap());
            }
        }
    }
    for (i, chunk) in decoded.iter().enumerate() {
        assert!((chunk.t_s - 0.02 * i as f64).abs() < 1e-9, "{}", chunk.t_s);
        match &chunk.body {
            AudioBody::Pcm { sample_rate, samples } => {
                assert_eq!((*sample_rate, samples.len()), (48_000, 960))
            }
            other => panic!("a PCM viewer got {other:?}"),
        }
    }

    // A viewer asking for a codec there is no such thing as is refused by name.
    let mut bad = connect(&server.ws("/v1/heads/mh/streams/s/view?audio=mp3")).await;
    match next_json(&mut bad).await {
        ServerMessage::Error { code, message, .. } => {
            assert_eq!(code.as_str(), "bad_request");
            assert!(message.contains("audio=mp3"), "{message}");
        }
        other => panic!("{other:?}"),
    }
    server.stop().await;
}

/// A `multipart/form-data` body of `(name, file name, bytes)` parts, as a browser or
/// Python's standard library would send it; the boundary is returned with it.
fn multipart(parts: &[(&str, Option<&str>, &[u8])]) -> (String, Vec<u8>) {
    let boundary = "facewire-test-boundary-7d41";
    let mut body = Vec::new();
    for (name, file, bytes) in parts {
        body.extend_from_slice(
            format!("--{boundary}\r\nContent-Disposition: form-data; name=\"{name}\"").as_bytes(),
        );
        if let Some(file) = file {
            body.extend_from_slice(format!("; filename=\"{file}\"").as_bytes());
        }
        body.extend_from_slice(b"\r\n\r\n");
        body.extend_from_slice(bytes);
        body.extend_from_slice(b"\r\n");
    }
    body.extend_from_slice(format!("--{boundary}--\r\n").as_bytes());
    (format!("multipart/form-data; boundary={boundary}"), body)
}

/// A mono 16-bit WAV of `samples` at `rate` Hz.
fn wav(rate: u32, samples: &[i16]) -> Vec<u8> {
    let spec = hound::WavSpec {
        channels: 1,
        sample_rate: rate,
        bits_per_sample: 16,
        sample_format: hound::SampleFormat::Int,
    };
    let mut out = std::io::Cursor::new(Vec::new());
    let mut writer = hound::WavWriter::new(&mut out, spec).unwrap();
    for &s in samples {
        writer.write_sample(s).unwrap();
    }
    writer.finalize().unwrap();
    out.into_inner()
}

async fn post_batch(
    server: &Server,
    stream: &str,
    parts: &[(&str, Option<&str>, &[u8])],
) -> (u16, serde_json::Value) {
    let (content_type, body) = multipart(parts);
    post(
        server,
        &format!("/v1/heads/mh/streams/{stream}/batch"),
        body,
        &content_type,
    )
    .await
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_batch_carries_its_voice_as_a_wav_part() {
    use facewire_proto::audio_chunk::{AudioBody, AudioChunk};
    let server = Server::start(memory_config()).await;
    server.register("mh", "makehuman_head", "").await;
    let mut listener = connect(&server.ws("/v1/heads/mh/streams/w/view?format=fwf2&audio=pcm")).await;
    assert!(matches!(
        next_json(&mut listener).await,
        ServerMessage::Snapshot(_)
    ));

    // Three frames from t = 5 s and 0.3 s of 16 kHz voice, which starts with the first frame.
    let lines = format!(
        "{}\n{}\n{}\n",
        jaw_line(0, 5.0),
        jaw_line(1, 5.1),
        jaw_line(2, 5.2)
    );
    let voice: Vec<i16> = (0..4800).map(|i| (i % 1000) as i16 - 500).collect();
    let wav_file = wav(16_000, &voice);
    let (status, accepted) = post_batch(
        &server,
        "w",
        &[
            ("stream", Some("talk.jsonl"), lines.as_bytes()),
            ("audio", Some("talk.wav"), &wav_file),
        ],
    )
    .await;
    assert_eq!(status, 202, "{accepted}");
    assert_eq!(accepted["frames"], 3);
    assert_eq!(accepted["audio_s"], 0.3);
    // From the first frame (5 s) to the last chunk (5.28 s).
    assert!(
        (accepted["duration_s"].as_f64().unwrap() - 0.28).abs() < 1e-9,
        "{accepted}"
    );

    // The listener hears the whole voice in 20 ms chunks on the frames' timeline, then the end.
    let (mut heard, mut frames) = (Vec::<AudioChunk>::new(), 0);
    loop {
        match next_message(&mut listener).await {
            Some(Message::Binary(bytes)) if bytes.starts_with(b"FWA1") => {
                heard.push(AudioChunk::decode(&bytes).unwrap())
            }
            Some(Message::Binary(_)) => frames += 1,
            Some(Message::Text(text)) => match serde_json::from_str(text.as_str()).unwrap() {
                ServerMessage::End { reason, .. } => {
                    assert_eq!(reason.as_str(), "batch_finished");
                    break;
                }
                other => panic!("{other:?}"),
            },
            other => panic!("{other:?}"),
        }
    }
    assert!(frames >= 1, "{frames} frames seen");
    assert_eq!(heard.len(), 15);
    let mut samples_heard = Vec::new();
    for (i, chunk) in heard.iter().enumerate() {
        assert!(
            (chunk.t_s - (5.0 + 0.02 * i as f64)).abs() < 1e-9,
            "chunk {i} at {}",
            chunk.t_s
        );
        match &chunk.body {
            AudioBody::Pcm { sample_rate, samples } => {
                assert_eq!(*sample_rate, 16_000);
                samples_heard.extend_from_slice(samples);
            }
            other => panic!("{other:?}"),
        }
    }
    assert_eq!(samples_heard, voice);

    // The voice alone, placed at t = 2 s by `audio_t_s`: a stream of audio without frames.
    let mut alone = connect(&server.ws("/v1/heads/mh/streams/v/view?format=fwf2&audio=pcm")).await;
    assert!(matches!(next_json(&mut alone).await, ServerMessage::Snapshot(_)));
    let (status, accepted) = post_batch(
        &server,
        "v",
        &[("audio", None, &wav_file), ("audio_t_s", None, b"2.0")],
    )
    .await;
    assert_eq!(
        (status, accepted["frames"].as_u64()),
        (202, Some(0)),
        "{accepted}"
    );
    match next_message(&mut alone).await {
        Some(Message::Binary(bytes)) => assert_eq!(AudioChunk::decode(&bytes).unwrap().t_s, 2.0),
        other => panic!("{other:?}"),
    }

    // Refused up front, naming the part: a broken WAV, a part nobody defined, a time that
    // is not one or is before 0, a repeated part, an empty form.
    let broken: &[u8] = b"RIFF\x10\x00\x00\x00WAVEfmt ";
    for (parts, code, says) in [
        (
            vec![("stream", None, lines.as_bytes()), ("audio", None, broken)],
            "bad_frame",
            "part \"audio\"",
        ),
        (vec![("video", None, broken)], "bad_request", "\"video\""),
        (
            vec![("audio", None, &wav_file[..]), ("audio_t_s", None, b"soon")],
            "bad_request",
            "audio_t_s",
        ),
        (
            vec![("audio", None, &wav_file[..]), ("audio_t_s", None, b"-5")],
            "bad_request",
            "from 0 to",
        ),
        (
            vec![("audio", None, &wav_file[..]), ("audio", None, &wav_file[..])],
            "bad_request",
            "twice",
        ),
        (vec![], "bad_request", "needs"),
    ] {
        let (status, body) = post_batch(&server, "x", &parts).await;
        assert_eq!((status, body["error"].as_str()), (400, Some(code)), "{body}");
        assert!(body["message"].as_str().unwrap().contains(says), "{body}");
    }
    server.stop().await;
}

/// The loudest 20 ms window of `samples` at `rate`, as its index.
fn loudest_window(samples: &[i16], rate: usize) -> usize {
    let window = rate / 50;
    let energy = |w: &[i16]| w.iter().map(|&s| f64::from(s).powi(2)).sum::<f64>();
    (0..samples.len() / window)
        .max_by(|&a, &b| {
            energy(&samples[a * window..][..window]).total_cmp(&energy(&samples[b * window..][..window]))
        })
        .unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_batch_carries_its_voice_as_an_ogg_opus_part() {
    use facewire_proto::audio_chunk::{AudioBody, AudioChunk};
    let mut config = memory_config();
    config.limits.max_batch_duration_s = 10.0;
    let server = Server::start(config).await;
    server.register("mh", "makehuman_head", "").await;
    // tests/voices/: the syllable voice's first 2 s (16 kHz) as opusenc wrote it.
    let opus_file = std::fs::read(crate::common::repo_path("tests/voices/syllables_2s.opus")).unwrap();
    let source = facewire::voice::read_wav(
        std::fs::File::open(crate::common::repo_path("data/streams/syllables.wav")).unwrap(),
        "syllables.wav",
    )
    .unwrap();
    let source = &source.samples[..32_000];

    let mut listener = connect(&server.ws("/v1/heads/mh/streams/g/view?format=fwf2&audio=pcm")).await;
    assert!(matches!(
        next_json(&mut listener).await,
        ServerMessage::Snapshot(_)
    ));
    let (status, accepted) = post_batch(
        &server,
        "g",
        &[
            ("audio", Some("talk.opus"), &opus_file),
            ("audio_t_s", None, b"1.0"),
        ],
    )
    .await;
    assert_eq!(status, 202, "{accepted}");
    assert_eq!(
        (accepted["frames"].as_u64(), accepted["audio_s"].as_f64()),
        (Some(0), Some(2.0))
    );
    // Heard as 48 kHz PCM in 20 ms chunks from t = 1 s: exactly the 2 s the file holds
    // (its pre-skip and end padding gone), loudest in the same 20 ms as the WAV it was
    // made from.
    let mut heard = Vec::new();
    let mut at = 1.0;
    loop {
        match next_message(&mut listener).await {
            Some(Message::Binary(bytes)) if bytes.starts_with(b"FWA1") => {
                let chunk = AudioChunk::decode(&bytes).unwrap();
                assert!(
                    (chunk.t_s - at).abs() < 1e-9,
                    "a chunk at {}, expected {at}",
                    chunk.t_s
                );
                match chunk.body {
                    AudioBody::Pcm { sample_rate, samples } => {
                        assert_eq!(sample_rate, 48_000);
                        at += samples.len() as f64 / 48_000.0;
                        heard.extend(samples);
                    }
                    other => panic!("{other:?}"),
                }
            }
            Some(Message::Text(text)) if text.contains(r#""type":"end""#) => break,
            Some(_) => {}
            None => panic!("the listener's socket closed"),
        }
    }
    assert_eq!(heard.len(), 96_000);
    assert_eq!(loudest_window(&heard, 48_000), loudest_window(source, 16_000));

    // Refused before decoding, naming the part: longer than the batch limit (lowered
    // here below the file's 2 s), a cut file.
    let mut strict = memory_config();
    strict.limits.max_batch_duration_s = 1.5;
    let strict = Server::start(strict).await;
    strict.register("mh", "makehuman_head", "").await;
    let (status, refused) = post_batch(&strict, "g", &[("audio", None, &opus_file)]).await;
    assert_eq!(status, 413, "{refused}");
    let (status, refused) = post_batch(&server, "h", &[("audio", None, &opus_file[..4_000])]).await;
    assert_eq!(status, 400, "{refused}");
    let refusal = refused.to_string();
    assert!(
        refusal.contains("not a readable Ogg file") && refusal.contains("part \\\"audio\\\""),
        "{refusal}"
    );
}

/// `count` 20 ms chunks of the syllable voice (16 kHz) from `from_s`, each at its own `t`.
fn voice_chunks(from_s: f64, count: usize) -> Vec<facewire_proto::audio_chunk::AudioChunk> {
    use facewire_proto::audio_chunk::{AudioBody, AudioChunk};
    let voice = facewire::voice::syllable_voice().unwrap();
    let first = (from_s * 16_000.0).round() as usize;
    (0..count)
        .map(|k| AudioChunk {
            t_s: from_s + 0.02 * k as f64,
            server_receive_us: 0,
            body: AudioBody::Pcm {
                sample_rate: 16_000,
                samples: voice.samples[first + 320 * k..first + 320 * (k + 1)].to_vec(),
            },
            ignored: Vec::new(),
        })
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_voice_alone_animates_the_head_and_the_producer_sees_what_was_derived() {
    use facewire::stream::syllables::SYLLABLE_S;
    let server = Server::start(memory_config()).await;
    server.register("mh", "makehuman_head", "").await;
    // A derived face is asked for by name, with its frame rate in range.
    for query in [
        "derive=mfcc",
        "derive=visemes&fps=0",
        "derive=visemes&fps=1000",
        "fps=30",
    ] {
        let url = server.ws(&format!("/v1/heads/mh/streams/s/produce?{query}"));
        match tokio_tungstenite::connect_async(url).await {
            Err(tokio_tungstenite::tungstenite::Error::Http(response)) => {
                assert_eq!(response.status(), 400, "{query}")
            }
            other => panic!("{query}: {other:?}"),
        }
    }
    let mut viewer = connect(&server.ws("/v1/heads/mh/streams/s/view?format=fwf2")).await;
    assert!(matches!(next_json(&mut viewer).await, ServerMessage::Snapshot(_)));
    let mut producer =
        connect(&server.ws("/v1/heads/mh/streams/s/produce?derive=visemes&fps=25&derived=1")).await;
    // "ma", "mi", "mu": 1.8 s of voice from the syllables' 7.2 s, at its own pace (sent at
    // once, the faces are derived faster than a viewer is written to and, newest winning,
    // a viewer on a loaded machine may see only the last, closed mouth), then a parameter
    // frame, which a derived stream refuses.
    let from_s = 12.0 * SYLLABLE_S;
    let mut ticks = tokio::time::interval(Duration::from_millis(20));
    for chunk in voice_chunks(from_s, 90) {
        ticks.tick().await;
        producer
            .send(Message::Binary(chunk.encode().into()))
            .await
            .unwrap();
    }
    producer
        .send(Message::Text(jaw_line(7, from_s).into()))
        .await
        .unwrap();
    let mut derived = Vec::new();
    loop {
        match next_json(&mut producer).await {
            ServerMessage::Derived {
                seq,
                t,
                viseme,
                confidence,
            } => {
                assert!((0.0..=1.0).contains(&confidence), "{confidence}");
                derived.push((seq, t, viseme.oculus));
            }
            ServerMessage::Error { code, field, seq, .. } => {
                assert_eq!(
                    (code.as_str(), field.as_deref(), seq),
                    ("bad_frame", Some("derive"), Some(7))
                );
                break;
            }
            other => panic!("{other:?}"),
        }
    }
    producer
        .send(Message::Text(r#"{"type":"end"}"#.into()))
        .await
        .unwrap();
    loop {
        match next_json(&mut producer).await {
            ServerMessage::Derived { seq, t, viseme, .. } => derived.push((seq, t, viseme.oculus)),
            ServerMessage::End { .. } => break,
            other => panic!("{other:?}"),
        }
    }
    // 25 frames a second from the first chunk's t over the 1.8 s, and perhaps a last one
    // closing the mouth; each m closes the lips within its syllable's first 0.25 s.
    assert!((45..=46).contains(&derived.len()), "{}", derived.len());
    for (k, (seq, t, _)) in derived.iter().enumerate() {
        assert_eq!(*seq, k as u64);
        assert!((t - (from_s + k as f64 / 25.0)).abs() < 1e-9, "{t}");
    }
    for syllable in 0..3 {
        let start = from_s + SYLLABLE_S * f64::from(syllable);
        assert!(
            derived
                .iter()
                .any(|(_, t, name)| name == "PP" && *t >= start && *t < start + 0.25),
            "no closure in syllable {syllable}: {derived:?}"
        );
    }
    // The viewer sees the derived frames (newest wins, the last one always), the mouth
    // moving, then the end.
    let (mut seen, mut moved) = (Vec::new(), 0usize);
    loop {
        match next_message(&mut viewer).await {
            Some(Message::Binary(bytes)) => {
                let frame = facewire_proto::viewer_frame::decode(&bytes).unwrap();
                moved = moved.max(frame.moved.len());
                let viseme = frame.viseme.expect("a derived frame names its viseme");
                assert_eq!((viseme.select1, viseme.blend), (viseme.select2, 63));
                let name = facewire::stream::visemes::VISEMES[usize::from(viseme.select1)].oculus;
                seen.push((frame.header.seq, frame.header.producer_time_s, name));
            }
            Some(Message::Text(text)) => {
                let message: ServerMessage = serde_json::from_str(text.as_str()).unwrap();
                assert!(matches!(message, ServerMessage::End { .. }), "{message:?}");
                break;
            }
            other => panic!("{other:?}"),
        }
    }
    assert!(moved > 100, "the mouth never moved: {moved} vertices");
    assert_eq!(seen.last().map(|s| s.0), derived.last().map(|d| d.0));
    for (seq, t, name) in &seen {
        assert_eq!(
            (derived[*seq as usize].1, derived[*seq as usize].2.as_str()),
            (*t, *name)
        );
    }
    server.stop().await;
}

/// From a sample arriving to the face that shows it leaving the server: the model's
/// look-ahead (52.5 ms), up to a chunk of waiting for the sample that completes it, and
/// the deform. The voice is sent at its own rate, 20 ms at a time.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_derived_face_follows_its_voice_by_the_look_ahead() {
    let server = Server::start(memory_config()).await;
    server.register("mh", "makehuman_head", "").await;
    let mut viewer = connect(&server.ws("/v1/heads/mh/streams/s/view?format=fwf2")).await;
    assert!(matches!(next_json(&mut viewer).await, ServerMessage::Snapshot(_)));
    let mut producer = connect(&server.ws("/v1/heads/mh/streams/s/produce?derive=visemes")).await;
    let chunks = voice_chunks(0.0, 75);
    let started = std::time::Instant::now();
    let sender = tokio::spawn(async move {
        for (k, chunk) in chunks.iter().enumerate() {
            tokio::time::sleep_until((started + Duration::from_millis(20 * k as u64)).into()).await;
            producer
                .send(Message::Binary(chunk.encode().into()))
                .await
                .unwrap();
        }
        producer
    });
    let (mut wall_ms, mut server_ms) = (Vec::new(), Vec::new());
    while let Some(message) = tokio::time::timeout(Duration::from_millis(400), viewer.next())
        .await
        .ok()
        .flatten()
    {
        let Ok(Message::Binary(bytes)) = message else {
            continue;
        };
        let frame = facewire_proto::viewer_frame::decode(&bytes).unwrap();
        let t = frame.header.producer_time_s;
        // The chunk holding the frame's own sample left the producer at its slot.
        let sent_ms = (t / 0.02).floor() * 20.0;
        wall_ms.push(started.elapsed().as_secs_f64() * 1e3 - sent_ms);
        server_ms.push((frame.header.server_send_us - frame.header.server_receive_us) as f64 / 1e3);
    }
    let producer = sender.await.unwrap();
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    assert!(wall_ms.len() > 30, "{} frames", wall_ms.len());
    let (wall, on_server) = (median(&mut wall_ms), median(&mut server_ms));
    println!("sample to face: median {wall:.1} ms at the viewer, {on_server:.1} ms in the server");
    assert!((25.0..150.0).contains(&wall), "median {wall} ms");
    assert!((25.0..150.0).contains(&on_server), "median {on_server} ms");
    drop(producer);
    server.stop().await;
}
