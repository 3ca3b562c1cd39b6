//! A head's texture through real sockets: registered with its OBJ's texture coordinates
//! and its image, named by the snapshot, its coordinates served as `uv.bin` (one per
//! triangle corner, as the OBJ gave them) and its image as it came, both kept across a
//! restart; a texture that is not an image is refused by name, and one given with an OBJ
//! without texture coordinates is not drawn, with a warning that says why.

use crate::common::service::{connect, next_json, post, Server};
use crate::common::texture::{solid_png, textured_makehuman_obj, textured_request};
use crate::common::{data, obj_positions};

use facewire::server::config::Config;
use facewire_proto::messages::{HeadInfo, ServerMessage};
use facewire_proto::texture_coords::TextureCoords;

async fn get(server: &Server, path: &str) -> (u16, String, Vec<u8>) {
    let response = reqwest::get(server.http(path)).await.unwrap();
    let status = response.status().as_u16();
    let content_type = response
        .headers()
        .get("content-type")
        .map(|v| v.to_str().unwrap().to_string())
        .unwrap_or_default();
    (status, content_type, response.bytes().await.unwrap().to_vec())
}

/// The texture the snapshot of head `id` names, or `None`.
async fn snapshot_texture(server: &Server, id: &str) -> Option<(String, String)> {
    let mut viewer = connect(&server.ws(&format!("/v1/heads/{id}/streams/main/view?format=fwf2"))).await;
    match next_json(&mut viewer).await {
        ServerMessage::Snapshot(snapshot) => snapshot.texture.map(|t| (t.uv, t.image)),
        other => panic!("expected the snapshot, got {other:?}"),
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_head_s_texture_is_served_with_its_coordinates_and_kept() {
    let dir = tempfile::tempdir().unwrap();
    let config = Config {
        data_dir: Some(dir.path().to_path_buf()),
        ..Config::default()
    };
    let server = Server::start(config.clone()).await;
    let png = solid_png(64, 32, [20, 200, 40]);
    let (status, body) = post(
        &server,
        "/v1/heads",
        textured_request("tex", &png).to_string(),
        "application/json",
    )
    .await;
    assert_eq!(status, 202, "{body}");
    let info = server.wait_ready("tex", "").await;
    assert!(info.fit.unwrap().warnings.iter().all(|w| !w.contains("texture")));

    let (uv_path, image_path) = snapshot_texture(&server, "tex")
        .await
        .expect("the snapshot names the texture");
    assert_eq!(
        (uv_path.as_str(), image_path.as_str()),
        ("/v1/heads/tex/uv.bin", "/v1/heads/tex/texture")
    );
    let (status, _, bytes) = get(&server, &uv_path).await;
    assert_eq!(status, 200);
    let uv = TextureCoords::decode(&bytes).unwrap();
    // One coordinate per vertex, each triangle's corners those of its vertices, as written.
    let positions = obj_positions(&data("heads/makehuman_head.obj"));
    assert_eq!(uv.coords.len(), positions.len());
    let mesh = facewire::head::obj::parse(&textured_makehuman_obj()).unwrap();
    assert_eq!(uv.corners, mesh.triangles);
    assert!(uv.coords.iter().flatten().all(|c| (0.0..=1.0).contains(c)));
    let (status, content_type, image) = get(&server, &image_path).await;
    assert_eq!((status, content_type.as_str()), (200, "image/png"));
    assert_eq!(image, png);

    // Not an image: refused, saying what it is not.
    let mut request = textured_request("bad", &png);
    request["texture"] = serde_json::json!("R0lGODlhAQABAAAAACw=");
    let (status, body) = post(&server, "/v1/heads", request.to_string(), "application/json").await;
    assert_eq!(status, 400, "{body}");
    assert!(
        body["message"].as_str().unwrap().contains("not a PNG or JPEG"),
        "{body}"
    );
    // An OBJ without texture coordinates: registered, not textured, and told why.
    let mut request = textured_request("plain", &png);
    request["obj"] = serde_json::json!(std::fs::read_to_string(data("heads/makehuman_head.obj")).unwrap());
    let (status, body) = post(&server, "/v1/heads", request.to_string(), "application/json").await;
    assert_eq!(status, 202, "{body}");
    let info: HeadInfo = server.wait_ready("plain", "").await;
    let warnings = info.fit.unwrap().warnings;
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("no texture coordinates on every face")),
        "{warnings:?}"
    );
    assert_eq!(snapshot_texture(&server, "plain").await, None);
    assert_eq!(get(&server, "/v1/heads/plain/uv.bin").await.0, 404);
    server.stop().await;

    // Kept across a restart.
    let server = Server::start(config).await;
    server.wait_ready("tex", "").await;
    assert!(snapshot_texture(&server, "tex").await.is_some());
    assert_eq!(get(&server, "/v1/heads/tex/texture").await.2, png);
    assert_eq!(
        TextureCoords::decode(&get(&server, "/v1/heads/tex/uv.bin").await.2).unwrap(),
        uv
    );
    server.stop().await;
}
