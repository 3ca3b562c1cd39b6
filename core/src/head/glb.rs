//! glTF 2.0 binary files (`.glb`), the format avatar makers export, read as the meshes a
//! head is made of: every mesh the scene places, in the scene's frame and in metres (the
//! format's unit) by its nodes' transforms, skinned meshes at their bind pose; each
//! mesh's primitives joined and welded where the file repeats a vertex at a UV or normal
//! seam, with a map from the file's vertices to the welded ones; morph targets kept with
//! their names. Which mesh is the skin and which are parts is [`super::glb_parts`]'s job.
//!
//! The file is parsed by the `gltf` crate; every accessor this reader follows is checked
//! against the binary chunk (type, stride, range, count) before it is read, so a file
//! that lies about its sizes is refused by name rather than read out of bounds.

use std::borrow::Cow;
use std::collections::HashMap;

use glam::{Mat3, Mat4, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::binary::Glb;
use gltf::mesh::Mode;
use gltf::{buffer, json, Accessor, Document, Semantic};

use super::obj::{TextureCoords, MAX_COORDINATE, MAX_ELEMENTS};

/// Millimetres in one glTF unit: the format's unit is the metre.
pub const MM_PER_METRE: f32 = 1000.0;

/// Deepest node nesting followed (avatar rigs nest a few dozen deep).
pub const MAX_NODE_DEPTH: usize = 256;

/// Most meshes one scene may place.
pub const MAX_MESHES: usize = 256;

/// Most morph targets one mesh may carry (ARKit's 52 and as many again).
pub const MAX_TARGETS: usize = 256;

/// Most vertex values (positions, targets' offsets, joints) read from one file: morph
/// targets multiply a mesh's size, so they are bounded together.
pub const MAX_VALUES: usize = 4 * MAX_ELEMENTS;

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum GlbError {
    #[error("not a glTF binary file the reader can use: {0}")]
    Format(String),
    #[error("the file has no scene")]
    NoScene,
    #[error(
        "node {node}: reached twice or nested more than {MAX_NODE_DEPTH} deep (the nodes must form trees)"
    )]
    NodeTree { node: usize },
    #[error("more than {MAX_MESHES} meshes placed in the scene")]
    TooManyMeshes,
    #[error("mesh {mesh:?}, primitive {primitive}: {what}")]
    Primitive {
        mesh: String,
        primitive: usize,
        what: String,
    },
    #[error("skin of mesh {mesh:?}: {what}")]
    Skin { mesh: String, what: String },
    #[error("mesh {mesh:?}: more than {MAX_ELEMENTS} vertices or triangles")]
    TooLarge { mesh: String },
    #[error("the scene places no triangles")]
    NoTriangles,
}

/// One mesh as the scene places it.
#[derive(Debug, Clone, PartialEq)]
pub struct GlbMesh {
    /// The node's name, else the mesh's, else `mesh N` (N its index in the file).
    pub name: String,
    /// The names the file gives its node and its mesh, for telling what it is.
    pub names: Vec<String>,
    /// Its primitives' material names.
    pub materials: Vec<String>,
    /// Welded vertices: metres, the scene's frame (glTF's +y up, +z forward).
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// For each of the file's vertices of this mesh (its primitives' in turn), the welded
    /// vertex it became.
    pub welded: Vec<u32>,
    /// Morph targets, each as an offset per welded vertex (metres, the scene's frame).
    pub targets: Vec<MorphTarget>,
    /// Whether it is skinned (placed by its joints at their bind pose).
    pub skinned: bool,
    /// Where it sits on its texture, when every primitive has `TEXCOORD_0`: a coordinate
    /// per file vertex (v up, as OBJ writes them), each triangle's corners by file vertex.
    pub texture_coords: Option<TextureCoords>,
    /// The base colour image every primitive's material names, when they name the same one.
    pub base_colour: Option<BaseColour>,
}

/// A mesh's base colour image, as its file has it.
#[derive(Debug, Clone, PartialEq)]
pub enum BaseColour {
    /// Inside the file's binary chunk: its MIME type and bytes as stored.
    Embedded { mime: String, bytes: Vec<u8> },
    /// Behind a URI (a file beside the `.glb`, or a `data:` URI), not read: a `.glb` is
    /// one upload. The URI as written.
    Uri(String),
}

/// A morph target (blend shape).
#[derive(Debug, Clone, PartialEq)]
pub struct MorphTarget {
    /// Its name from the mesh's `extras.targetNames`, else `target N`.
    pub name: String,
    pub offsets: Vec<Vec3>,
}

/// Every mesh the file's scene (its default, else its first) places, in node order.
pub fn read_glb(bytes: &[u8]) -> Result<Vec<GlbMesh>, GlbError> {
    let Parsed { document: gltf, bin } = parse(bytes)?;
    let blob = bin.as_deref().unwrap_or(&[]);
    let scene = gltf
        .default_scene()
        .or_else(|| gltf.scenes().next())
        .ok_or(GlbError::NoScene)?;
    let nodes: Vec<gltf::Node> = gltf.nodes().collect();
    let world = world_transforms(&nodes, scene.nodes().map(|n| n.index()))?;
    let placed: Vec<usize> = (0..nodes.len())
        .filter(|&i| world[i].is_some() && nodes[i].mesh().is_some())
        .collect();
    if placed.len() > MAX_MESHES {
        return Err(GlbError::TooManyMeshes);
    }
    let mut budget = MAX_VALUES;
    let mut meshes = Vec::with_capacity(placed.len());
    for i in placed {
        let node = &nodes[i];
        let transform = match node.skin() {
            Some(skin) => Placement::Skinned(joint_matrices(&skin, &world, blob, &mesh_label(node))?),
            None => Placement::Rigid(world[i].expect("placed nodes have a transform")),
        };
        meshes.push(read_mesh(node, &transform, blob, &mut budget)?);
    }
    if meshes.iter().all(|m| m.triangles.is_empty()) {
        return Err(GlbError::NoTriangles);
    }
    Ok(meshes)
}

/// A file's validated document and its binary chunk.
struct Parsed<'a> {
    document: Document,
    bin: Option<Cow<'a, [u8]>>,
}

/// The validated document and the binary chunk. The container's header and every
/// primitive's accessor indices are checked here first: the `gltf` crate (1.4) panics on a
/// header length under 12 bytes and on a POSITION naming an accessor the file lacks.
fn parse(bytes: &[u8]) -> Result<Parsed<'_>, GlbError> {
    let format = |what: String| GlbError::Format(what);
    let header = bytes
        .get(..12)
        .ok_or_else(|| format(format!("{} bytes, shorter than a GLB header", bytes.len())))?;
    if &header[..4] != b"glTF" {
        return Err(format("it does not start with `glTF` (a .glb file does)".into()));
    }
    let length = u32::from_le_bytes(header[8..12].try_into().expect("four bytes"));
    if !(12..=bytes.len() as u64).contains(&u64::from(length)) {
        return Err(format(format!(
            "the header gives a length of {length} bytes for a file of {}",
            bytes.len()
        )));
    }
    let glb = Glb::from_slice(bytes).map_err(|e| format(e.to_string()))?;
    let root = json::Root::from_slice(&glb.json).map_err(|e| format(format!("its JSON: {e}")))?;
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let targets = primitive.targets.iter().flatten().flat_map(|t| t.positions);
            let accessors = primitive.attributes.values().copied().chain(targets);
            if let Some(missing) = accessors.map(|a| a.value()).find(|&a| a >= root.accessors.len()) {
                return Err(format(format!(
                    "mesh {m}, primitive {p} names accessor {missing}; the file has {}",
                    root.accessors.len()
                )));
            }
        }
    }
    let document = Document::from_json(root).map_err(|e| format(e.to_string()))?;
    Ok(Parsed {
        document,
        bin: glb.bin,
    })
}

/// Each node's transform to the scene's frame, for the nodes the scene reaches.
fn world_transforms(
    nodes: &[gltf::Node],
    roots: impl Iterator<Item = usize>,
) -> Result<Vec<Option<Mat4>>, GlbError> {
    let mut world = vec![None; nodes.len()];
    let mut stack: Vec<(usize, Mat4, usize)> = roots.map(|n| (n, Mat4::IDENTITY, 0)).collect();
    while let Some((n, parent, depth)) = stack.pop() {
        if depth > MAX_NODE_DEPTH || world[n].is_some() {
            return Err(GlbError::NodeTree { node: n });
        }
        let local = Mat4::from_cols_array_2d(&nodes[n].transform().matrix());
        let placed = parent * local;
        world[n] = Some(placed);
        stack.extend(nodes[n].children().map(|c| (c.index(), placed, depth + 1)));
    }
    Ok(world)
}

/// How a mesh's vertices reach the scene's frame.
enum Placement {
    Rigid(Mat4),
    /// Each joint's bind-pose matrix (its transform times its inverse bind matrix).
    Skinned(Vec<Mat4>),
}

fn mesh_label(node: &gltf::Node) -> String {
    node.name()
        .or_else(|| node.mesh().and_then(|m| m.name()))
        .map_or_else(
            || format!("mesh {}", node.mesh().map_or(0, |m| m.index())),
            String::from,
        )
}

fn joint_matrices(
    skin: &gltf::Skin,
    world: &[Option<Mat4>],
    blob: &[u8],
    mesh: &str,
) -> Result<Vec<Mat4>, GlbError> {
    let bad = |what: String| GlbError::Skin {
        mesh: mesh.to_string(),
        what,
    };
    let inverse_bind: Vec<Mat4> = match skin.inverse_bind_matrices() {
        Some(accessor) => {
            check_accessor(&accessor, blob, &[DataType::F32], Dimensions::Mat4)
                .map_err(|e| bad(format!("inverse bind matrices: {e}")))?;
            let reader = skin.reader(|b| bin(b, blob));
            let matrices = reader
                .read_inverse_bind_matrices()
                .ok_or_else(|| bad("inverse bind matrices not in the file's binary chunk".into()))?;
            matrices.map(|m| Mat4::from_cols_array_2d(&m)).collect()
        }
        None => vec![Mat4::IDENTITY; skin.joints().len()],
    };
    if inverse_bind.len() < skin.joints().len() {
        return Err(bad(format!(
            "{} inverse bind matrices for {} joints",
            inverse_bind.len(),
            skin.joints().len()
        )));
    }
    skin.joints()
        .zip(inverse_bind)
        .map(|(joint, inverse)| {
            let placed = world[joint.index()]
                .ok_or_else(|| bad(format!("joint node {} is not in the scene", joint.index())))?;
            Ok(placed * inverse)
        })
        .collect()
}

/// The binary chunk for the buffer that is it; nothing for a buffer behind a URI.
fn bin<'a>(buffer: buffer::Buffer<'_>, blob: &'a [u8]) -> Option<&'a [u8]> {
    match buffer.source() {
        buffer::Source::Bin => Some(blob),
        buffer::Source::Uri(_) => None,
    }
}

/// Checks that `accessor` can be read from the binary chunk as `types` x `dimensions`:
/// dense, in the chunk, every element inside its buffer view.
fn check_accessor(
    accessor: &Accessor,
    blob: &[u8],
    types: &[DataType],
    dimensions: Dimensions,
) -> Result<(), String> {
    if accessor.sparse().is_some() {
        return Err("sparse accessors are not read".into());
    }
    if !types.contains(&accessor.data_type()) || accessor.dimensions() != dimensions {
        return Err(format!(
            "accessor {} holds {:?} {:?}, expected {dimensions:?} of {types:?}",
            accessor.index(),
            accessor.dimensions(),
            accessor.data_type()
        ));
    }
    let view = accessor
        .view()
        .ok_or_else(|| format!("accessor {} has no buffer view", accessor.index()))?;
    if bin(view.buffer(), blob).is_none() {
        return Err(format!(
            "accessor {}: its data is outside the file (a URI); pack it into the .glb",
            accessor.index()
        ));
    }
    let (count, size) = (accessor.count(), accessor.size());
    if count == 0 {
        return Err(format!(
            "accessor {} has no elements (glTF asks for at least one)",
            accessor.index()
        ));
    }
    if count > MAX_VALUES {
        return Err(format!(
            "accessor {}: {count} elements; at most {MAX_VALUES}",
            accessor.index()
        ));
    }
    let stride = view.stride().unwrap_or(size);
    let view_end = view.offset().checked_add(view.length());
    let last_end = stride
        .checked_mul(count - 1)
        .and_then(|s| s.checked_add(accessor.offset()))
        .and_then(|s| s.checked_add(size));
    match (view_end, last_end) {
        (Some(view_end), Some(last_end))
            if stride >= size && view_end <= blob.len() && last_end <= view.length() =>
        {
            Ok(())
        }
        _ => Err(format!(
            "accessor {} ({count} elements of {size} bytes, stride {stride}) does not fit its buffer view \
             (offset {}, length {}) in a binary chunk of {} bytes",
            accessor.index(),
            view.offset(),
            view.length(),
            blob.len()
        )),
    }
}

/// Up to four joints of a skinned vertex and their weights (`JOINTS_0`, `WEIGHTS_0`).
type Influences = ([u16; 4], [f32; 4]);

/// One primitive's file data, checked.
struct PrimitiveData {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    /// Per target, an offset per vertex (zero where the target leaves it out).
    targets: Vec<Vec<Vec3>>,
    /// Per vertex, its joints and their weights.
    joints: Vec<Influences>,
    /// Per vertex, its `TEXCOORD_0` (glTF's: v down), when the primitive has them.
    texture_coords: Option<Vec<[f32; 2]>>,
}

fn read_primitive(
    primitive: &gltf::Primitive,
    blob: &[u8],
    skinned: bool,
    budget: &mut usize,
) -> Result<PrimitiveData, String> {
    if primitive.mode() != Mode::Triangles {
        return Err(format!(
            "mode {:?}: only triangle lists are read",
            primitive.mode()
        ));
    }
    let positions_accessor = primitive
        .get(&Semantic::Positions)
        .ok_or_else(|| "it has no POSITION".to_string())?;
    check_accessor(&positions_accessor, blob, &[DataType::F32], Dimensions::Vec3)
        .map_err(|e| format!("POSITION: {e}"))?;
    let vertices = positions_accessor.count();
    let targets = primitive.morph_targets().len();
    if targets > MAX_TARGETS {
        return Err(format!("{targets} morph targets; at most {MAX_TARGETS}"));
    }
    let values = vertices.saturating_mul(targets + 1 + usize::from(skinned));
    *budget = budget
        .checked_sub(values)
        .ok_or_else(|| format!("{values} vertex values; at most {MAX_VALUES} in a file"))?;
    let reader = primitive.reader(|b| bin(b, blob));
    let positions: Vec<Vec3> = reader
        .read_positions()
        .ok_or("POSITION is not in the file's binary chunk")?
        .map(Vec3::from)
        .collect();
    let corners: Vec<u32> = match primitive.indices() {
        Some(indices) => {
            check_accessor(
                &indices,
                blob,
                &[DataType::U8, DataType::U16, DataType::U32],
                Dimensions::Scalar,
            )
            .map_err(|e| format!("indices: {e}"))?;
            reader
                .read_indices()
                .ok_or("indices are not in the file's binary chunk")?
                .into_u32()
                .collect()
        }
        None => (0..vertices as u32).collect(),
    };
    if !corners.len().is_multiple_of(3) {
        return Err(format!(
            "{} indices, not a whole number of triangles",
            corners.len()
        ));
    }
    if let Some(&past) = corners.iter().find(|&&c| c as usize >= vertices) {
        return Err(format!("index {past} is past its {vertices} vertices"));
    }
    let triangles = corners.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let mut offsets = Vec::with_capacity(targets);
    for (t, target) in primitive.morph_targets().enumerate() {
        if let Some(accessor) = target.positions() {
            check_accessor(&accessor, blob, &[DataType::F32], Dimensions::Vec3)
                .map_err(|e| format!("morph target {t}: {e}"))?;
            if accessor.count() != vertices {
                return Err(format!(
                    "morph target {t}: {} offsets for {vertices} vertices",
                    accessor.count()
                ));
            }
        }
    }
    for (t, (target, _, _)) in reader.read_morph_targets().enumerate() {
        offsets.push(match target {
            Some(values) => values.map(Vec3::from).collect(),
            None if primitive
                .morph_targets()
                .nth(t)
                .is_some_and(|m| m.positions().is_some()) =>
            {
                return Err(format!("morph target {t} is not in the file's binary chunk"))
            }
            None => vec![Vec3::ZERO; vertices],
        });
    }
    let joints = if skinned {
        read_joints(primitive, &reader, blob, vertices)?
    } else {
        Vec::new()
    };
    let texture_coords = match primitive.get(&Semantic::TexCoords(0)) {
        None => None,
        Some(accessor) => {
            check_accessor(
                &accessor,
                blob,
                &[DataType::F32, DataType::U8, DataType::U16],
                Dimensions::Vec2,
            )
            .map_err(|e| format!("TEXCOORD_0: {e}"))?;
            if accessor.count() != vertices {
                return Err(format!(
                    "TEXCOORD_0: {} for {vertices} vertices",
                    accessor.count()
                ));
            }
            let coords = reader
                .read_tex_coords(0)
                .ok_or("TEXCOORD_0 is not in the file's binary chunk")?
                .into_f32();
            Some(coords.collect())
        }
    };
    Ok(PrimitiveData {
        positions,
        triangles,
        targets: offsets,
        joints,
        texture_coords,
    })
}

fn read_joints<'a, 's, F>(
    primitive: &gltf::Primitive,
    reader: &gltf::mesh::Reader<'a, 's, F>,
    blob: &[u8],
    vertices: usize,
) -> Result<Vec<Influences>, String>
where
    F: Clone + Fn(buffer::Buffer<'a>) -> Option<&'s [u8]>,
{
    let (Some(joints), Some(weights)) = (
        primitive.get(&Semantic::Joints(0)),
        primitive.get(&Semantic::Weights(0)),
    ) else {
        return Err("a skinned mesh without JOINTS_0 and WEIGHTS_0".into());
    };
    check_accessor(&joints, blob, &[DataType::U8, DataType::U16], Dimensions::Vec4)
        .map_err(|e| format!("JOINTS_0: {e}"))?;
    check_accessor(
        &weights,
        blob,
        &[DataType::F32, DataType::U8, DataType::U16],
        Dimensions::Vec4,
    )
    .map_err(|e| format!("WEIGHTS_0: {e}"))?;
    if joints.count() != vertices || weights.count() != vertices {
        return Err(format!(
            "{} joints and {} weights for {vertices} vertices",
            joints.count(),
            weights.count()
        ));
    }
    let joints = reader
        .read_joints(0)
        .ok_or("JOINTS_0 is not in the file's binary chunk")?
        .into_u16();
    let weights = reader
        .read_weights(0)
        .ok_or("WEIGHTS_0 is not in the file's binary chunk")?
        .into_f32();
    Ok(joints.zip(weights).collect())
}

fn read_mesh(
    node: &gltf::Node,
    placement: &Placement,
    blob: &[u8],
    budget: &mut usize,
) -> Result<GlbMesh, GlbError> {
    let mesh = node.mesh().expect("placed nodes have a mesh");
    let name = mesh_label(node);
    let target_names = target_names(&mesh);
    let mut welded_of: HashMap<[u32; 3], u32> = HashMap::new();
    let mut out = GlbMesh {
        name: name.clone(),
        names: [node.name(), mesh.name()]
            .into_iter()
            .flatten()
            .map(String::from)
            .collect(),
        materials: Vec::new(),
        positions: Vec::new(),
        triangles: Vec::new(),
        welded: Vec::new(),
        targets: Vec::new(),
        skinned: matches!(placement, Placement::Skinned(_)),
        texture_coords: Some(TextureCoords {
            coords: Vec::new(),
            corners: Vec::new(),
        }),
        base_colour: None,
    };
    // The base colour image of every primitive so far: `Some(None)` before the first.
    let mut image: Option<Option<usize>> = Some(None);
    for (p, primitive) in mesh.primitives().enumerate() {
        let bad = |what: String| GlbError::Primitive {
            mesh: name.clone(),
            primitive: p,
            what,
        };
        if let Some(material) = primitive.material().name() {
            out.materials.push(material.to_string());
        }
        let data = read_primitive(&primitive, blob, out.skinned, budget).map_err(bad)?;
        if p > 0 && data.targets.len() != out.targets.len() {
            return Err(bad(format!(
                "{} morph targets where the mesh's first primitive has {}",
                data.targets.len(),
                out.targets.len()
            )));
        }
        if p == 0 {
            out.targets = (0..data.targets.len())
                .map(|t| MorphTarget {
                    name: target_names
                        .get(t)
                        .cloned()
                        .unwrap_or_else(|| format!("target {t}")),
                    offsets: Vec::new(),
                })
                .collect();
        }
        let first_file_vertex = out.welded.len();
        for (v, &position) in data.positions.iter().enumerate() {
            let key = position.to_array().map(f32::to_bits);
            let next = out.positions.len() as u32;
            let welded = *welded_of.entry(key).or_insert(next);
            if welded == next {
                let to_scene = match placement {
                    Placement::Rigid(m) => *m,
                    Placement::Skinned(joints) => blend(joints, data.joints[v]).map_err(bad)?,
                };
                let placed = to_scene.transform_point3(position);
                if !placed.is_finite() || placed.abs().max_element() > MAX_COORDINATE {
                    return Err(bad(format!("vertex {v} lands at {placed} in the scene")));
                }
                out.positions.push(placed);
                let linear = Mat3::from_mat4(to_scene);
                for (target, offsets) in out.targets.iter_mut().zip(&data.targets) {
                    target.offsets.push(linear * offsets[v]);
                }
            }
            out.welded.push(welded);
        }
        let flip = match placement {
            Placement::Rigid(m) => m.determinant() < 0.0,
            Placement::Skinned(_) => false,
        };
        out.triangles.extend(data.triangles.iter().map(|t| {
            let [a, b, c] = t.map(|c| out.welded[first_file_vertex + c as usize]);
            if flip {
                [a, c, b]
            } else {
                [a, b, c]
            }
        }));
        match (&mut out.texture_coords, data.texture_coords) {
            (Some(texture), Some(coords)) => {
                // glTF's v runs down the image, OBJ's (and uv.bin's) up.
                texture.coords.extend(coords.iter().map(|&[u, v]| [u, 1.0 - v]));
                texture.corners.extend(data.triangles.iter().map(|t| {
                    let [a, b, c] = t.map(|c| first_file_vertex as u32 + c);
                    if flip {
                        [a, c, b]
                    } else {
                        [a, b, c]
                    }
                }));
            }
            (texture, _) => *texture = None,
        }
        let this = primitive
            .material()
            .pbr_metallic_roughness()
            .base_color_texture()
            .map(|info| info.texture().source().index());
        image = match (image, this) {
            (Some(None), Some(index)) if p == 0 => Some(Some(index)),
            (Some(Some(kept)), Some(index)) if kept == index => Some(Some(kept)),
            _ => None,
        };
    }
    if let Some(Some(index)) = image {
        out.base_colour = embedded_image(node, index, blob);
    }
    if out.positions.len() > MAX_ELEMENTS || out.triangles.len() > MAX_ELEMENTS {
        return Err(GlbError::TooLarge { mesh: name });
    }
    out.names.dedup();
    out.materials.dedup();
    Ok(out)
}

/// Image `index` of the document `node` is in: its bytes when it is inside the file's
/// binary chunk, its URI when it is not. A view past the chunk is none.
fn embedded_image(node: &gltf::Node, index: usize, blob: &[u8]) -> Option<BaseColour> {
    let image = node.mesh()?.primitives().find_map(|p| {
        let texture = p
            .material()
            .pbr_metallic_roughness()
            .base_color_texture()?
            .texture();
        (texture.source().index() == index).then(|| texture.source())
    })?;
    match image.source() {
        gltf::image::Source::View { view, mime_type } => {
            let bytes = bin(view.buffer(), blob)?;
            let range = view.offset()..view.offset().checked_add(view.length())?;
            Some(BaseColour::Embedded {
                mime: mime_type.to_string(),
                bytes: bytes.get(range)?.to_vec(),
            })
        }
        gltf::image::Source::Uri { uri, .. } => Some(BaseColour::Uri(uri.to_string())),
    }
}

/// A skinned vertex's bind-pose matrix: its joints' matrices blended by its weights.
fn blend(joints: &[Mat4], (indices, weights): Influences) -> Result<Mat4, String> {
    let total: f32 = weights.iter().sum();
    if !(total.is_finite() && total > 0.0) {
        return Err(format!("a vertex's joint weights sum to {total}"));
    }
    let mut blended = Mat4::ZERO;
    for (&j, &w) in indices.iter().zip(&weights) {
        if w == 0.0 {
            continue;
        }
        let joint = joints
            .get(j as usize)
            .ok_or_else(|| format!("joint {j} of a skin with {} joints", joints.len()))?;
        blended += *joint * (w / total);
    }
    Ok(blended)
}

/// The names glTF exporters give morph targets: the mesh's `extras.targetNames`.
fn target_names(mesh: &gltf::Mesh) -> Vec<String> {
    #[derive(serde::Deserialize)]
    struct Extras {
        #[serde(rename = "targetNames")]
        target_names: Vec<String>,
    }
    mesh.extras()
        .as_ref()
        .and_then(|raw| serde_json::from_str::<Extras>(raw.get()).ok())
        .map_or_else(Vec::new, |e| e.target_names)
}
