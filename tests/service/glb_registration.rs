//! A glTF avatar registered in one request: the skin, teeth (both rows in one mesh),
//! tongue and eyes found by their names, metres taken from the format, the fit found
//! automatically; and the refusals, each naming what is wrong.

use crate::common::glb::ict_avatar;
use crate::common::service::{memory_config, Server};

use facewire::server::config::Auth;
use facewire::server::Config;

use serde_json::Value;

async fn post_glb(server: &Server, query: &str, body: Vec<u8>) -> (u16, Value) {
    let response = reqwest::Client::new()
        .post(server.http(&format!("/v1/heads{query}")))
        .header("content-type", "model/gltf-binary")
        .body(body)
        .send()
        .await
        .unwrap();
    (response.status().as_u16(), response.json().await.unwrap())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_avatar_registers_in_one_request_with_its_parts() {
    let server = Server::start(memory_config()).await;
    let (status, body) = post_glb(&server, "?id=avatar", ict_avatar()).await;
    assert_eq!(status, 202, "{body}");
    assert_eq!(
        body["source"],
        serde_json::json!({
            "format": "glb",
            "skin": "Head",
            "parts": [
                {"name": "wolf3d_teeth", "mesh": "Wolf3D_Teeth"},
                {"name": "tongue", "mesh": "Tongue"},
                {"name": "eyeleft", "mesh": "EyeLeft"}
            ],
            "left_out": ["Eyelashes"]
        })
    );
    let info = server.wait_ready("avatar", "").await;
    // Metres, as glTF says: no guess from the pupils.
    assert_eq!(info.mm_per_unit, 1000.0);
    let roles: Vec<(&str, &str, Option<&str>)> = info
        .parts
        .iter()
        .map(|p| (p.name.as_str(), p.role.as_str(), p.split_from.as_deref()))
        .collect();
    assert_eq!(
        roles,
        [
            ("wolf3d_teeth_upper", "skull", Some("wolf3d_teeth")),
            ("wolf3d_teeth_lower", "jaw", Some("wolf3d_teeth")),
            ("tongue", "tongue", None)
        ]
    );
    // Both eyeballs of the one eye mesh, each turning about its own centre.
    let mut sides: Vec<&str> = info.eyes.iter().map(|e| e.side.as_str()).collect();
    sides.sort();
    assert_eq!(sides, ["left", "right"], "{:?}", info.eyes);
    // The automatic fit on the skin in metres: 1.86 mm from the surface on average (0.61 in
    // the head's own centimetres; docs/FITTING.md "Units").
    let fit = info.fit.expect("a fit summary");
    assert!(fit.surface_mean_mm < 2.0, "{fit:?}");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_avatar_s_skin_texture_becomes_the_head_s() {
    let server = Server::start(memory_config()).await;
    let png = crate::common::texture::solid_png(16, 16, [200, 120, 100]);
    let avatar = crate::common::glb::ict_avatar_textured(Some(("image/png".into(), png.clone())));
    let (status, body) = post_glb(&server, "?id=textured", avatar).await;
    assert_eq!(status, 202, "{body}");
    assert_eq!(
        body["source"]["texture"],
        "the skin's base colour image, image/png"
    );
    let info = server.wait_ready("textured", "").await;
    let texture = reqwest::get(server.http("/v1/heads/textured/texture"))
        .await
        .unwrap();
    assert_eq!(texture.bytes().await.unwrap().as_ref(), png.as_slice());
    let uv = reqwest::get(server.http("/v1/heads/textured/uv.bin"))
        .await
        .unwrap();
    let uv = facewire_proto::texture_coords::TextureCoords::decode(&uv.bytes().await.unwrap()).unwrap();
    // A coordinate per vertex of the file's skin, every corner of the rest mesh one of them,
    // in the image (glTF's v down turned up).
    assert_eq!(uv.coords.len() as u32, info.vertices);
    assert_eq!(uv.corners.len() as u32, info.triangles);
    assert!(uv.coords.iter().flatten().all(|c| (0.0..=1.0).contains(c)));

    // An image the page cannot draw is left out, and the answer says so.
    let webp = crate::common::glb::ict_avatar_textured(Some((
        "image/webp".into(),
        b"RIFF\0\0\0\0WEBPVP8 ".to_vec(),
    )));
    let (status, body) = post_glb(&server, "?id=webp", webp).await;
    assert_eq!(status, 202, "{body}");
    let note = body["source"]["texture"].as_str().unwrap();
    assert!(
        note.contains("(image/webp) is left out") && note.contains("not a PNG or JPEG"),
        "{note}"
    );
    server.wait_ready("webp", "").await;
    let texture = reqwest::get(server.http("/v1/heads/webp/texture")).await.unwrap();
    assert_eq!(texture.status(), 404);

    // An image in a file beside the .glb cannot come with it: left out, and said so.
    let beside = crate::common::glb::ict_avatar_textured(Some((
        format!("{}textures/face_diffuse.png", crate::common::glb::URI_IMAGE),
        Vec::new(),
    )));
    let (status, body) = post_glb(&server, "?id=beside", beside).await;
    assert_eq!(status, 202, "{body}");
    let note = body["source"]["texture"].as_str().unwrap();
    assert!(
        note.contains("is left out")
            && note.contains("\"textures/face_diffuse.png\"")
            && note.contains("pack"),
        "{note}"
    );
    server.wait_ready("beside", "").await;
    let texture = reqwest::get(server.http("/v1/heads/beside/texture"))
        .await
        .unwrap();
    assert_eq!(texture.status(), 404);
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_glb_registration_is_refused_with_what_is_wrong() {
    let server = Server::start(memory_config()).await;
    let refused = |(status, body): (u16, Value)| {
        (
            status,
            body["error"].as_str().unwrap().to_string(),
            body["message"].as_str().unwrap().to_string(),
        )
    };

    let (status, code, message) = refused(post_glb(&server, "", ict_avatar()).await);
    assert_eq!((status, code.as_str()), (400, "bad_request"));
    assert!(message.contains("names its head with `?id=`"), "{message}");

    let (status, code, message) = refused(post_glb(&server, "?id=x", b"v 0 0 0\nf 1 1 1\n".to_vec()).await);
    assert_eq!((status, code.as_str()), (400, "bad_head"));
    assert!(
        message.starts_with(
            "glTF file: not a glTF binary file the reader can use: it does not start with `glTF`"
        ),
        "{message}"
    );

    let (status, code, message) = refused(post_glb(&server, "?id=x&roles=Hat%3Dnone", ict_avatar()).await);
    assert_eq!((status, code.as_str()), (400, "bad_head"));
    assert!(message.contains("a role is given for \"Hat\""), "{message}");

    let (status, code, message) = refused(post_glb(&server, "?id=x&roles=Head%3Dhat", ict_avatar()).await);
    assert_eq!((status, code.as_str()), (400, "bad_request"));
    assert!(message.contains("mesh role \"hat\""), "{message}");

    let (status, code, message) = refused(post_glb(&server, "?id=x&colour=red", ict_avatar()).await);
    assert_eq!((status, code.as_str()), (400, "bad_request"));
    assert!(message.contains("unknown field `colour`"), "{message}");

    // A JSON registration keeps its id in its body.
    let response = reqwest::Client::new()
        .post(server.http("/v1/heads?id=x"))
        .json(&serde_json::json!({"id": "x", "obj": "v 0 0 0\n"}))
        .send()
        .await
        .unwrap();
    assert_eq!(response.status().as_u16(), 400);
    let body: Value = response.json().await.unwrap();
    assert!(
        body["message"]
            .as_str()
            .unwrap()
            .contains("are for glTF registrations"),
        "{body}"
    );
    let heads: Vec<Value> = reqwest::get(server.http("/v1/heads"))
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert!(heads.is_empty(), "{heads:?}");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_avatar_takes_its_own_producer_token_from_a_header() {
    let server = Server::start(Config {
        auth: Auth {
            producer_token: Some("producer".into()),
            viewer_token: None,
            admin_token: Some("admin".into()),
        },
        ..memory_config()
    })
    .await;
    let response = reqwest::Client::new()
        .post(server.http("/v1/heads?id=avatar&token=admin"))
        .header("content-type", "model/gltf-binary")
        .header("x-facewire-producer-token", "mine")
        .body(ict_avatar())
        .send()
        .await
        .unwrap();
    assert_eq!(
        response.status().as_u16(),
        202,
        "{}",
        response.text().await.unwrap()
    );
    server.wait_ready("avatar", "?token=admin").await;
    // The head's own token lets its producer in; the server-wide one no longer does.
    let end_producer = |token: &str| {
        reqwest::Client::new()
            .delete(server.http(&format!("/v1/heads/avatar/streams/s/producer?token={token}")))
            .send()
    };
    assert_ne!(end_producer("mine").await.unwrap().status().as_u16(), 401);
    assert_eq!(end_producer("producer").await.unwrap().status().as_u16(), 401);
    server.stop().await;
}

/// The served pose of `head` for one ARKit frame (on a stream of its own), beside its
/// rest mesh: (rest, posed), metres, flattened.
async fn arkit_pose(server: &Server, head: &str, arkit: &str) -> (Vec<f32>, Vec<f32>) {
    use crate::common::service::{connect, next_frame};
    use futures_util::SinkExt;
    use tokio_tungstenite::tungstenite::Message;
    let bytes = reqwest::get(server.http(&format!("/v1/heads/{head}/mesh.bin")))
        .await
        .unwrap()
        .bytes()
        .await
        .unwrap();
    let rest = facewire_proto::mesh::RestMesh::decode(&bytes).unwrap();
    let rest: Vec<f32> = rest.positions.iter().flatten().copied().collect();
    let stream = arkit
        .to_ascii_lowercase()
        .replace(|c: char| !c.is_ascii_alphanumeric(), "");
    let mut viewer = connect(&server.ws(&format!("/v1/heads/{head}/streams/{stream}/view"))).await;
    let mut producer = connect(&server.ws(&format!("/v1/heads/{head}/streams/{stream}/produce"))).await;
    let line = format!(r#"{{"seq":0,"t":0,"arkit":{arkit}}}"#);
    producer.send(Message::Text(line.into())).await.unwrap();
    let frame = next_frame(&mut viewer).await;
    let mut posed = Vec::new();
    frame.apply(&rest, &mut posed);
    (rest, posed)
}

/// How far `posed` is from `rest` moved by the ICT target `name` (centimetres in the
/// file, metres on the server), over the vertices the target moves more than 0.1 mm:
/// (RMS, median), mm. The largest errors of any basis are inside the mouth socket, which
/// the model's jawOpen moves 32 mm and the mask does not reach; the median reads the face.
fn target_error_mm(rest: &[f32], posed: &[f32], name: &str) -> (f32, f32) {
    let target = crate::common::glb::ict_targets()
        .into_iter()
        .find(|t| t.name == name)
        .unwrap();
    assert_eq!(
        rest.len(),
        3 * target.displacements.len(),
        "the skin kept its vertices"
    );
    let mut errors: Vec<f32> = (0..target.displacements.len())
        .filter(|&v| target.displacements[v].length() * 10.0 > 0.1)
        .map(|v| {
            let expected = glam::Vec3::from_slice(&rest[3 * v..]) + target.displacements[v] * 0.01;
            (glam::Vec3::from_slice(&posed[3 * v..]) - expected).length() * 1e3
        })
        .collect();
    errors.sort_by(f32::total_cmp);
    let rms = (errors.iter().map(|e| e * e).sum::<f32>() / errors.len() as f32).sqrt();
    (rms, errors[errors.len() / 2])
}

/// An avatar's ARKit-named morph targets are kept with it: listed at registration and in
/// head info, they drive ARKit streams on it (its own retarget basis, derived from its
/// targets and its fit, completed by the shipped basis), and they survive a restart.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_avatar_s_arkit_targets_drive_its_arkit_streams() {
    use crate::common::glb::ict_avatar_with_targets;
    let dir = tempfile::tempdir().unwrap();
    let config = || Config {
        data_dir: Some(dir.path().to_path_buf()),
        ..Config::default()
    };
    let server = Server::start(config()).await;
    let (status, body) = post_glb(&server, "?id=talker", ict_avatar_with_targets()).await;
    assert_eq!(status, 202, "{body}");
    // The ICT model's 53 targets make 51 ARKit blendshapes (its brows' inner raise and its
    // cheeks' puff come in halves, summed; it has no tongueOut); `smile` is no ARKit name.
    let taken = body["source"]["arkit_targets"].as_array().unwrap();
    assert_eq!(taken.len(), 51, "{body}");
    assert_eq!(
        taken[0],
        serde_json::json!({"blendshape": "eyeBlinkLeft", "from": ["eyeBlink_L"]})
    );
    assert!(taken.contains(
        &serde_json::json!({"blendshape": "browInnerUp", "from": ["browInnerUp_L", "browInnerUp_R"]})
    ));
    assert_eq!(
        body["source"]["targets_left_out"],
        serde_json::json!([{"name": "smile", "why": "not named like an ARKit blendshape"}])
    );
    let (status, body) = post_glb(&server, "?id=plain", ict_avatar()).await;
    assert_eq!(status, 202, "{body}");
    assert!(body["source"].get("arkit_targets").is_none(), "{body}");
    let info = server.wait_ready("talker", "").await;
    assert_eq!(info.arkit_blendshapes.len(), 51);
    assert_eq!(info.arkit_blendshapes[0], "eyeBlinkLeft");
    assert!(!info.arkit_blendshapes.iter().any(|n| n == "tongueOut"));
    assert!(server.wait_ready("plain", "").await.arkit_blendshapes.is_empty());

    // jawOpen at full weight, against the model's own jawOpen: through the head's own
    // basis, and through the shipped one (made from another head's artist's jawOpen).
    let jaw = r#"{"jawOpen":1}"#;
    let mut own_jaw = Vec::new();
    for (arkit, target) in [(jaw, "jawOpen"), (r#"{"mouthSmileLeft":1}"#, "mouthSmile_L")] {
        let (rest, own) = arkit_pose(&server, "talker", arkit).await;
        let own_mm = target_error_mm(&rest, &own, target);
        let (rest, shipped) = arkit_pose(&server, "plain", arkit).await;
        let shipped_mm = target_error_mm(&rest, &shipped, target);
        eprintln!(
            "ICT avatar, {target} from the model's own: RMS {:.2} mm, median {:.2} mm with its own \
             targets; {:.2}, {:.2} mm with the shipped basis",
            own_mm.0, own_mm.1, shipped_mm.0, shipped_mm.1
        );
        assert!(own_mm.0 < shipped_mm.0, "{own_mm:?} vs {shipped_mm:?}");
        assert!(own_mm.1 < 0.7 * shipped_mm.1, "{own_mm:?} vs {shipped_mm:?}");
        if arkit == jaw {
            own_jaw = own;
        }
    }
    server.stop().await;

    // After a restart: the same blendshapes, the same pose.
    let server = Server::start(config()).await;
    let info = server.wait_ready("talker", "").await;
    assert_eq!(info.arkit_blendshapes.len(), 51);
    let (_, again) = arkit_pose(&server, "talker", jaw).await;
    assert_eq!(again, own_jaw);
    server.stop().await;
}
