//! Accepting connections and shutting down. An HTTP/1.1 server with limits a client cannot
//! outlast: at most `max_connections` at once, request headers within `header_timeout_s`
//! (a connection that sends nothing, or half a request, is closed), request handling
//! (body included) within `request_timeout_s` (the app's layer). On SIGINT or SIGTERM
//! every session closes with a reason, and the process waits for them at most
//! `shutdown_grace_s`.

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::Semaphore;
use tokio_util::task::TaskTracker;

use super::{app, AppState};

/// Kernel send buffer per connection, bytes (a few frames): small buffers bound how far a
/// slow viewer's socket falls behind, and latest-frame-wins above it decides what comes next.
const SOCKET_SEND_BUFFER: usize = 64 << 10;

/// Serves until SIGINT/SIGTERM or `state.shutdown` is cancelled. `on_bound` is told the
/// listening address (tests bind port 0).
pub async fn serve(state: AppState, on_bound: impl FnOnce(SocketAddr)) -> std::io::Result<()> {
    let listener = TcpListener::bind(state.config.addr).await?;
    on_bound(listener.local_addr()?);
    let stored = state
        .registry
        .load_stored()
        .await
        .map_err(std::io::Error::other)?;
    if stored > 0 {
        tracing::info!(heads = stored, "registering stored heads");
    }
    state.telemetry.heads.set(state.registry.list().len() as i64);
    let signal_token = state.shutdown.clone();
    tokio::spawn(async move {
        tokio::select! {
            _ = wait_for_signal() => tracing::info!("shutting down"),
            _ = signal_token.cancelled() => {}
        }
        signal_token.cancel();
    });
    let registry = state.registry.clone();
    tokio::spawn(async move { registry.sweep_streams(Duration::from_secs(1)).await });

    let limits = state.config.limits.clone();
    let router = app(state.clone());
    let slots = Arc::new(Semaphore::new(limits.max_connections));
    let connections = TaskTracker::new();
    let header_timeout = Duration::from_secs_f64(limits.header_timeout_s);
    loop {
        let slot = tokio::select! {
            _ = state.shutdown.cancelled() => break,
            slot = slots.clone().acquire_owned() => slot.expect("the slots are never closed"),
        };
        let tcp = tokio::select! {
            _ = state.shutdown.cancelled() => break,
            accepted = listener.accept() => match accepted {
                Ok((tcp, _)) => tcp,
                Err(e) => {
                    // Out of descriptors or similar: wait rather than spin.
                    tracing::warn!(error = %e, "accept failed");
                    tokio::time::sleep(Duration::from_millis(100)).await;
                    continue;
                }
            },
        };
        configure(&tcp);
        let service = TowerToHyperService::new(router.clone());
        let shutdown = state.shutdown.clone();
        connections.spawn(async move {
            let _slot = slot;
            let connection = hyper::server::conn::http1::Builder::new()
                .timer(TokioTimer::new())
                .header_read_timeout(header_timeout)
                .serve_connection(TokioIo::new(tcp), service)
                .with_upgrades();
            tokio::pin!(connection);
            tokio::select! {
                _ = connection.as_mut() => {}
                _ = shutdown.cancelled() => {
                    connection.as_mut().graceful_shutdown();
                    let _ = connection.await;
                }
            }
        });
    }
    drop(listener);
    connections.close();
    state.sessions.close();
    let grace = Duration::from_secs_f64(limits.shutdown_grace_s);
    let everything = async {
        connections.wait().await;
        state.sessions.wait().await;
    };
    if tokio::time::timeout(grace, everything).await.is_err() {
        tracing::warn!(
            connections = connections.len(),
            sessions = state.sessions.len(),
            "shutdown deadline passed; dropping what is left"
        );
    }
    Ok(())
}

fn configure(tcp: &TcpStream) {
    let _ = tcp.set_nodelay(true);
    let _ = socket2::SockRef::from(tcp).set_send_buffer_size(SOCKET_SEND_BUFFER);
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
