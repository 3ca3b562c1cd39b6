//! Where registered heads live between runs: one folder per head in the data directory
//! (`heads/<id>/head.obj`, `fit.toml`, `head.json`), every file written atomically.
//! `head.json` is written last and removed first, so a folder without it is an
//! interrupted write and is skipped (and reported) on load.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::atomic::write_atomic;

/// What a head was registered with: enough to register it again after a restart.
#[derive(Debug, Clone, PartialEq)]
pub struct HeadRecord {
    pub id: String,
    pub obj: Vec<u8>,
    pub fit_toml: String,
    pub meta: HeadMeta,
}

#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct HeadMeta {
    /// The head's own producer token, if it was registered with one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub producer_token: Option<String>,
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

    pub fn save(&self, record: &HeadRecord) -> Result<(), StoreError> {
        let dir = self.dir(&record.id);
        std::fs::create_dir_all(&dir).map_err(io(&dir))?;
        let obj = dir.join("head.obj");
        write_atomic(&obj, &record.obj).map_err(io(&obj))?;
        let fit = dir.join("fit.toml");
        write_atomic(&fit, record.fit_toml.as_bytes()).map_err(io(&fit))?;
        let meta = dir.join("head.json");
        let text = serde_json::to_vec_pretty(&record.meta).expect("metadata serializes");
        write_atomic(&meta, &text).map_err(io(&meta))
    }

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

    /// Every complete head folder, sorted by id; problems with single folders are
    /// returned beside the records instead of failing the whole load.
    pub fn load_all(&self) -> Result<(Vec<HeadRecord>, Vec<StoreError>), StoreError> {
        let mut records = Vec::new();
        let mut problems = Vec::new();
        let mut entries: Vec<_> = std::fs::read_dir(&self.root)
            .map_err(io(&self.root))?
            .filter_map(Result::ok)
            .filter(|e| e.path().is_dir())
            .collect();
        entries.sort_by_key(|e| e.file_name());
        for entry in entries {
            let dir = entry.path();
            let id = entry.file_name().to_string_lossy().into_owned();
            let meta_path = dir.join("head.json");
            if !meta_path.exists() {
                problems.push(StoreError::Invalid {
                    path: dir.display().to_string(),
                    message: "incomplete (no head.json): skipped".into(),
                });
                continue;
            }
            let load = || -> Result<HeadRecord, StoreError> {
                let meta_text = std::fs::read(&meta_path).map_err(io(&meta_path))?;
                let meta: HeadMeta = serde_json::from_slice(&meta_text).map_err(|e| StoreError::Invalid {
                    path: meta_path.display().to_string(),
                    message: e.to_string(),
                })?;
                let obj_path = dir.join("head.obj");
                let fit_path = dir.join("fit.toml");
                Ok(HeadRecord {
                    id: id.clone(),
                    obj: std::fs::read(&obj_path).map_err(io(&obj_path))?,
                    fit_toml: std::fs::read_to_string(&fit_path).map_err(io(&fit_path))?,
                    meta,
                })
            };
            match load() {
                Ok(record) => records.push(record),
                Err(e) => problems.push(e),
            }
        }
        Ok((records, problems))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn saves_loads_and_deletes() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path()).unwrap();
        let record = HeadRecord {
            id: "h1".into(),
            obj: b"v 0 0 0\n".to_vec(),
            fit_toml: "scale = 1.0\n".into(),
            meta: HeadMeta {
                producer_token: Some("t".into()),
            },
        };
        store.save(&record).unwrap();
        std::fs::create_dir_all(dir.path().join("heads/broken")).unwrap();
        let (records, problems) = store.load_all().unwrap();
        assert_eq!(records, vec![record]);
        assert_eq!(problems.len(), 1);
        assert!(problems[0].to_string().contains("broken"));
        store.delete("h1").unwrap();
        assert!(store.load_all().unwrap().0.is_empty());
    }
}
