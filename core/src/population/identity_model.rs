//! The ICT Face Model's identity space (ICT-FaceKit, MIT licence; data/heads/ict_identity/):
//! a generic neutral head plus 100 principal shape vectors from light-stage scans, all on
//! one topology. Any seed gives another realistic head with its teeth, gums, tongue and
//! eyes, so the fit and the deform are measured on heads nobody tuned them on. Every
//! identity shares the generic head's numbering: `ict_head.landmarks.toml` and every ICT
//! expression target apply to each. Positions in centimetres, +y up, +z out of the face.

use std::path::{Path, PathBuf};

use glam::Vec3;
use half::f16;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::head::Head;

/// The model's units: centimetres.
pub const MM_PER_UNIT: f32 = 10.0;

/// The parts the model holds, each with its own vertex numbering.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum IdentityPart {
    /// Face, head and neck with the mouth socket (13,294 vertices).
    Skin,
    /// Gums and tongue as one mesh.
    GumsTongue,
    /// Upper teeth (vertices 0..2207) then lower teeth, each tooth a closed piece.
    Teeth,
    /// Left then right eyeball.
    Eyes,
}

impl IdentityPart {
    pub const ALL: [IdentityPart; 4] = [
        IdentityPart::Skin,
        IdentityPart::GumsTongue,
        IdentityPart::Teeth,
        IdentityPart::Eyes,
    ];

    /// The part's name in `parts.json` and in `faces/NAME.faces`.
    pub fn name(self) -> &'static str {
        match self {
            IdentityPart::Skin => "skin",
            IdentityPart::GumsTongue => "gums_tongue",
            IdentityPart::Teeth => "teeth",
            IdentityPart::Eyes => "eyes",
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum IdentityModelError {
    #[error("{path}: {source}")]
    Read { path: PathBuf, source: std::io::Error },
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
}

#[derive(serde::Deserialize)]
struct PartsFile {
    components: usize,
    rows: usize,
    units: String,
    parts: std::collections::BTreeMap<String, PartRows>,
}

#[derive(serde::Deserialize)]
struct PartRows {
    row: usize,
    count: usize,
}

/// One part's rows in the model and its triangles (quads fanned), in the part's numbering.
#[derive(Debug, Clone)]
struct PartMesh {
    row: usize,
    count: usize,
    triangles: Vec<[u32; 3]>,
}

/// The loaded model: neutral positions and identity offsets (cm), and each part's mesh.
#[derive(Debug, Clone)]
pub struct IdentityModel {
    components: usize,
    neutral: Vec<Vec3>,
    /// `components` blocks of one offset per row.
    basis: Vec<Vec3>,
    parts: Vec<(IdentityPart, PartMesh)>,
}

impl IdentityModel {
    /// The folder the project ships the model in.
    pub fn shipped_dir(data_dir: &Path) -> PathBuf {
        data_dir.join("heads").join("ict_identity")
    }

    /// Loads `parts.json`, `neutral.f32`, `basis.f16` and `faces/*.faces` from `dir`,
    /// checking every size and index against the part table.
    pub fn load(dir: &Path) -> Result<IdentityModel, IdentityModelError> {
        let read = |name: &str| {
            let path = dir.join(name);
            std::fs::read(&path).map_err(|source| IdentityModelError::Read { path, source })
        };
        let invalid = |name: &str, message: String| IdentityModelError::Invalid {
            path: dir.join(name),
            message,
        };
        let table: PartsFile =
            serde_json::from_slice(&read("parts.json")?).map_err(|e| invalid("parts.json", e.to_string()))?;
        if table.units != "cm" {
            return Err(invalid(
                "parts.json",
                format!("units {:?}, expected \"cm\"", table.units),
            ));
        }
        let (rows, components) = (table.rows, table.components);
        let neutral_bytes = read("neutral.f32")?;
        if neutral_bytes.len() != rows * 12 {
            return Err(invalid(
                "neutral.f32",
                format!(
                    "{} bytes, expected {rows} rows of 3 float32 ({})",
                    neutral_bytes.len(),
                    rows * 12
                ),
            ));
        }
        let neutral = neutral_bytes
            .chunks_exact(12)
            .map(|c| {
                let f = |k: usize| f32::from_le_bytes([c[4 * k], c[4 * k + 1], c[4 * k + 2], c[4 * k + 3]]);
                Vec3::new(f(0), f(1), f(2))
            })
            .collect::<Vec<_>>();
        let basis_bytes = read("basis.f16")?;
        if basis_bytes.len() != components * rows * 6 {
            return Err(invalid(
                "basis.f16",
                format!(
                    "{} bytes, expected {components} components x {rows} rows of 3 float16 ({})",
                    basis_bytes.len(),
                    components * rows * 6
                ),
            ));
        }
        let basis = basis_bytes
            .chunks_exact(6)
            .map(|c| {
                let f = |k: usize| f16::from_le_bytes([c[2 * k], c[2 * k + 1]]).to_f32();
                Vec3::new(f(0), f(1), f(2))
            })
            .collect::<Vec<_>>();
        if let Some(bad) = neutral.iter().chain(&basis).position(|p| !p.is_finite()) {
            return Err(invalid("basis.f16", format!("value {bad} is not finite")));
        }
        let mut parts = Vec::new();
        for part in IdentityPart::ALL {
            let rows_of = table
                .parts
                .get(part.name())
                .ok_or_else(|| invalid("parts.json", format!("no part {:?}", part.name())))?;
            if rows_of.row + rows_of.count > rows {
                return Err(invalid(
                    "parts.json",
                    format!("part {:?} runs past row {rows}", part.name()),
                ));
            }
            let faces_name = format!("faces/{}.faces", part.name());
            let text = String::from_utf8_lossy(&read(&faces_name)?).into_owned();
            let triangles =
                parse_faces(&text, rows_of.count).map_err(|message| invalid(&faces_name, message))?;
            parts.push((
                part,
                PartMesh {
                    row: rows_of.row,
                    count: rows_of.count,
                    triangles,
                },
            ));
        }
        Ok(IdentityModel {
            components,
            neutral,
            basis,
            parts,
        })
    }

    /// The identity weights of `seed`: each drawn from N(0, `sigma`^2) by a ChaCha8
    /// generator seeded with `seed` (the same weights on every machine).
    pub fn weights(&self, seed: u64, sigma: f32) -> Vec<f32> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let normal = Normal::new(0.0, sigma.abs()).expect("a finite sigma");
        (0..self.components).map(|_| normal.sample(&mut rng)).collect()
    }

    /// `part` of the identity with these weights (missing ones are zero; the generic head
    /// with none), as a head named `name`.
    pub fn part(&self, part: IdentityPart, weights: &[f32], name: &str) -> Head {
        let (_, mesh) = self
            .parts
            .iter()
            .find(|(p, _)| *p == part)
            .expect("every part is loaded");
        let rows = self.neutral.len();
        let mut positions = self.neutral[mesh.row..mesh.row + mesh.count].to_vec();
        for (k, &w) in weights.iter().enumerate().take(self.components) {
            let offsets = &self.basis[k * rows + mesh.row..k * rows + mesh.row + mesh.count];
            for (p, o) in positions.iter_mut().zip(offsets) {
                *p += w * *o;
            }
        }
        Head::new(name, positions, mesh.triangles.clone())
    }
}

/// A `.faces` file: `#` comments, then one polygon a line (0-based corners), fanned into
/// triangles as the OBJ reader fans them.
fn parse_faces(text: &str, vertices: usize) -> Result<Vec<[u32; 3]>, String> {
    let mut triangles = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.starts_with('#') || line.trim().is_empty() {
            continue;
        }
        let corners = line
            .split_whitespace()
            .map(|c| c.parse::<u32>().ok().filter(|&v| (v as usize) < vertices))
            .collect::<Option<Vec<u32>>>()
            .ok_or_else(|| format!("line {}: a corner is not a vertex index below {vertices}", i + 1))?;
        if corners.len() < 3 {
            return Err(format!(
                "line {}: {} corners, a polygon needs 3",
                i + 1,
                corners.len()
            ));
        }
        for k in 1..corners.len() - 1 {
            triangles.push([corners[0], corners[k], corners[k + 1]]);
        }
    }
    Ok(triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model() -> IdentityModel {
        IdentityModel::load(&IdentityModel::shipped_dir(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("../data"),
        ))
        .unwrap()
    }

    #[test]
    fn the_generic_identity_is_the_shipped_ict_head() {
        let shipped =
            Head::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/heads/ict_head.obj")).unwrap();
        let generic = model().part(IdentityPart::Skin, &[], "generic");
        assert_eq!(generic.triangles, shipped.triangles);
        let worst = generic
            .positions
            .iter()
            .zip(&shipped.positions)
            .map(|(a, b)| a.distance(*b))
            .fold(0.0, f32::max);
        // The OBJ holds 5 decimals (cm).
        assert!(worst < 1e-5, "{worst} cm");
    }

    #[test]
    fn seeds_give_other_heads_and_the_same_head_each_time() {
        let model = model();
        let a = model.part(IdentityPart::Skin, &model.weights(7, 1.0), "a");
        let again = model.part(IdentityPart::Skin, &model.weights(7, 1.0), "again");
        let b = model.part(IdentityPart::Skin, &model.weights(8, 1.0), "b");
        assert_eq!(a.positions, again.positions);
        let moved = a
            .positions
            .iter()
            .zip(&b.positions)
            .map(|(p, q)| p.distance(*q))
            .fold(0.0, f32::max);
        // Identities differ by centimetres somewhere (head shape), not by microns.
        assert!(moved > 0.5, "{moved} cm");
        let w = model.weights(7, 1.5);
        let sd = (w.iter().map(|x| x * x).sum::<f32>() / w.len() as f32).sqrt();
        assert!((1.2..1.8).contains(&sd), "{sd}");
    }

    #[test]
    fn a_faces_file_with_a_bad_corner_names_its_line() {
        assert_eq!(
            parse_faces("# c\n0 1 2 3\n", 4).unwrap(),
            vec![[0, 1, 2], [0, 2, 3]]
        );
        let e = parse_faces("0 1 2\n0 1 9\n", 4).unwrap_err();
        assert!(e.starts_with("line 2:"), "{e}");
        assert!(parse_faces("0 1\n", 4).unwrap_err().contains("2 corners"));
    }
}
