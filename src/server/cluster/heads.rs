//! The head registry shared by every node. A head's metadata and fit are one JSON value
//! under its id in the key-value bucket `facewire_heads`; its mesh and parts are objects
//! `<id>/<tag>/head.obj` and `<id>/<tag>/parts/<name>.obj` in the object store
//! `facewire_meshes`, where the tag tells registrations of the same id apart. Objects are
//! written before the key and removed after it, so a node that sees a key finds its
//! meshes. Every node follows the bucket from its start (the current value of every key
//! first, then changes) and registers or drops heads to match; bindings stay local.

use std::time::Duration;

use async_nats::jetstream::{self, kv, object_store};
use bytes::Bytes;
use futures_util::StreamExt;
use serde::{Deserialize, Serialize};
use tokio::io::AsyncReadExt;
use tokio::sync::mpsc;
use tokio_util::sync::CancellationToken;

use crate::server::store::{HeadMeta, HeadRecord, PartRecord};

const HEADS_BUCKET: &str = "facewire_heads";
const MESHES_BUCKET: &str = "facewire_meshes";
/// How long a follower waits before watching again after the watch failed.
const REWATCH: Duration = Duration::from_secs(1);
/// Changes read from the bucket and not yet applied: the watch waits beyond this.
const CHANGES_WAITING: usize = 64;

/// The value under a head's id.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SharedHead {
    tag: String,
    fit_toml: String,
    /// Lists the parts; their meshes are objects.
    meta: HeadMeta,
}

/// A change to the shared registry, as [`ClusterHeads::changes`] reports it.
#[derive(Debug)]
pub enum HeadChange {
    /// `id` was registered (again) somewhere; [`ClusterHeads::load`] reads its meshes.
    Put {
        id: String,
        head: SharedHead,
    },
    Deleted {
        id: String,
    },
}

impl HeadChange {
    /// The change a bucket entry makes; `None` for a value that is not a head.
    fn of(entry: kv::Entry) -> Option<HeadChange> {
        let id = entry.key;
        if entry.operation != kv::Operation::Put {
            return Some(HeadChange::Deleted { id });
        }
        match serde_json::from_slice(&entry.value) {
            Ok(head) => Some(HeadChange::Put { id, head }),
            Err(e) => {
                tracing::warn!(head = %id, error = %e, "cluster registry entry skipped");
                None
            }
        }
    }
}

impl SharedHead {
    /// Tells registrations of the same id apart.
    pub fn tag(&self) -> &str {
        &self.tag
    }
}

#[derive(Debug, thiserror::Error)]
pub enum SharedHeadError {
    #[error("head {0:?} is already registered in the cluster")]
    Exists(String),
    #[error("cluster registry: {0}")]
    Bus(String),
}

fn bus(e: impl std::fmt::Display) -> SharedHeadError {
    SharedHeadError::Bus(e.to_string())
}

/// The shared registry's buckets; cloning is cheap.
#[derive(Clone)]
pub struct ClusterHeads {
    kv: kv::Store,
    objects: object_store::ObjectStore,
    /// To refuse at once, rather than after a timeout, while NATS is away.
    client: async_nats::Client,
}

fn mesh_name(id: &str, tag: &str) -> String {
    format!("{id}/{tag}/head.obj")
}

fn part_name(id: &str, tag: &str, part: &str) -> String {
    format!("{id}/{tag}/parts/{part}.obj")
}

impl ClusterHeads {
    /// Opens the buckets, making them (one replica) if this is the cluster's first node;
    /// buckets an operator made first, with more replicas, are used as they are. The error
    /// names the bucket.
    pub async fn open(
        js: &jetstream::Context,
        client: async_nats::Client,
    ) -> Result<ClusterHeads, (&'static str, String)> {
        let kv = match js.get_key_value(HEADS_BUCKET).await {
            Ok(kv) => kv,
            Err(_) => js
                .create_key_value(kv::Config {
                    bucket: HEADS_BUCKET.into(),
                    description: "facewire: registered heads (metadata and fit)".into(),
                    history: 1,
                    storage: jetstream::stream::StorageType::File,
                    ..Default::default()
                })
                .await
                .map_err(|e| (HEADS_BUCKET, e.to_string()))?,
        };
        let objects = match js.get_object_store(MESHES_BUCKET).await {
            Ok(objects) => objects,
            Err(_) => js
                .create_object_store(object_store::Config {
                    bucket: MESHES_BUCKET.into(),
                    description: Some("facewire: head and part meshes (OBJ)".into()),
                    storage: jetstream::stream::StorageType::File,
                    ..Default::default()
                })
                .await
                .map_err(|e| (MESHES_BUCKET, e.to_string()))?,
        };
        Ok(ClusterHeads { kv, objects, client })
    }

    /// Stores a new head for every node; `record.meta.registration_tag` must be set.
    /// Fails with `Exists` when any node has registered the id.
    pub async fn save(&self, record: &HeadRecord) -> Result<(), SharedHeadError> {
        self.check_connected()?;
        let id = record.id.as_str();
        let tag = record.meta.registration_tag.clone().unwrap_or_default();
        if self.current(id).await?.is_some() {
            return Err(SharedHeadError::Exists(id.to_string()));
        }
        let mut objects = vec![(mesh_name(id, &tag), &record.obj)];
        for part in &record.parts {
            objects.push((part_name(id, &tag, &part.name), &part.obj));
        }
        for (name, bytes) in &objects {
            self.objects
                .put(name.as_str(), &mut bytes.as_slice())
                .await
                .map_err(bus)?;
        }
        let value = SharedHead {
            tag: tag.clone(),
            fit_toml: record.fit_toml.clone(),
            meta: record.meta.listing(&record.parts),
        };
        let value = Bytes::from(serde_json::to_vec(&value).expect("head metadata serializes"));
        match self.kv.create(id, value).await {
            Ok(_) => Ok(()),
            Err(e) => {
                self.remove_objects(objects.iter().map(|(name, _)| name.clone()))
                    .await;
                match e.kind() {
                    kv::CreateErrorKind::AlreadyExists => Err(SharedHeadError::Exists(id.to_string())),
                    _ => Err(bus(e)),
                }
            }
        }
    }

    /// Removes a head for every node; false when the cluster has no such head.
    pub async fn delete(&self, id: &str) -> Result<bool, SharedHeadError> {
        self.check_connected()?;
        let Some(shared) = self.current(id).await? else {
            return Ok(false);
        };
        self.kv.delete(id).await.map_err(bus)?;
        let mut names = vec![mesh_name(id, &shared.tag)];
        for (part, _) in shared.meta.listed_parts() {
            names.push(part_name(id, &shared.tag, part));
        }
        self.remove_objects(names.into_iter()).await;
        Ok(true)
    }

    fn check_connected(&self) -> Result<(), SharedHeadError> {
        match self.client.connection_state() {
            async_nats::connection::State::Connected => Ok(()),
            _ => Err(SharedHeadError::Bus("not connected to NATS".into())),
        }
    }

    async fn current(&self, id: &str) -> Result<Option<SharedHead>, SharedHeadError> {
        match self.kv.entry(id).await.map_err(bus)? {
            Some(entry) if entry.operation == kv::Operation::Put => {
                serde_json::from_slice(&entry.value).map(Some).map_err(bus)
            }
            _ => Ok(None),
        }
    }

    async fn remove_objects(&self, names: impl Iterator<Item = String>) {
        for name in names {
            if let Err(e) = self.objects.delete(&name).await {
                tracing::warn!(object = %name, error = %e, "mesh object not removed");
            }
        }
    }

    async fn read_object(&self, name: &str) -> Result<Vec<u8>, SharedHeadError> {
        let mut object = self
            .objects
            .get(name)
            .await
            .map_err(|e| SharedHeadError::Bus(format!("{name}: {e}")))?;
        let mut bytes = Vec::new();
        object
            .read_to_end(&mut bytes)
            .await
            .map_err(|e| SharedHeadError::Bus(format!("{name}: {e}")))?;
        Ok(bytes)
    }

    pub async fn load(&self, id: &str, shared: SharedHead) -> Result<HeadRecord, SharedHeadError> {
        let obj = self.read_object(&mesh_name(id, &shared.tag)).await?;
        let mut parts = Vec::new();
        for (name, role) in shared.meta.listed_parts() {
            parts.push(PartRecord {
                name: name.to_string(),
                role,
                obj: self.read_object(&part_name(id, &shared.tag, name)).await?,
            });
        }
        Ok(HeadRecord {
            id: id.to_string(),
            obj,
            fit_toml: shared.fit_toml,
            parts,
            meta: shared.meta,
        })
    }

    /// Follows the bucket until `shutdown` or until the receiver is dropped: the current
    /// value of every key first, then each change, as [`HeadChange`]s in order. Watches
    /// again (from each key's current value, which is idempotent) when the watch fails, as
    /// it does while NATS restarts.
    pub fn changes(self, shutdown: CancellationToken) -> mpsc::Receiver<HeadChange> {
        let (tx, rx) = mpsc::channel(CHANGES_WAITING);
        tokio::spawn(async move {
            loop {
                match self.kv.watch_with_history(">").await {
                    Ok(mut changes) => loop {
                        let change = tokio::select! {
                            _ = shutdown.cancelled() => return,
                            change = changes.next() => change,
                        };
                        match change {
                            Some(Ok(entry)) => {
                                let Some(change) = HeadChange::of(entry) else {
                                    continue;
                                };
                                if tx.send(change).await.is_err() {
                                    return;
                                }
                            }
                            Some(Err(e)) => {
                                tracing::warn!(error = %e, "registry watch failed; watching again");
                                break;
                            }
                            None => break,
                        }
                    },
                    Err(e) => tracing::warn!(error = %e, "cannot watch the cluster registry; retrying"),
                }
                tokio::select! {
                    _ = shutdown.cancelled() => return,
                    _ = tokio::time::sleep(REWATCH) => {}
                }
            }
        });
        rx
    }
}
