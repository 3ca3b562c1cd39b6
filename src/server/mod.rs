//! The facewire service: a thin tokio/axum layer over the geometry core. Heads are
//! registered over HTTP, producers push parameter frames over WebSocket (or HTTP batches),
//! every (stream, algorithm) deforms once per frame, and viewers get encoded frames over
//! WebSocket, latest-frame-wins. `proto/PROTOCOL.md` documents every endpoint and byte.

mod channel;
pub mod config;
pub mod demo;
mod error;
mod ingest;
mod ops;
mod pipeline;
mod registry;
mod routes;
mod store;
mod telemetry;
mod view;

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Instant;

use axum::extract::DefaultBodyLimit;
use axum::http::HeaderMap;
use axum::routing::{get, post};
use axum::Router;
use tokio_util::sync::CancellationToken;

pub use config::{Config, ConfigError};
pub use registry::{valid_id, Registry, STEP_MM};
pub use store::{HeadMeta, HeadRecord, Store};
pub use telemetry::Telemetry;

use crate::deform::AlgoSpec;
use crate::stream::ArkitBasis;
use error::ApiError;

/// Microseconds since the Unix epoch: the clock every timestamp on the wire uses.
pub fn now_us() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_micros() as u64)
}

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
    pub default_spec: AlgoSpec,
    pub arkit: ArkitBasis,
    pub started: Instant,
    next_id: AtomicU64,
    viewers: AtomicUsize,
}

impl std::ops::Deref for AppState {
    type Target = Shared;

    fn deref(&self) -> &Shared {
        &self.inner
    }
}

impl AppState {
    /// State for `config`; opens the data directory (if any) but registers nothing yet.
    pub fn new(config: Config) -> Result<AppState, Box<dyn std::error::Error + Send + Sync>> {
        config.validate()?;
        let store = config.data_dir.as_deref().map(Store::open).transpose()?;
        let registry = Registry::new(store, config.limits.max_vertices);
        Ok(AppState {
            inner: Arc::new(Shared {
                default_spec: config.default_algorithm.parse()?,
                registry,
                telemetry: Arc::new(Telemetry::default()),
                shutdown: CancellationToken::new(),
                arkit: ArkitBasis::shipped(),
                started: Instant::now(),
                next_id: AtomicU64::new(1),
                viewers: AtomicUsize::new(0),
                config,
            }),
        })
    }

    pub fn next_id(&self) -> u64 {
        self.next_id.fetch_add(1, Ordering::Relaxed)
    }

    /// Counts a viewer in; false when the server is full.
    fn admit_viewer(&self) -> bool {
        let limit = self.config.limits.max_viewers;
        self.viewers
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |n| {
                (n < limit).then_some(n + 1)
            })
            .is_ok()
    }

    fn release_viewer(&self) {
        self.viewers.fetch_sub(1, Ordering::AcqRel);
    }
}

/// Checks a token from `?token=` or `Authorization: Bearer`; `expected` None means open.
fn check_token(
    expected: Option<&str>,
    query: Option<&str>,
    headers: &HeaderMap,
    what: &str,
) -> Result<(), ApiError> {
    let Some(expected) = expected else { return Ok(()) };
    let bearer = headers
        .get(axum::http::header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "));
    match query.or(bearer) {
        Some(given) if constant_time_eq(given.as_bytes(), expected.as_bytes()) => Ok(()),
        _ => Err(ApiError::unauthorized(what)),
    }
}

fn constant_time_eq(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// The service's routes; tests can drive it without a socket.
pub fn app(state: AppState) -> Router {
    let upload_limit = state.config.limits.max_upload_bytes;
    Router::new()
        .route("/healthz", get(ops::healthz))
        .route("/metrics", get(ops::metrics))
        .route("/v1/algorithms", get(routes::algorithms))
        .route("/v1/heads", get(routes::list_heads).post(routes::register_head))
        .route(
            "/v1/heads/{id}",
            get(routes::get_head).delete(routes::delete_head),
        )
        .route("/v1/heads/{id}/mesh.bin", get(routes::mesh_bin))
        .route("/v1/heads/{id}/mesh.obj", get(routes::mesh_obj))
        .route("/v1/heads/{id}/streams/{stream}/produce", get(ingest::produce))
        .route("/v1/heads/{id}/streams/{stream}/batch", post(ingest::batch))
        .route("/v1/heads/{id}/streams/{stream}/view", get(view::view))
        .merge(crate::web::routes())
        .layer(DefaultBodyLimit::max(upload_limit))
        .layer(tower_http::trace::TraceLayer::new_for_http())
        .with_state(state)
}

/// Kernel send buffer per connection, bytes (a few frames).
const SOCKET_SEND_BUFFER: usize = 64 << 10;

/// Serves until SIGINT/SIGTERM or `state.shutdown` is cancelled; sockets close with a
/// reason first. `on_bound` is told the listening address (tests bind port 0).
pub async fn serve(state: AppState, on_bound: impl FnOnce(std::net::SocketAddr)) -> std::io::Result<()> {
    let listener = tokio::net::TcpListener::bind(state.config.addr).await?;
    on_bound(listener.local_addr()?);
    let loaded = state.registry.load_stored().map_err(std::io::Error::other)?;
    if loaded > 0 {
        tracing::info!(heads = loaded, "registering stored heads");
    }
    let shutdown = state.shutdown.clone();
    let signal_token = shutdown.clone();
    tokio::spawn(async move {
        wait_for_signal().await;
        tracing::info!("shutting down");
        signal_token.cancel();
    });
    // Small send buffers bound how far behind a slow viewer's socket can fall: the
    // latest-frame-wins logic above the socket then decides what it gets next.
    let listener = axum::serve::ListenerExt::tap_io(listener, |tcp: &mut tokio::net::TcpStream| {
        let _ = tcp.set_nodelay(true);
        let _ = socket2::SockRef::from(&*tcp).set_send_buffer_size(SOCKET_SEND_BUFFER);
    });
    axum::serve(listener, app(state))
        .with_graceful_shutdown(async move { shutdown.cancelled().await })
        .await
}

async fn wait_for_signal() {
    let ctrl_c = tokio::signal::ctrl_c();
    #[cfg(unix)]
    {
        let mut term = match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(s) => s,
            Err(_) => {
                let _ = ctrl_c.await;
                return;
            }
        };
        tokio::select! {
            _ = ctrl_c => {}
            _ = term.recv() => {}
        }
    }
    #[cfg(not(unix))]
    {
        let _ = ctrl_c.await;
    }
}
