//! The head registry shared by every node. A head's metadata and fit are one JSON value
//! under its id in the key-value bucket `facewire_heads`; its mesh, parts and texture are
//! objects `<id>/<tag>/head.obj`, `<id>/<tag>/parts/<name>.obj` and `<id>/<tag>/texture`
//! in the object store
//! `facewire_meshes`, where the tag tells registrations of the same id apart. Objects are
//! written before the key and removed after it, so a node that sees a key finds its
//! meshes. Every node follows the bucket from its start (the current value of every key
//! first, then changes) and registers or drops heads to match; bindings stay local.
//!
//! Nothing read from the buckets is believed without proof. Each value is sealed with the
//! cluster key ([`Seal`]) for its key, and names the size and SHA-256 of every object it
//! uses, so a mesh is checked against the record before it is used and refused past the
//! upload limit before it is read. A head is deleted by a sealed tombstone
//! (`{"deleted": tag}`) in place of its record: a key removed, or a value put, by anyone
//! without the key is reported as [`HeadChange::Unproven`] and the nodes that keep the
//! head put it back ([`ClusterHeads::republish`]).

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Duration;

use async_nats::jetstream::{self, kv, object_store};
use bytes::Bytes;
use futures_util::StreamExt;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use tokio::io::AsyncReadExt;
use tokio::sync::mpsc;
use tokio_util::sync::CancellationToken;

use super::seal::{hex, Seal};
use super::watch_lag::WatchLag;
use super::{open_key_value, stream_exists};
use crate::server::ids::valid_id;
use crate::server::store::{HeadMeta, HeadRecord, PartRecord};

const HEADS_BUCKET: &str = "facewire_heads";
const MESHES_BUCKET: &str = "facewire_meshes";
/// How long a follower waits before watching again after the watch failed.
const REWATCH: Duration = Duration::from_secs(1);
/// The longest a follower reads one head's meshes: a read the bus left hanging ends, and
/// is tried again. The largest mesh the HTTP limit admits, 64 MiB, reads in a few seconds.
const LOAD_WITHIN: Duration = Duration::from_secs(60);
/// How often a follower checks that its watch delivers what the bucket holds.
const LAG_CHECK: Duration = Duration::from_secs(3);
/// Changes read from the bucket and not yet applied: the watch waits beyond this.
const CHANGES_WAITING: usize = 64;

/// An object's size and content, as the record naming it says.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectDigest {
    bytes: u64,
    /// Lowercase hex.
    sha256: String,
}

impl ObjectDigest {
    fn of(bytes: &[u8]) -> ObjectDigest {
        ObjectDigest {
            bytes: bytes.len() as u64,
            sha256: hex(&Sha256::digest(bytes)),
        }
    }
}

/// The value under a head's id.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SharedHead {
    tag: String,
    fit_toml: String,
    /// Lists the parts; their meshes are objects.
    meta: HeadMeta,
    /// Every object the head uses, by its name under `<id>/<tag>/` (`head.obj`,
    /// `parts/<name>.obj`).
    objects: BTreeMap<String, ObjectDigest>,
}

/// The value under a deleted head's id: the tag of the registration deleted.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Tombstone {
    deleted: String,
}

/// A value in the heads bucket.
#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum SharedValue {
    Head(SharedHead),
    Deleted(Tombstone),
}

/// What a key of the heads bucket holds, once its proof is checked.
enum Held {
    /// Nothing, or a key removed (at `revision`) by someone who proved nothing.
    Nothing {
        revision: Option<u64>,
    },
    Head {
        head: SharedHead,
        revision: u64,
    },
    Deleted {
        revision: u64,
    },
    /// A value without a valid proof, or that is no head.
    Unproven {
        revision: u64,
        why: String,
    },
}

impl Held {
    fn revision(&self) -> Option<u64> {
        match self {
            Held::Nothing { revision } => *revision,
            Held::Head { revision, .. } | Held::Deleted { revision } | Held::Unproven { revision, .. } => {
                Some(*revision)
            }
        }
    }
}

/// A change to the shared registry, as [`ClusterHeads::changes`] reports it.
#[derive(Debug)]
pub enum HeadChange {
    /// `id` was registered (again) somewhere; [`ClusterHeads::load`] reads its meshes.
    Put { id: String, head: SharedHead },
    /// `id` was deleted by a node of the cluster.
    Deleted { id: String },
    /// `id`'s value was changed or removed without proof: a node that keeps the head
    /// puts it back.
    Unproven { id: String, why: String },
}

impl HeadChange {
    /// The head id the change is to.
    pub fn id(&self) -> &str {
        match self {
            HeadChange::Put { id, .. } | HeadChange::Deleted { id } | HeadChange::Unproven { id, .. } => id,
        }
    }
}

impl SharedHead {
    /// Tells registrations of the same id apart.
    pub fn tag(&self) -> &str {
        &self.tag
    }

    /// Whether the record names only what a registration may: its tag and part names
    /// are ids (they become folder and file names on each node), and it names the
    /// objects of exactly its mesh and parts, and perhaps a texture.
    fn check(&self) -> Result<(), String> {
        if !valid_id(&self.tag) {
            return Err(format!("tag {:?} is not an id", self.tag));
        }
        let mut expected = vec!["head.obj".to_string()];
        for (part, _) in self.meta.listed_parts() {
            if !valid_id(part) {
                return Err(format!("part name {part:?} is not an id"));
            }
            expected.push(format!("parts/{part}.obj"));
        }
        // A texture is the one object a head may have or not; its own ARKit basis comes
        // with the blendshapes it defines.
        if self.objects.contains_key("texture") {
            expected.push("texture".to_string());
        }
        if !self.meta.arkit_blendshapes.is_empty() {
            expected.push(ARKIT_BASIS_OBJECT.to_string());
        }
        expected.sort();
        let named: Vec<&String> = self.objects.keys().collect();
        if named != expected.iter().collect::<Vec<_>>() {
            return Err(format!(
                "names the objects {named:?}, its mesh, parts, texture and ARKit basis are {expected:?}"
            ));
        }
        Ok(())
    }
}

#[derive(Debug, thiserror::Error)]
pub enum SharedHeadError {
    #[error("head {0:?} is already registered in the cluster")]
    Exists(String),
    #[error("cluster registry: {0}")]
    Bus(String),
    #[error("cluster registry: head {id:?}: {message}")]
    Refused { id: String, message: String },
}

fn bus(e: impl std::fmt::Display) -> SharedHeadError {
    SharedHeadError::Bus(e.to_string())
}

/// How the buckets are made when a node finds them missing.
#[derive(Debug, Clone, Copy)]
pub struct BucketSettings {
    /// Copies JetStream keeps of each bucket (1, or 3 on a three-server NATS cluster).
    pub replicas: usize,
}

/// What [`ClusterHeads::republish`] found.
#[derive(Debug, PartialEq, Eq)]
pub enum Republished {
    /// The bucket already held this registration.
    Held,
    /// It was missing (or its value unproven) and is back.
    Restored,
    /// The bucket holds another registration of the id, or its tombstone: the copy kept
    /// is out of date.
    Superseded,
}

/// The shared registry's buckets; cloning is cheap.
#[derive(Clone)]
pub struct ClusterHeads {
    js: jetstream::Context,
    kv: kv::Store,
    objects: object_store::ObjectStore,
    /// To refuse at once, rather than after a timeout, while NATS is away.
    client: async_nats::Client,
    seal: Arc<Seal>,
    settings: BucketSettings,
    /// The largest object read from the bus (the HTTP upload limit).
    max_object_bytes: u64,
}

fn mesh_name(id: &str, tag: &str) -> String {
    format!("{id}/{tag}/head.obj")
}

fn part_name(id: &str, tag: &str, part: &str) -> String {
    format!("{id}/{tag}/parts/{part}.obj")
}

fn texture_name(id: &str, tag: &str) -> String {
    format!("{id}/{tag}/texture")
}

/// A head's own ARKit basis among its objects.
const ARKIT_BASIS_OBJECT: &str = "arkit_basis.tsv";

fn arkit_basis_name(id: &str, tag: &str) -> String {
    format!("{id}/{tag}/{ARKIT_BASIS_OBJECT}")
}

fn place(id: &str) -> String {
    format!("kv/{HEADS_BUCKET}/{id}")
}

async fn heads_bucket(js: &jetstream::Context, settings: BucketSettings) -> Result<kv::Store, String> {
    open_key_value(
        js,
        kv::Config {
            bucket: HEADS_BUCKET.into(),
            description: "facewire: registered heads (metadata and fit)".into(),
            history: 1,
            storage: jetstream::stream::StorageType::File,
            num_replicas: settings.replicas,
            ..Default::default()
        },
    )
    .await
}

async fn meshes_bucket(
    js: &jetstream::Context,
    settings: BucketSettings,
) -> Result<object_store::ObjectStore, String> {
    if let Ok(objects) = js.get_object_store(MESHES_BUCKET).await {
        return Ok(objects);
    }
    js.create_object_store(object_store::Config {
        bucket: MESHES_BUCKET.into(),
        description: Some("facewire: head and part meshes (OBJ)".into()),
        storage: jetstream::stream::StorageType::File,
        num_replicas: settings.replicas,
        ..Default::default()
    })
    .await
    .map_err(|e| e.to_string())
}

impl ClusterHeads {
    /// Opens the buckets, making them (with `settings.replicas`) if this is the cluster's
    /// first node; buckets an operator made first are used as they are. The error names
    /// the bucket.
    pub async fn open(
        js: &jetstream::Context,
        client: async_nats::Client,
        seal: Arc<Seal>,
        settings: BucketSettings,
        max_object_bytes: usize,
    ) -> Result<ClusterHeads, (&'static str, String)> {
        let kv = heads_bucket(js, settings).await.map_err(|e| (HEADS_BUCKET, e))?;
        let objects = meshes_bucket(js, settings)
            .await
            .map_err(|e| (MESHES_BUCKET, e))?;
        Ok(ClusterHeads {
            js: js.clone(),
            kv,
            objects,
            client,
            seal,
            settings,
            max_object_bytes: max_object_bytes as u64,
        })
    }

    /// Makes the buckets again if they are gone (an operator or a stranger deleted them);
    /// true when one was made. The handles stay valid: buckets are found by name.
    pub async fn ensure_buckets(&self) -> Result<bool, String> {
        let mut made = false;
        for (bucket, stream) in [
            (HEADS_BUCKET, format!("KV_{HEADS_BUCKET}")),
            (MESHES_BUCKET, format!("OBJ_{MESHES_BUCKET}")),
        ] {
            if stream_exists(&self.js, &stream).await? {
                continue;
            }
            let made_now = match bucket {
                HEADS_BUCKET => heads_bucket(&self.js, self.settings).await.map(drop),
                _ => meshes_bucket(&self.js, self.settings).await.map(drop),
            };
            made_now.map_err(|e| format!("bucket {bucket:?}: {e}"))?;
            tracing::warn!(bucket, "cluster registry bucket was gone; made it again");
            made = true;
        }
        Ok(made)
    }

    /// Stores a new head for every node; `record.meta.registration_tag` must be set.
    /// Fails with `Exists` when any node has registered the id.
    pub async fn save(&self, record: &HeadRecord) -> Result<(), SharedHeadError> {
        self.check_connected()?;
        let id = record.id.as_str();
        let held = self.held(id).await?;
        if matches!(held, Held::Head { .. }) {
            return Err(SharedHeadError::Exists(id.to_string()));
        }
        let names = self.put_objects(record).await?;
        match self.write_record(record, held.revision()).await {
            Ok(()) => Ok(()),
            Err(e) => {
                self.remove_objects(names.into_iter()).await;
                Err(e)
            }
        }
    }

    /// Puts a head this node keeps back into the bucket when its key holds nothing, or
    /// holds what nobody of the cluster wrote there.
    pub async fn republish(&self, record: &HeadRecord) -> Result<Republished, SharedHeadError> {
        self.check_connected()?;
        let tag = record.meta.registration_tag.as_deref().unwrap_or_default();
        let held = self.held(&record.id).await?;
        match &held {
            Held::Head { head, .. } if head.tag == tag => return Ok(Republished::Held),
            Held::Head { .. } | Held::Deleted { .. } => return Ok(Republished::Superseded),
            Held::Nothing { .. } | Held::Unproven { .. } => {}
        }
        self.put_objects(record).await?;
        match self.write_record(record, held.revision()).await {
            Ok(()) => Ok(Republished::Restored),
            // Another node put it back first.
            Err(SharedHeadError::Exists(_)) => Ok(Republished::Held),
            Err(e) => Err(e),
        }
    }

    /// Writes each of `record`'s meshes as an object; their names.
    async fn put_objects(&self, record: &HeadRecord) -> Result<Vec<String>, SharedHeadError> {
        let (id, tag) = (
            record.id.as_str(),
            record.meta.registration_tag.as_deref().unwrap_or_default(),
        );
        let mut objects: Vec<(String, &[u8])> = vec![(mesh_name(id, tag), &record.obj)];
        for part in &record.parts {
            objects.push((part_name(id, tag, &part.name), &part.obj));
        }
        if let Some(texture) = &record.texture {
            objects.push((texture_name(id, tag), texture));
        }
        if let Some(basis) = &record.arkit_basis {
            objects.push((arkit_basis_name(id, tag), basis.as_bytes()));
        }
        let mut names = Vec::with_capacity(objects.len());
        for (name, mut bytes) in objects {
            if let Err(e) = self.objects.put(name.as_str(), &mut bytes).await {
                self.remove_objects(names.into_iter()).await;
                return Err(bus(e));
            }
            names.push(name);
        }
        Ok(names)
    }

    /// Writes `record`'s sealed value: created when the key has never held anything
    /// (`revision` `None`), else in place of what it held at `revision`.
    async fn write_record(&self, record: &HeadRecord, revision: Option<u64>) -> Result<(), SharedHeadError> {
        let id = record.id.as_str();
        let tag = record.meta.registration_tag.clone().unwrap_or_default();
        let mut objects = BTreeMap::from([("head.obj".to_string(), ObjectDigest::of(&record.obj))]);
        for part in &record.parts {
            objects.insert(format!("parts/{}.obj", part.name), ObjectDigest::of(&part.obj));
        }
        if let Some(texture) = &record.texture {
            objects.insert("texture".to_string(), ObjectDigest::of(texture));
        }
        if let Some(basis) = &record.arkit_basis {
            objects.insert(ARKIT_BASIS_OBJECT.to_string(), ObjectDigest::of(basis.as_bytes()));
        }
        let value = SharedHead {
            tag,
            fit_toml: record.fit_toml.clone(),
            meta: record.meta.listing(&record.parts),
            objects,
        };
        let value = serde_json::to_vec(&value).expect("head metadata serializes");
        self.write(id, &value, revision).await
    }

    async fn write(&self, id: &str, value: &[u8], revision: Option<u64>) -> Result<(), SharedHeadError> {
        let sealed = Bytes::from(self.seal.seal(&place(id), value));
        let exists = || SharedHeadError::Exists(id.to_string());
        match revision {
            None => match self.kv.create(id, sealed).await {
                Ok(_) => Ok(()),
                Err(e) if e.kind() == kv::CreateErrorKind::AlreadyExists => Err(exists()),
                Err(e) => Err(bus(e)),
            },
            Some(revision) => match self.kv.update(id, sealed, revision).await {
                Ok(_) => Ok(()),
                Err(e) if e.kind() == kv::UpdateErrorKind::WrongLastRevision => Err(exists()),
                Err(e) => Err(bus(e)),
            },
        }
    }

    /// Removes a head for every node (a sealed tombstone in place of its record, then its
    /// objects); false when the cluster has no such head.
    pub async fn delete(&self, id: &str) -> Result<bool, SharedHeadError> {
        self.check_connected()?;
        let Held::Head { head, revision } = self.held(id).await? else {
            return Ok(false);
        };
        let tombstone = serde_json::to_vec(&Tombstone {
            deleted: head.tag.clone(),
        })
        .expect("a tombstone serializes");
        match self.write(id, &tombstone, Some(revision)).await {
            Ok(()) => {}
            // Registered again or deleted meanwhile: what is there now stays.
            Err(SharedHeadError::Exists(_)) => return Ok(true),
            Err(e) => return Err(e),
        }
        let names = head
            .objects
            .keys()
            .map(|name| format!("{id}/{}/{name}", head.tag));
        self.remove_objects(names).await;
        Ok(true)
    }

    fn check_connected(&self) -> Result<(), SharedHeadError> {
        match self.client.connection_state() {
            async_nats::connection::State::Connected => Ok(()),
            _ => Err(SharedHeadError::Bus("not connected to NATS".into())),
        }
    }

    async fn held(&self, id: &str) -> Result<Held, SharedHeadError> {
        Ok(match self.kv.entry(id).await.map_err(bus)? {
            None => Held::Nothing { revision: None },
            Some(entry) => self.classify(&entry),
        })
    }

    /// What `entry` holds, its proof checked.
    fn classify(&self, entry: &kv::Entry) -> Held {
        let revision = entry.revision;
        if entry.operation != kv::Operation::Put {
            // A removal carries no proof: believed only when nothing is sealed.
            return match self.seal.is_keyed() {
                true => Held::Nothing {
                    revision: Some(revision),
                },
                false => Held::Deleted { revision },
            };
        }
        let unproven = |why: String| Held::Unproven { revision, why };
        let Some(value) = self.seal.open(&place(&entry.key), &entry.value) else {
            return unproven("its value carries no valid proof of the cluster key".into());
        };
        match serde_json::from_slice(value) {
            Ok(SharedValue::Head(head)) => match head.check() {
                Ok(()) => Held::Head { head, revision },
                Err(why) => unproven(why),
            },
            Ok(SharedValue::Deleted(tombstone)) if valid_id(&tombstone.deleted) => Held::Deleted { revision },
            Ok(SharedValue::Deleted(tombstone)) => {
                unproven(format!("a tombstone of tag {:?}", tombstone.deleted))
            }
            Err(e) => unproven(format!("not a head record: {e}")),
        }
    }

    async fn remove_objects(&self, names: impl Iterator<Item = String>) {
        for name in names {
            if let Err(e) = self.objects.delete(&name).await {
                tracing::warn!(object = %name, error = %e, "mesh object not removed");
            }
        }
    }

    /// Object `name`, if it is what `digest` says: its size is checked before it is read.
    async fn read_object(
        &self,
        name: &str,
        digest: Option<&ObjectDigest>,
    ) -> Result<Vec<u8>, SharedHeadError> {
        let refused = |message: String| SharedHeadError::Bus(format!("object {name:?}: {message}"));
        let info = self
            .objects
            .info(name)
            .await
            .map_err(|e| refused(e.to_string()))?;
        let size = info.size as u64;
        if size > self.max_object_bytes {
            return Err(refused(format!(
                "{size} bytes, past max_upload_bytes ({})",
                self.max_object_bytes
            )));
        }
        if let Some(digest) = digest.filter(|d| d.bytes != size) {
            return Err(refused(format!(
                "{size} bytes where its record says {}",
                digest.bytes
            )));
        }
        let object = self.objects.get(name).await.map_err(|e| refused(e.to_string()))?;
        let mut bytes = Vec::with_capacity(size as usize);
        object
            .take(self.max_object_bytes + 1)
            .read_to_end(&mut bytes)
            .await
            .map_err(|e| refused(e.to_string()))?;
        if let Some(digest) = digest {
            if ObjectDigest::of(&bytes) != *digest {
                return Err(refused("its content is not what its record names".into()));
            }
        } else if bytes.len() as u64 > self.max_object_bytes {
            return Err(refused("grew past max_upload_bytes while read".into()));
        }
        Ok(bytes)
    }

    /// Reads the meshes of `shared`, checked against it, within [`LOAD_WITHIN`].
    pub async fn load(&self, id: &str, shared: SharedHead) -> Result<HeadRecord, SharedHeadError> {
        tokio::time::timeout(LOAD_WITHIN, self.read_meshes(id, shared))
            .await
            .map_err(|_| {
                SharedHeadError::Bus(format!("head {id:?}: meshes not read within {LOAD_WITHIN:?}"))
            })?
    }

    async fn read_meshes(&self, id: &str, shared: SharedHead) -> Result<HeadRecord, SharedHeadError> {
        let digest = |name: &str| shared.objects.get(name);
        let obj = self
            .read_object(&mesh_name(id, &shared.tag), digest("head.obj"))
            .await?;
        let mut parts = Vec::new();
        for (name, role) in shared.meta.listed_parts() {
            let object = format!("parts/{name}.obj");
            parts.push(PartRecord {
                name: name.to_string(),
                role,
                obj: self
                    .read_object(&part_name(id, &shared.tag, name), digest(&object))
                    .await?,
            });
        }
        let texture = match digest("texture") {
            None => None,
            Some(digest) => {
                let bytes = self
                    .read_object(&texture_name(id, &shared.tag), Some(digest))
                    .await?;
                crate::server::texture_image::check(&bytes)
                    .map_err(|e| SharedHeadError::Bus(format!("head {id:?}: {e}")))?;
                Some(bytes)
            }
        };
        let arkit_basis = match digest(ARKIT_BASIS_OBJECT) {
            None => None,
            Some(digest) => {
                let bytes = self
                    .read_object(&arkit_basis_name(id, &shared.tag), Some(digest))
                    .await?;
                Some(String::from_utf8(bytes).map_err(|_| {
                    SharedHeadError::Bus(format!("head {id:?}: {ARKIT_BASIS_OBJECT} is not UTF-8"))
                })?)
            }
        };
        Ok(HeadRecord {
            id: id.to_string(),
            obj,
            fit_toml: shared.fit_toml,
            parts,
            texture,
            arkit_basis,
            meta: shared.meta,
        })
    }

    /// Follows the bucket until `shutdown` or until the receiver is dropped: the current
    /// value of every key first, then each change, as [`HeadChange`]s in order. Watches
    /// again (from each key's current value, which is idempotent) when the watch fails, as
    /// it does while NATS restarts or when the bucket is made again, and when it stalls: a
    /// revision the bucket holds and the watch has not delivered over a whole
    /// [`LAG_CHECK`] ([`WatchLag`]).
    pub fn changes(self, shutdown: CancellationToken) -> mpsc::Receiver<HeadChange> {
        let (tx, rx) = mpsc::channel(CHANGES_WAITING);
        tokio::spawn(async move {
            loop {
                tracing::debug!("watching the cluster registry");
                match self.kv.watch_with_history(">").await {
                    Ok(mut changes) => {
                        let mut lag = WatchLag::default();
                        let mut delivered = 0;
                        let mut checks = tokio::time::interval(LAG_CHECK);
                        checks.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
                        loop {
                            let change = tokio::select! {
                                _ = shutdown.cancelled() => return,
                                change = changes.next() => change,
                                _ = checks.tick() => {
                                    if self.watch_stalled(&mut lag, delivered).await {
                                        tracing::warn!(delivered, "registry watch stalled; watching again");
                                        break;
                                    }
                                    continue;
                                }
                            };
                            match change {
                                Some(Ok(entry)) => {
                                    delivered = delivered.max(entry.revision);
                                    let Some(change) = self.change(entry) else {
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
                        }
                    }
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

    /// One [`WatchLag`] check against the bucket's newest revision; a bucket that cannot be
    /// asked now (the bus failing over) is no sign of a stalled watch.
    async fn watch_stalled(&self, lag: &mut WatchLag, delivered: u64) -> bool {
        match self.kv.stream.get_info().await {
            Ok(info) => lag.stalled(info.state.last_sequence, delivered),
            Err(e) => {
                tracing::debug!(error = %e, "cluster registry's newest revision not read");
                false
            }
        }
    }

    /// The change a bucket entry makes; `None` for a key that is no head id.
    fn change(&self, entry: kv::Entry) -> Option<HeadChange> {
        if !valid_id(&entry.key) {
            tracing::warn!(key = %entry.key, "cluster registry key is no head id; skipped");
            return None;
        }
        let held = self.classify(&entry);
        let id = entry.key;
        Some(match held {
            Held::Head { head, .. } => HeadChange::Put { id, head },
            Held::Deleted { .. } => HeadChange::Deleted { id },
            Held::Nothing { .. } => HeadChange::Unproven {
                id,
                why: "removed without proof".into(),
            },
            Held::Unproven { why, .. } => HeadChange::Unproven { id, why },
        })
    }
}
