//! One producer per stream across nodes: a producer's node holds the stream's lease, a key
//! `<head>.<stream>` in the JetStream key-value bucket `facewire_producers` whose value is
//! the node's name. Claimed with a create (fails if held), kept by a compare-and-set
//! update every [`REFRESH`], released by a delete at the revision it holds. The bucket's
//! age limit ([`TTL`]) frees a lease whose node vanished without releasing it; sooner than
//! that, a claim that finds a lease asks its holder whether it is alive
//! (`facewire.node.<name>.alive`) whether it holds that lease, and takes the lease over
//! when no proven answer says so, so a producer whose node died can reconnect elsewhere
//! at once.
//!
//! With a cluster key, lease values and liveness answers are sealed ([`Seal`]): a value
//! nobody of the cluster wrote is no lease (a claim takes it over, its holder takes it
//! back), and an answer must carry the proof over the question's nonce, so neither a
//! forged lease nor a stranger answering for a node keeps a stream from its producer.
//! A claim that finds the key released, removed or overwritten without proof first asks
//! every node whether it holds the lease (`facewire.lease.who`): the holder answers with
//! its sealed name, so a lease deleted under a live producer lets no second one in.

use std::collections::HashSet;
use std::future::Future;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use async_nats::jetstream::{self, kv};
use bytes::Bytes;
use futures_util::StreamExt;
use tokio_util::sync::CancellationToken;

use super::heads::BucketSettings;
use super::seal::Seal;
use super::{open_key_value, stream_exists, ClusterError, PREFIX};
use crate::server::ids::valid_id;

pub const BUCKET: &str = "facewire_producers";
/// A lease nobody refreshes for this long is gone.
const TTL: Duration = Duration::from_secs(6);
/// How often a holder refreshes its lease.
const REFRESH: Duration = Duration::from_secs(2);
/// A holder that does not answer a liveness check within this is taken for dead.
const LIVENESS_TIMEOUT: Duration = Duration::from_secs(1);
/// A liveness question longer than this (bytes) is not answered.
const MAX_QUESTION_BYTES: usize = 256;
/// A fencing token's low bits hold the lease's revision; the bits above, the seconds
/// from [`FENCE_EPOCH_S`] to when the lease bucket was made, so that a bucket made again
/// (its revisions starting over at 1) still gives larger tokens than the one before.
const FENCE_REVISION_BITS: u32 = 36;
/// 2020-01-01 UTC, s since the Unix epoch.
const FENCE_EPOCH_S: i64 = 1_577_836_800;
/// What a liveness answer says.
const HELD: &[u8] = b"held";
const FREE: &[u8] = b"free";

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
    js: jetstream::Context,
    kv: kv::Store,
    client: async_nats::Client,
    node: String,
    seal: Arc<Seal>,
    settings: BucketSettings,
    /// Keys of the leases this node holds now: what its liveness answers say.
    held: Arc<Mutex<HashSet<String>>>,
    /// Makes every liveness question's nonce new.
    questions: AtomicU64,
}

fn alive_subject(node: &str) -> String {
    format!("{PREFIX}.node.{node}.alive")
}

/// Where a claim asks every node whether it holds a lease; only its holder answers.
fn who_subject() -> String {
    format!("{PREFIX}.lease.who")
}

/// Where the answer to "who holds it" question `question` is sealed.
fn who_place(question: &[u8]) -> String {
    format!("who/{}", String::from_utf8_lossy(question))
}

fn place(key: &str) -> String {
    format!("kv/{BUCKET}/{key}")
}

/// Where the answer to liveness question `question` asked of `node` is sealed.
fn answer_place(node: &str, question: &[u8]) -> String {
    format!("alive/{node}/{}", String::from_utf8_lossy(question))
}

/// The fencing token of revision `revision` of the bucket made at `made_s` (s since the
/// Unix epoch).
fn fence_token(made_s: i64, revision: u64) -> u64 {
    let made = (made_s - FENCE_EPOCH_S).max(0) as u64;
    (made << FENCE_REVISION_BITS) | (revision & ((1 << FENCE_REVISION_BITS) - 1))
}

/// When the lease bucket now in JetStream was made, s since the Unix epoch.
async fn bucket_made_s(js: &jetstream::Context) -> Result<i64, String> {
    let stream = js
        .get_stream(format!("KV_{BUCKET}"))
        .await
        .map_err(|e| e.to_string())?;
    Ok(stream.cached_info().created.unix_timestamp())
}

async fn bucket(js: &jetstream::Context, settings: BucketSettings) -> Result<kv::Store, String> {
    open_key_value(
        js,
        kv::Config {
            bucket: BUCKET.into(),
            description: "facewire: which node holds each stream's producer".into(),
            history: 1,
            max_age: TTL,
            storage: jetstream::stream::StorageType::File,
            num_replicas: settings.replicas,
            ..Default::default()
        },
    )
    .await
}

impl Leases {
    pub async fn open(
        js: &jetstream::Context,
        client: async_nats::Client,
        node: &str,
        seal: Arc<Seal>,
        settings: BucketSettings,
    ) -> Result<Leases, String> {
        Ok(Leases {
            js: js.clone(),
            kv: bucket(js, settings).await?,
            client,
            node: node.to_string(),
            seal,
            settings,
            held: Arc::default(),
            questions: AtomicU64::new(0),
        })
    }

    /// Makes the bucket again if it is gone; true when it was made.
    pub async fn ensure_bucket(&self) -> Result<bool, String> {
        if stream_exists(&self.js, &format!("KV_{BUCKET}")).await? {
            return Ok(false);
        }
        bucket(&self.js, self.settings)
            .await
            .map_err(|e| format!("bucket {BUCKET:?}: {e}"))?;
        tracing::warn!(bucket = BUCKET, "producer lease bucket was gone; made it again");
        Ok(true)
    }

    /// Answers liveness checks for this node until the connection closes: a question
    /// names a nonce and a lease key, the sealed answer says whether this node holds it.
    pub async fn answer_liveness(
        &self,
        client: &async_nats::Client,
    ) -> Result<impl Future<Output = ()>, ClusterError> {
        let subject = alive_subject(&self.node);
        let alive = client
            .subscribe(subject.clone())
            .await
            .map_err(|source| ClusterError::Subscribe { subject, source })?;
        let subject = who_subject();
        let who = client
            .subscribe(subject.clone())
            .await
            .map_err(|source| ClusterError::Subscribe { subject, source })?;
        let mut checks = futures_util::stream::select(alive, who);
        let (client, held, seal, node) = (
            client.clone(),
            self.held.clone(),
            self.seal.clone(),
            self.node.clone(),
        );
        Ok(async move {
            while let Some(check) = checks.next().await {
                let Some(reply) = check.reply else { continue };
                if check.payload.len() > MAX_QUESTION_BYTES {
                    continue;
                }
                let key = check
                    .payload
                    .split(|&b| b == b'\n')
                    .nth(1)
                    .map(String::from_utf8_lossy);
                let holds = key.is_some_and(|key| held.lock().expect("held lock").contains(key.as_ref()));
                let answer = if check.subject.as_str() == who_subject() {
                    // Every node hears it: only the holder answers, with its name.
                    if !holds {
                        continue;
                    }
                    seal.seal(&who_place(&check.payload), node.as_bytes())
                } else {
                    seal.seal(
                        &answer_place(&node, &check.payload),
                        if holds { HELD } else { FREE },
                    )
                };
                let _ = client.publish(reply, answer.into()).await;
            }
        })
    }

    /// The node a lease's value names, if a node of the cluster wrote it.
    fn holder(&self, key: &str, entry: &kv::Entry) -> Option<String> {
        if entry.operation != kv::Operation::Put {
            return None;
        }
        let node = std::str::from_utf8(self.seal.open(&place(key), &entry.value)?).ok()?;
        valid_id(node).then(|| node.to_string())
    }

    fn value(&self, key: &str) -> Bytes {
        self.seal.seal(&place(key), self.node.as_bytes()).into()
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
        let made_s = bucket_made_s(&self.js).await.map_err(|e| unavailable(&e))?;
        let busy = |node: String| LeaseError::Busy {
            head: head.to_string(),
            stream: stream.to_string(),
            node,
        };
        // A lease can change hands between reading it and taking it; a few tries settle it.
        for _ in 0..3 {
            let Some(entry) = self.kv.entry(&key).await.map_err(|e| unavailable(&e))? else {
                // Never held, or expired with its holder: free.
                match self.kv.create(&key, self.value(&key)).await {
                    Ok(revision) => return Ok(self.hold(key, (made_s, revision), cancel_producer)),
                    Err(e) if e.kind() == kv::CreateErrorKind::AlreadyExists => continue,
                    Err(e) => return Err(unavailable(&e)),
                }
            };
            let holder = self.holder(&key, &entry);
            match &holder {
                // This node's own lease is one its last producer has not released yet:
                // the local producer slot already says nobody else produces here.
                Some(holder) if *holder == self.node => {}
                Some(holder) => {
                    if self.holds(holder, &key).await {
                        return Err(busy(holder.clone()));
                    }
                }
                // Released, removed or written by someone without the cluster key: free,
                // unless a node answers that it holds it (the key was removed under it).
                None => {
                    if let Some(node) = self.who_holds(&key).await {
                        return Err(busy(node));
                    }
                }
            }
            if let Ok(revision) = self.kv.update(&key, self.value(&key), entry.revision).await {
                let from = holder.as_deref().unwrap_or("a value without proof");
                tracing::info!(%key, %from, "producer lease taken over");
                return Ok(self.hold(key, (made_s, revision), cancel_producer));
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

    /// A question about lease `key`: a nonce no earlier question had, then the key.
    fn question(&self, key: &str) -> String {
        let nonce = self.questions.fetch_add(1, Ordering::Relaxed);
        format!("{}-{}-{nonce}\n{key}", self.node, crate::server::now_us())
    }

    /// Whether `node` answers, with proof, that it holds lease `key`.
    async fn holds(&self, node: &str, key: &str) -> bool {
        let question = self.question(key);
        let check = self
            .client
            .request(alive_subject(node), Bytes::from(question.clone()));
        match tokio::time::timeout(LIVENESS_TIMEOUT, check).await {
            Ok(Ok(answer)) => {
                self.seal
                    .open(&answer_place(node, question.as_bytes()), &answer.payload)
                    == Some(HELD)
            }
            _ => false,
        }
    }

    /// The node that answers, with proof, that it holds lease `key`: asked of every node
    /// at once, waiting [`LIVENESS_TIMEOUT`] when none does.
    async fn who_holds(&self, key: &str) -> Option<String> {
        let question = self.question(key);
        let ask = self.client.request(who_subject(), Bytes::from(question.clone()));
        let answer = tokio::time::timeout(LIVENESS_TIMEOUT, ask).await.ok()?.ok()?;
        let node = self.seal.open(&who_place(question.as_bytes()), &answer.payload)?;
        let node = std::str::from_utf8(node).ok()?;
        (valid_id(node) && node != self.node).then(|| node.to_string())
    }

    /// Holds lease `key`, claimed at `revision` of the bucket made at `made_s`.
    fn hold(&self, key: String, (made_s, revision): (i64, u64), cancel_producer: CancellationToken) -> Lease {
        let released = CancellationToken::new();
        let fence = Arc::new(AtomicU64::new(fence_token(made_s, revision)));
        let check = Arc::new(LeaseCheck {
            kv: self.kv.clone(),
            value: self.value(&key),
            key: key.clone(),
            confirmed_at_stall: AtomicU64::new(0),
            lost: AtomicBool::new(false),
        });
        self.held.lock().expect("held lock").insert(key.clone());
        tokio::spawn(keep(
            Held {
                js: self.js.clone(),
                kv: self.kv.clone(),
                value: self.value(&key),
                seal: self.seal.clone(),
                held: self.held.clone(),
                key,
                revision,
                fence: fence.clone(),
            },
            released.clone(),
            cancel_producer,
        ));
        Lease {
            released,
            fence,
            check,
        }
    }
}

/// Asks the bucket whether a lease is still this node's: what a node that was stalled
/// (frozen, or starved of CPU past a liveness check) does before it relays anything more,
/// since another node may have taken the lease over meanwhile and the others may not have
/// seen a message of the new lease yet to fence the old one by.
pub struct LeaseCheck {
    kv: kv::Store,
    key: String,
    /// This node's sealed value for the key.
    value: Bytes,
    /// The last stall ([`super::relay`]'s count) after which the lease was confirmed.
    confirmed_at_stall: AtomicU64,
    /// Found taken over: nothing more is relayed under it.
    lost: AtomicBool,
}

impl LeaseCheck {
    /// Whether the lease may still be relayed under after stall number `stall` (stalls
    /// counted from 1): asked of the bucket once per stall, waiting at most
    /// [`LIVENESS_TIMEOUT`]; `true` when NATS does not answer (the lease's refresh decides
    /// then, as it does without a stall), and not asked again until the next stall.
    pub async fn held_after(&self, stall: u64) -> bool {
        if self.lost.load(Ordering::Acquire) {
            return false;
        }
        if self.confirmed_at_stall.load(Ordering::Acquire) >= stall {
            return true;
        }
        let ours = match tokio::time::timeout(LIVENESS_TIMEOUT, self.kv.entry(&self.key)).await {
            // Another node's value: taken over. Removed or released: nobody else holds it,
            // and the lease's refresh takes it back.
            Ok(Ok(Some(entry))) => entry.operation != kv::Operation::Put || entry.value == self.value,
            Ok(Ok(None)) => true,
            Ok(Err(e)) => {
                tracing::debug!(key = %self.key, error = %e, "lease not checked after a stall");
                true
            }
            Err(_) => {
                tracing::debug!(key = %self.key, "lease not checked after a stall: NATS did not answer in time");
                true
            }
        };
        if ours {
            self.confirmed_at_stall.fetch_max(stall, Ordering::AcqRel);
        } else {
            tracing::warn!(key = %self.key, "after a stall the producer lease is another node's; relaying nothing more under it");
            self.lost.store(true, Ordering::Release);
        }
        ours
    }
}

/// A held lease; dropping it releases the lease.
pub struct Lease {
    released: CancellationToken,
    /// The lease's fencing token (the revision it was claimed at, above it when the bucket
    /// was made). A later holder's is larger (revisions only grow, and a bucket made again
    /// is made later), so other nodes drop what an earlier holder still
    /// relays after losing it.
    fence: Arc<AtomicU64>,
    check: Arc<LeaseCheck>,
}

impl Lease {
    pub fn fence(&self) -> u64 {
        self.fence.load(Ordering::Acquire)
    }

    /// What asks whether the lease is still this node's after a stall.
    pub fn check(&self) -> Arc<LeaseCheck> {
        self.check.clone()
    }
}

/// What [`keep`] holds.
struct Held {
    js: jetstream::Context,
    kv: kv::Store,
    /// This node's sealed value for the key.
    value: Bytes,
    seal: Arc<Seal>,
    /// The node's held keys, to take `key` out of when done.
    held: Arc<Mutex<HashSet<String>>>,
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
        js,
        kv,
        value,
        seal,
        held,
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
        match kv.update(&key, value.clone(), revision).await {
            Ok(next) => revision = next,
            Err(e) if e.kind() == kv::UpdateErrorKind::WrongLastRevision => {
                // Expired while NATS was away, taken over, or overwritten or removed by
                // someone without the cluster key: take it back unless a node holds it.
                match take_back(&kv, &seal, &key, &value).await {
                    Some(next) => {
                        tracing::info!(%key, "producer lease expired, or changed without proof; taken back");
                        revision = next;
                        // The bucket may have been made again meanwhile: the token then
                        // starts from its making.
                        if let Ok(made_s) = bucket_made_s(&js).await {
                            fence.store(fence_token(made_s, next), Ordering::Release);
                        }
                    }
                    None => {
                        tracing::warn!(%key, "producer lease lost to another node; closing this producer");
                        cancel_producer.cancel();
                        held.lock().expect("held lock").remove(&key);
                        return;
                    }
                }
            }
            // NATS is away: keep producing here, try again on the next tick.
            Err(e) => tracing::debug!(%key, error = %e, "producer lease not refreshed"),
        }
    }
    held.lock().expect("held lock").remove(&key);
    if let Err(e) = kv.delete_expect_revision(&key, Some(revision)).await {
        tracing::debug!(%key, error = %e, "producer lease not released; it expires by itself");
    }
}

/// Writes `value` back under `key` when no node of the cluster holds it (the key is gone,
/// or holds a value without proof); the new revision, or `None` when another node holds it.
async fn take_back(kv: &kv::Store, seal: &Seal, key: &str, value: &Bytes) -> Option<u64> {
    let entry = kv.entry(key).await.ok()?;
    match entry {
        None => kv.create(key, value.clone()).await.ok(),
        Some(entry) => {
            let proven =
                entry.operation == kv::Operation::Put && seal.open(&place(key), &entry.value).is_some();
            // This node's own value (written again by anyone) is still this node's.
            match proven && entry.value != *value {
                true => None,
                false => kv.update(key, value.clone(), entry.revision).await.ok(),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bucket_made_again_gives_larger_fencing_tokens() {
        let made = 1_780_000_000;
        assert!(fence_token(made, 2) > fence_token(made, 1));
        // Made a second later, its first revision is above any the earlier one reached.
        assert!(fence_token(made + 1, 1) > fence_token(made, (1 << FENCE_REVISION_BITS) - 1));
        assert_eq!(fence_token(FENCE_EPOCH_S, 7), 7);
    }
}
