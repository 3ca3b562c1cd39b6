//! Several facewire nodes over a real NATS server: `facewire serve` child processes with
//! `bus = "nats://..."`, a head registered on one node and served by all, a stream produced
//! on one node and watched on others frame for frame, one producer per stream across
//! nodes, and the faults the cluster must survive (a node killed, NATS restarted).

mod common;

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use common::nats::NatsServer;
use common::service::{close_code, connect, next_json, next_message, Server, Socket};
use facewire_proto::frame::{decode, ViewerFrame};
use facewire_proto::messages::{HeadInfo, ServerMessage};
use futures_util::SinkExt;
use tokio_tungstenite::tungstenite::Message;

const HEAD: &str = "mh";
const STREAM: &str = "talk";

async fn node(nats: &NatsServer, name: &str) -> Server {
    Server::spawn(&format!(
        "bus = \"{}\"\nnode_name = \"{name}\"\n[limits]\nproducer_idle_s = 60.0\n",
        nats.url()
    ))
    .await
}

/// Head info from `server`, or `None` while it does not know the head.
async fn info(server: &Server, id: &str) -> Option<HeadInfo> {
    let response = reqwest::get(server.http(&format!("/v1/heads/{id}")))
        .await
        .unwrap();
    match response.status().as_u16() {
        200 => Some(response.json().await.unwrap()),
        404 => None,
        status => panic!("GET head {id}: {status}"),
    }
}

/// Waits until `server` has `id` ready (registered on another node, followed here).
async fn wait_ready_anywhere(server: &Server, id: &str, within: Duration) {
    let started = Instant::now();
    loop {
        if let Some(info) = info(server, id).await {
            match info.status.as_str() {
                "ready" => return,
                "failed" => panic!("{id} failed on {}: {:?}", server.addr, info.error),
                _ => {}
            }
        }
        assert!(
            started.elapsed() < within,
            "{id} not ready on {} within {within:?}",
            server.addr
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

async fn wait_gone(server: &Server, id: &str, within: Duration) {
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

/// A frame line whose jaw moves with `seq`, so every frame differs.
fn line(seq: u64) -> String {
    let jaw = 0.15 + 0.15 * (seq as f64 * 0.4).sin();
    format!(
        r#"{{"seq":{seq},"t":{},"au":{{"jaw_drop":{jaw}}}}}"#,
        seq as f64 / 30.0
    )
}

async fn viewer(server: &Server) -> Socket {
    let mut socket = connect(&server.ws(&format!("/v1/heads/{HEAD}/streams/{STREAM}/view"))).await;
    assert!(matches!(next_json(&mut socket).await, ServerMessage::Snapshot(_)));
    socket
}

async fn producer(server: &Server) -> Socket {
    connect(&server.ws(&format!("/v1/heads/{HEAD}/streams/{STREAM}/produce"))).await
}

/// Sends frame `seq` and waits for its ack.
async fn produce(socket: &mut Socket, seq: u64) {
    socket.send(Message::Text(line(seq).into())).await.unwrap();
    match next_json(socket).await {
        ServerMessage::Ack { seq: acked, .. } => assert_eq!(acked, seq),
        other => panic!("expected the ack of {seq}, got {other:?}"),
    }
}

/// Frames by seq until `end` (whose reason is returned).
async fn frames_until_end(socket: &mut Socket) -> (BTreeMap<u64, ViewerFrame>, String) {
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
async fn next_seq(socket: &mut Socket, wait: Duration) -> Option<u64> {
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
    let n1 = node(&nats, "n1").await;
    let n2 = node(&nats, "n2").await;
    let n3 = node(&nats, "n3").await;

    n1.register(HEAD, "makehuman_head", "").await;
    wait_ready_anywhere(&n2, HEAD, Duration::from_secs(30)).await;
    wait_ready_anywhere(&n3, HEAD, Duration::from_secs(30)).await;

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

    // Deleted on one node, gone on every node.
    let deleted = reqwest::Client::new()
        .delete(n3.http(&format!("/v1/heads/{HEAD}")))
        .send()
        .await
        .unwrap();
    assert_eq!(deleted.status(), 204);
    wait_gone(&n1, HEAD, Duration::from_secs(5)).await;
    wait_gone(&n2, HEAD, Duration::from_secs(5)).await;

    // A node that starts later catches up: the head registered before it is served.
    n1.register("late", "makehuman_head", "").await;
    let n4 = node(&nats, "n4").await;
    wait_ready_anywhere(&n4, "late", Duration::from_secs(30)).await;
    assert!(info(&n4, HEAD).await.is_none(), "the deleted head stays deleted");
}
