//! glTF avatars: a `.glb` written from the shipped ICT head and its parts (in metres,
//! Z-up under a root node, the skin split over two materials with seams repeated, a
//! morph target, a skin) reads back as the same head, welded, with its parts told apart;
//! files that lie about their sizes are refused by name.

use facewire::head::{glb_head, read_glb, GlbError, Head, MeshRole, PartRole};
use glam::{Mat4, Vec3};

use crate::common::data;
use crate::common::glb::{pack, scaled_turn_about_x, write_glb, GlbMeshSpec, GlbPrimitive, GlbSkin};

/// Head units (cm) to metres.
const METRES_PER_CM: f32 = 0.01;

/// `triangles` of `positions` as one primitive with its own vertices (each shared vertex
/// repeated, as exporters repeat them at material borders), every `seam_every`-th
/// triangle's corners repeated again as at a UV seam. Returns the primitive and, per
/// file vertex, the head vertex it came from.
fn primitive(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    material: &str,
    seam_every: usize,
) -> (GlbPrimitive, Vec<u32>) {
    let mut source: Vec<u32> = Vec::new();
    let mut index_of = std::collections::HashMap::new();
    let mut indices = Vec::new();
    for (k, t) in triangles.iter().enumerate() {
        for &v in t {
            let seam = seam_every > 0 && k % seam_every == 0;
            let i = match (seam, index_of.get(&v)) {
                (false, Some(&i)) => i,
                _ => {
                    source.push(v);
                    let i = source.len() as u32 - 1;
                    if !seam {
                        index_of.insert(v, i);
                    }
                    i
                }
            };
            indices.push(i);
        }
    }
    let placed = source
        .iter()
        .map(|&v| to_file(positions[v as usize]).to_array())
        .collect();
    let primitive = GlbPrimitive {
        material: material.to_string(),
        positions: placed,
        indices,
        targets: Vec::new(),
        joints: None,
        texcoords: None,
        base_colour: None,
    };
    (primitive, source)
}

/// The file's frame: Z-up, the root node turns it back to +y up and scales cm to metres.
fn root() -> Mat4 {
    Mat4::from_cols_array(&scaled_turn_about_x(METRES_PER_CM, -90.0))
}

fn to_file(head_cm: Vec3) -> Vec3 {
    Mat4::from_rotation_x(90f32.to_radians()).transform_point3(head_cm)
}

fn mesh(name: &str, primitives: Vec<GlbPrimitive>) -> GlbMeshSpec {
    GlbMeshSpec {
        name: name.to_string(),
        matrix: None,
        primitives,
        target_names: Vec::new(),
    }
}

fn whole(name: &str, head: &Head) -> GlbMeshSpec {
    mesh(name, vec![primitive(&head.positions, &head.triangles, name, 0).0])
}

#[test]
fn an_avatar_file_reads_back_as_the_head_and_parts_it_was_written_from() {
    let skin = Head::load(&data("heads/ict_head.obj")).unwrap();
    let half = skin.triangles.len() / 2;
    let (mut face, face_source) = primitive(&skin.positions, &skin.triangles[..half], "Skin", 7);
    let (lips, lips_source) = primitive(&skin.positions, &skin.triangles[half..], "Lips", 0);
    // A morph target moving every vertex 1 cm along the file's +y (the head's -z).
    face.targets = vec![vec![[0.0, 1.0, 0.0]; face.positions.len()]];
    let mut lips = lips;
    lips.targets = vec![vec![[0.0, 1.0, 0.0]; lips.positions.len()]];
    let mut head_mesh = mesh("Head", vec![face, lips]);
    head_mesh.target_names = vec!["jawForward".into()];
    let part = |file: &str| Head::load(&data(&format!("heads/{file}"))).unwrap();
    let teeth_upper = part("ict_head_teeth_upper.obj");
    let teeth_lower = part("ict_head_teeth_lower.obj");
    let rows = teeth_upper.positions.len() as u32;
    let both_rows: Vec<[u32; 3]> = teeth_upper
        .triangles
        .iter()
        .copied()
        .chain(teeth_lower.triangles.iter().map(|t| t.map(|v| v + rows)))
        .collect();
    let teeth_positions: Vec<Vec3> = teeth_upper
        .positions
        .iter()
        .chain(&teeth_lower.positions)
        .copied()
        .collect();
    let teeth = Head::new("teeth", teeth_positions, both_rows);
    let lash = Head::new("lash", vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
    let bytes = write_glb(
        &[
            head_mesh,
            whole("Teeth", &teeth),
            whole("Tongue", &part("ict_head_gums_lower_tongue.obj")),
            whole("Eyes", &part("ict_head_eyes.obj")),
            whole("Eyelashes", &lash),
        ],
        root().to_cols_array(),
        None,
    );

    let meshes = read_glb(&bytes).unwrap();
    let names: Vec<&str> = meshes.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["Head", "Teeth", "Tongue", "Eyes", "Eyelashes"]);
    let read = &meshes[0];
    // Welded: as many vertices as the head has distinct positions, each where it was.
    let distinct: std::collections::HashSet<[u32; 3]> = skin
        .positions
        .iter()
        .map(|p| p.to_array().map(f32::to_bits))
        .collect();
    assert_eq!(read.positions.len(), distinct.len());
    let source: Vec<u32> = face_source.iter().chain(&lips_source).copied().collect();
    assert_eq!(read.welded.len(), source.len());
    let mut worst = 0f32;
    for (file_vertex, &from) in source.iter().enumerate() {
        let expected = skin.positions[from as usize] * METRES_PER_CM;
        worst = worst.max(read.positions[read.welded[file_vertex] as usize].distance(expected));
    }
    assert!(
        worst < 1e-6,
        "a welded vertex is {worst} m from where the head has it"
    );
    // Triangles in the file's order, each turning the same way as the head's.
    assert_eq!(read.triangles.len(), skin.triangles.len());
    for (k, (&read_t, &head_t)) in read.triangles.iter().zip(&skin.triangles).enumerate() {
        let normal = |p: [Vec3; 3]| (p[1] - p[0]).cross(p[2] - p[0]);
        let a = normal(read_t.map(|v| read.positions[v as usize]));
        let b = normal(head_t.map(|v| skin.positions[v as usize]));
        assert!(a.dot(b) >= 0.0, "triangle {k} turned over");
    }
    // The target's offset, 1 cm along the file's +y, is 0.01 m along the head's -z.
    assert_eq!(read.targets.len(), 1);
    assert_eq!(read.targets[0].name, "jawForward");
    for offset in &read.targets[0].offsets {
        assert!(offset.distance(Vec3::new(0.0, 0.0, -0.01)) < 1e-7, "{offset}");
    }

    let head = glb_head(meshes, &[]).unwrap();
    assert_eq!(head.skin.name, "Head");
    let parts: Vec<(&str, Option<PartRole>)> =
        head.parts.iter().map(|(m, r)| (m.name.as_str(), *r)).collect();
    assert_eq!(
        parts,
        [
            ("Teeth", None),
            ("Tongue", Some(PartRole::Tongue)),
            ("Eyes", Some(PartRole::Eyes))
        ]
    );
    assert_eq!(head.left_out, ["Eyelashes"]);
    // Its maker's name for the eyes can be overruled.
    let meshes = read_glb(&bytes).unwrap();
    let head = glb_head(meshes, &[("Eyes".into(), MeshRole::Left)]).unwrap();
    assert_eq!(head.left_out, ["Eyes", "Eyelashes"]);
}

#[test]
fn a_skinned_mesh_is_read_at_its_bind_pose() {
    // Two joints whose bind-pose matrices both take the file's centimetres to metres; the
    // mesh node's own transform (a 5 m shift) is ignored, as glTF says for skinned meshes.
    let joint_at = [Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.3, -0.2, 0.1)];
    let joint_matrices: Vec<[f32; 16]> = joint_at
        .iter()
        .map(|&t| Mat4::from_translation(t).to_cols_array())
        .collect();
    let inverse_bind: Vec<[f32; 16]> = joint_at
        .iter()
        .map(|&t| (Mat4::from_translation(-t) * Mat4::from_scale(Vec3::splat(METRES_PER_CM))).to_cols_array())
        .collect();
    let positions = vec![[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0]];
    let joints = vec![
        ([0, 1, 0, 0], [0.5, 0.5, 0.0, 0.0]),
        ([1, 0, 0, 0], [1.0, 0.0, 0.0, 0.0]),
        ([0, 0, 0, 0], [2.0, 0.0, 0.0, 0.0]),
    ];
    let mut spec = mesh(
        "Head",
        vec![GlbPrimitive {
            material: "Skin".into(),
            positions,
            indices: vec![0, 1, 2],
            targets: Vec::new(),
            joints: Some(joints),
            texcoords: None,
            base_colour: None,
        }],
    );
    spec.matrix = Some(Mat4::from_translation(Vec3::splat(5.0)).to_cols_array());
    let skin = GlbSkin {
        joint_matrices,
        inverse_bind,
    };
    let bytes = write_glb(&[spec], Mat4::IDENTITY.to_cols_array(), Some(&skin));
    let meshes = read_glb(&bytes).unwrap();
    assert!(meshes[0].skinned);
    let expected = [Vec3::ZERO, Vec3::new(0.1, 0.0, 0.0), Vec3::new(0.0, 0.1, 0.0)];
    for (read, expected) in meshes[0].positions.iter().zip(expected) {
        assert!(read.distance(expected) < 1e-6, "{read} against {expected}");
    }
}

/// The JSON and binary chunks of a small file, for corrupting.
fn small_file() -> (serde_json::Value, Vec<u8>) {
    let lash = Head::new("lash", vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
    let bytes = write_glb(&[whole("Face", &lash)], Mat4::IDENTITY.to_cols_array(), None);
    let json_length = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json = serde_json::from_slice(&bytes[20..20 + json_length]).unwrap();
    let bin = bytes[20 + json_length + 8..].to_vec();
    (json, bin)
}

fn refusal(json: &serde_json::Value, bin: &[u8]) -> String {
    match read_glb(&pack(&serde_json::to_vec(json).unwrap(), bin)) {
        Ok(meshes) => panic!("read {} meshes", meshes.len()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn a_file_that_lies_about_its_sizes_is_refused_by_name() {
    let (json, bin) = small_file();
    assert!(read_glb(&pack(&serde_json::to_vec(&json).unwrap(), &bin)).is_ok());

    let mut more = json.clone();
    more["accessors"][0]["count"] = 1000.into();
    let message = refusal(&more, &bin);
    assert!(message.starts_with("mesh \"Face\", primitive 0: POSITION: accessor 0 (1000 elements of 12 bytes, stride 12) does not fit"), "{message}");

    let mut past = json.clone();
    past["bufferViews"][0]["byteOffset"] = 4000.into();
    let message = refusal(&past, &bin);
    assert!(message.contains("does not fit its buffer view"), "{message}");

    let mut index = bin.clone();
    let index_offset = json["bufferViews"][1]["byteOffset"].as_u64().unwrap() as usize;
    index[index_offset..index_offset + 4].copy_from_slice(&7u32.to_le_bytes());
    assert_eq!(
        refusal(&json, &index),
        "mesh \"Face\", primitive 0: index 7 is past its 3 vertices"
    );

    let mut kind = json.clone();
    kind["accessors"][0]["type"] = "VEC2".into();
    assert!(refusal(&kind, &bin).contains("expected Vec3 of [F32]"));

    let mut cycle = json.clone();
    cycle["nodes"][1]["children"] = serde_json::json!([0]);
    let message = refusal(&cycle, &bin);
    assert!(
        message.contains("reached twice") || message.starts_with("not a glTF binary file"),
        "{message}"
    );

    let mut lines = json.clone();
    lines["meshes"][0]["primitives"][0]["mode"] = 1.into();
    assert_eq!(
        refusal(&lines, &bin),
        "mesh \"Face\", primitive 0: mode Lines: only triangle lists are read"
    );

    // Found by fuzzing: each of these made the `gltf` crate panic before it was checked.
    let mut missing = json.clone();
    missing["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 9.into();
    assert_eq!(
        refusal(&missing, &bin),
        "not a glTF binary file the reader can use: mesh 0, primitive 0 names accessor 9; the file has 2"
    );
    let mut empty = json.clone();
    empty["accessors"][0]["count"] = 0.into();
    assert!(refusal(&empty, &bin).ends_with("accessor 0 has no elements (glTF asks for at least one)"));
    let mut short_header = pack(&serde_json::to_vec(&json).unwrap(), &bin);
    short_header[8..12].copy_from_slice(&4u32.to_le_bytes());
    assert_eq!(
        read_glb(&short_header).unwrap_err().to_string(),
        format!(
            "not a glTF binary file the reader can use: the header gives a length of 4 bytes for a file of {}",
            short_header.len()
        )
    );

    let bytes = write_glb(
        &[whole(
            "Face",
            &Head::new("t", vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]),
        )],
        Mat4::IDENTITY.to_cols_array(),
        None,
    );
    for cut in [0, 11, 30, bytes.len() - 1] {
        assert!(
            matches!(read_glb(&bytes[..cut]), Err(GlbError::Format(_))),
            "cut at {cut}"
        );
    }
    assert!(matches!(
        read_glb(b"v 0 0 0\nf 1 1 1\n"),
        Err(GlbError::Format(_))
    ));
}
