//! Work a client can start is bounded: no finite head panics the automatic fit, a mesh
//! built to be expensive is refused before it is drawn, a head and its parts share one
//! budget and lie within reach of each other, the heads a server holds are counted, and a
//! fit whose request ended stops and frees its slot only once it has stopped.

use std::time::{Duration, Instant};

use crate::common::service::{memory_config, post, Server};
use facewire::cancel::Cancel;
use facewire::fit::{fit_automatically, fit_automatically_unless, AutomaticFitError};
use facewire::head::Head;
use facewire::mask::Mask;
use glam::{Mat3, Vec3};
use serde_json::json;

fn makehuman() -> Head {
    Head::load(&crate::common::data("heads/makehuman_head.obj")).unwrap()
}

fn moved(head: &Head, f: impl Fn(Vec3) -> Vec3) -> Head {
    Head::new(
        &head.name,
        head.positions.iter().map(|&p| f(p)).collect(),
        head.triangles.clone(),
    )
}

/// A few thousand of the head's vertices joined by `count` triangles between random ones:
/// each triangle spans a good part of the head.
fn spanning_triangles(head: &Head, count: usize) -> Head {
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    let mut next = |n: usize| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state % n as u64) as u32
    };
    let n = head.positions.len();
    let triangles = (0..count).map(|_| [next(n), next(n), next(n)]).collect();
    Head::new("spanning.obj", head.positions.clone(), triangles)
}

fn obj_text(head: &Head) -> String {
    let mut out = Vec::new();
    facewire::head::obj::write(&mut out, &[], &head.positions, &head.triangles).unwrap();
    String::from_utf8(out).unwrap()
}

#[test]
fn the_automatic_fit_answers_every_finite_head_without_panicking() {
    let mask = Mask::candide3();
    let head = makehuman();
    let centre = head.bounds().center();
    let mut cases: Vec<(String, Head)> = Vec::new();
    for exponent in [-30, -12, -7, 7, 11, 20, 30] {
        let s = 10f32.powi(exponent);
        cases.push((format!("scaled by 1e{exponent}"), moved(&head, |p| p * s)));
    }
    cases.push(("moved 1e9 away".into(), moved(&head, |p| p + Vec3::splat(1e9))));
    for (axis, degrees) in [(Vec3::X, 90.0), (Vec3::new(1.0, 2.0, 3.0), 137.0)] {
        let turn = Mat3::from_axis_angle(axis.normalize(), f32::to_radians(degrees));
        cases.push((format!("turned {degrees} degrees"), moved(&head, |p| turn * p)));
    }
    cases.push(("flattened".into(), moved(&head, |p| Vec3::new(p.x, p.y, 0.0))));
    cases.push(("on a line".into(), moved(&head, |p| Vec3::new(p.x, 0.0, 0.0))));
    cases.push(("in one point".into(), moved(&head, |_| centre)));
    cases.push((
        "one triangle".into(),
        Head::new("one.obj", vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]),
    ));
    cases.push((
        "one triangle a thousand times".into(),
        Head::new(
            "same.obj",
            vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            vec![[0, 1, 2]; 1000],
        ),
    ));
    for (what, case) in &cases {
        // Answering at all is the test: a panic fails it. Every refusal names the head.
        match fit_automatically(case, &mask, None) {
            Ok(found) => assert!(found.fit.check_ranges().is_ok(), "{what}: {:?}", found.fit),
            Err(e) => assert!(e.to_string().starts_with(&case.name), "{what}: {e}"),
        }
    }
    // A head a hundred billion times too large for its fit's ranges is refused by range.
    let huge = &cases[4].1;
    let error = fit_automatically(huge, &mask, None).unwrap_err();
    assert!(matches!(error, AutomaticFitError::Range { .. }), "{error}");
}

#[test]
fn a_mesh_of_spanning_triangles_is_refused_before_it_is_drawn() {
    let head = spanning_triangles(&makehuman(), 250_000);
    let started = Instant::now();
    let error = fit_automatically(&head, &Mask::candide3(), None).unwrap_err();
    let message = error.to_string();
    assert!(matches!(error, AutomaticFitError::RasterCost { .. }), "{message}");
    assert!(message.contains("head-sized images"), "{message}");
    // Refused from one pass over the triangles, not after drawing them.
    assert!(
        started.elapsed() < Duration::from_secs(2),
        "{:?}",
        started.elapsed()
    );
    // Every shipped head is far inside the bound.
    for name in [
        "ict_head",
        "makehuman_head",
        "lee_perry_smith_head",
        "ict_identity_1",
    ] {
        let shipped = Head::load(&crate::common::data(&format!("heads/{name}.obj"))).unwrap();
        let coverage = facewire::head::raster_cost::coverage(&shipped.positions, &shipped.triangles).unwrap();
        assert!(
            coverage < facewire::head::raster_cost::MAX_RASTER_COVERAGE / 5.0,
            "{name}: {coverage}"
        );
    }
}

#[test]
fn a_cancelled_fit_stops_with_cancelled() {
    let cancel = Cancel::new();
    cancel.cancel();
    let error = fit_automatically_unless(&makehuman(), &Mask::candide3(), None, &cancel).unwrap_err();
    assert!(matches!(error, AutomaticFitError::Cancelled { .. }), "{error}");
}

async fn failure(server: &Server, id: &str) -> String {
    for _ in 0..600 {
        let info = server.info(id, "").await;
        match info.status.as_str() {
            "failed" => return info.error.unwrap_or_default(),
            "ready" => panic!("{id} registered"),
            _ => tokio::time::sleep(Duration::from_millis(50)).await,
        }
    }
    panic!("{id} still registering");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_head_and_its_parts_share_one_budget_and_stay_within_reach() {
    let mut config = memory_config();
    // MakeHuman's head: 4,352 vertices, 8,652 triangles.
    config.limits.max_vertices = 6_000;
    config.limits.max_triangles = 12_000;
    config.limits.max_heads = 3;
    let server = Server::start(config).await;
    let head = makehuman();
    let obj = obj_text(&head);
    let fit = std::fs::read_to_string(crate::common::data("heads/makehuman_head.fit.toml")).unwrap();
    let small_part = |offset: Vec3, copies: usize| {
        let mut text = String::new();
        for k in 0..copies {
            let o = offset + Vec3::X * k as f32 * 0.01;
            text += &format!(
                "v {} {} {}\nv {} {} {}\nv {} {} {}\n",
                o.x,
                o.y,
                o.z,
                o.x + 0.1,
                o.y,
                o.z,
                o.x,
                o.y + 0.1,
                o.z
            );
        }
        for k in 0..copies {
            text += &format!("f {} {} {}\n", 3 * k + 1, 3 * k + 2, 3 * k + 3);
        }
        text
    };
    let register = |id: &str, part: String| {
        json!({"id": id, "obj": obj, "fit": fit,
               "parts": [{"name": "extra", "role": "skull", "obj": part}]})
        .to_string()
    };
    let centre = head.bounds().center();
    // Accepted (202), then failed in the background: the reason.
    let failed_with = async |id: &str, part: String| {
        let (status, body) = post(&server, "/v1/heads", register(id, part), "application/json").await;
        assert_eq!(status, 202, "{body}");
        failure(&server, id).await
    };
    // 4,352 + 700 x 3 = 6,452 vertices together: over, though each alone is under.
    let error = failed_with("many", small_part(centre, 700)).await;
    assert!(
        error.contains("parts/extra.obj brings the vertices to 6452; this server takes at most 6000"),
        "{error}"
    );
    // 8,652 + 3 + 3,400 triangles: over 12,000.
    let crowded = small_part(centre, 3) + &"f 1 2 3\n".repeat(3_400);
    let error = failed_with("crowded", crowded).await;
    assert!(error.contains("brings the triangles to 12055"), "{error}");
    // A part a million head units away is not part of this head (one 1e30 away is refused
    // by the OBJ reader: no coordinate past 1e15).
    let error = failed_with("far", small_part(Vec3::splat(1e6), 1)).await;
    assert!(error.contains("part \"extra\" lies"), "{error}");
    // Three heads (failed ones count: they hold their uploads) are the most; a fourth is
    // refused at once.
    let (status, body) = post(
        &server,
        "/v1/heads",
        register("fourth", small_part(centre, 1)),
        "application/json",
    )
    .await;
    assert_eq!(status, 429, "{body}");
    let body = body.to_string();
    assert!(
        body.contains("limit_reached") && body.contains("3 heads"),
        "{body}"
    );
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_fit_whose_request_ended_stops_and_holds_its_slot_until_then() {
    let mut config = memory_config();
    config.limits.max_registrations = 1;
    config.limits.request_timeout_s = 0.2;
    let server = Server::start(config).await;
    let request = json!({
        "id": "ict",
        "obj": std::fs::read_to_string(crate::common::data("heads/ict_head.obj")).unwrap(),
    })
    .to_string();
    let (status, body) = post(&server, "/v1/heads", request, "application/json").await;
    assert_eq!(status, 408, "{body}");
    // The request is over; its fit still holds the one slot until it has stopped, and it
    // stops within a step of its cancelling. It may have stopped already: the fit counts
    // its cancelling before it gives the slot back, so a free slot, read first, means the
    // count is there when read next.
    let busy = server.healthz().await["work"]["busy"].as_u64().unwrap();
    let stopped = server.metrics().await.contains("facewire_fits_cancelled_total 1");
    assert!(
        busy == 1 || stopped,
        "the slot was freed while the fit ran on (busy {busy})"
    );
    let started = Instant::now();
    while server.healthz().await["work"]["busy"].as_u64() != Some(0) {
        assert!(started.elapsed() < Duration::from_secs(10), "the fit ran on");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let metrics = server.metrics().await;
    assert!(metrics.contains("facewire_fits_cancelled_total 1"), "{metrics}");
    // A mesh built to be expensive is refused by the fit at once, the reason named.
    let spanning = obj_text(&spanning_triangles(&makehuman(), 100_000));
    let (status, body) = post(
        &server,
        "/v1/heads",
        json!({"id": "spanning", "obj": spanning}).to_string(),
        "application/json",
    )
    .await;
    assert_eq!(status, 400, "{body}");
    assert!(body.to_string().contains("head-sized images"), "{body}");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stream_runs_at_most_its_pipelines() {
    use crate::common::service::{close_code, connect, next_json};
    use facewire_proto::messages::ServerMessage;
    let mut config = memory_config();
    config.limits.max_pipelines_per_stream = 2;
    let server = Server::start(config).await;
    server.register("mh", "makehuman_head", "").await;
    let view = |query: &str| server.ws(&format!("/v1/heads/mh/streams/main/view?{query}"));
    let mut first = connect(&view("format=fwf1")).await;
    assert!(matches!(next_json(&mut first).await, ServerMessage::Snapshot(_)));
    let mut second = connect(&view("format=fwf2&heat=folds")).await;
    assert!(matches!(next_json(&mut second).await, ServerMessage::Snapshot(_)));
    // A third kind of frame would start a third pipeline: refused by name ...
    let mut third = connect(&view("format=json")).await;
    match next_json(&mut third).await {
        ServerMessage::Error { code, message, .. } => {
            assert_eq!(code.as_str(), "limit_reached");
            assert!(message.contains("runs 2 pipelines"), "{message}");
        }
        other => panic!("expected limit_reached, got {other:?}"),
    }
    assert_eq!(close_code(&mut third).await, 4503);
    // ... while a viewer of a running one joins it.
    let mut again = connect(&view("format=fwf1")).await;
    assert!(matches!(next_json(&mut again).await, ServerMessage::Snapshot(_)));
    server.stop().await;
}
