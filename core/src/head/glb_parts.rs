//! Which of a glTF avatar's meshes is the head's skin and which are its parts (teeth,
//! gums, tongue, eyes), told by the names avatar makers give their nodes, meshes and
//! materials (`Wolf3D_Head`, `Wolf3D_Teeth`, `EyeLeft`, `tongue_geo`, ...) unless the user
//! names the role of a mesh. What is neither (hair, lashes, brows, clothes, a body) is
//! left out and listed, so the caller can say so.

use std::fmt;
use std::str::FromStr;

use super::glb::GlbMesh;
use super::part::{PartRole, MAX_PARTS};

/// What one mesh is taken for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshRole {
    /// The head's skin: the mesh the mask is fitted to and the algorithm deforms.
    Skin,
    /// A part; `None` for teeth or gums whose row the caller infers (or splits).
    Part(Option<PartRole>),
    /// Not used.
    Left,
}

impl fmt::Display for MeshRole {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MeshRole::Skin => f.write_str("skin"),
            MeshRole::Part(Some(role)) => write!(f, "{role}"),
            MeshRole::Part(None) => f.write_str("part"),
            MeshRole::Left => f.write_str("none"),
        }
    }
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("mesh role {found:?}: expected skin, part, skull, jaw, tongue, eyes or none")]
pub struct MeshRoleError {
    found: String,
}

impl FromStr for MeshRole {
    type Err = MeshRoleError;

    fn from_str(s: &str) -> Result<MeshRole, MeshRoleError> {
        match s {
            "skin" => Ok(MeshRole::Skin),
            "part" => Ok(MeshRole::Part(None)),
            "none" => Ok(MeshRole::Left),
            other => other
                .parse::<PartRole>()
                .map(|r| MeshRole::Part(Some(r)))
                .map_err(|_| MeshRoleError {
                    found: other.chars().take(64).collect(),
                }),
        }
    }
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum GlbPartsError {
    #[error("no mesh is named like a head or face ({named}); say which it is, for example `{example}=skin`")]
    NoSkin { named: String, example: String },
    #[error("meshes {first:?} and {second:?} are both taken for the skin; say which is, with `NAME=skin`")]
    TwoSkins { first: String, second: String },
    #[error("a role is given for {name:?}, but the file has no mesh of that name ({named})")]
    UnknownMesh { name: String, named: String },
    #[error("{count} meshes are taken for parts, at most {MAX_PARTS}; leave some out with `NAME=none`")]
    TooManyParts { count: usize },
}

/// The skin, the parts (each with its role, or `None` to infer) and what was left out.
#[derive(Debug, Clone)]
pub struct GlbHead {
    pub skin: GlbMesh,
    pub parts: Vec<(GlbMesh, Option<PartRole>)>,
    /// Names of the meshes not used.
    pub left_out: Vec<String>,
}

/// The role a mesh's names suggest: its node's and mesh's names, else its materials'
/// (a face mesh may carry the eye whites' material; its own name says what it is).
pub fn role_by_name(mesh: &GlbMesh) -> MeshRole {
    role_in(&mesh.names)
        .or_else(|| role_in(&mesh.materials))
        .unwrap_or(MeshRole::Left)
}

/// The role the words in `names` suggest, if any does.
fn role_in(names: &[String]) -> Option<MeshRole> {
    let names = names.join(" ").to_lowercase();
    let has = |words: &[&str]| words.iter().any(|w| names.contains(w));
    let row = || match (has(&["lower", "bottom", "jaw"]), has(&["upper", "top", "skull"])) {
        (true, false) => Some(PartRole::Jaw),
        (false, true) => Some(PartRole::Skull),
        _ => None,
    };
    if has(&["tongue"]) {
        Some(MeshRole::Part(Some(PartRole::Tongue)))
    } else if has(&["teeth", "tooth", "gum"]) {
        Some(MeshRole::Part(row()))
    } else if has(&[
        "lash",
        "brow",
        "lid",
        "shadow",
        "occlusion",
        "tear",
        "wet",
        "hair",
    ]) {
        Some(MeshRole::Left)
    } else if has(&["head", "face"]) {
        Some(MeshRole::Skin)
    } else if has(&["eye", "iris", "cornea", "pupil", "sclera"]) {
        Some(MeshRole::Part(Some(PartRole::Eyes)))
    } else if has(&["body", "cloth", "outfit", "shirt", "hat", "glass", "shoe"]) {
        Some(MeshRole::Left)
    } else {
        None
    }
}

/// Splits `meshes` into skin, parts and the rest: each mesh's role from `given` (by its
/// name) or else from its names ([`role_by_name`]). One mesh must be the skin.
pub fn glb_head(meshes: Vec<GlbMesh>, given: &[(String, MeshRole)]) -> Result<GlbHead, GlbPartsError> {
    let named = || {
        let mut names: Vec<String> = meshes.iter().take(12).map(|m| format!("{:?}", m.name)).collect();
        if meshes.len() > 12 {
            names.push(format!("and {} more", meshes.len() - 12));
        }
        names.join(", ")
    };
    if let Some((name, _)) = given
        .iter()
        .find(|(name, _)| meshes.iter().all(|m| &m.name != name))
    {
        return Err(GlbPartsError::UnknownMesh {
            name: name.clone(),
            named: named(),
        });
    }
    let roles: Vec<MeshRole> = meshes
        .iter()
        .map(|m| {
            given
                .iter()
                .find(|(name, _)| name == &m.name)
                .map_or_else(|| role_by_name(m), |(_, r)| *r)
        })
        .collect();
    let skins: Vec<usize> = (0..meshes.len())
        .filter(|&i| roles[i] == MeshRole::Skin)
        .collect();
    match skins[..] {
        [] => {
            return Err(GlbPartsError::NoSkin {
                named: named(),
                example: meshes
                    .iter()
                    .max_by_key(|m| m.positions.len())
                    .map_or_else(String::new, |m| m.name.clone()),
            })
        }
        [_] => {}
        [a, b, ..] => {
            return Err(GlbPartsError::TwoSkins {
                first: meshes[a].name.clone(),
                second: meshes[b].name.clone(),
            })
        }
    }
    let part_count = roles.iter().filter(|r| matches!(r, MeshRole::Part(_))).count();
    if part_count > MAX_PARTS {
        return Err(GlbPartsError::TooManyParts { count: part_count });
    }
    let (mut skin, mut parts, mut left_out) = (None, Vec::new(), Vec::new());
    for (mesh, role) in meshes.into_iter().zip(roles) {
        match role {
            MeshRole::Skin => skin = Some(mesh),
            MeshRole::Part(role) => parts.push((mesh, role)),
            MeshRole::Left => left_out.push(mesh.name),
        }
    }
    Ok(GlbHead {
        skin: skin.expect("one skin was found"),
        parts,
        left_out,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mesh named `names[0]` with the materials after it.
    fn mesh(names: &[&str]) -> GlbMesh {
        GlbMesh {
            name: names[0].to_string(),
            names: vec![names[0].to_string()],
            materials: names[1..].iter().map(|n| n.to_string()).collect(),
            positions: vec![glam::Vec3::ZERO; names.len()],
            triangles: Vec::new(),
            welded: Vec::new(),
            targets: Vec::new(),
            skinned: false,
            texture_coords: None,
            base_colour: None,
        }
    }

    #[test]
    fn avatar_makers_names_are_told_apart() {
        let cases = [
            (&["Wolf3D_Head", "Wolf3D_Skin"][..], MeshRole::Skin),
            (&["Wolf3D_Teeth"], MeshRole::Part(None)),
            (&["teeth_lower"], MeshRole::Part(Some(PartRole::Jaw))),
            (&["UpperGums"], MeshRole::Part(Some(PartRole::Skull))),
            (&["tongue_geo"], MeshRole::Part(Some(PartRole::Tongue))),
            (&["EyeLeft", "Wolf3D_Eye"], MeshRole::Part(Some(PartRole::Eyes))),
            (&["Face", "N00_000_00_EyeWhite_00_EYE"], MeshRole::Skin),
            (&["Mesh_12", "Cornea"], MeshRole::Part(Some(PartRole::Eyes))),
            (&["Object_3"], MeshRole::Left),
            (&["Eyelashes"], MeshRole::Left),
            (&["Wolf3D_Hair"], MeshRole::Left),
            (&["EyeOcclusion"], MeshRole::Left),
            (&["Wolf3D_Outfit_Top"], MeshRole::Left),
            (&["Body"], MeshRole::Left),
        ];
        for (names, role) in cases {
            assert_eq!(role_by_name(&mesh(names)), role, "{names:?}");
        }
    }

    #[test]
    fn roles_given_by_name_win_and_unknown_names_are_refused() {
        let meshes = vec![mesh(&["Body"]), mesh(&["Teeth"]), mesh(&["Hat"])];
        assert!(matches!(
            glb_head(meshes.clone(), &[]),
            Err(GlbPartsError::NoSkin { .. })
        ));
        let head = glb_head(
            meshes.clone(),
            &[
                ("Body".into(), MeshRole::Skin),
                ("Teeth".into(), MeshRole::Part(Some(PartRole::Jaw))),
            ],
        )
        .unwrap();
        assert_eq!(head.skin.name, "Body");
        assert_eq!(head.parts.len(), 1);
        assert_eq!(head.parts[0].1, Some(PartRole::Jaw));
        assert_eq!(head.left_out, vec!["Hat".to_string()]);
        let unknown = glb_head(meshes, &[("Torso".into(), MeshRole::Skin)]).unwrap_err();
        assert_eq!(
            unknown.to_string().split(" (").next().unwrap(),
            "a role is given for \"Torso\", but the file has no mesh of that name"
        );
    }

    #[test]
    fn two_skins_are_refused_by_name() {
        let error = glb_head(vec![mesh(&["Head"]), mesh(&["Face"])], &[]).unwrap_err();
        assert_eq!(
            error,
            GlbPartsError::TwoSkins {
                first: "Head".into(),
                second: "Face".into()
            }
        );
    }

    #[test]
    fn mesh_roles_read_by_name() {
        assert_eq!("skin".parse(), Ok(MeshRole::Skin));
        assert_eq!("jaw".parse(), Ok(MeshRole::Part(Some(PartRole::Jaw))));
        assert_eq!("none".parse(), Ok(MeshRole::Left));
        assert!("hat".parse::<MeshRole>().is_err());
    }
}
