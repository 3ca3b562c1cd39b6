//! Operations endpoints: `/healthz` for load balancers (with what an operator needs to
//! know: heads by status, live streams, viewers, stored heads that could not be loaded)
//! and `/metrics` for Prometheus.

use axum::extract::State;
use axum::http::header;
use axum::response::IntoResponse;
use axum::Json;
use serde_json::json;

use super::head::HeadStatus;
use super::AppState;

pub async fn healthz(State(state): State<AppState>) -> impl IntoResponse {
    let heads = state.registry.list();
    let count = |f: fn(&HeadStatus) -> bool| heads.iter().filter(|h| f(&h.status())).count();
    Json(json!({
        "status": "ok",
        "heads": heads.len(),
        "ready": count(|s| matches!(s, HeadStatus::Ready(_))),
        "registering": count(|s| matches!(s, HeadStatus::Registering { .. })),
        "failed": count(|s| matches!(s, HeadStatus::Failed(_))),
        "work": {
            "busy": state.registry.busy_slots(),
            "slots": state.config.limits.max_registrations,
        },
        "streams": heads.iter().map(|h| h.stream_count()).sum::<usize>(),
        "viewers": state.config.limits.max_viewers - state.viewer_slots.available_permits(),
        "stored_problems": state.registry.problems(),
        "bus": match &state.cluster {
            Some(cluster) => json!({
                "kind": "nats",
                "node": cluster.node,
                "connected": cluster.connected(),
                "store_problem": cluster.store_problem(),
            }),
            None => json!({"kind": "local"}),
        },
        "uptime_s": state.started.elapsed().as_secs_f64(),
    }))
}

pub async fn metrics(State(state): State<AppState>) -> impl IntoResponse {
    (
        [(
            header::CONTENT_TYPE,
            "application/openmetrics-text; version=1.0.0; charset=utf-8",
        )],
        state.telemetry.render(),
    )
}
