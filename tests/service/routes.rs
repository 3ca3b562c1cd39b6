//! The routes without a socket (`facewire::server::app`): the whole token table (every
//! endpoint with every kind of token), and JSON errors for what no handler answers.

use std::time::Duration;

use axum::body::Body;
use axum::http::{Method, Request, StatusCode};
use axum::Router;
use facewire::server::config::Auth;
use facewire::server::{app, AppState, Config};
use tower::ServiceExt;

use crate::common::data;
use crate::common::service::memory_config;

async fn call(
    router: &Router,
    method: Method,
    uri: &str,
    token: Option<&str>,
    body: Body,
) -> (StatusCode, Vec<u8>) {
    let mut request = Request::builder().method(method).uri(uri);
    if let Some(token) = token {
        request = request.header("authorization", format!("Bearer {token}"));
    }
    let response = router.clone().oneshot(request.body(body).unwrap()).await.unwrap();
    let status = response.status();
    let bytes = axum::body::to_bytes(response.into_body(), 64 << 20)
        .await
        .unwrap();
    (status, bytes.to_vec())
}

/// Like [`call`] with no token, for answers that are JSON.
async fn call_json(
    router: &Router,
    method: Method,
    uri: &str,
    body: Body,
) -> (StatusCode, serde_json::Value) {
    let (status, bytes) = call(router, method, uri, None, body).await;
    (status, serde_json::from_slice(&bytes).unwrap())
}

/// A server state with every token set and two ready heads: `own` (with its own producer
/// token) and `plain` (without).
async fn guarded() -> Router {
    let state = AppState::new(Config {
        auth: Auth {
            producer_token: Some("producer".into()),
            viewer_token: Some("viewer".into()),
            admin_token: Some("admin".into()),
        },
        ..memory_config()
    })
    .unwrap();
    let router = app(state);
    let obj = std::fs::read_to_string(data("heads/makehuman_head.obj")).unwrap();
    let fit = std::fs::read_to_string(data("heads/makehuman_head.fit.toml")).unwrap();
    for (id, own) in [("own", Some("own")), ("plain", None)] {
        let body = serde_json::json!({"id": id, "obj": obj, "fit": fit, "producer_token": own});
        let info = register_and_wait(&router, body, Some("admin")).await;
        assert_eq!(info["status"], "ready", "{info}");
    }
    router
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_endpoint_takes_exactly_the_tokens_of_the_table() {
    let router = guarded().await;
    let tokens = [
        None,
        Some("wrong"),
        Some("viewer"),
        Some("producer"),
        Some("own"),
        Some("admin"),
    ];
    // (method, path, which of `tokens` are let in); the WebSocket routes answer a request
    // that is not an upgrade with 4xx, anything but 401 means the token was let in.
    let open = [true; 6];
    let viewer = [false, false, true, false, false, true];
    let admin = [false, false, false, false, false, true];
    let producer_plain = [false, false, false, true, false, true];
    let producer_own = [false, false, false, false, true, true];
    let table: [(Method, &str, [bool; 6]); 26] = [
        (Method::GET, "/healthz", open),
        (Method::GET, "/", open),
        (Method::GET, "/app.js", open),
        (Method::GET, "/metrics", admin),
        (Method::GET, "/v1/algorithms", viewer),
        (Method::GET, "/v1/heads", viewer),
        (Method::GET, "/v1/heads/own", viewer),
        (Method::GET, "/v1/heads/own/mesh.bin", viewer),
        (Method::GET, "/v1/heads/own/lips.bin", viewer),
        (Method::GET, "/v1/heads/own/mesh.obj", viewer),
        (Method::GET, "/v1/heads/own/fit", viewer),
        (Method::GET, "/v1/heads/own/fit.png?view=side", viewer),
        (Method::GET, "/v1/heads/own/streams/s/view", viewer),
        (Method::GET, "/v1/heads/own/recordings", viewer),
        (Method::GET, "/v1/heads/own/recordings/r/view", viewer),
        (Method::DELETE, "/v1/heads/own/recordings/r", producer_own),
        (Method::DELETE, "/v1/heads/plain/recordings/r", producer_plain),
        (Method::POST, "/v1/heads", admin),
        (Method::DELETE, "/v1/heads/nosuch", admin),
        (Method::GET, "/v1/heads/own/streams/s/produce", producer_own),
        (Method::POST, "/v1/heads/own/streams/s/batch", producer_own),
        (Method::DELETE, "/v1/heads/own/streams/s/producer", producer_own),
        (Method::GET, "/v1/heads/plain/streams/s/produce", producer_plain),
        (Method::POST, "/v1/heads/plain/streams/s/batch", producer_plain),
        (
            Method::DELETE,
            "/v1/heads/plain/streams/s/producer",
            producer_plain,
        ),
        (Method::GET, "/v1/heads/plain", viewer),
    ];
    for (method, path, allowed) in &table {
        for (token, allowed) in tokens.iter().zip(allowed) {
            let (status, body) = call(&router, method.clone(), path, *token, Body::empty()).await;
            let let_in = status != StatusCode::UNAUTHORIZED;
            assert_eq!(
                let_in,
                *allowed,
                "{method} {path} with token {token:?}: {status} {}",
                String::from_utf8_lossy(&body)
            );
            if !let_in {
                let error: serde_json::Value = serde_json::from_slice(&body).unwrap();
                assert_eq!(error["error"], "unauthorized");
            }
        }
    }
    // The query parameter works as the header does.
    let (status, _) = call(
        &router,
        Method::GET,
        "/v1/heads?token=viewer",
        None,
        Body::empty(),
    )
    .await;
    assert_eq!(status, StatusCode::OK);
}

#[tokio::test]
async fn what_no_route_answers_is_a_json_error() {
    let router = app(AppState::new(memory_config()).unwrap());
    let (status, body) = call(&router, Method::GET, "/v2/nothing", None, Body::empty()).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    let body: serde_json::Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(body["error"], "not_found");
    let (status, body) = call(&router, Method::PUT, "/v1/heads", None, Body::empty()).await;
    assert_eq!(status, StatusCode::METHOD_NOT_ALLOWED);
    let body: serde_json::Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(body["error"], "not_found");
    let (status, body) = call(&router, Method::POST, "/v1/heads", None, Body::from("{")).await;
    assert_eq!(status, StatusCode::BAD_REQUEST);
    let body: serde_json::Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(body["error"], "bad_request");
    let landmarks = serde_json::json!({
        "id": "x",
        "obj": std::fs::read_to_string(data("heads/makehuman_head.obj")).unwrap(),
        "landmarks": "mm_per_unit = nan\\n",
    });
    let (status, body) = call_json(
        &router,
        Method::POST,
        "/v1/heads",
        Body::from(landmarks.to_string()),
    )
    .await;
    assert_eq!(
        (status, body["error"].as_str()),
        (StatusCode::BAD_REQUEST, Some("bad_landmarks")),
        "{body}"
    );
}

/// Posts a registration request and waits for the registration to end; the head info.
async fn register_and_wait(
    router: &Router,
    body: serde_json::Value,
    token: Option<&str>,
) -> serde_json::Value {
    let id = body["id"].as_str().unwrap().to_string();
    let (status, answer) = call(
        router,
        Method::POST,
        "/v1/heads",
        token,
        Body::from(body.to_string()),
    )
    .await;
    assert_eq!(
        status,
        StatusCode::ACCEPTED,
        "{}",
        String::from_utf8_lossy(&answer)
    );
    for _ in 0..400 {
        let (_, info) = call(
            router,
            Method::GET,
            &format!("/v1/heads/{id}"),
            token,
            Body::empty(),
        )
        .await;
        let info: serde_json::Value = serde_json::from_slice(&info).unwrap();
        if info["status"] != "registering" {
            return info;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    panic!("{id} still registering");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_head_with_its_lips_apart_is_closed_at_registration() {
    let router = app(AppState::new(memory_config()).unwrap());
    // The MakeHuman head with its mouth 6 mm open, and the neutral head's landmarks.
    let head = crate::common::part_open_head("makehuman_head", "makehuman_arkit/jawOpen.target", 0.16);
    let mut obj = Vec::new();
    facewire::head::obj::write(&mut obj, &[], &head.positions, &head.triangles).unwrap();
    let landmarks = std::fs::read_to_string(data("heads/makehuman_head.landmarks.toml")).unwrap();
    let body =
        serde_json::json!({"id": "open", "obj": String::from_utf8(obj).unwrap(), "landmarks": landmarks});
    let info = register_and_wait(&router, body, None).await;
    assert_eq!(info["status"], "ready", "{info}");
    let said = info["fit"]["warnings"][0].as_str().unwrap();
    assert!(
        said.starts_with("the inner lips were 6.1 mm apart at rest: registration closed them"),
        "{info}"
    );
    let (status, report) = call_json(&router, Method::GET, "/v1/heads/open/fit", Body::empty()).await;
    assert_eq!(status, StatusCode::OK, "{report}");
    let open_mm = report["mouth_closed"]["open_mm"].as_f64().unwrap();
    assert!((open_mm - 6.09).abs() < 0.01, "{report}");
    assert!(report["inner_lip_gap_mm"].as_f64().unwrap() <= 0.5, "{report}");
    // The rest mesh viewers get is the closed head.
    let (status, mesh) = call(
        &router,
        Method::GET,
        "/v1/heads/open/mesh.obj",
        None,
        Body::empty(),
    )
    .await;
    assert_eq!(status, StatusCode::OK);
    let served = facewire::head::Head::from_obj_bytes("mesh.obj", &mesh).unwrap();
    let moved = served
        .positions
        .iter()
        .zip(&head.positions)
        .filter(|(a, b)| a.distance(**b) > 1e-4)
        .count();
    assert!(moved > 100, "{moved} vertices moved");
}

/// A fit that disagrees with itself says so: on ICT identity 41's face cut (a population
/// member, 6.1 mm from its reference) the face's shape could not be read where the learned
/// reader saw the face, and the fit follows the reader alone. The warning is kept in the fit
/// file, in head info's `fit.warnings` and in the fit report (`from_fit`).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_automatic_fit_that_disagrees_with_itself_is_registered_with_a_warning() {
    use facewire::population::{self, Maker};
    let spec = population::members()
        .into_iter()
        .find(|m| m.name() == "ict seed 41 (sigma 1), face cut")
        .unwrap();
    let member = Maker::new(&crate::common::repo_path("data"))
        .unwrap()
        .make(&spec)
        .unwrap();
    let mut obj = Vec::new();
    facewire::head::obj::write(&mut obj, &[], &member.head.positions, &member.head.triangles).unwrap();
    let router = app(AppState::new(memory_config()).unwrap());
    let body = serde_json::json!({"id": "cut", "obj": String::from_utf8(obj).unwrap()});
    let info = register_and_wait(&router, body, None).await;
    assert_eq!(info["status"], "ready", "{info}");
    // Beside the face cut's own warnings (mask vertices past the mesh's edge).
    let said = info["fit"]["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|w| w.as_str())
        .find(|w| w.starts_with("automatic fit: "))
        .unwrap_or_else(|| panic!("{info}"));
    assert!(
        said.starts_with("automatic fit: the face's shape (its profile, lips and eyes) could not be read"),
        "{said}"
    );
    let (status, report) = call_json(&router, Method::GET, "/v1/heads/cut/fit", Body::empty()).await;
    assert_eq!(status, StatusCode::OK, "{report}");
    let warning = report["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .find(|w| w["kind"] == "from_fit")
        .unwrap_or_else(|| panic!("{report}"));
    assert_eq!(warning["message"], said, "{report}");
    assert_eq!(warning["note"], said, "{report}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_head_with_neither_fit_nor_landmarks_is_fitted_automatically() {
    let router = app(AppState::new(memory_config()).unwrap());
    let obj = std::fs::read_to_string(data("heads/ict_head.obj")).unwrap();
    let info = register_and_wait(&router, serde_json::json!({"id": "found", "obj": obj}), None).await;
    assert_eq!(info["status"], "ready", "{info}");
    let mean = info["fit"]["surface_mean_mm"].as_f64().unwrap();
    assert!(mean < 2.0, "{info}");
    assert_eq!(info["fit"]["warnings"], serde_json::json!([]), "{info}");

    // Its report, and pictures of it from the front and the side.
    let (status, report) = call_json(&router, Method::GET, "/v1/heads/found/fit", Body::empty()).await;
    assert_eq!(status, StatusCode::OK, "{report}");
    assert_eq!(report["surface"]["mean_mm"], info["fit"]["surface_mean_mm"]);
    let regions: Vec<&str> = report["regions"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["region"].as_str().unwrap())
        .collect();
    assert_eq!(
        regions,
        ["eyes", "brow", "nose", "mouth", "jaw", "forehead_and_cheeks"]
    );
    assert!(report["inner_lip_gap_mm"].as_f64().unwrap() < 2.0, "{report}");
    let mut pictures = Vec::new();
    for view in ["front", "side"] {
        let uri = format!("/v1/heads/found/fit.png?view={view}");
        let (status, png) = call(&router, Method::GET, &uri, None, Body::empty()).await;
        assert_eq!(status, StatusCode::OK);
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n", "{view}");
        pictures.push(png);
    }
    assert_ne!(pictures[0], pictures[1]);
    let (status, again) = call(
        &router,
        Method::GET,
        "/v1/heads/found/fit.png",
        None,
        Body::empty(),
    )
    .await;
    assert_eq!(
        (status, &again),
        (StatusCode::OK, &pictures[0]),
        "front is the default"
    );
    let (status, body) = call_json(
        &router,
        Method::GET,
        "/v1/heads/found/fit.png?view=top",
        Body::empty(),
    )
    .await;
    assert_eq!(
        (status, body["error"].as_str()),
        (StatusCode::BAD_REQUEST, Some("bad_request")),
        "{body}"
    );
    assert!(
        body["message"].as_str().unwrap().contains("front or side"),
        "{body}"
    );

    // A mesh with no face: refused at once, naming the reason and the way out.
    let ball = crate::common::ball_obj();
    let ball = serde_json::json!({"id": "ball", "obj": ball});
    let (status, body) = call_json(&router, Method::POST, "/v1/heads", Body::from(ball.to_string())).await;
    assert_eq!(
        (status, body["error"].as_str()),
        (StatusCode::BAD_REQUEST, Some("bad_head")),
        "{body}"
    );
    let message = body["message"].as_str().unwrap_or_default();
    assert!(
        message.contains("no face found") && message.contains("Give landmarks"),
        "{body}"
    );

    // Both a fit and landmarks: which one was meant is not guessed.
    let both = serde_json::json!({"id": "both", "obj": "v 0 0 0", "fit": "", "landmarks": ""});
    let (status, body) = call_json(&router, Method::POST, "/v1/heads", Body::from(both.to_string())).await;
    assert_eq!(
        (status, body["error"].as_str()),
        (StatusCode::BAD_REQUEST, Some("bad_request")),
        "{body}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn heads_that_cannot_be_animated_fail_with_the_reason() {
    let router = app(AppState::new(memory_config()).unwrap());
    let fit = std::fs::read_to_string(data("heads/makehuman_head.fit.toml")).unwrap();
    let obj = std::fs::read_to_string(data("heads/makehuman_head.obj")).unwrap();
    let one_triangle = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".to_string();
    let mut same_point = "v 1 2 3\n".repeat(5000);
    same_point.push_str(&"f 1 2 3\n".repeat(100));
    let huge_scale = fit
        .lines()
        .map(|l| match l.starts_with("scale") {
            true => "scale = 1e30".to_string(),
            false => l.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n");
    for (id, obj, fit, says) in [
        ("one", one_triangle, fit.clone(), "vertices"),
        ("same", same_point, fit.clone(), "extent"),
        ("scaled", obj, huge_scale, "scale"),
    ] {
        let info = register_and_wait(
            &router,
            serde_json::json!({"id": id, "obj": obj, "fit": fit}),
            None,
        )
        .await;
        assert_eq!(info["status"], "failed", "{info}");
        let error = info["error"].as_str().unwrap();
        assert!(error.contains(says), "{id}: {error}");
        let (status, body) = call(
            &router,
            Method::GET,
            &format!("/v1/heads/{id}/mesh.bin"),
            None,
            Body::empty(),
        )
        .await;
        assert_eq!(status, StatusCode::CONFLICT);
        let body: serde_json::Value = serde_json::from_slice(&body).unwrap();
        assert_eq!(body["error"], "registration_failed");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn reads_may_come_from_another_origin_and_writes_may_not() {
    // A page served by one node of a cluster reads heads and meshes from the others.
    let router = app(AppState::new(memory_config()).unwrap());
    let request = Request::builder()
        .method(Method::GET)
        .uri("/v1/heads")
        .header("origin", "http://127.0.0.1:9001")
        .body(Body::empty())
        .unwrap();
    let response = router.clone().oneshot(request).await.unwrap();
    assert_eq!(response.status(), StatusCode::OK);
    assert_eq!(
        response
            .headers()
            .get("access-control-allow-origin")
            .map(|v| v.to_str().unwrap()),
        Some("*")
    );
    // A preflight for a registration (POST with JSON) is not granted.
    let preflight = Request::builder()
        .method(Method::OPTIONS)
        .uri("/v1/heads")
        .header("origin", "http://127.0.0.1:9001")
        .header("access-control-request-method", "POST")
        .body(Body::empty())
        .unwrap();
    let response = router.oneshot(preflight).await.unwrap();
    let allowed = response
        .headers()
        .get("access-control-allow-methods")
        .map(|v| v.to_str().unwrap().to_string())
        .unwrap_or_default();
    assert!(!allowed.contains("POST"), "{allowed}");
    assert!(allowed.contains("GET"), "{allowed}");
}
