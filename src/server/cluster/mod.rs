//! Several facewire nodes over NATS (`bus = "nats://..."`). Nodes exchange what is small —
//! producers' parameter frames and stream ends, on core NATS subjects — and each deforms
//! locally for its own viewers, so adding a node adds deform and fan-out capacity. What
//! must agree across nodes lives in JetStream: the head registry (a key-value bucket for
//! metadata and fits, the object store for meshes and parts) and the producer leases that
//! keep one producer per stream. Bindings, pipelines and sockets stay node-local.
//! Subjects, buckets and message formats: `proto/PROTOCOL.md` "Cluster bus".
//!
//! An adapter: it reports what the bus brings (heads put and deleted, other nodes' frames,
//! voices and ends) and never touches this node's registry; `crate::server::follow`
//! applies those reports.
//!
//! - [`relay`]: frames and ends between nodes; [`lease`]: one producer per stream and
//!   node liveness; [`heads`]: the shared registry; [`credentials`]: how a node
//!   authenticates to NATS; [`seal`]: the cluster key's proof on every message.

mod credentials;
mod heads;
mod lease;
mod relay;
mod seal;
mod watch_lag;

use std::sync::{Arc, Mutex};
use std::time::Duration;

use async_nats::jetstream;

use super::bus_url::redacted;
use super::config::BusAuth;
use super::telemetry::Telemetry;
use crate::mask::Mask;
pub use credentials::CredentialError;
pub use heads::{BucketSettings, ClusterHeads, HeadChange, Republished, SharedHead, SharedHeadError};
pub use lease::LeaseError;
pub use relay::{Remote, RemoteBody};

/// Subject and bucket names start with this.
const PREFIX: &str = "facewire";
/// How long a JetStream request (a lease, a registry entry, a mesh chunk) may take before
/// the operation is refused as `bus_unavailable`.
const JETSTREAM_TIMEOUT: Duration = Duration::from_secs(3);

/// Whether JetStream stream `stream` (a bucket's: `KV_<bucket>`, `OBJ_<bucket>`) exists:
/// `Ok(false)` only when JetStream says it does not, an error when it cannot say (NATS
/// away, a leader being elected), so that no bucket is made again on a doubt.
async fn stream_exists(js: &jetstream::Context, stream: &str) -> Result<bool, String> {
    use jetstream::context::GetStreamErrorKind;
    match js.get_stream(stream).await {
        Ok(_) => Ok(true),
        Err(e) => match e.kind() {
            GetStreamErrorKind::JetStream(error)
                if error.error_code() == jetstream::ErrorCode::STREAM_NOT_FOUND =>
            {
                Ok(false)
            }
            _ => Err(format!("stream {stream:?}: {e}")),
        },
    }
}

/// The key-value bucket `config` names, made with `config` when it does not exist (by the
/// cluster's first node); one an operator made first is used as it is.
async fn open_key_value(
    js: &jetstream::Context,
    config: jetstream::kv::Config,
) -> Result<jetstream::kv::Store, String> {
    if let Ok(kv) = js.get_key_value(config.bucket.as_str()).await {
        return Ok(kv);
    }
    js.create_key_value(config).await.map_err(|e| e.to_string())
}

#[derive(Debug, thiserror::Error)]
pub enum ClusterError {
    #[error(transparent)]
    Credentials(#[from] CredentialError),
    #[error("bus {url:?}: cannot connect to NATS: {source}")]
    Connect {
        url: String,
        source: async_nats::ConnectError,
    },
    #[error(
        "bus {url:?}: JetStream bucket {bucket:?}: {message} (is the server started with JetStream, `-js`?)"
    )]
    Bucket {
        url: String,
        bucket: &'static str,
        message: String,
    },
    #[error("bus {url:?}: {message}")]
    Url { url: String, message: String },
    #[error("bus: cannot subscribe to {subject:?}: {source}")]
    Subscribe {
        subject: String,
        source: async_nats::SubscribeError,
    },
}

/// This node's connection to the cluster; cloning the `Arc` is cheap.
pub struct Cluster {
    client: async_nats::Client,
    /// This node's name: in leases, in liveness subjects, in logs.
    pub node: String,
    pub heads: ClusterHeads,
    leases: Arc<lease::Leases>,
    outbox: relay::Outbox,
    seal: Arc<seal::Seal>,
    /// Why the buckets cannot be used now, as the last check found; `None` when they can.
    store_problem: Mutex<Option<String>>,
}

impl Cluster {
    /// Connects to NATS at `url` (one server, or several of a NATS cluster,
    /// comma-separated) as `node` and opens (or creates, with `settings`) the buckets; no
    /// mesh larger than `max_object_bytes` is read from them. Fails when no server can be
    /// reached now; once connected, the client reconnects by itself (to any server of the
    /// NATS cluster) for as long as the node runs.
    pub async fn connect(
        url: &str,
        auth: &BusAuth,
        node: &str,
        mask: Arc<Mask>,
        telemetry: Arc<Telemetry>,
        settings: BucketSettings,
        max_object_bytes: usize,
    ) -> Result<Cluster, ClusterError> {
        let (options, bare_urls) = credentials::connect_options(auth, url).await?;
        let seal = Arc::new(seal::Seal::new(auth.cluster_key.as_ref())?);
        if !seal.is_keyed() {
            tracing::warn!(
                "no cluster_key: every message on the bus is believed; set [bus_auth] cluster_key on every node"
            );
        }
        let url = &redacted(url);
        let servers = bare_urls
            .iter()
            .map(|u| u.parse::<async_nats::ServerAddr>())
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| ClusterError::Url {
                url: url.to_string(),
                message: e.to_string(),
            })?;
        let client = options
            .name(format!("facewire {node}"))
            // A node never needs its own messages back: its viewers read its producers
            // directly.
            .no_echo()
            .connection_timeout(Duration::from_secs(5))
            .max_reconnects(None)
            .event_callback(|event| async move {
                match event {
                    async_nats::Event::Connected => tracing::info!("bus connected"),
                    async_nats::Event::Disconnected => tracing::warn!("bus disconnected; reconnecting"),
                    other => tracing::info!(event = %other, "bus event"),
                }
            })
            .connect(servers)
            .await
            .map_err(|source| ClusterError::Connect {
                url: url.to_string(),
                source,
            })?;
        let mut js = jetstream::new(client.clone());
        js.set_timeout(JETSTREAM_TIMEOUT);
        let bucket_error = |bucket: &'static str| {
            move |e: &dyn std::fmt::Display| ClusterError::Bucket {
                url: url.to_string(),
                bucket,
                message: e.to_string(),
            }
        };
        let heads = ClusterHeads::open(&js, client.clone(), seal.clone(), settings, max_object_bytes)
            .await
            .map_err(|(bucket, e)| bucket_error(bucket)(&e))?;
        let leases = lease::Leases::open(&js, client.clone(), node, seal.clone(), settings)
            .await
            .map_err(|e| bucket_error(lease::BUCKET)(&e))?;
        let outbox = relay::Outbox::start(client.clone(), seal.clone(), mask, telemetry);
        Ok(Cluster {
            client,
            node: node.to_string(),
            heads,
            leases: Arc::new(leases),
            outbox,
            seal,
            store_problem: Mutex::new(None),
        })
    }

    /// Makes the buckets again if any is gone; true when one was made (the heads this node
    /// keeps are then to be published again). The error is why they cannot be used, also
    /// kept for [`Cluster::store_problem`].
    pub async fn ensure_store(&self) -> Result<bool, String> {
        let checked = match self.connected() {
            false => Err("not connected to NATS".to_string()),
            true => match self.heads.ensure_buckets().await {
                Ok(made) => self.leases.ensure_bucket().await.map(|leases| made || leases),
                Err(e) => Err(e),
            },
        };
        *self.store_problem.lock().expect("store lock") = checked.as_ref().err().cloned();
        checked
    }

    /// Why the cluster's buckets cannot be used, as last checked; `None` when they can.
    pub fn store_problem(&self) -> Option<String> {
        self.store_problem.lock().expect("store lock").clone()
    }

    /// Starts what the node does for the bus: answering liveness checks, and handing
    /// every checked message from other nodes' producers to `deliver` (this node's copy
    /// of the stream is the follower's to change: `crate::server::follow`).
    pub async fn start(
        self: &Arc<Self>,
        mask: Arc<Mask>,
        telemetry: Arc<Telemetry>,
        deliver: impl Fn(Remote<'_>) -> Result<(), &'static str> + Send + 'static,
    ) -> Result<(), ClusterError> {
        let liveness = self.leases.answer_liveness(&self.client).await?;
        tokio::spawn(liveness);
        let inbound = relay::inbound(&self.client, self.seal.clone(), mask, telemetry, deliver).await?;
        tokio::spawn(inbound);
        Ok(())
    }

    /// Whether any node holds `head`'s stream `stream`'s producer lease now.
    pub async fn lease_held(&self, head: &str, stream: &str) -> Result<bool, LeaseError> {
        self.leases.is_held(head, stream).await
    }

    /// Whether the NATS connection is up now.
    pub fn connected(&self) -> bool {
        self.client.connection_state() == async_nats::connection::State::Connected
    }

    /// Claims `head`'s stream `stream` for a producer on this node: a relay that sends
    /// the producer's frames to every node and holds the lease until it drops.
    pub async fn claim(
        &self,
        head: &str,
        stream: &str,
        cancel_producer: tokio_util::sync::CancellationToken,
    ) -> Result<Box<dyn super::stream::Relay>, LeaseError> {
        if !self.connected() {
            return Err(LeaseError::Unavailable("not connected to NATS".into()));
        }
        let lease = self.leases.claim(head, stream, cancel_producer).await?;
        Ok(Box::new(self.outbox.relay(head, stream, lease)))
    }
}
