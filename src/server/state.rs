//! What every handler shares, behind one cheap handle (`Arc<Shared>`): the configuration,
//! the head registry, metrics, the shutdown signal, the tracker of open sessions, and the
//! viewer slots. Made once per server, so tests can run several servers in one process.

use std::sync::Arc;
use std::time::{Duration, Instant};

use tokio::sync::Semaphore;
use tokio_util::sync::CancellationToken;
use tokio_util::task::TaskTracker;

use super::auth::Tokens;
use super::cluster::{BucketSettings, Cluster, ClusterError, LeaseError};
use super::config::{Bus, Config, ConfigError};
use super::error::ApiError;
use super::head::StreamLimits;
use super::head_store::HeadStore;
use super::recordings::{RecordingBudget, RecordingLimits};
use super::registry::{Registry, RegistryLimits};
use super::store::{Store, StoreError};
use super::stream::{ProducerPermit, Stream};
use super::telemetry::Telemetry;
use super::trim::Trimmer;
use crate::deform::AlgoSpec;
use crate::head::MeshBudget;
use crate::mask::Mask;
use crate::speech::{ModelError, VisemeModel};

/// Everything the handlers share; cloning is cheap.
#[derive(Clone)]
pub struct AppState {
    inner: Arc<Shared>,
}

pub struct Shared {
    pub config: Config,
    pub registry: Registry,
    pub telemetry: Arc<Telemetry>,
    /// Cancelled on shutdown: every socket closes with a reason.
    pub shutdown: CancellationToken,
    /// Every producer and viewer session and every playing batch, so shutdown can wait
    /// for their closing messages.
    pub sessions: TaskTracker,
    pub default_spec: AlgoSpec,
    /// The algorithms viewers may ask for, when the configuration limits them.
    pub allowed_specs: Option<Vec<AlgoSpec>>,
    pub tokens: Tokens,
    pub viewer_slots: Arc<Semaphore>,
    /// Gives the memory of retired pipelines back, at most once a second.
    pub trimmer: Arc<Trimmer>,
    pub mask: Arc<Mask>,
    /// The viseme model of audio-only producers (`derive=visemes`).
    pub speech_model: Arc<VisemeModel>,
    pub started: Instant,
    /// The cluster this node is part of (`bus` is a NATS URL); `None` alone.
    pub cluster: Option<Arc<Cluster>>,
}

impl std::ops::Deref for AppState {
    type Target = Shared;

    fn deref(&self) -> &Shared {
        &self.inner
    }
}

#[derive(Debug, thiserror::Error)]
pub enum StateError {
    #[error("configuration: {0}")]
    Config(#[from] ConfigError),
    #[error("data directory: {0}")]
    Store(#[from] StoreError),
    #[error(transparent)]
    Cluster(#[from] ClusterError),
    #[error("the viseme model: {0}")]
    SpeechModel(#[from] ModelError),
    #[error("bus {0:?}: a cluster node is started with `AppState::start`")]
    NeedsStart(String),
}

impl AppState {
    /// State for a single node (`bus = "local"`); opens the data directory (if any) but
    /// registers nothing yet.
    pub fn new(config: Config) -> Result<AppState, StateError> {
        config.validate()?;
        if let Bus::Nats(url) = config.bus()? {
            return Err(StateError::NeedsStart(super::bus_url::redacted(&url)));
        }
        let store = match config.data_dir.as_deref() {
            Some(dir) => HeadStore::Dir(Store::open(dir)?),
            None => HeadStore::Memory,
        };
        let mask = Arc::new(Mask::candide3());
        AppState::build(config, store, None, mask, Arc::default())
    }

    /// State for `config`, alone or as a cluster node: connects to the bus, opens its
    /// buckets and starts following the cluster's heads and streams.
    pub async fn start(config: Config) -> Result<AppState, StateError> {
        config.validate()?;
        let Bus::Nats(url) = config.bus()? else {
            return AppState::new(config);
        };
        let node = config
            .node_name
            .clone()
            .unwrap_or_else(|| super::ids::unique_name("node"));
        let telemetry = Arc::new(Telemetry::default());
        let mask = Arc::new(Mask::candide3());
        let settings = BucketSettings {
            replicas: config.bus_replicas,
        };
        let cluster = Arc::new(
            Cluster::connect(
                &url,
                &config.bus_auth,
                &node,
                mask.clone(),
                telemetry.clone(),
                settings,
                config.limits.max_upload_bytes,
            )
            .await?,
        );
        // The node keeps every head of the cluster in its data directory too, to put back
        // what the buckets lose.
        let local = config.data_dir.as_deref().map(Store::open).transpose()?;
        let store = HeadStore::Cluster {
            heads: Box::new(cluster.heads.clone()),
            local,
        };
        let state = AppState::build(config, store, Some(cluster.clone()), mask, telemetry)?;
        super::follow::start(
            &cluster,
            state.registry.clone(),
            state.mask.clone(),
            state.telemetry.clone(),
            state.shutdown.clone(),
        )
        .await?;
        tracing::info!(%url, node = %node, "cluster node started");
        Ok(state)
    }

    /// Takes `stream`'s producer slot here and, in a cluster, on every node (the relay to
    /// the other nodes comes with it): `ProducerBusy` when a producer holds it anywhere,
    /// `BusUnavailable` when the cluster cannot say.
    pub async fn claim_producer(&self, head: &str, stream: &Arc<Stream>) -> Result<ProducerPermit, ApiError> {
        let mut permit = stream
            .claim_producer()
            .ok_or_else(|| ApiError::ProducerBusy(stream.name.clone()))?;
        if let Some(cluster) = &self.cluster {
            match cluster.claim(head, &stream.name, permit.cancel_token()).await {
                Ok(relay) => permit.relay_to(relay),
                Err(e) => {
                    permit.abandon();
                    return Err(match e {
                        LeaseError::Busy { .. } => ApiError::ProducerBusy(stream.name.clone()),
                        LeaseError::Unavailable(message) => ApiError::BusUnavailable(message),
                    });
                }
            }
        }
        Ok(permit)
    }

    fn build(
        config: Config,
        store: HeadStore,
        cluster: Option<Arc<Cluster>>,
        mask: Arc<Mask>,
        telemetry: Arc<Telemetry>,
    ) -> Result<AppState, StateError> {
        let speech_model = Arc::new(VisemeModel::embedded()?);
        let (default_spec, allowed_specs) = config.allowed_algorithms().expect("validated by the caller");
        let limits = &config.limits;
        let shutdown = CancellationToken::new();
        let registry = Registry::new(
            store,
            RegistryLimits {
                budget: MeshBudget::new(limits.max_vertices, limits.max_triangles),
                max_heads: limits.max_heads,
                max_bindings: limits.max_bindings_per_head,
                max_registrations: limits.max_registrations,
                streams: StreamLimits {
                    max_streams: limits.max_streams_per_head,
                    linger: Duration::from_secs_f64(limits.stream_linger_s),
                    recordings: RecordingLimits {
                        max_per_head: limits.max_recordings_per_head,
                        max_frames: limits.max_recording_frames,
                        budget: RecordingBudget::new(limits.max_recording_bytes),
                        mask: mask.clone(),
                    },
                },
            },
            shutdown.clone(),
        );
        Ok(AppState {
            inner: Arc::new(Shared {
                registry,
                telemetry,
                shutdown,
                sessions: TaskTracker::new(),
                default_spec,
                allowed_specs,
                tokens: Tokens::new(&config.auth),
                viewer_slots: Arc::new(Semaphore::new(limits.max_viewers)),
                trimmer: Arc::default(),
                mask,
                speech_model,
                started: Instant::now(),
                cluster,
                config,
            }),
        })
    }
}
