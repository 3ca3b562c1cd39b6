//! Parts of a head (teeth, gums, tongue): roles given or inferred, registered over HTTP,
//! served as meshes (and which of the tongue part's vertices are the tongue), listed in
//! head info and the snapshot, stored and reloaded, placed on the wire by the jaw's motion.

use crate::common::service::{connect, ict_parts, ict_request, next_frame, next_json, Server};
use crate::common::{data, ict_head, register};

use facewire::animate::{jaw_motion, AnimatedHead, PartInput};
use facewire::head::{Head, PartRole};
use facewire::server::Config;
use facewire_proto::mesh::RestMesh;
use facewire_proto::messages::{HeadInfo, ServerMessage};
use facewire_proto::vertex_weights::VertexWeights;
use futures_util::SinkExt;
use glam::{Quat, Vec3};
use serde_json::{json, Value};
use tokio_tungstenite::tungstenite::Message;

#[test]
fn a_head_has_at_most_one_tongue() {
    let tongue = |name: &str| PartInput {
        name: name.into(),
        role: Some(PartRole::Tongue),
        mesh: Head::load(&data("heads/ict_head_gums_lower_tongue.obj")).unwrap(),
    };
    let error = AnimatedHead::with_parts(register("ict_head"), vec![tongue("a"), tongue("b")])
        .err()
        .unwrap();
    assert_eq!(
        error.to_string(),
        "parts \"a\" and \"b\" are both tongues; a head has at most one"
    );
}

#[test]
fn teeth_and_gums_find_their_roles_by_the_mouth_line() {
    let head = ict_head();
    let roles: Vec<PartRole> = head.parts.iter().map(|p| p.role).collect();
    assert_eq!(
        roles,
        [PartRole::Skull, PartRole::Jaw, PartRole::Skull, PartRole::Tongue]
    );
    assert!(head.has_jaw_parts());
}

async fn post(server: &Server, body: &Value) -> (u16, Value) {
    let response = reqwest::Client::new()
        .post(server.http("/v1/heads"))
        .json(body)
        .send()
        .await
        .unwrap();
    (response.status().as_u16(), response.json().await.unwrap())
}

fn roles(info: &HeadInfo) -> Vec<(String, String)> {
    info.parts
        .iter()
        .map(|p| (p.name.clone(), p.role.clone()))
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn parts_register_serve_travel_and_survive_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    let config = || Config {
        data_dir: Some(dir.path().to_path_buf()),
        ..Config::default()
    };
    let server = Server::start(config()).await;

    // Refusals name the part.
    let mut bad_role = ict_parts();
    bad_role[1]["role"] = json!("incisors");
    let (status, body) = post(&server, &ict_request("bad", bad_role)).await;
    assert_eq!(
        (status, body["error"].as_str()),
        (400, Some("bad_request")),
        "{body}"
    );
    assert!(
        body["message"].as_str().unwrap().contains("teeth_lower"),
        "{body}"
    );
    let mut bad_name = ict_parts();
    bad_name[0]["name"] = json!("Upper Teeth");
    let (status, body) = post(&server, &ict_request("bad", bad_name)).await;
    assert_eq!((status, body["error"].as_str()), (400, Some("bad_id")), "{body}");
    let nine: Vec<Value> = (0..9)
        .map(|i| json!({"name": format!("p{i}"), "obj": "v 0 0 0\n"}))
        .collect();
    let (status, body) = post(&server, &ict_request("bad", json!(nine))).await;
    assert_eq!(status, 400, "{body}");
    assert!(body["message"].as_str().unwrap().contains("at most 8"), "{body}");

    let (status, body) = post(&server, &ict_request("ict", ict_parts())).await;
    assert_eq!(status, 202, "{body}");
    let info = server.wait_ready("ict", "").await;
    let expected_roles: Vec<(String, String)> = [
        ("teeth_upper", "skull"),
        ("teeth_lower", "jaw"),
        ("gums_upper", "skull"),
        ("gums_lower_tongue", "tongue"),
    ]
    .map(|(n, r)| (n.to_string(), r.to_string()))
    .to_vec();
    assert_eq!(roles(&info), expected_roles);
    // Head info says how well the fit lays the mask on the head, as `facewire fit` does.
    let reg = register("ict_head");
    let residuals = facewire::fit::residuals::measure(
        &reg.head,
        &reg.fitted.neutral,
        &reg.fitted.mask.used_vertices(),
        &[],
        reg.mm_per_unit(),
    );
    let fit = info.fit.expect("a fit summary");
    assert_eq!(fit.surface_mean_mm, residuals.surface.mean_mm);
    assert_eq!(fit.surface_max_mm, residuals.surface.max_mm);
    assert!((1.4..1.6).contains(&fit.surface_mean_mm), "{fit:?}");

    // Each part's mesh, as listed.
    for part in &info.parts {
        let bytes = reqwest::get(server.http(&part.mesh))
            .await
            .unwrap()
            .bytes()
            .await
            .unwrap();
        let mesh = RestMesh::decode(&bytes).unwrap();
        assert_eq!(mesh.positions.len() as u32, part.vertices, "{}", part.name);
        assert_eq!(mesh.triangles.len() as u32, part.triangles, "{}", part.name);
    }
    // The eyes part, split one a side, listed apart from the parts, each mesh served.
    let eyes: Vec<(&str, &str, u32)> = info
        .eyes
        .iter()
        .map(|e| (e.name.as_str(), e.side.as_str(), e.vertices))
        .collect();
    assert_eq!(eyes, [("eyes_left", "left", 1570), ("eyes_right", "right", 1570)]);
    for eye in &info.eyes {
        let bytes = reqwest::get(server.http(&eye.mesh))
            .await
            .unwrap()
            .bytes()
            .await
            .unwrap();
        let mesh = RestMesh::decode(&bytes).unwrap();
        assert_eq!(mesh.positions.len() as u32, eye.vertices, "{}", eye.name);
        assert_eq!(eye.split_from.as_deref(), Some("eyes"));
        // 6 mm and 2 mm in this head's centimetres.
        assert!((eye.iris_radius - 0.6).abs() < 1e-6 && (eye.pupil_radius - 0.2).abs() < 1e-6);
    }
    let missing = reqwest::get(server.http("/v1/heads/ict/parts/molars/mesh.bin"))
        .await
        .unwrap();
    assert_eq!(missing.status(), 404);
    // The tongue part says which of its vertices are the tongue itself: as the library's
    // tongue shaper has them; no other part has such weights.
    let tongue_bins: Vec<(&str, &str)> = info
        .parts
        .iter()
        .filter_map(|p| Some((p.name.as_str(), p.tongue_proper.as_deref()?)))
        .collect();
    assert_eq!(
        tongue_bins,
        [(
            "gums_lower_tongue",
            "/v1/heads/ict/parts/gums_lower_tongue/tongue.bin"
        )]
    );
    let bytes = reqwest::get(server.http(tongue_bins[0].1))
        .await
        .unwrap()
        .bytes()
        .await
        .unwrap();
    let weights = VertexWeights::decode(&bytes).unwrap().weights;
    let animated = ict_head();
    let (_, shaper) = animated.tongue.as_ref().expect("the ICT head has a tongue");
    let expected: Vec<u8> = shaper
        .free_vertices()
        .iter()
        .map(|&f| if f { 255 } else { 0 })
        .collect();
    assert_eq!(weights, expected);
    let tongue = weights.iter().filter(|&&w| w == 255).count();
    assert!(
        tongue > 100 && tongue < weights.len() - 100,
        "{tongue} of {} vertices the tongue itself: the part also holds the lower gums",
        weights.len()
    );
    let not_a_tongue = reqwest::get(server.http("/v1/heads/ict/parts/teeth_upper/tongue.bin"))
        .await
        .unwrap();
    assert_eq!(not_a_tongue.status(), 404);

    // The snapshot lists them; a jaw drop's frame carries the jaw's motion.
    let mut viewer = connect(&server.ws("/v1/heads/ict/streams/main/view?format=fwf2")).await;
    match next_json(&mut viewer).await {
        ServerMessage::Snapshot(snapshot) => {
            assert_eq!(snapshot.parts, info.parts);
            assert_eq!(snapshot.eyes, info.eyes);
            assert_eq!(snapshot.format.as_deref(), Some("fwf2"));
            assert!(snapshot
                .sections
                .iter()
                .any(|s| (s.kind, s.name.as_str()) == (9, "eye_motion")));
        }
        other => panic!("{other:?}"),
    }
    let mut producer = connect(&server.ws("/v1/heads/ict/streams/main/produce")).await;
    let line = r#"{"seq":0,"t":0,"au":{"jaw_drop":0.6}}"#;
    producer.send(Message::Text(line.into())).await.unwrap();
    let frame = next_frame(&mut viewer).await;
    let reg = register("ict_head");
    let mut weights = vec![0.0; 65];
    weights[1] = 0.6;
    let mask_now = crate::common::posed(&reg, &weights);
    let jaw = jaw_motion(reg.mask_rest(), &mask_now, &reg.fitted.fit.pose);
    let sent = Quat::from_array(frame.jaw.rotation);
    assert!(sent.abs_diff_eq(jaw.rotation, 1e-6), "{sent} vs {jaw:?}");
    assert!(Vec3::from_array(frame.jaw.translation).abs_diff_eq(jaw.translation, 1e-4));
    let degrees = sent.angle_between(Quat::IDENTITY).to_degrees();
    eprintln!("jaw_drop 0.6 opens the ICT jaw {degrees:.1} degrees");
    assert!((3.0..30.0).contains(&degrees), "{degrees}");
    assert_eq!(frame.layout, facewire_proto::viewer_frame::FrameLayout::Fwf2);
    assert!(frame.parts.is_empty(), "a tongue at rest sends no deltas");
    assert!(frame.eyes.is_empty(), "eyes looking ahead send no motion");

    // A raised tongue tip travels as the tongue part's deltas, as the library shapes it.
    let line = r#"{"seq":1,"t":0.1,"fap":{"raise_tongue_tip":800}}"#;
    producer.send(Message::Text(line.into())).await.unwrap();
    let frame = next_frame(&mut viewer).await;
    let tongue = frame.part(3).expect("tongue deltas");
    assert_eq!(frame.parts.len(), 1);
    assert_eq!(usize::from(tongue.part), 3);
    assert_eq!(tongue.vertex_count, 2409);
    let head = ict_head();
    let (_, shaper) = head.tongue.as_ref().unwrap();
    let mut expected = vec![Vec3::ZERO; shaper.vertex_count()];
    shaper.shape(
        &facewire::stream::Frame {
            faps: vec![(44, 800.0)],
            ..Default::default()
        },
        &mut expected,
    );
    // ... and as the contact constraint then keeps it out of the teeth (the jaw at rest).
    let contact = head.contact.as_ref().expect("the ICT head has teeth");
    let mut skin = head.registration.head.positions.clone();
    let mut scratch = contact.scratch(skin.len(), expected.len());
    let pushed = contact.apply(
        &mut skin,
        glam::Affine3A::IDENTITY,
        Some(&mut expected),
        &mut scratch,
    );
    eprintln!(
        "the raised tip: {} tongue vertices pushed out of the teeth",
        pushed.tongue_pushed
    );
    let mut sent = vec![Vec3::ZERO; expected.len()];
    for &(v, counts) in &tongue.moved {
        sent[v as usize] = Vec3::from_array(counts.map(|c| c as f32)) * frame.step;
    }
    let worst = sent
        .iter()
        .zip(&expected)
        .map(|(a, b)| (*a - *b).abs().max_element())
        .fold(0.0f32, f32::max);
    assert!(
        worst <= 0.5 * frame.step * 1.001,
        "{worst} vs step {}",
        frame.step
    );
    let highest = expected.iter().map(|d| d.y).fold(0.0f32, f32::max) * head.registration.mm_per_unit();
    assert!(highest > 10.0, "the tip rose {highest} mm");
    assert!(
        tongue.moved.len() > 100,
        "{} tongue vertices moved",
        tongue.moved.len()
    );
    // The left eye looks 20 degrees to the face's left: its motion, and only its, travels.
    let line = r#"{"seq":2,"t":0.2,"fap":{"yaw_l_eyeball":34907}}"#;
    producer.send(Message::Text(line.into())).await.unwrap();
    let frame = next_frame(&mut viewer).await;
    assert_eq!(frame.eyes.len(), 1, "{:?}", frame.eyes);
    let eye = &info.eyes[0];
    assert_eq!(frame.eyes[0].eye, 0);
    let motion = frame.eyes[0].motion;
    let centre = Vec3::from_array(eye.centre);
    let forward = Vec3::from_array(eye.forward);
    let turned = Quat::from_array(motion.rotation) * forward;
    assert!((turned.angle_between(forward).to_degrees() - 20.0).abs() < 0.01);
    assert!(turned.x > forward.x);
    let moved_centre = Quat::from_array(motion.rotation) * centre + Vec3::from_array(motion.translation);
    assert!(moved_centre.distance(centre) < 1e-4, "{moved_centre} vs {centre}");
    drop((viewer, producer));
    server.stop().await;

    // Stored and registered again, roles and all.
    let server = Server::start(config()).await;
    let info = server.wait_ready("ict", "").await;
    assert_eq!(roles(&info), expected_roles);
    assert_eq!(info.eyes.len(), 2);
    server.stop().await;
}

#[test]
fn facewire_deform_writes_the_parts_where_the_jaw_puts_them() {
    let scratch = tempfile::tempdir().unwrap();
    let stream = scratch.path().join("open.jsonl");
    std::fs::write(
        &stream,
        "{\"seq\":0,\"t\":0,\"au\":{\"jaw_drop\":0.6},\"head_rotation_rad\":[0,0.2,0]}\n",
    )
    .unwrap();
    let out = scratch.path().join("out");
    let (upper, lower) = (
        data("heads/ict_head_teeth_upper.obj"),
        data("heads/ict_head_teeth_lower.obj"),
    );
    let part = std::ffi::OsStr::new("--part");
    let eyes = format!("eyes:{}", data("heads/ict_head_eyes.obj").display());
    let run = crate::common::facewire_deform(
        "ict_head",
        &stream,
        &out,
        &[
            part,
            upper.as_os_str(),
            part,
            lower.as_os_str(),
            part,
            eyes.as_ref(),
        ],
    );
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(
        stderr.contains("part ict_head_eyes_left: 1570 vertices, the left eye, turns about its centre"),
        "{stderr}"
    );
    assert!(
        stderr.contains("part ict_head_teeth_lower: 2204 vertices, moves with the jaw"),
        "{stderr}"
    );
    let written = std::fs::read_to_string(out.join("frame_00000.obj")).unwrap();
    assert!(written.contains("\no ict_head_teeth_upper\n") && written.contains("\no ict_head_teeth_lower\n"));
    assert!(written.contains("\no ict_head_eyes_left\n") && written.contains("\no ict_head_eyes_right\n"));
    let positions: Vec<Vec3> = crate::common::obj_positions(&out.join("frame_00000.obj"))
        .into_iter()
        .map(Vec3::from_array)
        .collect();
    let reg = register("ict_head");
    let upper = Head::load(&data("heads/ict_head_teeth_upper.obj")).unwrap();
    let lower = Head::load(&data("heads/ict_head_teeth_lower.obj")).unwrap();
    let n = reg.vertex_count();
    // Then the two eyeballs, 1,570 vertices each.
    assert_eq!(
        positions.len(),
        n + upper.positions.len() + lower.positions.len() + 2 * 1570
    );
    // The upper teeth turn with the head; the lower ones open with the jaw first.
    let frame = facewire::stream::Frame {
        head_rotation_rad: Some([0.0, 0.2, 0.0]),
        ..Default::default()
    };
    let head = facewire::animate::head_motion(&frame, &reg.fitted.fit.pose);
    let mut weights = vec![0.0; 65];
    weights[1] = 0.6;
    let jaw = jaw_motion(
        reg.mask_rest(),
        &crate::common::posed(&reg, &weights),
        &reg.fitted.fit.pose,
    );
    let mm = reg.mm_per_unit();
    for (p, rest) in positions[n..].iter().zip(&upper.positions) {
        assert!(
            p.distance(head.apply(*rest)) * mm < 1e-3,
            "{p} vs {}",
            head.apply(*rest)
        );
    }
    for (p, rest) in positions[n + upper.positions.len()..]
        .iter()
        .zip(&lower.positions)
    {
        let expected = head.apply(jaw.apply(*rest));
        assert!(p.distance(expected) * mm < 1e-3, "{p} vs {expected}");
    }
}
