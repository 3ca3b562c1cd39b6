//! What every handler shares, behind one cheap handle (`Arc<Shared>`): the configuration,
//! the head registry, metrics, the shutdown signal, the tracker of open sessions, and the
//! viewer slots. Made once per server, so tests can run several servers in one process.

use std::sync::Arc;
use std::time::{Duration, Instant};

use tokio::sync::Semaphore;
use tokio_util::sync::CancellationToken;
use tokio_util::task::TaskTracker;

use super::auth::Tokens;
use super::config::{Config, ConfigError};
use super::head::StreamLimits;
use super::registry::{Registry, RegistryLimits};
use super::store::{Store, StoreError};
use super::telemetry::Telemetry;
use super::trim::Trimmer;
use crate::deform::AlgoSpec;
use crate::mask::Mask;
use crate::stream::ArkitBasis;

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
    pub arkit: Arc<ArkitBasis>,
    pub started: Instant,
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
}

impl AppState {
    /// State for `config`; opens the data directory (if any) but registers nothing yet.
    pub fn new(config: Config) -> Result<AppState, StateError> {
        config.validate()?;
        let (default_spec, allowed_specs) = config.allowed_algorithms()?;
        let store = config.data_dir.as_deref().map(Store::open).transpose()?;
        let limits = &config.limits;
        let shutdown = CancellationToken::new();
        let registry = Registry::new(
            store,
            RegistryLimits {
                max_vertices: limits.max_vertices,
                max_bindings: limits.max_bindings_per_head,
                max_registrations: limits.max_registrations,
                streams: StreamLimits {
                    max_streams: limits.max_streams_per_head,
                    linger: Duration::from_secs_f64(limits.stream_linger_s),
                },
            },
            shutdown.clone(),
        );
        Ok(AppState {
            inner: Arc::new(Shared {
                registry,
                telemetry: Arc::new(Telemetry::default()),
                shutdown,
                sessions: TaskTracker::new(),
                default_spec,
                allowed_specs,
                tokens: Tokens::new(&config.auth),
                viewer_slots: Arc::new(Semaphore::new(limits.max_viewers)),
                trimmer: Arc::default(),
                mask: Arc::new(Mask::candide3()),
                arkit: Arc::new(ArkitBasis::shipped()),
                started: Instant::now(),
                config,
            }),
        })
    }
}
