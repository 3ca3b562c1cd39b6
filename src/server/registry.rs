//! The registered heads: adding one (stored first, then registered in the background),
//! deleting one (its streams end, its registration stops, its folder goes), loading the
//! data directory at start, and the sweep that drops streams nobody uses. A cheap handle
//! around shared state; its locks are std mutexes never held across an `.await`.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use tokio::sync::{OwnedSemaphorePermit, Semaphore};
use tokio_util::sync::CancellationToken;

use super::error::ApiError;
use super::head::{HeadEntry, HeadStatus, StreamLimits};
use super::head_store::HeadStore;
use super::ids::valid_id;
use super::registration::{register, RegistrationError, RegistrationInput};
use super::store::{HeadMeta, HeadRecord};
use super::trim::release_memory;
use crate::head::MeshBudget;
use facewire_proto::codes::EndReason;

/// Registry limits, from the configuration.
#[derive(Debug, Clone)]
pub struct RegistryLimits {
    /// Vertices and triangles of a head and its parts together.
    pub budget: MeshBudget,
    pub max_heads: usize,
    pub max_bindings: usize,
    pub max_registrations: usize,
    pub streams: StreamLimits,
}

/// Shared registry of heads; cloning is cheap.
#[derive(Clone)]
pub struct Registry {
    inner: Arc<Inner>,
}

struct Inner {
    heads: Mutex<HashMap<String, Arc<HeadEntry>>>,
    store: HeadStore,
    limits: RegistryLimits,
    registrations: Arc<Semaphore>,
    shutdown: CancellationToken,
    /// Stored folders that could not be loaded and have no valid id to delete them by.
    problems: Mutex<Vec<String>>,
}

impl Registry {
    pub fn new(store: HeadStore, limits: RegistryLimits, shutdown: CancellationToken) -> Registry {
        Registry {
            inner: Arc::new(Inner {
                heads: Mutex::new(HashMap::new()),
                store,
                registrations: Arc::new(Semaphore::new(limits.max_registrations)),
                limits,
                shutdown,
                problems: Mutex::new(Vec::new()),
            }),
        }
    }

    /// Where heads are kept beyond this process.
    pub fn store(&self) -> &HeadStore {
        &self.inner.store
    }

    pub fn get(&self, id: &str) -> Option<Arc<HeadEntry>> {
        self.inner.heads.lock().expect("heads lock").get(id).cloned()
    }

    /// A head that exists, or `unknown_head`.
    pub fn head(&self, id: &str) -> Result<Arc<HeadEntry>, ApiError> {
        self.get(id).ok_or_else(|| ApiError::UnknownHead(id.to_string()))
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

    pub fn problems(&self) -> Vec<String> {
        self.inner.problems.lock().expect("problems lock").clone()
    }

    /// The budget a head and its parts are read within.
    pub fn budget(&self) -> MeshBudget {
        self.inner.limits.budget
    }

    /// Registration slots in use now (uploads, fits, registrations, fit pictures).
    pub fn busy_slots(&self) -> usize {
        self.inner.limits.max_registrations - self.inner.registrations.available_permits()
    }

    /// `limit_reached` when the server holds `max_heads` heads already.
    pub fn check_room(&self) -> Result<(), ApiError> {
        let held = self.inner.heads.lock().expect("heads lock").len();
        match held < self.inner.limits.max_heads {
            true => Ok(()),
            false => Err(self.full()),
        }
    }

    fn full(&self) -> ApiError {
        ApiError::LimitReached(format!(
            "this server holds {} heads, the most it takes (max_heads); delete one first",
            self.inner.limits.max_heads
        ))
    }

    /// A registration slot: at most `max_registrations` uploads, registrations and fit
    /// pictures run at once. Waits up to `wait` for one.
    pub async fn registration_slot(&self, wait: Duration) -> Result<OwnedSemaphorePermit, ApiError> {
        let acquire = self.inner.registrations.clone().acquire_owned();
        match tokio::time::timeout(wait, acquire).await {
            Ok(Ok(permit)) => Ok(permit),
            Ok(Err(_)) => Err(ApiError::ShuttingDown),
            Err(_) => Err(ApiError::LimitReached(format!(
                "{} registrations are running, the most at once; try again later",
                self.inner.limits.max_registrations
            ))),
        }
    }

    /// Adds a head and starts its registration in the background, holding `slot` until it
    /// finishes. `persist` stores it first (false when it was just loaded from there).
    pub async fn register(
        &self,
        mut record: HeadRecord,
        persist: bool,
        slot: OwnedSemaphorePermit,
    ) -> Result<Arc<HeadEntry>, ApiError> {
        if !valid_id(&record.id) {
            return Err(ApiError::BadId {
                what: "head id",
                id: record.id,
            });
        }
        if persist {
            if let HeadStore::Cluster { .. } = self.inner.store {
                record.meta.registration_tag = Some(super::ids::unique_name("reg"));
            }
        }
        let entry = {
            let mut heads = self.inner.heads.lock().expect("heads lock");
            if heads.contains_key(&record.id) {
                return Err(ApiError::HeadExists(record.id));
            }
            if heads.len() >= self.inner.limits.max_heads {
                return Err(self.full());
            }
            let entry = Arc::new(HeadEntry::new(
                record.id.clone(),
                record.meta.clone(),
                HeadStatus::Registering { progress: 0.0 },
                self.inner.limits.streams.clone(),
                self.inner.store.recordings_dir(&record.id),
            ));
            heads.insert(entry.id.clone(), entry.clone());
            entry
        };
        let record = match persist {
            true => match self.inner.store.save(record).await {
                Ok(record) => record,
                Err(e) => return Err(self.forget(&entry, e)),
            },
            false => record,
        };
        let input = RegistrationInput {
            obj: record.obj,
            fit_toml: record.fit_toml,
            parts: record.parts,
            texture: record.texture,
            arkit_basis: record.arkit_basis,
            arkit_blendshapes: record.meta.arkit_blendshapes,
            budget: self.inner.limits.budget,
            max_bindings: self.inner.limits.max_bindings,
        };
        let job_entry = entry.clone();
        let shutdown = self.inner.shutdown.clone();
        tokio::task::spawn_blocking(move || {
            let _slot = slot;
            let cancelled = || job_entry.deleted.is_cancelled() || shutdown.is_cancelled();
            let progress = |p| job_entry.set_status(HeadStatus::Registering { progress: p });
            let status = match register(input, cancelled, progress) {
                Ok(ready) => {
                    tracing::info!(
                        head = %job_entry.id,
                        vertices = ready.animated.registration.vertex_count(),
                        fit_surface_mean_mm = ready.fit.surface_mean_mm,
                        fit_surface_max_mm = ready.fit.surface_max_mm,
                        "head registered"
                    );
                    job_entry.recordings.restore(&job_entry.id);
                    HeadStatus::Ready(Arc::new(ready))
                }
                Err(RegistrationError::Cancelled) => {
                    tracing::info!(head = %job_entry.id, "registration cancelled");
                    HeadStatus::Failed("registration cancelled".into())
                }
                Err(e) => {
                    tracing::warn!(head = %job_entry.id, error = %e, "registration failed");
                    HeadStatus::Failed(e.to_string())
                }
            };
            job_entry.set_status(status);
            release_memory();
        });
        Ok(entry)
    }

    /// Drops an entry whose registration could not start (only that entry: in a cluster,
    /// another node's head of the same id may have replaced it meanwhile); passes its
    /// error on.
    fn forget(&self, entry: &Arc<HeadEntry>, error: ApiError) -> ApiError {
        let mut heads = self.inner.heads.lock().expect("heads lock");
        if heads.get(&entry.id).is_some_and(|held| Arc::ptr_eq(held, entry)) {
            heads.remove(&entry.id);
        }
        error
    }

    /// Removes a head: its streams end, its sockets close, its registration stops and its
    /// stored copy (complete, partial or broken; in the cluster, on every node) is removed.
    pub async fn delete(&self, id: &str) -> Result<(), ApiError> {
        if !valid_id(id) {
            return Err(ApiError::UnknownHead(id.to_string()));
        }
        let stored_problem = {
            let mut problems = self.inner.problems.lock().expect("problems lock");
            let before = problems.len();
            problems.retain(|p| !p.starts_with(&format!("{id}: ")));
            problems.len() != before
        };
        let known_here = self.get(id).is_some();
        let kept = self.inner.store.delete(id).await?;
        let dropped = self.drop_local(id);
        if !known_here && !dropped && !stored_problem && !kept {
            return Err(ApiError::UnknownHead(id.to_string()));
        }
        Ok(())
    }

    /// Drops head `id` from this node only (its stored copy stays): its streams end, its
    /// sockets close, its registration stops. False when this node did not have it.
    pub fn drop_local(&self, id: &str) -> bool {
        let Some(entry) = self.inner.heads.lock().expect("heads lock").remove(id) else {
            return false;
        };
        entry.end_streams(EndReason::HeadDeleted);
        entry.deleted.cancel();
        drop(entry);
        tokio::task::spawn_blocking(release_memory);
        true
    }

    /// Registers every head stored in the data directory; heads that cannot be loaded
    /// are listed as failed (and can be deleted), folders with no valid id are reported
    /// in `/healthz`. Returns how many heads are registering.
    pub async fn load_stored(&self) -> Result<usize, ApiError> {
        let Some(store) = self.inner.store.dir().cloned() else {
            return Ok(0);
        };
        let found = tokio::task::spawn_blocking(move || store.load_all())
            .await
            .map_err(ApiError::internal)?
            .map_err(ApiError::internal)?;
        for path in &found.cleaned {
            tracing::info!(%path, "removed the leftover of an interrupted write");
        }
        for broken in found.broken {
            tracing::warn!(problem = %broken.problem, "stored head skipped");
            match broken.id {
                Some(id) => {
                    let entry = HeadEntry::new(
                        id.clone(),
                        HeadMeta::default(),
                        HeadStatus::Failed(format!("stored head cannot be loaded: {}", broken.problem)),
                        self.inner.limits.streams.clone(),
                        None,
                    );
                    self.inner
                        .heads
                        .lock()
                        .expect("heads lock")
                        .insert(id, Arc::new(entry));
                }
                None => self
                    .inner
                    .problems
                    .lock()
                    .expect("problems lock")
                    .push(broken.problem.to_string()),
            }
        }
        let count = found.records.len();
        for record in found.records {
            let slot = self.registration_slot(Duration::MAX).await?;
            self.register(record, false, slot).await?;
        }
        Ok(count)
    }

    /// Drops unused streams of every head, every `period`, until shutdown.
    pub async fn sweep_streams(&self, period: Duration) {
        let mut ticks = tokio::time::interval(period);
        ticks.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        loop {
            tokio::select! {
                _ = self.inner.shutdown.cancelled() => return,
                now = ticks.tick() => {
                    for head in self.list() {
                        head.sweep(now);
                    }
                }
            }
        }
    }
}
