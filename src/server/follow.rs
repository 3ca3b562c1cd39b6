//! This node follows the cluster: what the bus adapter ([`super::cluster`]) reports is
//! applied to this node's registry here, and only here, so neither imports the other.
//!
//! - Heads put and deleted in the shared registry are registered or dropped here, and
//!   kept in (or removed from) the node's data directory ([`follow_heads`]).
//! - What the shared registry loses (a bucket deleted, a record removed or overwritten by
//!   someone without the cluster key) is put back from those copies ([`keep_store`]).
//! - Other nodes' frames, voices and ends go into this node's copy of their stream,
//!   held to the rules a producer's socket is ([`deliver`]).
//! - Streams relayed from a node that vanished end ([`end_orphans`]).

use std::collections::HashMap;
use std::sync::Arc;
use std::time::Duration;

use tokio_util::sync::CancellationToken;
use tokio_util::time::{delay_queue, DelayQueue};

use super::cluster::{
    Cluster, ClusterError, ClusterHeads, HeadChange, Remote, RemoteBody, Republished, SharedHead,
};
use super::registry::Registry;
use super::store::{HeadRecord, Store};
use super::telemetry::Telemetry;
use crate::mask::Mask;
use facewire_proto::codes::EndReason;

/// Starts following `cluster` into `registry` until `shutdown`.
pub async fn start(
    cluster: &Arc<Cluster>,
    registry: Registry,
    mask: Arc<Mask>,
    telemetry: Arc<Telemetry>,
    shutdown: CancellationToken,
) -> Result<(), ClusterError> {
    let (relayed, hops) = (registry.clone(), telemetry.clone());
    cluster
        .start(mask, telemetry, move |message| deliver(&relayed, &hops, message))
        .await?;
    tokio::spawn(end_orphans(registry.clone(), cluster.clone(), shutdown.clone()));
    tokio::spawn(follow_heads(
        cluster.heads.clone(),
        registry.clone(),
        shutdown.clone(),
    ));
    tokio::spawn(keep_store(cluster.clone(), registry, shutdown));
    Ok(())
}

/// Puts one checked message from another node into this node's copy of its stream; the
/// error is why it was dropped.
fn deliver(registry: &Registry, telemetry: &Telemetry, message: Remote<'_>) -> Result<(), &'static str> {
    let head = registry.get(message.head).ok_or("unknown_head")?;
    let stream = head.stream(message.stream).map_err(|_| "stream_limit")?;
    // This node's own producer holds the stream: nothing from the bus goes into it.
    if stream.is_leased_here() {
        return Err("local_producer");
    }
    match message.body {
        RemoteBody::Audio(audio) => {
            stream.admit_relayed(message.lease, None)?;
            stream.publish_audio_relayed(Arc::new(audio));
        }
        RemoteBody::End(reason) => {
            stream.admit_relayed(message.lease, None)?;
            stream.end(reason);
        }
        RemoteBody::Frame(received) => {
            stream.admit_relayed(message.lease, Some((received.frame.seq, received.frame.time_s)))?;
            let now = super::now_us();
            telemetry
                .bus_hop_seconds
                .observe(now.saturating_sub(received.received_us) as f64 * 1e-6);
            stream.publish_relayed(Arc::new(received));
        }
    }
    Ok(())
}

/// Keeps `registry` in step with the shared one until `shutdown`: every head in it is
/// registered here, every head deleted from it is dropped here. A head this node fails to
/// take (the bus timed out reading its meshes, the disk refused its copy) is tried again,
/// after [`RETRY_FIRST`] doubling to [`RETRY_LAST`], until it is taken or a later change to
/// its id replaces it: no change to that head may ever come to prompt it.
async fn follow_heads(heads: ClusterHeads, registry: Registry, shutdown: CancellationToken) {
    let mut changes = heads.clone().changes(shutdown);
    // One entry per id at most, each a head a trusted node put in the shared registry:
    // bounded by the registry's own size.
    let mut retries: DelayQueue<(String, SharedHead, Duration)> = DelayQueue::new();
    let mut waiting: HashMap<String, delay_queue::Key> = HashMap::new();
    loop {
        let (id, shared, wait) = tokio::select! {
            change = changes.recv() => {
                let Some(change) = change else { return };
                if let Some(key) = waiting.remove(change.id()) {
                    retries.remove(&key);
                }
                match change {
                    HeadChange::Deleted { id } => {
                        if registry.drop_local(&id) {
                            tracing::info!(head = %id, "head deleted on another node");
                        }
                        if let Err(e) = registry.store().forget_copy(&id).await {
                            tracing::warn!(head = %id, error = %e, "local copy of a deleted head not removed");
                        }
                        continue;
                    }
                    HeadChange::Unproven { id, why } => {
                        tracing::warn!(head = %id, %why, "cluster registry entry changed without the cluster key");
                        if let Some(local) = registry.store().local_copies() {
                            put_back(&heads, local, &id).await;
                        }
                        continue;
                    }
                    HeadChange::Put { id, head } => (id, head, RETRY_FIRST),
                }
            }
            Some(due) = std::future::poll_fn(|cx| retries.poll_expired(cx)) => {
                let (id, shared, wait) = due.into_inner();
                waiting.remove(&id);
                (id, shared, wait)
            }
        };
        tracing::debug!(head = %id, "taking a head from the cluster registry");
        if let Err(untaken) = take(&heads, &registry, &id, shared).await {
            tracing::warn!(head = %id, error = %untaken.why, retry_in_s = wait.as_secs_f64(), "cluster head not taken yet");
            let key = retries.insert((id.clone(), untaken.shared, (wait * 2).min(RETRY_LAST)), wait);
            waiting.insert(id, key);
        }
    }
}

/// The first wait before a head not taken is tried again; each failure doubles it.
const RETRY_FIRST: Duration = Duration::from_millis(500);
/// The longest wait between tries.
const RETRY_LAST: Duration = Duration::from_secs(30);

/// A head not taken for a reason that may pass, kept to be tried again.
struct Untaken {
    shared: SharedHead,
    why: String,
}

/// Registers head `id` here as the shared registry holds it (`shared`), keeping a copy on
/// this node's disk; an error when the bus or the disk failed (worth trying again).
async fn take(
    heads: &ClusterHeads,
    registry: &Registry,
    id: &str,
    shared: SharedHead,
) -> Result<(), Untaken> {
    match registry.get(id).map(|h| h.registration_tag().map(str::to_string)) {
        Some(Some(tag)) if tag == shared.tag() => return Ok(()),
        Some(_) => {
            tracing::info!(head = %id, "head registered again on another node");
            registry.drop_local(id);
        }
        None => {}
    }
    let record = match heads.load(id, shared.clone()).await {
        Ok(record) => record,
        Err(e) => {
            return Err(Untaken {
                shared,
                why: format!("not loaded: {e}"),
            })
        }
    };
    let record = match registry.store().copy_from_cluster(record).await {
        Ok(record) => record,
        Err(e) => {
            return Err(Untaken {
                shared,
                why: format!("not kept on this node's disk: {e}"),
            })
        }
    };
    let Ok(slot) = registry.registration_slot(Duration::MAX).await else {
        return Ok(());
    };
    // A head that does not build here fails the same way on every try: not tried again.
    if let Err(e) = registry.register(record, false, slot).await {
        tracing::warn!(head = %id, error = %e, "cluster head not registered here");
    }
    Ok(())
}

/// How often the buckets are checked.
const STORE_CHECK: Duration = Duration::from_secs(2);

/// Keeps the shared registry whole until `shutdown`: at start, and whenever a bucket had
/// to be made again, every head this node keeps a copy of goes back into the buckets
/// where they lack it (a key another node wrote since, or a tombstone, wins: the copy is
/// then out of date, and following the bucket replaces or removes it).
async fn keep_store(cluster: Arc<Cluster>, registry: Registry, shutdown: CancellationToken) {
    let mut ticks = tokio::time::interval(STORE_CHECK);
    let mut republish = true;
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => return,
            _ = ticks.tick() => {}
        }
        match cluster.ensure_store().await {
            Ok(made) => republish |= made,
            Err(e) => {
                tracing::warn!(error = %e, "cluster buckets cannot be used");
                continue;
            }
        }
        let Some(local) = registry.store().local_copies().cloned() else {
            continue;
        };
        if !std::mem::take(&mut republish) {
            continue;
        }
        let found = match tokio::task::spawn_blocking(move || local.load_all()).await {
            Ok(Ok(found)) => found,
            other => {
                tracing::warn!(?other, "local copies of the cluster's heads not read");
                republish = true;
                continue;
            }
        };
        for record in found.records {
            republish |= !republish_one(&cluster.heads, &record).await;
        }
    }
}

/// Puts this node's copy of head `id` back into the buckets, if it keeps one.
async fn put_back(heads: &ClusterHeads, local: &Store, id: &str) {
    let (local, owned_id) = (local.clone(), id.to_string());
    match tokio::task::spawn_blocking(move || local.load(&owned_id)).await {
        Ok(Ok(record)) => {
            // Tried again when the next unproven change or bucket check comes.
            republish_one(heads, &record).await;
        }
        _ => tracing::info!(head = %id, "no local copy to put back"),
    }
}

/// Puts `record` back into the buckets where they lack it; false when the bus failed.
async fn republish_one(heads: &ClusterHeads, record: &HeadRecord) -> bool {
    match heads.republish(record).await {
        Ok(Republished::Restored) => {
            tracing::warn!(head = %record.id, "head put back into the cluster registry from this node's copy");
            true
        }
        Ok(Republished::Held | Republished::Superseded) => true,
        Err(e) => {
            tracing::warn!(head = %record.id, error = %e, "head not put back");
            false
        }
    }
}

/// How often relayed streams are looked at.
const CHECK_EVERY: Duration = Duration::from_secs(1);
/// A relayed stream silent for less than this is not asked about: its end may be on the
/// way over the bus, after its last frame.
const SILENT_FOR: Duration = Duration::from_secs(1);

/// Ends that always come: a stream fed from another node's producer ends for this node's
/// viewers when that producer's node vanishes without sending the end (killed, cut off).
/// Its lease then expires; each node checks the leases of the streams it relays once they
/// fall silent, and ends those nobody holds with `producer_disconnected`. Runs until
/// `shutdown`.
async fn end_orphans(registry: Registry, cluster: Arc<Cluster>, shutdown: CancellationToken) {
    let mut ticks = tokio::time::interval(CHECK_EVERY);
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => return,
            _ = ticks.tick() => {}
        }
        let now = tokio::time::Instant::now();
        for head in registry.list() {
            for stream in head.streams() {
                if stream
                    .relay_silent_for(now)
                    .is_none_or(|silent| silent < SILENT_FOR)
                {
                    continue;
                }
                match cluster.lease_held(&head.id, &stream.name).await {
                    Ok(true) => {}
                    Ok(false) => {
                        tracing::info!(
                            head = %head.id,
                            stream = %stream.name,
                            "the producer's node went away without ending the stream; ending it"
                        );
                        stream.end(EndReason::ProducerDisconnected);
                    }
                    // The bus is away: nothing is known, nothing is ended.
                    Err(e) => tracing::debug!(error = %e, "lease not read"),
                }
            }
        }
    }
}
