//! Where registered heads live between runs: one folder per head in the data directory
//! (`heads/<id>/head.obj`, `fit.toml`, `parts/<name>.obj`, `texture` and `arkit_basis.tsv`
//! when it has them, `head.json`), every file
//! written atomically.
//! `head.json` is written last and removed first, so a folder without it is an
//! interrupted write: it is removed at start, with any temporary file left by a crash.
//! Folders that cannot be loaded are reported, never fatal. Blocking: call it from the
//! blocking pool.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::auth::TokenDigest;
use crate::atomic::write_atomic;
use crate::head::PartRole;

/// What a head was registered with: enough to register it again after a restart.
#[derive(Debug, Clone, PartialEq)]
pub struct HeadRecord {
    pub id: String,
    pub obj: Vec<u8>,
    pub fit_toml: String,
    /// Teeth, gums, tongue (stored as `parts/<name>.obj`, listed with their roles in
    /// `head.json`).
    pub parts: Vec<PartRecord>,
    /// Its texture image, PNG or JPEG, checked ([`super::texture_image`]), stored as
    /// `texture`.
    pub texture: Option<Vec<u8>>,
    /// Its own ARKit retarget basis (`ArkitBasis` text, mask units), derived at
    /// registration from its ARKit morph targets; the blendshapes it defines are
    /// `meta.arkit_blendshapes`. Stored as `arkit_basis.tsv`.
    pub arkit_basis: Option<String>,
    pub meta: HeadMeta,
}

/// A head's own ARKit basis in its folder.
const ARKIT_BASIS_FILE: &str = "arkit_basis.tsv";

/// A part mesh as registered.
#[derive(Debug, Clone, PartialEq)]
pub struct PartRecord {
    pub name: String,
    /// `None`: inferred at registration.
    pub role: Option<PartRole>,
    pub obj: Vec<u8>,
}

/// A part in `head.json`: its mesh is `parts/<name>.obj`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct StoredPart {
    name: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    role: Option<PartRole>,
}

/// `head.json`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeadMeta {
    /// SHA-256 (hex) of the head's own producer token, if it was registered with one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub producer_token_sha256: Option<String>,
    /// Written by versions that stored the token itself; read once and replaced by its
    /// digest.
    #[serde(default, skip_serializing)]
    producer_token: Option<String>,
    /// Written from `HeadRecord::parts` on save, read back into it on load.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    parts: Vec<StoredPart>,
    /// With the cluster bus: tells registrations of the same id apart (a head deleted
    /// and registered again is a new head on every node).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub registration_tag: Option<String>,
    /// The ARKit blendshapes the head's own basis (`arkit_basis.tsv`) defines.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub arkit_blendshapes: Vec<String>,
}

impl HeadMeta {
    pub fn with_producer_token(token: Option<&str>) -> HeadMeta {
        HeadMeta {
            producer_token_sha256: token
                .filter(|t| !t.is_empty())
                .map(|t| TokenDigest::of(t).to_hex()),
            producer_token: None,
            parts: Vec::new(),
            registration_tag: None,
            arkit_blendshapes: Vec::new(),
        }
    }

    /// This metadata listing `parts` (names and roles; their meshes are stored apart).
    pub fn listing(&self, parts: &[PartRecord]) -> HeadMeta {
        HeadMeta {
            parts: parts
                .iter()
                .map(|p| StoredPart {
                    name: p.name.clone(),
                    role: p.role,
                })
                .collect(),
            ..self.clone()
        }
    }

    /// The parts listed, as (name, role).
    pub fn listed_parts(&self) -> impl Iterator<Item = (&str, Option<PartRole>)> {
        self.parts.iter().map(|p| (p.name.as_str(), p.role))
    }

    pub fn producer_token(&self) -> Option<TokenDigest> {
        self.producer_token_sha256
            .as_deref()
            .and_then(TokenDigest::from_hex)
    }
}

#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    #[error("{path}: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("{path}: {message}")]
    Invalid { path: String, message: String },
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> StoreError + '_ {
    move |source| StoreError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// A stored head that could not be loaded.
#[derive(Debug)]
pub struct BrokenHead {
    /// The folder's name, when it is a valid head id (then `DELETE` removes it).
    pub id: Option<String>,
    pub problem: StoreError,
}

/// What [`Store::load_all`] found.
#[derive(Debug, Default)]
pub struct StoredHeads {
    pub records: Vec<HeadRecord>,
    pub broken: Vec<BrokenHead>,
    /// Leftovers of interrupted writes that were removed (paths).
    pub cleaned: Vec<String>,
}

#[derive(Debug, Clone)]
pub struct Store {
    root: PathBuf,
}

impl Store {
    pub fn open(data_dir: &Path) -> Result<Store, StoreError> {
        let root = data_dir.join("heads");
        std::fs::create_dir_all(&root).map_err(io(&root))?;
        Ok(Store { root })
    }

    fn dir(&self, id: &str) -> PathBuf {
        self.root.join(id)
    }

    /// Head `id`'s recordings folder ([`super::recording_shelf`]); it goes with the head.
    pub fn recordings_dir(&self, id: &str) -> PathBuf {
        self.dir(id).join("recordings")
    }

    pub fn save(&self, record: &HeadRecord) -> Result<(), StoreError> {
        let dir = self.dir(&record.id);
        std::fs::create_dir_all(&dir).map_err(io(&dir))?;
        let obj = dir.join("head.obj");
        write_atomic(&obj, &record.obj).map_err(io(&obj))?;
        let fit = dir.join("fit.toml");
        write_atomic(&fit, record.fit_toml.as_bytes()).map_err(io(&fit))?;
        if !record.parts.is_empty() {
            let parts = dir.join("parts");
            std::fs::create_dir_all(&parts).map_err(io(&parts))?;
            for part in &record.parts {
                let path = parts.join(format!("{}.obj", part.name));
                write_atomic(&path, &part.obj).map_err(io(&path))?;
            }
        }
        if let Some(texture) = &record.texture {
            let path = dir.join("texture");
            write_atomic(&path, texture).map_err(io(&path))?;
        }
        if let Some(basis) = &record.arkit_basis {
            let path = dir.join(ARKIT_BASIS_FILE);
            write_atomic(&path, basis.as_bytes()).map_err(io(&path))?;
        }
        self.save_meta(&record.id, &record.meta.listing(&record.parts))
    }

    fn save_meta(&self, id: &str, meta: &HeadMeta) -> Result<(), StoreError> {
        let path = self.dir(id).join("head.json");
        let text = serde_json::to_vec_pretty(meta).expect("metadata serializes");
        write_atomic(&path, &text).map_err(io(&path))
    }

    /// Removes a head's folder, complete or not; nothing there is fine.
    pub fn delete(&self, id: &str) -> Result<(), StoreError> {
        let dir = self.dir(id);
        let meta = dir.join("head.json");
        match std::fs::remove_file(&meta) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(io(&meta)(e)),
        }
        match std::fs::remove_dir_all(&dir) {
            Ok(()) => Ok(()),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
            Err(e) => Err(io(&dir)(e)),
        }
    }

    /// Every complete head folder, sorted by id. Leftovers of interrupted writes are
    /// removed; folders that cannot be loaded are reported beside the records.
    pub fn load_all(&self) -> Result<StoredHeads, StoreError> {
        let mut found = StoredHeads::default();
        let mut entries: Vec<_> = std::fs::read_dir(&self.root)
            .map_err(io(&self.root))?
            .filter_map(Result::ok)
            .collect();
        entries.sort_by_key(|e| e.file_name());
        for entry in entries {
            let path = entry.path();
            let name = entry.file_name().to_string_lossy().into_owned();
            if !path.is_dir() {
                if name.starts_with(".tmp") {
                    std::fs::remove_file(&path).map_err(io(&path))?;
                    found.cleaned.push(path.display().to_string());
                }
                continue;
            }
            if !super::ids::valid_id(&name) {
                found.broken.push(BrokenHead {
                    id: None,
                    problem: StoreError::Invalid {
                        path: path.display().to_string(),
                        message: "not a valid head id (1-64 of a-z 0-9 - _): skipped".into(),
                    },
                });
                continue;
            }
            for leftover in std::fs::read_dir(&path)
                .map_err(io(&path))?
                .filter_map(Result::ok)
            {
                if leftover.file_name().to_string_lossy().starts_with(".tmp") {
                    std::fs::remove_file(leftover.path()).map_err(io(&leftover.path()))?;
                    found.cleaned.push(leftover.path().display().to_string());
                }
            }
            if !path.join("head.json").exists() {
                self.delete(&name)?;
                found.cleaned.push(path.display().to_string());
                continue;
            }
            match self.load(&name) {
                Ok(record) => found.records.push(record),
                Err(problem) => found.broken.push(BrokenHead {
                    id: Some(name),
                    problem,
                }),
            }
        }
        Ok(found)
    }

    /// Head `id` as stored.
    pub fn load(&self, id: &str) -> Result<HeadRecord, StoreError> {
        let dir = self.dir(id);
        let meta_path = dir.join("head.json");
        let meta_text = std::fs::read(&meta_path).map_err(io(&meta_path))?;
        let mut meta: HeadMeta = serde_json::from_slice(&meta_text).map_err(|e| StoreError::Invalid {
            path: meta_path.display().to_string(),
            message: e.to_string(),
        })?;
        if let Some(token) = meta.producer_token.take() {
            meta = HeadMeta::with_producer_token(Some(&token));
            self.save_meta(id, &meta)?;
        }
        let obj_path = dir.join("head.obj");
        let fit_path = dir.join("fit.toml");
        let mut parts = Vec::with_capacity(meta.parts.len());
        for part in &meta.parts {
            if !super::ids::valid_id(&part.name) {
                return Err(StoreError::Invalid {
                    path: meta_path.display().to_string(),
                    message: format!("part name {:?} is not 1-64 of a-z 0-9 - _", part.name),
                });
            }
            let path = dir.join("parts").join(format!("{}.obj", part.name));
            parts.push(PartRecord {
                name: part.name.clone(),
                role: part.role,
                obj: std::fs::read(&path).map_err(io(&path))?,
            });
        }
        let texture_path = dir.join("texture");
        let texture = match std::fs::read(&texture_path) {
            Ok(bytes) => {
                super::texture_image::check(&bytes).map_err(|e| StoreError::Invalid {
                    path: texture_path.display().to_string(),
                    message: e.to_string(),
                })?;
                Some(bytes)
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => return Err(io(&texture_path)(e)),
        };
        let basis_path = dir.join(ARKIT_BASIS_FILE);
        let arkit_basis = match std::fs::read_to_string(&basis_path) {
            Ok(text) => Some(text),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => return Err(io(&basis_path)(e)),
        };
        Ok(HeadRecord {
            id: id.to_string(),
            obj: std::fs::read(&obj_path).map_err(io(&obj_path))?,
            fit_toml: std::fs::read_to_string(&fit_path).map_err(io(&fit_path))?,
            parts,
            texture,
            arkit_basis,
            meta,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(id: &str) -> HeadRecord {
        HeadRecord {
            id: id.into(),
            obj: b"v 0 0 0\n".to_vec(),
            fit_toml: "scale = 1.0\n".into(),
            parts: Vec::new(),
            texture: None,
            arkit_basis: None,
            meta: HeadMeta::with_producer_token(Some("t")),
        }
    }

    #[test]
    fn parts_are_stored_with_their_roles_and_loaded_back() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path()).unwrap();
        let mut head = record("h2");
        head.parts = vec![
            PartRecord {
                name: "teeth".into(),
                role: None,
                obj: b"v 1 0 0\n".to_vec(),
            },
            PartRecord {
                name: "tongue".into(),
                role: Some(PartRole::Tongue),
                obj: b"v 2 0 0\n".to_vec(),
            },
        ];
        store.save(&head).unwrap();
        assert_eq!(
            std::fs::read(dir.path().join("heads/h2/parts/tongue.obj")).unwrap(),
            b"v 2 0 0\n"
        );
        let loaded = store.load_all().unwrap().records.remove(0);
        assert_eq!(loaded.parts, head.parts);
        assert_eq!(loaded.meta.parts.len(), 2);
        assert_eq!(loaded.meta.parts[1].role, Some(PartRole::Tongue));
    }

    #[test]
    fn a_texture_is_stored_and_loaded_back_and_a_broken_one_named() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path()).unwrap();
        let mut head = record("h3");
        let mut png = vec![0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n', 0, 0, 0, 13];
        png.extend_from_slice(b"IHDR");
        png.extend_from_slice(&[0, 0, 0, 4, 0, 0, 0, 2, 8, 2, 0, 0, 0]);
        head.texture = Some(png);
        store.save(&head).unwrap();
        assert_eq!(store.load("h3").unwrap(), head);
        std::fs::write(dir.path().join("heads/h3/texture"), b"not an image").unwrap();
        let error = store.load("h3").unwrap_err().to_string();
        assert!(
            error.contains("heads/h3/texture") && error.contains("not a PNG or JPEG"),
            "{error}"
        );
    }

    #[test]
    fn an_own_arkit_basis_is_stored_with_its_blendshapes_and_loaded_back() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path()).unwrap();
        let mut head = record("h4");
        head.arkit_basis = Some("jawOpen\t3\t0\t-0.1\t0\n".into());
        head.meta.arkit_blendshapes = vec!["jawOpen".into(), "tongueOut".into()];
        store.save(&head).unwrap();
        assert_eq!(
            std::fs::read_to_string(dir.path().join("heads/h4/arkit_basis.tsv")).unwrap(),
            "jawOpen\t3\t0\t-0.1\t0\n"
        );
        let stored = std::fs::read_to_string(dir.path().join("heads/h4/head.json")).unwrap();
        assert!(stored.contains("\"arkit_blendshapes\""), "{stored}");
        assert_eq!(store.load("h4").unwrap(), head);
        // A head without one writes neither.
        store.save(&record("h5")).unwrap();
        assert!(!dir.path().join("heads/h5/arkit_basis.tsv").exists());
        let stored = std::fs::read_to_string(dir.path().join("heads/h5/head.json")).unwrap();
        assert!(!stored.contains("arkit"), "{stored}");
    }

    #[test]
    fn saves_loads_and_deletes() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path()).unwrap();
        store.save(&record("h1")).unwrap();
        let stored = std::fs::read_to_string(dir.path().join("heads/h1/head.json")).unwrap();
        assert!(
            !stored.contains("\"t\""),
            "the token itself is not stored: {stored}"
        );
        assert_eq!(store.load_all().unwrap().records, vec![record("h1")]);
        store.delete("h1").unwrap();
        assert!(store.load_all().unwrap().records.is_empty());
    }

    #[test]
    fn leftovers_are_cleaned_and_bad_folders_reported() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path()).unwrap();
        store.save(&record("good")).unwrap();
        let heads = dir.path().join("heads");
        std::fs::create_dir_all(heads.join("partial")).unwrap();
        std::fs::write(heads.join("partial/head.obj"), "v 0 0 0\n").unwrap();
        std::fs::write(heads.join("good/.tmpAbC123"), "half").unwrap();
        std::fs::write(heads.join(".tmpXyZ"), "half").unwrap();
        std::fs::create_dir_all(heads.join("Not Valid")).unwrap();
        std::fs::create_dir_all(heads.join("corrupt")).unwrap();
        std::fs::write(heads.join("corrupt/head.json"), "{").unwrap();
        let found = store.load_all().unwrap();
        assert_eq!(found.records, vec![record("good")]);
        assert_eq!(found.cleaned.len(), 3, "{:?}", found.cleaned);
        assert!(!heads.join("partial").exists());
        assert!(!heads.join("good/.tmpAbC123").exists());
        let broken: Vec<_> = found.broken.iter().map(|b| b.id.clone()).collect();
        assert_eq!(broken, vec![None, Some("corrupt".to_string())]);
        assert!(found.broken[0].problem.to_string().contains("Not Valid"));
        store.delete("corrupt").unwrap();
        assert!(!heads.join("corrupt").exists());
    }

    #[test]
    fn stored_plain_tokens_are_replaced_by_their_digest() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path()).unwrap();
        store.save(&record("h")).unwrap();
        std::fs::write(dir.path().join("heads/h/head.json"), r#"{"producer_token":"t"}"#).unwrap();
        let found = store.load_all().unwrap();
        assert_eq!(found.records[0].meta.producer_token(), Some(TokenDigest::of("t")));
        let stored = std::fs::read_to_string(dir.path().join("heads/h/head.json")).unwrap();
        assert!(
            stored.contains("producer_token_sha256") && !stored.contains("\"t\""),
            "{stored}"
        );
    }
}
