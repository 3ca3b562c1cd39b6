//! One producer per stream across nodes: a producer's node holds the stream's lease, a key
//! `<head>.<stream>` in the JetStream key-value bucket `facewire_producers` whose value is
//! the node's name. Claimed with a create (fails if held), kept by a compare-and-set
//! update every [`REFRESH`], released by a delete at the revision it holds. The bucket's
//! age limit ([`TTL`]) frees a lease whose node vanished without releasing it; sooner than
//! that, a claim that finds a lease asks its holder whether it is alive
//! (`facewire.node.<name>.alive`) and takes the lease over when nobody answers, so a
//! producer whose node died can reconnect elsewhere at once.

use std::future::Future;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use async_nats::jetstream::{self, kv};
use bytes::Bytes;
use futures_util::StreamExt;
use tokio_util::sync::CancellationToken;

use super::{ClusterError, PREFIX};

pub const BUCKET: &str = "facewire_producers";
/// A lease nobody refreshes for this long is gone.
const TTL: Duration = Duration::from_secs(6);
/// How often a holder refreshes its lease.
const REFRESH: Duration = Duration::from_secs(2);
/// A holder that does not answer a liveness check within this is taken for dead.
const LIVENESS_TIMEOUT: Duration = Duration::from_secs(1);

#[derive(Debug, thiserror::Error)]
pub enum LeaseError {
    #[error("stream {stream:?} of head {head:?} has a producer on node {node:?}; one at a time")]
    Busy {
        head: String,
        stream: String,
        node: String,
    },
    #[error("the cluster bus cannot grant the producer lease now: {0}")]
    Unavailable(String),
}

pub struct Leases {
    kv: kv::Store,
    client: async_nats::Client,
    node: String,
}

fn alive_subject(node: &str) -> String {
    format!("{PREFIX}.node.{node}.alive")
}

impl Leases {
    pub async fn open(
        js: &jetstream::Context,
        client: async_nats::Client,
        node: &str,
    ) -> Result<Leases, jetstream::context::CreateKeyValueError> {
        // Made by the cluster's first node; one an operator made first is used as it is.
        let kv = match js.get_key_value(BUCKET).await {
            Ok(kv) => kv,
            Err(_) => {
                js.create_key_value(kv::Config {
                    bucket: BUCKET.into(),
                    description: "facewire: which node holds each stream's producer".into(),
                    history: 1,
                    max_age: TTL,
                    storage: jetstream::stream::StorageType::File,
                    ..Default::default()
                })
                .await?
            }
        };
        Ok(Leases {
            kv,
            client,
            node: node.to_string(),
        })
    }

    /// Answers liveness checks for this node until the connection closes.
    pub async fn answer_liveness(
        &self,
        client: &async_nats::Client,
    ) -> Result<impl Future<Output = ()>, ClusterError> {
        let subject = alive_subject(&self.node);
        let mut checks = client
            .subscribe(subject.clone())
            .await
            .map_err(|source| ClusterError::Subscribe { subject, source })?;
        let client = client.clone();
        Ok(async move {
            while let Some(check) = checks.next().await {
                if let Some(reply) = check.reply {
                    let _ = client.publish(reply, Bytes::new()).await;
                }
            }
        })
    }

    /// Claims the lease of `head`'s `stream` for this node. `cancel_producer` is
    /// cancelled if the lease is lost later (another node took it over while this one
    /// could not refresh it).
    pub async fn claim(
        &self,
        head: &str,
        stream: &str,
        cancel_producer: CancellationToken,
    ) -> Result<Lease, LeaseError> {
        let key = format!("{head}.{stream}");
        let unavailable = |e: &dyn std::fmt::Display| LeaseError::Unavailable(e.to_string());
        // A lease can change hands between reading it and taking it; a few tries settle it.
        for _ in 0..3 {
            match self.kv.create(&key, self.node.clone().into()).await {
                Ok(revision) => return Ok(self.hold(key, revision, cancel_producer)),
                Err(e) if e.kind() == kv::CreateErrorKind::AlreadyExists => {}
                Err(e) => return Err(unavailable(&e)),
            }
            let Some(entry) = self.kv.entry(&key).await.map_err(|e| unavailable(&e))? else {
                continue;
            };
            if entry.operation != kv::Operation::Put {
                continue;
            }
            let holder = String::from_utf8_lossy(&entry.value).into_owned();
            // This node's own lease is one its last producer has not released yet: the
            // local producer slot already says nobody else produces here.
            if holder != self.node && self.alive(&holder).await {
                return Err(LeaseError::Busy {
                    head: head.to_string(),
                    stream: stream.to_string(),
                    node: holder,
                });
            }
            if let Ok(revision) = self
                .kv
                .update(&key, self.node.clone().into(), entry.revision)
                .await
            {
                tracing::info!(%key, from = %holder, "producer lease taken over");
                return Ok(self.hold(key, revision, cancel_producer));
            }
        }
        Err(LeaseError::Unavailable(format!(
            "the lease of {key:?} kept changing hands"
        )))
    }

    /// Whether some node holds the lease of `head`'s `stream` now.
    pub async fn is_held(&self, head: &str, stream: &str) -> Result<bool, LeaseError> {
        let entry = self
            .kv
            .entry(format!("{head}.{stream}"))
            .await
            .map_err(|e| LeaseError::Unavailable(e.to_string()))?;
        Ok(entry.is_some_and(|e| e.operation == kv::Operation::Put))
    }

    async fn alive(&self, node: &str) -> bool {
        let check = self.client.request(alive_subject(node), Bytes::new());
        matches!(tokio::time::timeout(LIVENESS_TIMEOUT, check).await, Ok(Ok(_)))
    }

    fn hold(&self, key: String, revision: u64, cancel_producer: CancellationToken) -> Lease {
        let released = CancellationToken::new();
        let fence = Arc::new(AtomicU64::new(revision));
        tokio::spawn(keep(
            Held {
                kv: self.kv.clone(),
                node: self.node.clone(),
                key,
                revision,
                fence: fence.clone(),
            },
            released.clone(),
            cancel_producer,
        ));
        Lease { released, fence }
    }
}

/// A held lease; dropping it releases the lease.
pub struct Lease {
    released: CancellationToken,
    /// The revision the lease was claimed at: its fencing token. A later holder's is
    /// larger (revisions only grow), so other nodes drop what an earlier holder still
    /// relays after losing it.
    fence: Arc<AtomicU64>,
}

impl Lease {
    pub fn fence(&self) -> u64 {
        self.fence.load(Ordering::Acquire)
    }
}

/// What [`keep`] holds.
struct Held {
    kv: kv::Store,
    node: String,
    key: String,
    revision: u64,
    fence: Arc<AtomicU64>,
}

impl Drop for Lease {
    fn drop(&mut self) {
        self.released.cancel();
    }
}

/// Refreshes the lease until it is released (then deletes it, if still ours) or lost
/// (then cancels the producer).
async fn keep(held: Held, released: CancellationToken, cancel_producer: CancellationToken) {
    let Held {
        kv,
        node,
        key,
        mut revision,
        fence,
    } = held;
    let mut ticks = tokio::time::interval_at(tokio::time::Instant::now() + REFRESH, REFRESH);
    loop {
        tokio::select! {
            _ = released.cancelled() => break,
            _ = ticks.tick() => {}
        }
        match kv.update(&key, node.clone().into(), revision).await {
            Ok(next) => revision = next,
            Err(e) if e.kind() == kv::UpdateErrorKind::WrongLastRevision => {
                // Expired while NATS was away, or taken over: take it back if it is free.
                match kv.create(&key, node.clone().into()).await {
                    Ok(next) => {
                        revision = next;
                        fence.store(next, Ordering::Release);
                    }
                    Err(_) => {
                        tracing::warn!(%key, "producer lease lost to another node; closing this producer");
                        cancel_producer.cancel();
                        return;
                    }
                }
            }
            // NATS is away: keep producing here, try again on the next tick.
            Err(e) => tracing::debug!(%key, error = %e, "producer lease not refreshed"),
        }
    }
    if let Err(e) = kv.delete_expect_revision(&key, Some(revision)).await {
        tracing::debug!(%key, error = %e, "producer lease not released; it expires by itself");
    }
}
