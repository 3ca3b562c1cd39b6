//! A cluster that trusts no one on the bus: with a cluster key, a plain NATS client that
//! can write facewire's buckets (as any client of an open NATS server can) changes
//! nothing in the registry, takes or holds no stream, and cannot make the cluster forget
//! its heads by deleting what it stores; and a cluster on three NATS servers with
//! replicated buckets loses nothing when one of them is killed during a stream.

use std::time::{Duration, Instant};

use async_nats::jetstream::{self, kv};
use futures_util::SinkExt;
use sha2::{Digest, Sha256};
use tokio_tungstenite::tungstenite::Message;

use crate::bus::{info, next_seq, produce, producer, viewer, HEAD, STREAM};
use crate::common::data;
use crate::common::nats::{subscribed, NatsCluster, NatsServer};
use crate::common::service::{close_code, connect, moving_jaw_line, next_json, Server, Socket};
use facewire_proto::messages::ServerMessage;

const CLUSTER_KEY: &str = "a key only the cluster's nodes hold";

fn keyed(bus: &str, name: &str) -> String {
    format!(
        "bus = \"{bus}\"\nnode_name = \"{name}\"\n[limits]\nproducer_idle_s = 60.0\n\
         [bus_auth]\ncluster_key = \"{CLUSTER_KEY}\"\n"
    )
}

fn hex_sha256(text: &str) -> String {
    Sha256::digest(text.as_bytes())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The MakeHuman head as a registration body, with its own producer token.
fn head_body(id: &str, producer_token: &str) -> serde_json::Value {
    serde_json::json!({
        "id": id,
        "obj": std::fs::read_to_string(data("heads/makehuman_head.obj")).unwrap(),
        "fit": std::fs::read_to_string(data("heads/makehuman_head.fit.toml")).unwrap(),
        "producer_token": producer_token,
    })
}

/// A producer socket with `token`, or the HTTP status it was refused with.
async fn producer_with(server: &Server, token: &str) -> Result<Socket, u16> {
    let url = server.ws(&format!(
        "/v1/heads/{HEAD}/streams/{STREAM}/produce?token={token}"
    ));
    match tokio_tungstenite::connect_async(url.as_str()).await {
        Ok((socket, _)) => Ok(socket),
        Err(tokio_tungstenite::tungstenite::Error::Http(response)) => Err(response.status().as_u16()),
        Err(e) => panic!("{url}: {e}"),
    }
}

/// Waits until `check` holds, up to `within`; panics naming `what` if it never does.
async fn eventually<F: std::future::Future<Output = bool>>(
    what: &str,
    within: Duration,
    mut check: impl FnMut() -> F,
) {
    let started = Instant::now();
    while !check().await {
        assert!(started.elapsed() < within, "{what}: not within {within:?}");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// Registers the MakeHuman head as `id` on `server` as soon as the bus takes it (up to 10 s).
async fn register_once_the_bus_allows(server: &Server, id: &str, producer_token: &str) {
    let body = head_body(id, producer_token);
    eventually("a registration taken", Duration::from_secs(10), || async {
        server.heads("").register(id, &body).await.is_ok()
    })
    .await;
}

/// The value under `key`, if a value (not a removal) is there.
async fn value(bucket: &kv::Store, key: &str) -> Option<Vec<u8>> {
    let entry = bucket.entry(key).await.ok()??;
    (entry.operation == kv::Operation::Put).then(|| entry.value.to_vec())
}

/// Whether `server` has head `id` ready.
async fn ready(server: &Server, id: &str) -> bool {
    info(server, id).await.is_some_and(|i| i.status == "ready")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn with_a_cluster_key_a_client_on_the_bus_changes_nothing_in_the_registry() {
    let nats = NatsServer::start();
    let n1 = Server::spawn(&keyed(&nats.url(), "n1")).await;
    let n2 = Server::spawn(&keyed(&nats.url(), "n2")).await;
    assert_eq!(
        n1.heads("")
            .register(HEAD, &head_body(HEAD, "owner"))
            .await
            .unwrap(),
        202
    );
    n1.wait_ready(HEAD, "").await;
    n2.wait_ready_in_cluster(HEAD, Duration::from_secs(30)).await;

    let js = jetstream::new(async_nats::connect(nats.url()).await.unwrap());
    let heads = js.get_key_value("facewire_heads").await.unwrap();
    let sealed = value(&heads, HEAD).await.unwrap();
    assert!(
        sealed.starts_with(b"mac:"),
        "{}",
        String::from_utf8_lossy(&sealed)
    );
    let record_start = sealed.iter().position(|&b| b == b'\n').unwrap() + 1;
    let mut record: serde_json::Value = serde_json::from_slice(&sealed[record_start..]).unwrap();

    // The head's record replaced by one whose token digest is the stranger's, and a head
    // of the stranger's own written beside it: the first is put back as it was, the
    // second never registered.
    record["meta"]["producer_token_sha256"] = hex_sha256("attacker").into();
    heads
        .put(HEAD, serde_json::to_vec(&record).unwrap().into())
        .await
        .unwrap();
    heads
        .put("forged", serde_json::to_vec(&record).unwrap().into())
        .await
        .unwrap();
    eventually("the record put back", Duration::from_secs(5), || async {
        value(&heads, HEAD).await.as_deref() == Some(&sealed[..])
    })
    .await;
    for node in [&n1, &n2] {
        assert_eq!(
            producer_with(node, "attacker").await.err(),
            Some(401),
            "{}",
            node.addr
        );
        let mut owner = producer_with(node, "owner").await.unwrap();
        produce(&mut owner, 0).await;
        owner
            .send(Message::Text(r#"{"type":"end"}"#.into()))
            .await
            .unwrap();
        assert!(info(node, "forged").await.is_none(), "{}", node.addr);
        assert!(ready(node, HEAD).await, "{}", node.addr);
    }

    // The head's key removed: no node drops the head, and the key comes back.
    heads.delete(HEAD).await.unwrap();
    eventually("the removed record put back", Duration::from_secs(5), || async {
        value(&heads, HEAD).await.as_deref() == Some(&sealed[..])
    })
    .await;
    tokio::time::sleep(Duration::from_secs(1)).await;
    for node in [&n1, &n2] {
        assert!(ready(node, HEAD).await, "{}", node.addr);
    }

    // Every bucket deleted under a live stream: the nodes make them again and put their
    // heads back, the producer takes its lease back in the new bucket and its frames go
    // on reaching the other node (the new lease's token is above the old one's), new
    // registrations and producers work, and a node started afterwards has every head.
    let mut watcher = viewer(&n2).await;
    let mut owner = producer_with(&n1, "owner").await.unwrap();
    produce(&mut owner, 0).await;
    js.delete_key_value("facewire_heads").await.unwrap();
    js.delete_object_store("facewire_meshes").await.unwrap();
    js.delete_key_value("facewire_producers").await.unwrap();
    eventually(
        "the buckets made again, the head back",
        Duration::from_secs(10),
        || async {
            match js.get_key_value("facewire_heads").await {
                Ok(heads) => value(&heads, HEAD).await.is_some(),
                Err(_) => false,
            }
        },
    )
    .await;
    register_once_the_bus_allows(&n2, "second", "owner").await;
    n1.wait_ready_in_cluster("second", Duration::from_secs(30)).await;
    // Past two lease refreshes (2 s each) in the new bucket.
    for seq in 1..=150 {
        produce(&mut owner, seq).await;
        tokio::time::sleep(Duration::from_millis(30)).await;
    }
    let mut last = None;
    while let Some(seq) = next_seq(&mut watcher, Duration::from_millis(500)).await {
        last = Some(seq);
    }
    assert_eq!(
        last,
        Some(150),
        "frames under the new bucket's lease did not cross"
    );
    let leases = js.get_key_value("facewire_producers").await.unwrap();
    assert!(value(&leases, &format!("{HEAD}.{STREAM}")).await.is_some());
    for node in [&n1, &n2] {
        let health = node.healthz().await;
        assert_eq!(
            health["bus"]["store_problem"],
            serde_json::Value::Null,
            "{health}"
        );
    }
    let n3 = Server::spawn(&keyed(&nats.url(), "n3")).await;
    n3.wait_ready_in_cluster(HEAD, Duration::from_secs(30)).await;
    n3.wait_ready_in_cluster("second", Duration::from_secs(30)).await;
    assert!(info(&n3, "forged").await.is_none());
}

/// Two keyed nodes on one NATS server, the MakeHuman head registered on n1 and ready on
/// n2, and the lease bucket as a plain client (holding no key) sees it.
async fn keyed_pair_sharing_the_head() -> (NatsServer, Server, Server, kv::Store) {
    let nats = NatsServer::start();
    let n1 = Server::spawn(&keyed(&nats.url(), "n1")).await;
    let n2 = Server::spawn(&keyed(&nats.url(), "n2")).await;
    n1.register(HEAD, "makehuman_head", "").await;
    n2.wait_ready_in_cluster(HEAD, Duration::from_secs(30)).await;
    let js = jetstream::new(async_nats::connect(nats.url()).await.unwrap());
    let leases = js.get_key_value("facewire_producers").await.unwrap();
    (nats, n1, n2, leases)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn with_a_cluster_key_nobody_on_the_bus_takes_or_holds_a_stream() {
    let (nats, n1, n2, leases) = keyed_pair_sharing_the_head().await;
    let key = format!("{HEAD}.{STREAM}");

    // The lease overwritten under a live producer, twice over its refresh period: the
    // producer goes on and its frames still reach the other node.
    let mut watcher = viewer(&n2).await;
    let mut source = producer(&n1).await;
    produce(&mut source, 0).await;
    let held = value(&leases, &key).await.unwrap();
    assert!(held.starts_with(b"mac:"));
    for seq in 1..=150 {
        if seq % 50 == 0 {
            leases.put(&key, "n9".into()).await.unwrap();
        }
        produce(&mut source, seq).await;
        tokio::time::sleep(Duration::from_millis(30)).await;
    }
    let mut last = 0;
    while let Some(seq) = next_seq(&mut watcher, Duration::from_millis(500)).await {
        last = seq;
    }
    assert_eq!(last, 150, "the other node's viewer stopped at {last}");
    eventually("the lease taken back", Duration::from_secs(5), || async {
        value(&leases, &key).await.as_deref() == Some(&held[..])
    })
    .await;

    // A node's old sealed lease written back after its producer left, and a stranger
    // answering liveness checks for a node that never was: neither holds the stream.
    source
        .send(Message::Text(r#"{"type":"end"}"#.into()))
        .await
        .unwrap();
    eventually("the lease released", Duration::from_secs(5), || async {
        value(&leases, &key).await.is_none()
    })
    .await;
    leases.put(&key, held.clone().into()).await.unwrap();
    let mut second = producer(&n2).await;
    produce(&mut second, 0).await;
    drop(second);
    let client = async_nats::connect(nats.url()).await.unwrap();
    let mut checks = subscribed(&client, "facewire.node.n9.alive".into()).await;
    let answerer = client.clone();
    tokio::spawn(async move {
        while let Some(check) = futures_util::StreamExt::next(&mut checks).await {
            if let Some(reply) = check.reply {
                let _ = answerer.publish(reply, "held".into()).await;
            }
        }
    });
    eventually("n2's producer gone", Duration::from_secs(10), || async {
        value(&leases, &key).await.is_none()
    })
    .await;
    leases.put(&key, "n9".into()).await.unwrap();
    let mut third = producer(&n1).await;
    third
        .send(Message::Text(moving_jaw_line(0).into()))
        .await
        .unwrap();
    match next_json(&mut third).await {
        ServerMessage::Ack { seq, .. } => assert_eq!(seq, 0),
        other => panic!("a producer beside a stranger's lease: {other:?}"),
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn with_a_cluster_key_a_lease_deleted_under_its_producer_lets_no_second_one_in() {
    // A client allowed to delete keys removes a live producer's lease; a second producer
    // asks another node for the stream at once, before the holder's next refresh would
    // notice: the holder answers "who holds it", the second is refused and the first goes
    // on, its frames reaching the other node.
    let (_nats, n1, n2, leases) = keyed_pair_sharing_the_head().await;
    let key = format!("{HEAD}.{STREAM}");

    let mut watcher = viewer(&n2).await;
    let mut source = producer(&n1).await;
    for seq in 0..=100 {
        if seq == 30 || seq == 70 {
            leases.delete(&key).await.unwrap();
            let mut second = producer(&n2).await;
            assert_eq!(
                close_code(&mut second).await,
                4409,
                "a second producer beside the first"
            );
        }
        produce(&mut source, seq).await;
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let mut last = 0;
    while let Some(seq) = next_seq(&mut watcher, Duration::from_millis(500)).await {
        last = seq;
    }
    assert_eq!(last, 100, "the other node's viewer stopped at {last}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn three_nats_servers_one_killed_during_a_stream_lose_nothing() {
    let mut nats = NatsCluster::start(3);
    nats.wait_jetstream().await;
    // The nodes start on the first server (they learn the others from it); the one
    // started last is given the whole list, the killed server first.
    let on_first = |name: &str| {
        format!(
            "bus = \"{}\"\nbus_replicas = 3\nnode_name = \"{name}\"\n[limits]\nproducer_idle_s = 60.0\n",
            nats.servers[0].url()
        )
    };
    let n1 = Server::spawn(&on_first("n1")).await;
    let n2 = Server::spawn(&on_first("n2")).await;
    n1.register(HEAD, "makehuman_head", "").await;
    n2.wait_ready_in_cluster(HEAD, Duration::from_secs(30)).await;

    let mut watcher = viewer(&n2).await;
    let mut source = connect(&n1.ws(&format!("/v1/heads/{HEAD}/streams/{STREAM}/produce"))).await;
    let frames = 240;
    let killed_at = 60;
    let produced = tokio::spawn(async move {
        for seq in 0..frames {
            produce(&mut source, seq).await;
            tokio::time::sleep(Duration::from_millis(33)).await;
        }
        source
    });
    let mut arrivals: Vec<(u64, Instant)> = Vec::new();
    while let Some(seq) = next_seq(&mut watcher, Duration::from_secs(5)).await {
        arrivals.push((seq, Instant::now()));
        if seq == killed_at {
            nats.servers[0].kill();
        }
        if seq == frames - 1 {
            break;
        }
    }
    let _source = produced.await.unwrap();
    let seqs: Vec<u64> = arrivals.iter().map(|(seq, _)| *seq).collect();
    assert_eq!(
        seqs.last(),
        Some(&(frames - 1)),
        "frames did not resume: {seqs:?}"
    );
    assert!(seqs.windows(2).all(|w| w[0] < w[1]), "out of order: {seqs:?}");
    let longest_gap = arrivals.windows(2).map(|w| w[1].1 - w[0].1).max().unwrap();
    eprintln!(
        "NATS server killed at frame {killed_at}: {} of {frames} frames reached the other node, the longest gap {:.0} ms",
        seqs.len(),
        longest_gap.as_secs_f64() * 1e3
    );
    assert!(
        longest_gap < Duration::from_secs(2),
        "frames resumed after {longest_gap:?}"
    );

    // No head lost: both nodes still have it, a node started now (its first server the
    // dead one) finds it, and a new registration goes through.
    for node in [&n1, &n2] {
        assert!(ready(node, HEAD).await, "{}", node.addr);
    }
    let mut everywhere = format!("bus = \"{}\"\nbus_replicas = 3\nnode_name = \"n3\"\n", nats.url());
    everywhere.push_str("[limits]\nproducer_idle_s = 60.0\n");
    let n3 = Server::spawn(&everywhere).await;
    n3.wait_ready_in_cluster(HEAD, Duration::from_secs(30)).await;
    register_once_the_bus_allows(&n3, "second", "").await;
    n1.wait_ready_in_cluster("second", Duration::from_secs(30)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_head_from_the_bus_obeys_the_upload_limit() {
    // The MakeHuman head's mesh is 244,356 bytes: n2 takes no upload that large, and
    // takes none from the bus either (its size is read before the mesh).
    let nats = NatsServer::start();
    let plain = |name: &str, limits: &str| {
        format!(
            "bus = \"{}\"\nnode_name = \"{name}\"\n[limits]\nproducer_idle_s = 60.0\n{limits}",
            nats.url()
        )
    };
    let n1 = Server::spawn(&plain("n1", "")).await;
    let n2 = Server::spawn(&plain("n2", "max_upload_bytes = 200000\n")).await;
    n1.register(HEAD, "makehuman_head", "").await;
    let n3 = Server::spawn(&plain("n3", "")).await;
    n3.wait_ready_in_cluster(HEAD, Duration::from_secs(30)).await;
    assert!(
        info(&n2, HEAD).await.is_none(),
        "n2 took a mesh past its upload limit"
    );
}
