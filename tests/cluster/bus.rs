//! Several facewire nodes over a real NATS server: `facewire serve` child processes with
//! `bus = "nats://..."`, a head registered on one node and served by all (its texture
//! too), a stream produced on one node and watched on others frame for frame, one producer
//! per stream across nodes, and the faults the cluster must survive (a node killed, NATS
//! restarted).

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use crate::common::nats::{subscribed, NatsServer};
use crate::common::service::{
    close_code, connect, moving_jaw_line, next_json, next_message, pcm_chunk, post, Server, Socket,
    OPUS_LOOKAHEAD_S,
};
use facewire_proto::messages::{HeadInfo, ServerMessage};
use facewire_proto::viewer_frame::{decode, ViewerFrame};
use futures_util::SinkExt;
use tokio_tungstenite::tungstenite::Message;

pub(crate) const HEAD: &str = "mh";
pub(crate) const STREAM: &str = "talk";

async fn node(nats: &NatsServer, name: &str) -> Server {
    Server::spawn(&format!(
        "bus = \"{}\"\nnode_name = \"{name}\"\n[limits]\nproducer_idle_s = 60.0\n",
        nats.url()
    ))
    .await
}

/// Head info from `server`, or `None` while it does not know the head.
pub(crate) async fn info(server: &Server, id: &str) -> Option<HeadInfo> {
    let response = reqwest::get(server.http(&format!("/v1/heads/{id}")))
        .await
        .unwrap();
    match response.status().as_u16() {
        200 => Some(response.json().await.unwrap()),
        404 => None,
        status => panic!("GET head {id}: {status}"),
    }
}

/// An unlabelled metric's value from `server`'s `/metrics`.
pub(crate) async fn metric(server: &Server, name: &str) -> f64 {
    let text = server.metrics().await;
    text.lines()
        .find_map(|line| line.strip_prefix(name)?.strip_prefix(' ')?.trim().parse().ok())
        .unwrap_or_else(|| panic!("no {name} in /metrics of {}", server.addr))
}

pub(crate) async fn wait_gone(server: &Server, id: &str, within: Duration) {
    let started = Instant::now();
    while info(server, id).await.is_some() {
        assert!(
            started.elapsed() < within,
            "{id} still on {} after {within:?}",
            server.addr
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// Three nodes on `nats`, the MakeHuman head registered on the first and ready on all.
async fn three_nodes_with_the_head(nats: &NatsServer) -> (Server, Server, Server) {
    let n1 = node(nats, "n1").await;
    let n2 = node(nats, "n2").await;
    let n3 = node(nats, "n3").await;
    n1.register(HEAD, "makehuman_head", "").await;
    n2.wait_ready_in_cluster(HEAD, Duration::from_secs(30)).await;
    n3.wait_ready_in_cluster(HEAD, Duration::from_secs(30)).await;
    (n1, n2, n3)
}

pub(crate) async fn viewer(server: &Server) -> Socket {
    let mut socket = connect(&server.ws(&format!("/v1/heads/{HEAD}/streams/{STREAM}/view"))).await;
    assert!(matches!(next_json(&mut socket).await, ServerMessage::Snapshot(_)));
    socket
}

pub(crate) async fn producer(server: &Server) -> Socket {
    connect(&server.ws(&format!("/v1/heads/{HEAD}/streams/{STREAM}/produce"))).await
}

/// Sends frame `seq` and waits for its ack.
pub(crate) async fn produce(socket: &mut Socket, seq: u64) {
    socket
        .send(Message::Text(moving_jaw_line(seq).into()))
        .await
        .unwrap();
    match next_json(socket).await {
        ServerMessage::Ack { seq: acked, .. } => assert_eq!(acked, seq),
        other => panic!("expected the ack of {seq}, got {other:?}"),
    }
}

/// Frames by seq until `end` (whose reason is returned).
pub(crate) async fn frames_until_end(socket: &mut Socket) -> (BTreeMap<u64, ViewerFrame>, String) {
    let mut frames = BTreeMap::new();
    loop {
        match next_message(socket).await {
            Some(Message::Binary(bytes)) => {
                let frame = decode(&bytes).unwrap();
                frames.insert(frame.header.seq, frame);
            }
            Some(Message::Text(text)) => match serde_json::from_str(text.as_str()).unwrap() {
                ServerMessage::End { reason, .. } => return (frames, reason.to_string()),
                other => panic!("expected a frame or end, got {other:?}"),
            },
            other => panic!("expected a frame or end, got {other:?}"),
        }
    }
}

/// The next frame's seq, skipping JSON messages; `None` when nothing comes within `wait`.
pub(crate) async fn next_seq(socket: &mut Socket, wait: Duration) -> Option<u64> {
    let deadline = Instant::now() + wait;
    loop {
        let left = deadline.checked_duration_since(Instant::now())?;
        match tokio::time::timeout(left, futures_util::StreamExt::next(socket)).await {
            Ok(Some(Ok(Message::Binary(bytes)))) => return Some(decode(&bytes).unwrap().header.seq),
            Ok(Some(Ok(_))) => {}
            Ok(_) => panic!("the viewer's socket closed"),
            Err(_) => return None,
        }
    }
}

/// The frame without its send time: what must be equal on every node (the receive time
/// is the producer's node's, carried over the bus).
fn content(frame: &ViewerFrame) -> ViewerFrame {
    let mut frame = frame.clone();
    frame.header.server_send_us = 0;
    frame
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn three_nodes_share_a_head_and_a_stream_frame_for_frame() {
    let nats = NatsServer::start();
    let (n1, n2, n3) = three_nodes_with_the_head(&nats).await;

    // Viewers on the producer's node (the single-node path) and on a node with no producer.
    let mut here = viewer(&n2).await;
    let mut there = viewer(&n3).await;
    let mut socket = producer(&n2).await;
    let mut ticks = tokio::time::interval(Duration::from_millis(33));
    for seq in 0..40 {
        ticks.tick().await;
        produce(&mut socket, seq).await;
        if seq == 5 {
            // One producer per stream, across nodes.
            let mut second = producer(&n3).await;
            assert_eq!(close_code(&mut second).await, 4409);
        }
    }
    socket
        .send(Message::Text(r#"{"type":"end"}"#.into()))
        .await
        .unwrap();

    let (local, local_end) = frames_until_end(&mut here).await;
    let (remote, remote_end) = frames_until_end(&mut there).await;
    assert_eq!(local_end, "producer_ended");
    assert_eq!(remote_end, "producer_ended");
    assert!(remote.len() >= 30, "node 3 showed {} of 40 frames", remote.len());
    let (mut compared, mut moving) = (0, 0);
    for (seq, frame) in &remote {
        if let Some(same) = local.get(seq) {
            assert_eq!(content(frame), content(same), "frame {seq} differs between nodes");
            compared += 1;
            moving += usize::from(!frame.moved.is_empty());
        }
    }
    assert!(compared >= 30, "{compared} frames compared");
    assert!(moving >= 25, "{moving} of them move the head");
    // The bus carried parameters: 40 frames and the end out of node 2, into node 3, each
    // frame's hop measured.
    assert_eq!(metric(&n2, "facewire_bus_messages_out_total").await, 41.0);
    assert_eq!(metric(&n3, "facewire_bus_messages_in_total").await, 41.0);
    assert_eq!(metric(&n3, "facewire_bus_hop_seconds_count").await, 40.0);

    // Deleted on one node, gone on every node.
    let deleted = reqwest::Client::new()
        .delete(n3.http(&format!("/v1/heads/{HEAD}")))
        .send()
        .await
        .unwrap();
    assert_eq!(deleted.status(), 204);
    wait_gone(&n1, HEAD, Duration::from_secs(5)).await;
    wait_gone(&n2, HEAD, Duration::from_secs(5)).await;

    // A node that starts later catches up: the head registered before it is served, its
    // texture with it.
    let png = crate::common::texture::solid_png(8, 8, [30, 210, 50]);
    let request = crate::common::texture::textured_request("late", &png);
    let (status, body) = post(&n1, "/v1/heads", request.to_string(), "application/json").await;
    assert_eq!(status, 202, "{body}");
    n1.wait_ready("late", "").await;
    let n4 = node(&nats, "n4").await;
    n4.wait_ready_in_cluster("late", Duration::from_secs(30)).await;
    assert!(info(&n4, HEAD).await.is_none(), "the deleted head stays deleted");
    let texture = reqwest::get(n4.http("/v1/heads/late/texture")).await.unwrap();
    assert_eq!(texture.status(), 200);
    assert_eq!(texture.bytes().await.unwrap().as_ref(), png.as_slice());
    let uv = reqwest::get(n4.http("/v1/heads/late/uv.bin")).await.unwrap();
    assert_eq!(uv.status(), 200);

    // An avatar's own ARKit basis travels with it.
    let (status, body) = post(
        &n1,
        "/v1/heads?id=avatar",
        crate::common::glb::ict_avatar_with_targets(),
        "model/gltf-binary",
    )
    .await;
    assert_eq!(status, 202, "{body}");
    n4.wait_ready_in_cluster("avatar", Duration::from_secs(30)).await;
    let on_n4 = info(&n4, "avatar").await.unwrap();
    assert_eq!(
        on_n4.arkit_blendshapes,
        n1.wait_ready("avatar", "").await.arkit_blendshapes
    );
    assert_eq!(on_n4.arkit_blendshapes.len(), 51);
}

/// Sends frames from `first` at 30 fps until `stop`, then returns the next seq. Reconnects
/// to the next of `urls` (round robin) when its node goes away, as a producer client
/// should; each reconnect is reported with how long it took.
async fn keep_producing(
    urls: Vec<String>,
    first: u64,
    stop: tokio_util::sync::CancellationToken,
) -> (u64, Vec<Duration>) {
    let mut seq = first;
    let mut reconnects = Vec::new();
    let mut at = 0;
    let mut socket = connect(&urls[at]).await;
    let mut ticks = tokio::time::interval(Duration::from_millis(33));
    while !stop.is_cancelled() {
        ticks.tick().await;
        let sent = socket.send(Message::Text(moving_jaw_line(seq).into())).await;
        let acked = match sent {
            Ok(()) => matches!(
                tokio::time::timeout(Duration::from_secs(2), futures_util::StreamExt::next(&mut socket))
                    .await,
                Ok(Some(Ok(Message::Text(_))))
            ),
            Err(_) => false,
        };
        if acked {
            seq += 1;
            continue;
        }
        let lost = Instant::now();
        loop {
            at = (at + 1) % urls.len();
            if let Ok((mut next, _)) = tokio_tungstenite::connect_async(&urls[at]).await {
                // A refusal (the lease still held) comes as an error and a close.
                next.send(Message::Text(moving_jaw_line(seq).into()))
                    .await
                    .unwrap();
                if let Ok(Some(Ok(Message::Text(text)))) =
                    tokio::time::timeout(Duration::from_secs(2), futures_util::StreamExt::next(&mut next))
                        .await
                {
                    if text.contains("\"ack\"") {
                        seq += 1;
                        socket = next;
                        break;
                    }
                }
            }
            assert!(
                lost.elapsed() < Duration::from_secs(20),
                "no node took the producer back"
            );
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        reconnects.push(lost.elapsed());
    }
    (seq, reconnects)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_killed_node_drops_only_its_own_connections() {
    let nats = NatsServer::start();
    let (n1, n2, n3) = three_nodes_with_the_head(&nats).await;

    let mut on_n2 = viewer(&n2).await;
    let mut on_n3 = viewer(&n3).await;
    let produce_path = format!("/v1/heads/{HEAD}/streams/{STREAM}/produce");
    let stop = tokio_util::sync::CancellationToken::new();
    // The producer starts on node 2 and moves to node 1 when node 2 dies.
    let producing = tokio::spawn(keep_producing(
        vec![n2.ws(&produce_path), n1.ws(&produce_path)],
        0,
        stop.clone(),
    ));
    let mut last_on_n2 = 0;
    while last_on_n2 < 20 {
        last_on_n2 = next_seq(&mut on_n2, Duration::from_secs(5))
            .await
            .expect("frames on node 2");
    }

    drop(n2); // SIGKILL: no goodbyes

    // Node 3's viewer keeps watching: the producer resumes on node 1 and its frames come
    // on, with no end in between.
    let killed = Instant::now();
    let mut last_on_n3 = 0;
    while last_on_n3 < last_on_n2 + 30 {
        last_on_n3 = next_seq(&mut on_n3, Duration::from_secs(10))
            .await
            .expect("frames on node 3 after node 2 died");
    }
    let resumed_after = killed.elapsed();

    // Node 2's viewer reconnects to node 1 and starts from the newest frame at once.
    match next_message(&mut on_n2).await {
        None | Some(Message::Close(_)) => {}
        Some(other) => panic!("node 2's viewer still open: {other:?}"),
    }
    let mut moved = viewer(&n1).await;
    let first = next_seq(&mut moved, Duration::from_millis(500))
        .await
        .expect("the newest frame within 0.5 s");
    assert!(first >= last_on_n3, "resumed at {first}, behind {last_on_n3}");

    stop.cancel();
    let (_, reconnects) = producing.await.unwrap();
    assert_eq!(reconnects.len(), 1, "{reconnects:?}");
    assert!(
        reconnects[0] < Duration::from_secs(3),
        "the producer took {:?} to resume on node 1",
        reconnects[0]
    );
    println!(
        "producer resumed on node 1 {:?} after its node died; node 3 saw 30 new frames {:?} after the kill",
        reconnects[0], resumed_after
    );
    for survivor in [&n1, &n3] {
        assert_eq!(info(survivor, HEAD).await.unwrap().status, "ready");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_nats_restart_is_survived_without_restarting_facewire() {
    let mut nats = NatsServer::start();
    let n1 = node(&nats, "n1").await;
    let n2 = node(&nats, "n2").await;
    n1.register(HEAD, "makehuman_head", "").await;
    n2.wait_ready_in_cluster(HEAD, Duration::from_secs(30)).await;

    let mut on_n2 = viewer(&n2).await;
    let stop = tokio_util::sync::CancellationToken::new();
    let producing = tokio::spawn(keep_producing(
        vec![n1.ws(&format!("/v1/heads/{HEAD}/streams/{STREAM}/produce"))],
        0,
        stop.clone(),
    ));
    let mut last = 0;
    while last < 10 {
        last = next_seq(&mut on_n2, Duration::from_secs(5))
            .await
            .expect("frames on node 2");
    }

    nats.kill();
    tokio::time::sleep(Duration::from_millis(300)).await;
    // While NATS is away, what needs the cluster is refused at once, with the reason.
    let asked = Instant::now();
    let mut refused = connect(&n2.ws(&format!("/v1/heads/{HEAD}/streams/other/produce"))).await;
    match next_json(&mut refused).await {
        ServerMessage::Error { code, .. } => assert_eq!(code.as_str(), "bus_unavailable"),
        other => panic!("expected bus_unavailable, got {other:?}"),
    }
    assert_eq!(close_code(&mut refused).await, 4503);
    let registering = reqwest::Client::new()
        .post(n2.http("/v1/heads"))
        .json(&serde_json::json!({
            "id": "during",
            "obj": std::fs::read_to_string(crate::common::data("heads/makehuman_head.obj")).unwrap(),
            "fit": std::fs::read_to_string(crate::common::data("heads/makehuman_head.fit.toml")).unwrap(),
        }))
        .send()
        .await
        .unwrap();
    assert_eq!(registering.status(), 503);
    assert!(
        asked.elapsed() < Duration::from_secs(2),
        "refused after {:?}",
        asked.elapsed()
    );
    tokio::time::sleep(Duration::from_millis(1700)).await;
    nats.restart();
    let restarted = Instant::now();
    // Frames produced on node 1 reach node 2 again.
    let before = last;
    while last < before + 60 + 30 {
        last = next_seq(&mut on_n2, Duration::from_secs(15))
            .await
            .expect("frames on node 2 after NATS came back");
    }
    let resumed = restarted.elapsed();
    assert!(
        resumed < Duration::from_secs(10),
        "frames resumed {resumed:?} after the restart"
    );

    // The registry survived and is followed again: a head registered now reaches node 1.
    assert_eq!(info(&n2, HEAD).await.unwrap().status, "ready");
    n2.register("after", "makehuman_head", "").await;
    n1.wait_ready_in_cluster("after", Duration::from_secs(30)).await;
    // And the lease is still held: a second producer on node 2 is refused.
    let mut second = producer(&n2).await;
    assert_eq!(close_code(&mut second).await, 4409);

    stop.cancel();
    let (_, reconnects) = producing.await.unwrap();
    assert!(
        reconnects.is_empty(),
        "the producer on node 1 was never dropped: {reconnects:?}"
    );
    println!("frames flowed between nodes again {resumed:?} after NATS restarted");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn buckets_an_operator_made_first_are_used_as_they_are() {
    // An operator makes the heads bucket with settings of its own (on a NATS cluster: more
    // replicas); a node must use it, not refuse to start.
    let nats = NatsServer::start();
    let client = async_nats::connect(nats.url()).await.unwrap();
    let js = async_nats::jetstream::new(client);
    js.create_key_value(async_nats::jetstream::kv::Config {
        bucket: "facewire_heads".into(),
        description: "made by the operator".into(),
        history: 5,
        ..Default::default()
    })
    .await
    .unwrap();
    let n1 = node(&nats, "n1").await;
    n1.register(HEAD, "makehuman_head", "").await;
    let heads = js.get_key_value("facewire_heads").await.unwrap();
    assert_eq!(heads.status().await.unwrap().history(), 5);
    assert!(
        heads.get(HEAD).await.unwrap().is_some(),
        "the head is in the operator's bucket"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_head_a_node_could_not_take_at_first_is_taken_once_it_can() {
    // A node that fails to take a head from the shared registry (here its disk refuses the
    // copy: a file stands where the head's folder goes; under load it is the bus timing out)
    // tries again, rather than waiting for a change to that head that may never come.
    let nats = NatsServer::start();
    let n1 = node(&nats, "n1").await;
    let n2 = node(&nats, "n2").await;
    let blocker = n2.data_dir().unwrap().join("heads").join(HEAD);
    std::fs::create_dir_all(blocker.parent().unwrap()).unwrap();
    std::fs::write(&blocker, b"not a folder").unwrap();
    n1.register(HEAD, "makehuman_head", "").await;
    // n1 has put the head in the shared registry; n2 has seen it and failed to keep it.
    tokio::time::sleep(Duration::from_secs(2)).await;
    assert!(info(&n2, HEAD).await.is_none(), "n2 kept the head through a file");
    std::fs::remove_file(&blocker).unwrap();
    n2.wait_ready_in_cluster(HEAD, Duration::from_secs(20)).await;
    assert!(blocker.join("head.obj").is_file(), "n2 keeps its copy on disk");
}

#[test]
fn a_node_that_cannot_reach_nats_at_start_exits_with_the_reason() {
    // Nothing listens on this port: the node says so and exits, rather than serving
    // alone as if it were a cluster.
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("node.toml");
    std::fs::write(&config, format!("bus = \"nats://127.0.0.1:{port}\"\n")).unwrap();
    let started = Instant::now();
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_facewire"))
        .args(["serve", "--addr", "127.0.0.1:0", "--config"])
        .arg(&config)
        .output()
        .unwrap();
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains(&format!(
            "bus \"nats://127.0.0.1:{port}\": cannot connect to NATS"
        )),
        "{stderr}"
    );
    assert!(
        started.elapsed() < Duration::from_secs(10),
        "took {:?}",
        started.elapsed()
    );
}

/// The audio chunks a viewer hears until the stream ends.
async fn audio_until_end(socket: &mut Socket) -> Vec<facewire_proto::audio_chunk::AudioChunk> {
    let mut heard = Vec::new();
    loop {
        match next_message(socket).await {
            Some(Message::Binary(bytes)) if bytes.starts_with(b"FWA1") => {
                heard.push(facewire_proto::audio_chunk::AudioChunk::decode(&bytes).unwrap())
            }
            Some(Message::Binary(_)) => {}
            Some(Message::Text(text)) => match serde_json::from_str(text.as_str()).unwrap() {
                ServerMessage::End { .. } => return heard,
                other => panic!("expected audio, a frame or end, got {other:?}"),
            },
            other => panic!("expected audio, a frame or end, got {other:?}"),
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_producer_s_voice_is_heard_on_another_node() {
    use facewire_proto::audio_chunk::AudioBody;
    let nats = NatsServer::start();
    let n1 = node(&nats, "n1").await;
    let n2 = node(&nats, "n2").await;
    n1.register(HEAD, "makehuman_head", "").await;
    n2.wait_ready_in_cluster(HEAD, Duration::from_secs(30)).await;
    let listen = |codec: &str| {
        n2.ws(&format!(
            "/v1/heads/{HEAD}/streams/{STREAM}/view?format=fwf2&audio={codec}"
        ))
    };
    let (mut pcm, mut opus) = (connect(&listen("pcm")).await, connect(&listen("opus")).await);
    for viewer in [&mut pcm, &mut opus] {
        assert!(matches!(next_json(viewer).await, ServerMessage::Snapshot(_)));
    }

    // Half a second of voice between two frames, sent at its own pace, on node 1.
    let mut socket = producer(&n1).await;
    produce(&mut socket, 0).await;
    let sent: Vec<_> = (0..25)
        .map(|i| pcm_chunk(0.02 * f64::from(i), i as i16))
        .collect();
    let mut ticks = tokio::time::interval(Duration::from_millis(20));
    for chunk in &sent {
        ticks.tick().await;
        socket.send(Message::Binary(chunk.encode().into())).await.unwrap();
    }
    produce(&mut socket, 1).await;
    socket
        .send(Message::Text(r#"{"type":"end"}"#.into()))
        .await
        .unwrap();

    // Node 2 hears every chunk as sent, in order, stamped with node 1's receipt...
    let heard = audio_until_end(&mut pcm).await;
    assert_eq!(
        heard.len(),
        sent.len(),
        "node 2 heard {} of 25 chunks",
        heard.len()
    );
    for (got, want) in heard.iter().zip(&sent) {
        assert_eq!((got.t_s, &got.body), (want.t_s, &want.body));
        assert!(got.server_receive_us > 1_700_000_000_000_000);
    }
    // ... and the same voice in Opus, encoded once on node 1: thirteen 40 ms packets from
    // t = 0 on (each stamped at its first decoded sample, the encoder's look-ahead
    // earlier), the last holding the final 20 ms closed with silence when the stream ended.
    let packets = audio_until_end(&mut opus).await;
    assert_eq!(packets.len(), 13);
    for (i, packet) in packets.iter().enumerate() {
        assert!(
            (packet.t_s - (0.04 * i as f64 - OPUS_LOOKAHEAD_S)).abs() < 1e-9,
            "packet {i} at {}",
            packet.t_s
        );
        assert!(matches!(packet.body, AudioBody::Opus { .. }));
    }
    // Two frames, 25 chunks, 13 packets and the end.
    assert_eq!(
        metric(&n2, "facewire_bus_messages_in_total").await,
        2.0 + 25.0 + 13.0 + 1.0
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stream_whose_producers_node_dies_ends_for_the_other_nodes_viewers() {
    let nats = NatsServer::start();
    let n1 = node(&nats, "n1").await;
    let n2 = node(&nats, "n2").await;
    n1.register(HEAD, "makehuman_head", "").await;
    n2.wait_ready_in_cluster(HEAD, Duration::from_secs(30)).await;
    let mut watching = viewer(&n2).await;
    let mut source = producer(&n1).await;
    for seq in 0..10 {
        produce(&mut source, seq).await;
    }
    assert!(next_seq(&mut watching, Duration::from_secs(5)).await.is_some());
    drop(n1); // SIGKILL: the producer's node sends no end, and its producer never returns
    let killed = Instant::now();
    // Its lease expires (6 s after its last refresh); node 2 then ends the stream.
    let (_, reason) = frames_until_end(&mut watching).await;
    let ended_after = killed.elapsed();
    assert_eq!(reason, "producer_disconnected");
    assert!(ended_after < Duration::from_secs(10), "{ended_after:?}");
    println!("the orphaned stream ended on node 2 {ended_after:?} after its producer's node died");
    drop(source);
}

/// A labelled counter's value from `server`'s `/metrics` (0 when never counted).
async fn dropped(server: &Server, code: &str) -> f64 {
    let prefix = format!("facewire_bus_dropped_total{{code=\"{code}\"}} ");
    server
        .metrics()
        .await
        .lines()
        .find_map(|line| line.strip_prefix(&prefix)?.trim().parse().ok())
        .unwrap_or(0.0)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn with_a_cluster_key_a_client_on_the_bus_changes_nothing_a_viewer_sees() {
    let nats = NatsServer::start();
    let keyed = |name: &str| {
        format!(
            "bus = \"{}\"\nnode_name = \"{name}\"\n[limits]\nproducer_idle_s = 60.0\n\
             [bus_auth]\ncluster_key = \"a key only the cluster's nodes hold\"\n",
            nats.url()
        )
    };
    let n1 = Server::spawn(&keyed("n1")).await;
    let n2 = Server::spawn(&keyed("n2")).await;
    n1.register(HEAD, "makehuman_head", "").await;
    n2.wait_ready_in_cluster(HEAD, Duration::from_secs(30)).await;
    let mut on_n1 = viewer(&n1).await;
    let mut on_n2 = viewer(&n2).await;
    let mut source = producer(&n1).await;
    // A plain client on the bus, without the key: forged frames (a seq far ahead, an
    // old and a future receive time, the newest lease there could be), forged ends, and
    // frames with no headers at all, on the live stream's subject.
    let forger = async_nats::connect(nats.url()).await.unwrap();
    let subject = format!("facewire.params.{HEAD}.{STREAM}");
    let mut forged = 0;
    for seq in 0..40 {
        produce(&mut source, seq).await;
        if seq % 10 == 5 {
            for received_us in ["0", "18446744073709551615"] {
                let mut headers = async_nats::HeaderMap::new();
                headers.insert("Facewire-Received-Us", received_us);
                headers.insert("Facewire-Lease", "18446744073709551615");
                headers.insert("Facewire-Mac", "00".repeat(32).as_str());
                let line = moving_jaw_line(1_000_000 + seq);
                forger
                    .publish_with_headers(subject.clone(), headers, line.into())
                    .await
                    .unwrap();
            }
            let mut end = async_nats::HeaderMap::new();
            end.insert("Facewire-End", "producer_cancelled");
            end.insert("Facewire-Lease", "18446744073709551615");
            forger
                .publish_with_headers(subject.clone(), end, bytes::Bytes::new())
                .await
                .unwrap();
            forger
                .publish(subject.clone(), moving_jaw_line(2_000_000 + seq).into())
                .await
                .unwrap();
            forged += 4;
        }
    }
    forger.flush().await.unwrap();
    source
        .send(Message::Text(r#"{"type":"end"}"#.into()))
        .await
        .unwrap();
    for (node, socket) in [("n1", &mut on_n1), ("n2", &mut on_n2)] {
        let (frames, reason) = frames_until_end(socket).await;
        assert_eq!(reason, "producer_ended", "{node}");
        let last = frames.keys().next_back().copied();
        assert_eq!(last, Some(39), "{node}: {:?}", frames.keys().collect::<Vec<_>>());
    }
    // Every forged message was refused for its proof: on n2 as bad_mac, on n1 as well
    // (the producer's own node takes nothing from the bus into its stream).
    for node in [&n1, &n2] {
        let refused = dropped(node, "bad_mac").await;
        assert_eq!(refused, forged as f64, "{}", node.addr);
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn without_a_key_the_bus_is_still_held_to_a_producers_rules() {
    use futures_util::StreamExt;
    let nats = NatsServer::start();
    let n1 = node(&nats, "n1").await;
    let n2 = node(&nats, "n2").await;
    n1.register(HEAD, "makehuman_head", "").await;
    n2.wait_ready_in_cluster(HEAD, Duration::from_secs(30)).await;
    let mut on_n2 = viewer(&n2).await;
    let mut source = producer(&n1).await;
    let client = async_nats::connect(nats.url()).await.unwrap();
    let subject = format!("facewire.params.{HEAD}.{STREAM}");
    let mut overheard = subscribed(&client, subject.clone()).await;
    for seq in 0..10 {
        produce(&mut source, seq).await;
    }
    // Node 2 has every real frame before anything is forged (two publishers' messages
    // are not ordered against each other).
    let mut seen = Vec::new();
    while seen.last() != Some(&9) {
        seen.push(
            next_seq(&mut on_n2, Duration::from_secs(5))
                .await
                .expect("frames on n2"),
        );
    }
    // A real frame overheard, replayed as it was: its seq is old by now.
    let real = overheard.next().await.unwrap();
    assert!(
        real.headers
            .as_ref()
            .is_some_and(|h| h.get("Facewire-End").is_none()),
        "the first message overheard is not a frame: {:?}",
        real.headers
    );
    let lease = real
        .headers
        .as_ref()
        .unwrap()
        .get("Facewire-Lease")
        .unwrap()
        .to_string();
    client
        .publish_with_headers(
            subject.clone(),
            real.headers.clone().unwrap(),
            real.payload.clone(),
        )
        .await
        .unwrap();
    // Under an earlier lease than the stream's: fenced.
    let mut old_lease = async_nats::HeaderMap::new();
    old_lease.insert("Facewire-Lease", "0");
    old_lease.insert("Facewire-Received-Us", "1");
    client
        .publish_with_headers(subject.clone(), old_lease, moving_jaw_line(500).into())
        .await
        .unwrap();
    // Under the stream's own lease with a receive time at the epoch: admitted (there is
    // no key to prove otherwise) but its hop held to 60 s.
    let mut epoch = async_nats::HeaderMap::new();
    epoch.insert("Facewire-Lease", lease.as_str());
    epoch.insert("Facewire-Received-Us", "0");
    client
        .publish_with_headers(subject.clone(), epoch, moving_jaw_line(600).into())
        .await
        .unwrap();
    client.flush().await.unwrap();
    while seen.last() != Some(&600) {
        seen.push(
            next_seq(&mut on_n2, Duration::from_secs(5))
                .await
                .expect("frames on n2"),
        );
    }
    assert!(seen.windows(2).all(|w| w[0] < w[1]), "{seen:?}");
    assert!(!seen.contains(&500), "{seen:?}");
    // The counters are read from /metrics, polled to a deadline: a loaded machine may
    // take long, and the failure names every drop counted.
    let deadline = tokio::time::Instant::now() + Duration::from_secs(10);
    loop {
        let (stale, fenced) = (dropped(&n2, "stale").await, dropped(&n2, "fenced").await);
        if (stale, fenced) == (1.0, 1.0) {
            break;
        }
        let counted: Vec<String> = n2
            .metrics()
            .await
            .lines()
            .filter(|line| line.starts_with("facewire_bus_dropped_total"))
            .map(str::to_string)
            .collect();
        assert!(
            stale <= 1.0 && fenced <= 1.0 && tokio::time::Instant::now() < deadline,
            "n2 dropped stale {stale}, fenced {fenced} (one each expected): {counted:?}"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let hops = metric(&n2, "facewire_bus_hop_seconds_sum").await;
    let count = metric(&n2, "facewire_bus_hop_seconds_count").await;
    assert!(hops <= 60.0 + count, "hop sum {hops} s over {count} frames");
}

/// The seqs of the frames `viewer` receives up to frame `last`; panics on the stream's end
/// or anything but frames.
async fn seqs_until(viewer: &mut Socket, last: u64) -> Vec<u64> {
    let mut seen = Vec::new();
    while seen.last() != Some(&last) {
        match next_message(viewer).await {
            Some(Message::Binary(bytes)) => seen.push(decode(&bytes).unwrap().header.seq),
            Some(Message::Text(text)) => {
                if let ServerMessage::End { reason, .. } = serde_json::from_str(text.as_str()).unwrap() {
                    panic!("ended ({reason}) after {seen:?}");
                }
            }
            other => panic!("expected frames, got {other:?} after {seen:?}"),
        }
    }
    seen
}

/// A producer on `node` sends frames 0-9 (seen by `viewer`); then the node is frozen and
/// frames 10-19 wait in its socket. The producer's socket, to keep open.
async fn freeze_holding_frames(node: &Server, viewer: &mut Socket) -> Socket {
    let mut socket = producer(node).await;
    for seq in 0..10 {
        produce(&mut socket, seq).await;
    }
    while next_seq(viewer, Duration::from_secs(5)).await != Some(9) {}
    signal(node, "STOP");
    for seq in 10..20 {
        socket
            .send(Message::Text(moving_jaw_line(seq).into()))
            .await
            .unwrap();
    }
    socket
}

/// Sends `signal` (`STOP`, `CONT`) to a node's process.
fn signal(server: &Server, signal: &str) {
    let pid = server.pid().expect("a child process").to_string();
    let status = std::process::Command::new("kill")
        .args([&format!("-{signal}"), &pid])
        .status()
        .unwrap();
    assert!(status.success(), "kill -{signal} {pid}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_node_frozen_while_its_stream_was_taken_over_relays_nothing_when_it_wakes() {
    let nats = NatsServer::start();
    let (n1, n2, n3) = three_nodes_with_the_head(&nats).await;
    let mut on_n3 = viewer(&n3).await;
    let first = freeze_holding_frames(&n1, &mut on_n3).await;
    // The producer moves on: node 2 takes the lease over (node 1 does not
    // answer its liveness check).
    let mut second = producer(&n2).await;
    for seq in 100..110 {
        produce(&mut second, seq).await;
    }
    // Node 1 wakes, takes in what waited and finds its lease gone.
    signal(&n1, "CONT");
    for seq in 110..140 {
        produce(&mut second, seq).await;
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let seen = seqs_until(&mut on_n3, 139).await;
    assert!(seen.iter().all(|&s| s >= 100), "{seen:?}");
    assert!(seen.windows(2).all(|w| w[0] < w[1]), "{seen:?}");
    println!(
        "node 3 dropped {} messages of node 1's lost lease",
        dropped(&n3, "fenced").await
    );
    drop(first);
}

/// The same freeze, with the new holder frozen too as soon as it has taken the lease, so
/// that nothing of the new lease has reached node 3 when node 1 wakes: node 1 finds the
/// lease gone before it relays the frames its socket held, and node 3's viewer sees none
/// of them. (Seen once before the check, under load: node 1's frame 19 reached node 3
/// before node 2's first frame.)
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_woken_node_checks_its_lease_before_relaying_what_it_held() {
    use async_nats::jetstream;
    let nats = NatsServer::start();
    let (n1, n2, n3) = three_nodes_with_the_head(&nats).await;
    let leases = jetstream::new(async_nats::connect(nats.url()).await.unwrap())
        .get_key_value("facewire_producers")
        .await
        .unwrap();
    let key = format!("{HEAD}.{STREAM}");
    let revision = || async { leases.entry(&key).await.unwrap().map_or(0, |e| e.revision) };
    let mut on_n3 = viewer(&n3).await;
    let first = freeze_holding_frames(&n1, &mut on_n3).await;
    let held = revision().await;
    // Node 2 takes the lease over (node 1 does not answer its liveness check), then
    // freezes before it has anything to relay.
    let mut second = producer(&n2).await;
    let deadline = Instant::now() + Duration::from_secs(10);
    while revision().await == held {
        assert!(Instant::now() < deadline, "node 2 did not take the lease over");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    signal(&n2, "STOP");
    signal(&n1, "CONT");
    // Node 1 reads what its socket held; whatever it would relay has time to arrive.
    let deadline = Instant::now() + Duration::from_secs(10);
    while dropped(&n1, "lease_lost").await < 1.0 {
        assert!(
            Instant::now() < deadline,
            "node 1 dropped nothing of its lost lease"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    tokio::time::sleep(Duration::from_millis(500)).await;
    signal(&n2, "CONT");
    for seq in 100..140 {
        produce(&mut second, seq).await;
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let seen = seqs_until(&mut on_n3, 139).await;
    assert!(seen.iter().all(|&s| s >= 100), "{seen:?}");
    println!(
        "node 1 dropped {} messages of its lost lease after waking",
        dropped(&n1, "lease_lost").await
    );
    drop(first);
}

/// A voice alone, as Opus packets on node 1, animates the head for a viewer on node 2.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_face_derived_from_a_voice_on_one_node_is_seen_on_another() {
    use facewire::stream::syllables::SYLLABLE_S;
    use facewire::stream::visemes::VISEMES;
    use facewire_proto::audio_chunk::{AudioBody, AudioChunk};
    let nats = NatsServer::start();
    let n1 = node(&nats, "n1").await;
    let n2 = node(&nats, "n2").await;
    n1.register(HEAD, "makehuman_head", "").await;
    n2.wait_ready_in_cluster(HEAD, Duration::from_secs(30)).await;
    let mut watcher = connect(&n2.ws(&format!("/v1/heads/{HEAD}/streams/{STREAM}/view?format=fwf2"))).await;
    assert!(matches!(
        next_json(&mut watcher).await,
        ServerMessage::Snapshot(_)
    ));

    // "ma", "mi" of the syllable voice as 20 ms Opus packets (16 kHz in, 48 kHz out), at
    // the voice's own pace: node 2 relays a stream from when the bus tells it the stream
    // began, and sent all at once the faces were all derived before it did.
    let voice = facewire::voice::syllable_voice().unwrap();
    let from = (12.0 * SYLLABLE_S * 16_000.0).round() as usize;
    let mut encoder = opus::Encoder::new(16_000, opus::Channels::Mono, opus::Application::Voip).unwrap();
    let mut socket = connect(&n1.ws(&format!(
        "/v1/heads/{HEAD}/streams/{STREAM}/produce?derive=visemes&derived=1"
    )))
    .await;
    let mut ticks = tokio::time::interval(Duration::from_millis(20));
    for k in 0..60 {
        ticks.tick().await;
        let pcm = &voice.samples[from + 320 * k..from + 320 * (k + 1)];
        let chunk = AudioChunk {
            t_s: 0.02 * k as f64,
            server_receive_us: 0,
            body: AudioBody::Opus {
                packet: encoder.encode_vec(pcm, 1275).unwrap(),
            },
            ignored: Vec::new(),
        };
        socket.send(Message::Binary(chunk.encode().into())).await.unwrap();
    }
    socket
        .send(Message::Text(r#"{"type":"end"}"#.into()))
        .await
        .unwrap();
    let mut derived = BTreeMap::new();
    loop {
        match next_json(&mut socket).await {
            ServerMessage::Derived { seq, viseme, .. } => {
                derived.insert(seq, viseme.oculus);
            }
            ServerMessage::End { .. } => break,
            other => panic!("{other:?}"),
        }
    }
    // 30 frames a second over 1.2 s, and perhaps a closing one.
    assert!((36..=37).contains(&derived.len()), "{}", derived.len());
    assert!(derived.values().any(|name| name == "PP"), "{derived:?}");

    let (frames, reason) = frames_until_end(&mut watcher).await;
    assert_eq!(reason, "producer_ended");
    assert_eq!(frames.keys().last(), derived.keys().last());
    for (seq, frame) in &frames {
        let viseme = frame.viseme.expect("the viseme in every derived frame");
        assert_eq!(
            VISEMES[usize::from(viseme.select1)].oculus,
            derived[seq],
            "frame {seq}"
        );
    }
    assert!(
        frames.values().any(|f| f.moved.len() > 100),
        "the mouth never moved"
    );
}
