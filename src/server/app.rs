//! The service's routes, as one function of the state so tests can drive it without a
//! socket. Each route's access level is a route layer ([`super::auth`]); around them all
//! a layer gives each request an id (in its log span and in `internal` answers) and a
//! deadline, and unknown paths and methods get JSON errors like every other refusal.
//! Reads (`GET`, `HEAD`) may come from any origin: a page served by one node of a cluster
//! fetches heads and meshes from the others (`web/nodes.js`). Tokens travel in the query
//! or the `Authorization` header, never in cookies, so this exposes nothing a cross-site
//! page could not already ask for with the token.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use axum::extract::{Request, State};
use axum::http::Method;
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::{delete, get, post};
use axum::Router;
use tracing::Instrument;

use super::error::{ApiError, REQUEST_ID};
use super::{auth, batch, heads, ops, producer, replay, view, web, AppState};

pub fn app(state: AppState) -> Router {
    let viewer = || middleware::from_fn_with_state(state.clone(), auth::viewer);
    let producer = || middleware::from_fn_with_state(state.clone(), auth::producer);
    let admin = || middleware::from_fn_with_state(state.clone(), auth::admin);
    Router::new()
        .route("/healthz", get(ops::healthz))
        .route("/metrics", get(ops::metrics).route_layer(admin()))
        .route("/v1/algorithms", get(heads::algorithms).route_layer(viewer()))
        .route(
            "/v1/heads",
            get(heads::list_heads)
                .route_layer(viewer())
                .merge(post(heads::register_head).route_layer(admin())),
        )
        .route(
            "/v1/heads/{id}",
            get(heads::get_head)
                .route_layer(viewer())
                .merge(delete(heads::delete_head).route_layer(admin())),
        )
        .route(
            "/v1/heads/{id}/mesh.bin",
            get(heads::mesh_bin).route_layer(viewer()),
        )
        .route(
            "/v1/heads/{id}/lips.bin",
            get(heads::lips_bin).route_layer(viewer()),
        )
        .route("/v1/heads/{id}/uv.bin", get(heads::uv_bin).route_layer(viewer()))
        .route(
            "/v1/heads/{id}/texture",
            get(heads::texture).route_layer(viewer()),
        )
        .route(
            "/v1/heads/{id}/parts/{part}/mesh.bin",
            get(heads::part_mesh_bin).route_layer(viewer()),
        )
        .route(
            "/v1/heads/{id}/parts/{part}/tongue.bin",
            get(heads::part_tongue_bin).route_layer(viewer()),
        )
        .route(
            "/v1/heads/{id}/mesh.obj",
            get(heads::mesh_obj).route_layer(viewer()),
        )
        .route("/v1/heads/{id}/fit", get(heads::fit_report).route_layer(viewer()))
        .route(
            "/v1/heads/{id}/fit.png",
            get(heads::fit_png).route_layer(viewer()),
        )
        .route(
            "/v1/heads/{id}/recordings",
            get(heads::list_recordings).route_layer(viewer()),
        )
        .route(
            "/v1/heads/{id}/recordings/{name}",
            delete(heads::delete_recording).route_layer(producer()),
        )
        .route(
            "/v1/heads/{id}/recordings/{name}/view",
            get(replay::view).route_layer(viewer()),
        )
        .route(
            "/v1/heads/{id}/streams/{stream}/produce",
            get(producer::produce).route_layer(producer()),
        )
        .route(
            "/v1/heads/{id}/streams/{stream}/batch",
            post(batch::batch).route_layer(producer()),
        )
        .route(
            "/v1/heads/{id}/streams/{stream}/producer",
            delete(batch::cancel_producer).route_layer(producer()),
        )
        .route(
            "/v1/heads/{id}/streams/{stream}/view",
            get(view::view).route_layer(viewer()),
        )
        .merge(web::routes())
        .fallback(not_found)
        .method_not_allowed_fallback(method_not_allowed)
        .layer(middleware::from_fn_with_state(state.clone(), request_context))
        .layer(
            tower_http::cors::CorsLayer::new()
                .allow_origin(tower_http::cors::Any)
                .allow_methods([Method::GET, Method::HEAD])
                .allow_headers([axum::http::header::AUTHORIZATION]),
        )
        .layer(axum::extract::DefaultBodyLimit::max(
            state.config.limits.max_upload_bytes,
        ))
        .with_state(state)
}

async fn not_found(request: Request) -> ApiError {
    ApiError::NotFound(request.uri().path().to_string())
}

async fn method_not_allowed(method: Method, request: Request) -> ApiError {
    ApiError::MethodNotAllowed {
        method: method.to_string(),
        path: request.uri().path().to_string(),
    }
}

/// Gives the request an id and a deadline (`request_timeout_s`).
async fn request_context(State(state): State<AppState>, request: Request, next: Next) -> Response {
    static NEXT: AtomicU64 = AtomicU64::new(1);
    let id = format!("r{}", NEXT.fetch_add(1, Ordering::Relaxed));
    let span =
        tracing::info_span!("request", id = %id, method = %request.method(), path = %request.uri().path());
    let limit_s = state.config.limits.request_timeout_s;
    REQUEST_ID
        .scope(
            id,
            async move {
                match tokio::time::timeout(Duration::from_secs_f64(limit_s), next.run(request)).await {
                    Ok(response) => response,
                    Err(_) => ApiError::Timeout(limit_s).into_response(),
                }
            }
            .instrument(span),
        )
        .await
}
