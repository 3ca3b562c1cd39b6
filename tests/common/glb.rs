//! A glTF binary (`.glb`) writer for the tests: named meshes as nodes under one root node
//! with a transform, each mesh's triangles in one or more primitives with a material
//! name (and its base colour image, inside the file), texture coordinates, morph targets
//! named in `extras.targetNames`, and optionally a skin. Built by
//! hand from the glTF 2.0 specification so the reader is tested against files it did not
//! write itself.

use serde_json::{json, Value};

/// One primitive: its own vertices (the file repeats shared ones, as exporters do at
/// seams and material borders), triangles over them, per target an offset per vertex.
pub struct GlbPrimitive {
    pub material: String,
    pub positions: Vec<[f32; 3]>,
    pub indices: Vec<u32>,
    pub targets: Vec<Vec<[f32; 3]>>,
    /// Per vertex, joints and weights (a skinned mesh).
    pub joints: Option<Vec<([u16; 4], [f32; 4])>>,
    /// Per vertex, `TEXCOORD_0` (glTF's: v down).
    pub texcoords: Option<Vec<[f32; 2]>>,
    /// The material's base colour image: its MIME type and bytes, stored in the file; or,
    /// with a "MIME type" `uri:NAME`, an image behind the URI `NAME` (not in the file).
    pub base_colour: Option<(String, Vec<u8>)>,
}

/// A base colour "MIME type" that writes the image as a URI (`uri:face.png`).
pub const URI_IMAGE: &str = "uri:";

pub struct GlbMeshSpec {
    pub name: String,
    /// The mesh node's own matrix (column-major), identity if `None`.
    pub matrix: Option<[f32; 16]>,
    pub primitives: Vec<GlbPrimitive>,
    pub target_names: Vec<String>,
}

/// A skin over joint nodes placed by `joint_matrices` (children of the root), with
/// `inverse_bind` matrices; every skinned mesh uses it.
pub struct GlbSkin {
    pub joint_matrices: Vec<[f32; 16]>,
    pub inverse_bind: Vec<[f32; 16]>,
}

#[derive(Default)]
struct Binary {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Binary {
    /// Appends `data` as a buffer view and an accessor over it; returns the accessor.
    fn accessor(&mut self, data: &[u8], count: usize, component: u32, kind: &str, extra: Value) -> usize {
        while !self.bytes.len().is_multiple_of(4) {
            self.bytes.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bytes.len(), "byteLength": data.len()}));
        self.bytes.extend_from_slice(data);
        let mut accessor = json!({"bufferView": self.views.len() - 1, "componentType": component, "count": count, "type": kind});
        if let (Value::Object(a), Value::Object(e)) = (&mut accessor, extra) {
            a.extend(e);
        }
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    fn vec3(&mut self, values: &[[f32; 3]], bounds: bool) -> usize {
        let data: Vec<u8> = values.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
        let extra = if bounds {
            let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
            for v in values {
                for k in 0..3 {
                    lo[k] = lo[k].min(v[k]);
                    hi[k] = hi[k].max(v[k]);
                }
            }
            json!({"min": lo, "max": hi})
        } else {
            json!({})
        };
        self.accessor(&data, values.len(), 5126, "VEC3", extra)
    }
}

/// The file: `meshes` as children of one root node whose matrix is `root` (column-major).
pub fn write_glb(meshes: &[GlbMeshSpec], root: [f32; 16], skin: Option<&GlbSkin>) -> Vec<u8> {
    let mut binary = Binary::default();
    let (mut nodes, mut json_meshes, mut materials) = (vec![json!({})], Vec::new(), Vec::<String>::new());
    let (mut material_json, mut images) = (Vec::<Value>::new(), Vec::<Value>::new());
    let mut children = Vec::new();
    for (m, mesh) in meshes.iter().enumerate() {
        let mut primitives = Vec::new();
        for primitive in &mesh.primitives {
            let position = binary.vec3(&primitive.positions, true);
            let indices: Vec<u8> = primitive.indices.iter().flat_map(|i| i.to_le_bytes()).collect();
            let indices = binary.accessor(&indices, primitive.indices.len(), 5125, "SCALAR", json!({}));
            let targets: Vec<Value> = primitive
                .targets
                .iter()
                .map(|offsets| json!({"POSITION": binary.vec3(offsets, true)}))
                .collect();
            let material = match materials.iter().position(|n| n == &primitive.material) {
                Some(m) => m,
                None => {
                    let mut entry = json!({"name": primitive.material});
                    if let Some((uri, _)) = primitive
                        .base_colour
                        .as_ref()
                        .filter(|(mime, _)| mime.starts_with(URI_IMAGE))
                    {
                        images.push(json!({"uri": &uri[URI_IMAGE.len()..]}));
                        entry["pbrMetallicRoughness"] =
                            json!({"baseColorTexture": {"index": images.len() - 1}});
                    } else if let Some((mime, bytes)) = &primitive.base_colour {
                        while !binary.bytes.len().is_multiple_of(4) {
                            binary.bytes.push(0);
                        }
                        binary.views.push(
                            json!({"buffer": 0, "byteOffset": binary.bytes.len(), "byteLength": bytes.len()}),
                        );
                        binary.bytes.extend_from_slice(bytes);
                        images.push(json!({"bufferView": binary.views.len() - 1, "mimeType": mime}));
                        entry["pbrMetallicRoughness"] =
                            json!({"baseColorTexture": {"index": images.len() - 1}});
                    }
                    materials.push(primitive.material.clone());
                    material_json.push(entry);
                    materials.len() - 1
                }
            };
            let mut attributes = json!({"POSITION": position});
            if let Some(coords) = &primitive.texcoords {
                let data: Vec<u8> = coords.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
                attributes["TEXCOORD_0"] =
                    json!(binary.accessor(&data, coords.len(), 5126, "VEC2", json!({})));
            }
            if let Some(joints) = &primitive.joints {
                let j: Vec<u8> = joints
                    .iter()
                    .flat_map(|(j, _)| j.iter().flat_map(|v| v.to_le_bytes()))
                    .collect();
                let w: Vec<u8> = joints
                    .iter()
                    .flat_map(|(_, w)| w.iter().flat_map(|v| v.to_le_bytes()))
                    .collect();
                attributes["JOINTS_0"] = json!(binary.accessor(&j, joints.len(), 5123, "VEC4", json!({})));
                attributes["WEIGHTS_0"] = json!(binary.accessor(&w, joints.len(), 5126, "VEC4", json!({})));
            }
            let mut json_primitive =
                json!({"attributes": attributes, "indices": indices, "material": material});
            if !targets.is_empty() {
                json_primitive["targets"] = json!(targets);
            }
            primitives.push(json_primitive);
        }
        let mut json_mesh = json!({"name": mesh.name, "primitives": primitives});
        if !mesh.target_names.is_empty() {
            json_mesh["extras"] = json!({"targetNames": mesh.target_names});
        }
        json_meshes.push(json_mesh);
        let mut node = json!({"name": mesh.name, "mesh": m});
        if let Some(matrix) = mesh.matrix {
            node["matrix"] = json!(matrix);
        }
        if mesh.primitives.iter().any(|p| p.joints.is_some()) {
            node["skin"] = json!(0);
        }
        nodes.push(node);
        children.push(nodes.len() - 1);
    }
    let mut skins = Vec::new();
    if let Some(skin) = skin {
        let mut joints = Vec::new();
        for (j, matrix) in skin.joint_matrices.iter().enumerate() {
            nodes.push(json!({"name": format!("joint {j}"), "matrix": matrix}));
            joints.push(nodes.len() - 1);
            children.push(nodes.len() - 1);
        }
        let data: Vec<u8> = skin
            .inverse_bind
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let inverse = binary.accessor(&data, skin.inverse_bind.len(), 5126, "MAT4", json!({}));
        skins.push(json!({"joints": joints, "inverseBindMatrices": inverse}));
    }
    nodes[0] = json!({"name": "root", "matrix": root, "children": children});
    let mut document = json!({
        "asset": {"version": "2.0", "generator": "facewire tests"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": nodes,
        "meshes": json_meshes,
        "materials": material_json,
        "buffers": [{"byteLength": binary.bytes.len()}],
        "bufferViews": binary.views,
        "accessors": binary.accessors,
    });
    if !skins.is_empty() {
        document["skins"] = json!(skins);
    }
    if !images.is_empty() {
        // One texture per image, in the same order.
        document["textures"] = json!((0..images.len())
            .map(|i| json!({"source": i}))
            .collect::<Vec<_>>());
        document["images"] = json!(images);
    }
    pack(&serde_json::to_vec(&document).unwrap(), &binary.bytes)
}

/// The GLB container: header, JSON chunk (space-padded), BIN chunk (zero-padded).
pub fn pack(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let pad = |n: usize| n.next_multiple_of(4);
    let total = 12 + 8 + pad(json.len()) + 8 + pad(bin.len());
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(pad(json.len()) as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(json);
    out.resize(out.len() + pad(json.len()) - json.len(), b' ');
    out.extend_from_slice(&(pad(bin.len()) as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(bin);
    out.resize(total, 0);
    out
}

/// Column-major matrix of `scale` times a rotation of `degrees` about +x.
pub fn scaled_turn_about_x(scale: f32, degrees: f32) -> [f32; 16] {
    (glam::Mat4::from_scale(glam::Vec3::splat(scale)) * glam::Mat4::from_rotation_x(degrees.to_radians()))
        .to_cols_array()
}

/// `head` (the shipped heads' cm, +y up) as one mesh of a file written Z-up.
pub fn z_up_mesh(name: &str, head: &facewire::head::Head) -> GlbMeshSpec {
    let turn = glam::Mat4::from_rotation_x(90f32.to_radians());
    GlbMeshSpec {
        name: name.to_string(),
        matrix: None,
        primitives: vec![GlbPrimitive {
            material: name.to_string(),
            positions: head
                .positions
                .iter()
                .map(|&p| turn.transform_point3(p).to_array())
                .collect(),
            indices: head.triangles.iter().flatten().copied().collect(),
            targets: Vec::new(),
            joints: None,
            texcoords: None,
            base_colour: None,
        }],
        target_names: Vec::new(),
    }
}

/// The shipped ICT head as an avatar maker would export it: in metres, Z-up under a root
/// node that turns it upright, its skin `Head`, both rows of teeth in one mesh
/// `Wolf3D_Teeth`, `Tongue`, `EyeLeft` (both eyeballs) and a stray `Eyelashes` triangle.
pub fn ict_avatar() -> Vec<u8> {
    ict_avatar_textured(None)
}

/// [`ict_avatar`] with the ICT Face Model's 53 expression targets on its skin as morph
/// targets under the model's own names (`mouthSmile_L`, `browInnerUp_L` and `_R`, no
/// `tongueOut`), and a `smile` (a copy of `mouthSmile_L`) that no ARKit name fits.
pub fn ict_avatar_with_targets() -> Vec<u8> {
    ict_avatar_built(None, true)
}

/// The ICT Face Model's expression targets of the shipped ICT head (centimetres, +y up),
/// by name.
pub fn ict_targets() -> Vec<facewire::targets::ExpressionTarget> {
    let head = facewire::head::Head::load(&super::data("heads/ict_head.obj")).unwrap();
    facewire::targets::ExpressionTarget::load_dir(
        &super::data("heads/ict_targets/skin"),
        head.positions.len(),
    )
    .unwrap()
}

/// [`ict_avatar`] with its skin textured: `TEXCOORD_0` from each vertex's place across
/// the face (x and the file's up, z) and the base colour image `image` (MIME type, bytes).
pub fn ict_avatar_textured(image: Option<(String, Vec<u8>)>) -> Vec<u8> {
    ict_avatar_built(image, false)
}

fn ict_avatar_built(image: Option<(String, Vec<u8>)>, with_targets: bool) -> Vec<u8> {
    use facewire::head::Head;
    let load = |file: &str| Head::load(&super::data(&format!("heads/{file}"))).unwrap();
    let (upper, lower) = (load("ict_head_teeth_upper.obj"), load("ict_head_teeth_lower.obj"));
    let rows = upper.positions.len() as u32;
    let teeth = Head::new(
        "teeth",
        upper.positions.iter().chain(&lower.positions).copied().collect(),
        upper
            .triangles
            .iter()
            .copied()
            .chain(lower.triangles.iter().map(|t| t.map(|v| v + rows)))
            .collect(),
    );
    let lash = Head::new(
        "lash",
        vec![glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::Y],
        vec![[0, 1, 2]],
    );
    let mut skin = z_up_mesh("Head", &load("ict_head.obj"));
    if with_targets {
        let turn = glam::Mat4::from_rotation_x(90f32.to_radians());
        let mut targets = ict_targets();
        let smile = targets.iter().find(|t| t.name == "mouthSmile_L").unwrap().clone();
        targets.push(facewire::targets::ExpressionTarget {
            name: "smile".into(),
            ..smile
        });
        skin.target_names = targets.iter().map(|t| t.name.clone()).collect();
        skin.primitives[0].targets = targets
            .iter()
            .map(|t| {
                t.displacements
                    .iter()
                    .map(|&d| turn.transform_vector3(d).to_array())
                    .collect()
            })
            .collect();
    }
    if let Some(image) = image {
        for primitive in &mut skin.primitives {
            let (lo, hi) = primitive
                .positions
                .iter()
                .fold(([f32::MAX; 2], [f32::MIN; 2]), |(lo, hi), p| {
                    (
                        [lo[0].min(p[0]), lo[1].min(p[2])],
                        [hi[0].max(p[0]), hi[1].max(p[2])],
                    )
                });
            let across = |p: &[f32; 3]| {
                [
                    (p[0] - lo[0]) / (hi[0] - lo[0]),
                    1.0 - (p[2] - lo[1]) / (hi[1] - lo[1]),
                ]
            };
            primitive.texcoords = Some(primitive.positions.iter().map(across).collect());
            primitive.base_colour = Some(image.clone());
        }
    }
    write_glb(
        &[
            skin,
            z_up_mesh("Wolf3D_Teeth", &teeth),
            z_up_mesh("Tongue", &load("ict_head_gums_lower_tongue.obj")),
            z_up_mesh("EyeLeft", &load("ict_head_eyes.obj")),
            z_up_mesh("Eyelashes", &lash),
        ],
        scaled_turn_about_x(0.01, -90.0),
        None,
    )
}

/// `glb` written in `dir` as a glTF exporter's "separate" files: `STEM.gltf`, its buffer
/// `STEM.bin` and each image `image N.png`, named by percent-encoded URIs (names with
/// spaces, as exporters write them). The files, the `.gltf` first.
pub fn write_separate(glb: &[u8], dir: &std::path::Path, stem: &str) -> Vec<std::path::PathBuf> {
    let word = |at: usize| u32::from_le_bytes(glb[at..at + 4].try_into().unwrap()) as usize;
    let json_length = word(12);
    let mut json: Value = serde_json::from_slice(&glb[20..20 + json_length]).unwrap();
    let bin_at = 20 + json_length;
    let bin = &glb[bin_at + 8..bin_at + 8 + word(bin_at)];
    let encoded = |name: &str| name.replace(' ', "%20");
    json["buffers"][0]["uri"] = json!(encoded(&format!("{stem}.bin")));
    let mut files = vec![dir.join(format!("{stem}.gltf")), dir.join(format!("{stem}.bin"))];
    std::fs::write(&files[1], bin).unwrap();
    let views = json["bufferViews"].clone();
    if let Some(images) = json.get_mut("images").and_then(Value::as_array_mut) {
        for (i, image) in images.iter_mut().enumerate() {
            let view = &views[image["bufferView"].as_u64().unwrap() as usize];
            let from = view["byteOffset"].as_u64().unwrap_or(0) as usize;
            let bytes = &bin[from..from + view["byteLength"].as_u64().unwrap() as usize];
            let name = format!("image {i}.png");
            std::fs::write(dir.join(&name), bytes).unwrap();
            files.push(dir.join(&name));
            *image = json!({ "uri": encoded(&name) });
        }
    }
    std::fs::write(&files[0], serde_json::to_vec(&json).unwrap()).unwrap();
    files
}
