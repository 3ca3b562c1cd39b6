//! Registration from a glTF binary avatar: `POST /v1/heads?id=NAME` with
//! `Content-Type: model/gltf-binary` and the `.glb` as the body. The skin and the parts
//! are found in the file (`head::glb_head`: by their names, or as `roles=` says), welded,
//! in metres, and turned into the OBJ texts every registration stores (the skin's with its
//! texture coordinates, and its base colour image kept as the head's texture, when it has
//! them); the fit is found automatically with the format's own unit (1000 mm per metre),
//! not a guess.

use serde::Deserialize;

use super::error::ApiError;
use super::ids::valid_id;
use super::store::PartRecord;
use super::texture_image;
use crate::head::{glb_head, obj, read_glb, BaseColour, GlbMesh, MeshRole};
use crate::stream::ArkitTargets;
use crate::targets::ExpressionTarget;
use facewire_proto::messages::{ArkitTargetSource, HeadSource, PartSource, TargetLeftOut};

/// The body's content type that makes a registration a glTF one.
pub const CONTENT_TYPE: &str = "model/gltf-binary";

/// Most `NAME=ROLE` pairs `roles=` may give (more than any avatar has meshes).
const MAX_ROLES: usize = 64;

/// The query of a glTF registration.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GlbQuery {
    /// The head's id.
    pub id: Option<String>,
    /// `MESH=ROLE` pairs, comma-separated: a mesh's role (skin, part, skull, jaw, tongue,
    /// eyes or none) where its name does not say it.
    pub roles: Option<String>,
    /// The request's token, which the route layer has already checked.
    #[serde(default, rename = "token")]
    _token: Option<String>,
}

/// What a glTF file registers: the skin and the parts as OBJ texts, in metres, the
/// skin's base colour image when it has one the page can draw, and its morph targets that
/// make ARKit blendshapes (named by ARKit, metres per unit weight).
pub struct GlbUpload {
    pub obj: String,
    pub parts: Vec<PartRecord>,
    pub texture: Option<Vec<u8>>,
    pub arkit_targets: Vec<ExpressionTarget>,
    pub source: HeadSource,
}

/// Reads `bytes` as a head with its parts (blocking: the file is parsed and welded).
pub fn glb_upload(bytes: &[u8], roles: Option<&str>) -> Result<GlbUpload, ApiError> {
    let roles = parse_roles(roles.unwrap_or(""))?;
    let meshes = read_glb(bytes).map_err(|e| ApiError::BadHead(format!("glTF file: {e}")))?;
    let mut head = glb_head(meshes, &roles).map_err(|e| ApiError::BadHead(format!("glTF file: {e}")))?;
    let mut taken: Vec<String> = Vec::new();
    let mut parts = Vec::with_capacity(head.parts.len());
    let mut part_sources = Vec::with_capacity(head.parts.len());
    for (mesh, role) in &head.parts {
        let name = part_name(&mesh.name, &taken);
        taken.push(name.clone());
        part_sources.push(PartSource {
            name: name.clone(),
            mesh: mesh.name.clone(),
        });
        parts.push(PartRecord {
            name,
            role: *role,
            obj: obj_text(mesh).into_bytes(),
        });
    }
    let (texture, texture_note) = skin_texture(&head.skin);
    let sorted = ArkitTargets::sort(
        std::mem::take(&mut head.skin.targets)
            .into_iter()
            .map(|t| ExpressionTarget::from_displacements(&t.name, t.offsets))
            .collect(),
    );
    Ok(GlbUpload {
        obj: match (&texture, &head.skin.texture_coords) {
            (Some(_), Some(coords)) => textured_obj_text(&head.skin, coords),
            _ => obj_text(&head.skin),
        },
        parts,
        texture,
        source: HeadSource {
            format: "glb".into(),
            skin: head.skin.name.clone(),
            parts: part_sources,
            left_out: head.left_out,
            texture: texture_note,
            arkit_targets: sorted
                .chosen
                .iter()
                .zip(&sorted.made_from)
                .map(|(target, from)| ArkitTargetSource {
                    blendshape: target.name.clone(),
                    from: from.clone(),
                })
                .collect(),
            targets_left_out: sorted
                .left_out
                .into_iter()
                .map(|(name, why)| TargetLeftOut {
                    name,
                    why: why.to_string(),
                })
                .collect(),
        },
        arkit_targets: sorted.chosen,
    })
}

/// The longest part of an image's URI a note quotes (a `data:` URI can be megabytes).
const URI_QUOTED: usize = 60;

/// The skin's texture image when the page can draw it (PNG or JPEG, inside the file, with
/// `TEXCOORD_0` on every primitive), and what the registration says about it.
fn skin_texture(skin: &GlbMesh) -> (Option<Vec<u8>>, Option<String>) {
    let (mime, bytes) = match &skin.base_colour {
        None => return (None, None),
        Some(BaseColour::Uri(uri)) => {
            let quoted: String = uri.chars().take(URI_QUOTED).collect();
            let more = if uri.chars().count() > URI_QUOTED {
                "..."
            } else {
                ""
            };
            let note = format!(
                "the skin's base colour image is left out: it is not inside the file but behind the URI \
                 {quoted:?}{more}; pack the image into the .glb's binary chunk to keep it (the \
                 page's \"Your own head\" does, given the image)"
            );
            return (None, Some(note));
        }
        Some(BaseColour::Embedded { mime, bytes }) => (mime, bytes),
    };
    if skin.texture_coords.is_none() {
        let note =
            format!("the skin's base colour image ({mime}) is left out: not every primitive has TEXCOORD_0");
        return (None, Some(note));
    }
    match texture_image::check(bytes) {
        Ok(format) => (
            Some(bytes.clone()),
            Some(format!("the skin's base colour image, {}", format.content_type())),
        ),
        Err(e) => (
            None,
            Some(format!("the skin's base colour image ({mime}) is left out: {e}")),
        ),
    }
}

/// `MESH=ROLE,MESH=ROLE`.
fn parse_roles(text: &str) -> Result<Vec<(String, MeshRole)>, ApiError> {
    let pairs: Vec<&str> = text.split(',').filter(|p| !p.trim().is_empty()).collect();
    if pairs.len() > MAX_ROLES {
        return Err(ApiError::BadRequest(format!(
            "roles: {} pairs; at most {MAX_ROLES}",
            pairs.len()
        )));
    }
    pairs
        .into_iter()
        .map(|pair| {
            let (mesh, role) = pair
                .rsplit_once('=')
                .ok_or_else(|| ApiError::BadRequest(format!("roles: {pair:?} is not MESH=ROLE")))?;
            let role = role
                .trim()
                .parse::<MeshRole>()
                .map_err(|e| ApiError::BadRequest(format!("roles: {e}")))?;
            Ok((mesh.trim().to_string(), role))
        })
        .collect()
}

/// A part name (1-64 of `a-z 0-9 - _`) from a mesh's name, unlike every one `taken`.
fn part_name(mesh: &str, taken: &[String]) -> String {
    let base: String = mesh
        .chars()
        .map(|c| c.to_ascii_lowercase())
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .take(56)
        .collect();
    let base = if base.is_empty() { "part".to_string() } else { base };
    let mut name = base.clone();
    let mut n = 2;
    while taken.contains(&name) || !valid_id(&name) {
        name = format!("{base}_{n}");
        n += 1;
    }
    name
}

fn obj_text(mesh: &GlbMesh) -> String {
    let mut out = Vec::new();
    obj::write(&mut out, &[], &mesh.positions, &mesh.triangles).expect("writing to memory cannot fail");
    String::from_utf8(out).expect("OBJ text is ASCII")
}

fn textured_obj_text(mesh: &GlbMesh, texture: &obj::TextureCoords) -> String {
    let mut out = Vec::new();
    obj::write_textured(&mut out, &mesh.positions, &mesh.triangles, texture)
        .expect("writing to memory cannot fail");
    String::from_utf8(out).expect("OBJ text is ASCII")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roles_are_read_as_mesh_and_role_pairs() {
        let roles = parse_roles("Wolf3D_Teeth=jaw, Body = skin,").unwrap();
        assert_eq!(
            roles,
            vec![
                (
                    "Wolf3D_Teeth".to_string(),
                    MeshRole::Part(Some(crate::head::PartRole::Jaw))
                ),
                ("Body".to_string(), MeshRole::Skin)
            ]
        );
        assert!(parse_roles("Body")
            .unwrap_err()
            .to_string()
            .contains("\"Body\" is not MESH=ROLE"));
        assert!(parse_roles("Body=hat")
            .unwrap_err()
            .to_string()
            .contains("mesh role \"hat\""));
    }

    #[test]
    fn part_names_are_ids_made_from_mesh_names() {
        assert_eq!(part_name("Wolf3D_Teeth", &[]), "wolf3d_teeth");
        assert_eq!(part_name("Eye Left.001", &[]), "eye_left_001");
        assert_eq!(part_name("EyeLeft", &["eyeleft".to_string()]), "eyeleft_2");
        assert_eq!(part_name("", &[]), "part");
    }
}
