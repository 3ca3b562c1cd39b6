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

use std::sync::Arc;
use std::time::Duration;

use async_nats::jetstream;

use super::bus_url::redacted;
use super::config::BusAuth;
use super::telemetry::Telemetry;
use crate::mask::Mask;
pub use credentials::CredentialError;
pub use heads::{ClusterHeads, HeadChange, SharedHeadError};
pub use lease::LeaseError;
pub use relay::{Remote, RemoteBody};

/// Subject and bucket names start with this.
const PREFIX: &str = "facewire";
/// How long a JetStream request (a lease, a registry entry, a mesh chunk) may take before
/// the operation is refused as `bus_unavailable`.
const JETSTREAM_TIMEOUT: Duration = Duration::from_secs(3);

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
}

impl Cluster {
    /// Connects to NATS at `url` as `node` and opens (or creates) the buckets. Fails when
    /// the server cannot be reached now; once connected, the client reconnects by itself
    /// for as long as the node runs.
    pub async fn connect(
        url: &str,
        auth: &BusAuth,
        node: &str,
        mask: Arc<Mask>,
        telemetry: Arc<Telemetry>,
    ) -> Result<Cluster, ClusterError> {
        let (options, bare_url) = credentials::connect_options(auth, url).await?;
        let seal = Arc::new(seal::Seal::new(auth.cluster_key.as_ref())?);
        if !seal.is_keyed() {
            tracing::warn!(
                "no cluster_key: every message on the bus is believed; set [bus_auth] cluster_key on every node"
            );
        }
        let url = &redacted(url);
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
            .connect(bare_url)
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
        let heads = ClusterHeads::open(&js, client.clone())
            .await
            .map_err(|(bucket, e)| bucket_error(bucket)(&e))?;
        let leases = lease::Leases::open(&js, client.clone(), node)
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
        })
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
