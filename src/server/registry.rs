//! The registered heads: registration (parse, fit, bind inputs) off the async runtime
//! with visible progress, the per-head cache of bound algorithms, and the rest mesh in
//! the forms viewers download. A cheap handle around shared state; its locks are std
//! mutexes never held across an `.await`.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use bytes::Bytes;
use tokio::sync::OnceCell;

use super::channel::Channel;
use super::store::{HeadRecord, Store};
use crate::deform::{bind, AlgoSpec, Binding, Registration};
use crate::fit::{FitFile, FittedMask, Landmarks, SolveOptions};
use crate::head::Head;
use crate::mask::Mask;
use crate::metrics::LipRegion;
use facewire_proto::messages::HeadInfo;

/// Lowercase letters, digits, `-` and `_`, 1 to 64 of them.
pub fn valid_id(id: &str) -> bool {
    (1..=64).contains(&id.len())
        && id
            .bytes()
            .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-' || b == b'_')
}

/// A head ready to animate.
pub struct ReadyHead {
    pub registration: Registration,
    pub lip_region: LipRegion,
    /// `mesh.bin` (PROTOCOL.md) and OBJ of the rest mesh.
    pub rest_bin: Bytes,
    pub rest_obj: Bytes,
    /// Quantization step of viewer frames, head units (0.08 mm).
    pub step: f32,
    bindings: Mutex<HashMap<String, Arc<OnceCell<Arc<Binding>>>>>,
}

/// Largest quantization error of viewer frames is half of this, in mm.
pub const STEP_MM: f32 = 0.08;

impl ReadyHead {
    /// The binding for `spec`, bound once (off the runtime) and shared.
    pub async fn binding(self: &Arc<Self>, spec: &AlgoSpec) -> Arc<Binding> {
        let cell = self
            .bindings
            .lock()
            .expect("bindings lock")
            .entry(spec.to_string())
            .or_default()
            .clone();
        let head = self.clone();
        let spec = *spec;
        cell.get_or_init(|| async move {
            let binding = tokio::task::spawn_blocking(move || bind(&head.registration, &spec))
                .await
                .expect("binding does not panic");
            Arc::new(binding)
        })
        .await
        .clone()
    }

    pub fn bound_algorithms(&self) -> Vec<String> {
        let mut specs: Vec<String> = self
            .bindings
            .lock()
            .expect("bindings lock")
            .iter()
            .filter(|(_, cell)| cell.initialized())
            .map(|(s, _)| s.clone())
            .collect();
        specs.sort();
        specs
    }
}

#[derive(Clone)]
pub enum HeadStatus {
    Registering { progress: f32 },
    Ready(Arc<ReadyHead>),
    Failed(String),
}

/// One registered head and its streams.
pub struct HeadEntry {
    pub id: String,
    pub record: HeadRecord,
    status: Mutex<HeadStatus>,
    channels: Mutex<HashMap<String, Arc<Channel>>>,
}

impl HeadEntry {
    pub fn status(&self) -> HeadStatus {
        self.status.lock().expect("status lock").clone()
    }

    fn set_status(&self, status: HeadStatus) {
        *self.status.lock().expect("status lock") = status;
    }

    pub fn ready(&self) -> Option<Arc<ReadyHead>> {
        match self.status() {
            HeadStatus::Ready(r) => Some(r),
            _ => None,
        }
    }

    /// The stream's channel, created on first use.
    pub fn channel(&self, name: &str) -> Arc<Channel> {
        self.channels
            .lock()
            .expect("channels lock")
            .entry(name.to_string())
            .or_insert_with(|| Arc::new(Channel::new(name)))
            .clone()
    }

    pub fn channels(&self) -> Vec<Arc<Channel>> {
        self.channels
            .lock()
            .expect("channels lock")
            .values()
            .cloned()
            .collect()
    }

    pub fn info(&self) -> HeadInfo {
        let (status, progress, error, ready) = match self.status() {
            HeadStatus::Registering { progress } => ("registering", progress, None, None),
            HeadStatus::Ready(r) => ("ready", 1.0, None, Some(r)),
            HeadStatus::Failed(e) => ("failed", 0.0, Some(e), None),
        };
        let mut streams: Vec<String> = self.channels().iter().map(|c| c.name.clone()).collect();
        streams.sort();
        HeadInfo {
            id: self.id.clone(),
            vertices: ready.as_ref().map_or(0, |r| r.registration.vertex_count() as u32),
            triangles: ready
                .as_ref()
                .map_or(0, |r| r.registration.head.triangles.len() as u32),
            mm_per_unit: ready.as_ref().map_or(0.0, |r| r.registration.mm_per_unit()),
            status: status.into(),
            progress,
            error,
            streams,
            algorithms: ready.map(|r| r.bound_algorithms()).unwrap_or_default(),
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum RegistryError {
    #[error("head id {0:?} is not valid: use 1-64 lowercase letters, digits, '-' or '_'")]
    BadId(String),
    #[error("head {0:?} is already registered")]
    Exists(String),
    #[error("no head {0:?}")]
    Unknown(String),
    #[error("{0}")]
    Store(#[from] super::store::StoreError),
}

/// Shared registry of heads; cloning is cheap.
#[derive(Clone)]
pub struct Registry {
    inner: Arc<Inner>,
}

struct Inner {
    heads: Mutex<HashMap<String, Arc<HeadEntry>>>,
    store: Option<Store>,
    max_vertices: usize,
}

impl Registry {
    pub fn new(store: Option<Store>, max_vertices: usize) -> Registry {
        Registry {
            inner: Arc::new(Inner {
                heads: Mutex::new(HashMap::new()),
                store,
                max_vertices,
            }),
        }
    }

    pub fn get(&self, id: &str) -> Option<Arc<HeadEntry>> {
        self.inner.heads.lock().expect("heads lock").get(id).cloned()
    }

    pub fn list(&self) -> Vec<Arc<HeadEntry>> {
        let mut heads: Vec<_> = self
            .inner
            .heads
            .lock()
            .expect("heads lock")
            .values()
            .cloned()
            .collect();
        heads.sort_by(|a, b| a.id.cmp(&b.id));
        heads
    }

    /// Adds a head and starts its registration in the background. `persist` writes it to
    /// the data directory first (false when it was just loaded from there).
    pub fn register(&self, record: HeadRecord, persist: bool) -> Result<Arc<HeadEntry>, RegistryError> {
        if !valid_id(&record.id) {
            return Err(RegistryError::BadId(record.id));
        }
        let entry = {
            let mut heads = self.inner.heads.lock().expect("heads lock");
            if heads.contains_key(&record.id) {
                return Err(RegistryError::Exists(record.id));
            }
            let entry = Arc::new(HeadEntry {
                id: record.id.clone(),
                record,
                status: Mutex::new(HeadStatus::Registering { progress: 0.0 }),
                channels: Mutex::new(HashMap::new()),
            });
            heads.insert(entry.id.clone(), entry.clone());
            entry
        };
        if persist {
            if let Some(store) = &self.inner.store {
                if let Err(e) = store.save(&entry.record) {
                    self.inner.heads.lock().expect("heads lock").remove(&entry.id);
                    return Err(e.into());
                }
            }
        }
        let max_vertices = self.inner.max_vertices;
        let task_entry = entry.clone();
        tokio::task::spawn_blocking(move || {
            let progress = |p: f32| task_entry.set_status(HeadStatus::Registering { progress: p });
            let status = match prepare(&task_entry.record, max_vertices, progress) {
                Ok(ready) => {
                    tracing::info!(head = %task_entry.id, vertices = ready.registration.vertex_count(), "head registered");
                    HeadStatus::Ready(Arc::new(ready))
                }
                Err(message) => {
                    tracing::warn!(head = %task_entry.id, %message, "registration failed");
                    HeadStatus::Failed(message)
                }
            };
            task_entry.set_status(status);
        });
        Ok(entry)
    }

    /// Removes a head; its streams end.
    pub fn delete(&self, id: &str) -> Result<Arc<HeadEntry>, RegistryError> {
        let entry = self
            .inner
            .heads
            .lock()
            .expect("heads lock")
            .remove(id)
            .ok_or_else(|| RegistryError::Unknown(id.to_string()))?;
        if let Some(store) = &self.inner.store {
            store.delete(id)?;
        }
        for channel in entry.channels() {
            channel.end("head deleted");
        }
        Ok(entry)
    }

    /// Registers every head stored in the data directory.
    pub fn load_stored(&self) -> Result<usize, RegistryError> {
        let Some(store) = &self.inner.store else {
            return Ok(0);
        };
        let (records, problems) = store.load_all()?;
        for problem in problems {
            tracing::warn!(%problem, "stored head skipped");
        }
        let count = records.len();
        for record in records {
            self.register(record, false)?;
        }
        Ok(count)
    }
}

/// Parses, fits and registers a head (blocking; seconds for big heads).
fn prepare(record: &HeadRecord, max_vertices: usize, progress: impl Fn(f32)) -> Result<ReadyHead, String> {
    let head = Head::from_obj_bytes(&format!("{}.obj", record.id), &record.obj)
        .map_err(|e| format!("head.obj: {e}"))?;
    if head.positions.len() > max_vertices {
        return Err(format!(
            "head.obj has {} vertices; this server accepts at most {max_vertices}",
            head.positions.len()
        ));
    }
    progress(0.2);
    let mask = Mask::candide3();
    let fit = FitFile::parse("fit.toml", &record.fit_toml)
        .and_then(|f| f.resolve("fit.toml", &mask))
        .map_err(|e| e.to_string())?;
    progress(0.3);
    let registration = Registration::new(head, FittedMask::new(mask, fit));
    progress(0.9);
    let lip_region = LipRegion::new(
        &registration.head,
        &registration.anchors,
        registration.mm_per_unit(),
    )
    .map_err(|e| format!("lip region: {e}"))?;
    let step = STEP_MM / registration.mm_per_unit();
    Ok(ReadyHead {
        rest_bin: Bytes::from(mesh_bin(&registration)),
        rest_obj: Bytes::from(mesh_obj(&registration)),
        registration,
        lip_region,
        step,
        bindings: Mutex::new(HashMap::new()),
    })
}

/// `mesh.bin`: magic "FWM1", u32 vertex count, u32 triangle count, f32 mm per unit,
/// positions (3 x f32 each), triangles (3 x u32 each); little-endian.
fn mesh_bin(reg: &Registration) -> Vec<u8> {
    let head = &reg.head;
    let mut out = Vec::with_capacity(16 + head.positions.len() * 12 + head.triangles.len() * 12);
    out.extend_from_slice(b"FWM1");
    out.extend_from_slice(&(head.positions.len() as u32).to_le_bytes());
    out.extend_from_slice(&(head.triangles.len() as u32).to_le_bytes());
    out.extend_from_slice(&reg.mm_per_unit().to_le_bytes());
    for p in &head.positions {
        for x in p.to_array() {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    for t in &head.triangles {
        for v in t {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    out
}

fn mesh_obj(reg: &Registration) -> Vec<u8> {
    let mut out = Vec::new();
    crate::head::obj::write(
        &mut out,
        &["facewire rest mesh (head units)".to_string()],
        &reg.head.positions,
        &reg.head.triangles,
    )
    .expect("writing to memory cannot fail");
    out
}

/// Solves a fit from landmarks TOML for a registration request (blocking).
pub fn fit_from_landmarks(obj: &[u8], landmarks_toml: &str) -> Result<String, String> {
    let head = Head::from_obj_bytes("head.obj", obj).map_err(|e| format!("head.obj: {e}"))?;
    let landmarks: Landmarks = toml::from_str(landmarks_toml).map_err(|e| format!("landmarks: {e}"))?;
    let mask = Mask::candide3();
    landmarks
        .validate("landmarks", mask.vertices.len(), head.positions.len())
        .map_err(|e| e.to_string())?;
    let pairs: Vec<(u32, glam::DVec3)> = landmarks
        .landmarks
        .iter()
        .map(|l| (l.mask_vertex, head.positions[l.head_vertex as usize].as_dvec3()))
        .collect();
    let solution =
        crate::fit::solve_fit(&mask, &pairs, &[], &SolveOptions::default()).map_err(|e| e.to_string())?;
    let mm_per_unit = landmarks
        .mm_per_unit
        .unwrap_or_else(|| crate::fit::Fit::mm_per_unit_from_pupils(&mask, &solution.shape, &solution.pose));
    let fit = crate::fit::Fit {
        pose: solution.pose,
        shape: solution.shape,
        nudges: Vec::new(),
        mm_per_unit,
    };
    Ok(FitFile::from_fit(&fit, &mask, None).to_toml())
}
