//! Where registered heads are kept beyond this process: nowhere (the demo, tests), the
//! data directory (one node), or the cluster's shared registry (`bus = "nats://..."`),
//! with a copy in the node's own data directory from which it puts back what the
//! cluster's buckets lose. The registry saves and deletes through this one interface.

use super::cluster::{ClusterHeads, SharedHeadError};
use super::error::ApiError;
use super::store::{HeadRecord, Store};

pub enum HeadStore {
    Memory,
    Dir(Store),
    Cluster {
        heads: Box<ClusterHeads>,
        /// This node's copy of every head of the cluster.
        local: Option<Store>,
    },
}

/// Saves `record` in `store` in the blocking pool; hands it back (it goes there and
/// returns, never copied).
async fn save_on_disk(store: &Store, record: HeadRecord) -> Result<HeadRecord, ApiError> {
    let store = store.clone();
    let (record, saved) = tokio::task::spawn_blocking(move || {
        let saved = store.save(&record);
        (record, saved)
    })
    .await
    .map_err(ApiError::internal)?;
    saved.map_err(ApiError::internal)?;
    Ok(record)
}

/// Runs `work` on `store` in the blocking pool.
async fn on_disk<T: Send + 'static>(
    store: &Store,
    work: impl FnOnce(&Store) -> Result<T, super::store::StoreError> + Send + 'static,
) -> Result<T, ApiError> {
    let store = store.clone();
    tokio::task::spawn_blocking(move || work(&store))
        .await
        .map_err(ApiError::internal)?
        .map_err(ApiError::internal)
}

impl HeadStore {
    /// Keeps `record`; hands it back.
    pub async fn save(&self, record: HeadRecord) -> Result<HeadRecord, ApiError> {
        match self {
            HeadStore::Memory => Ok(record),
            HeadStore::Dir(store) => save_on_disk(store, record).await,
            HeadStore::Cluster { heads, local } => {
                match heads.save(&record).await {
                    Ok(()) => {}
                    Err(SharedHeadError::Exists(id)) => return Err(ApiError::HeadExists(id)),
                    Err(e) => return Err(ApiError::BusUnavailable(e.to_string())),
                }
                match local {
                    Some(local) => save_on_disk(local, record).await,
                    None => Ok(record),
                }
            }
        }
    }

    /// In a cluster: keeps this node's copy of a head registered elsewhere.
    pub async fn copy_from_cluster(&self, record: HeadRecord) -> Result<HeadRecord, ApiError> {
        match self {
            HeadStore::Cluster {
                local: Some(local), ..
            } => save_on_disk(local, record).await,
            _ => Ok(record),
        }
    }

    /// In a cluster: forgets this node's copy of a head deleted elsewhere.
    pub async fn forget_copy(&self, id: &str) -> Result<(), ApiError> {
        match self {
            HeadStore::Cluster {
                local: Some(local), ..
            } => {
                let id = id.to_string();
                on_disk(local, move |store| store.delete(&id)).await
            }
            _ => Ok(()),
        }
    }

    /// Forgets head `id`; true when it was kept here (the data directory counts every id
    /// as kept: removing nothing is fine).
    pub async fn delete(&self, id: &str) -> Result<bool, ApiError> {
        match self {
            HeadStore::Memory => Ok(false),
            HeadStore::Dir(store) => {
                let store = store.clone();
                let id = id.to_string();
                tokio::task::spawn_blocking(move || store.delete(&id))
                    .await
                    .map_err(ApiError::internal)?
                    .map_err(ApiError::internal)?;
                Ok(false)
            }
            HeadStore::Cluster { heads, .. } => {
                let deleted = heads
                    .delete(id)
                    .await
                    .map_err(|e| ApiError::BusUnavailable(e.to_string()))?;
                self.forget_copy(id).await?;
                Ok(deleted)
            }
        }
    }

    /// The data directory, when heads are kept there and registered from it at start (a
    /// cluster node registers what the cluster holds).
    pub fn dir(&self) -> Option<&Store> {
        match self {
            HeadStore::Dir(store) => Some(store),
            _ => None,
        }
    }

    /// Where head `id`'s recordings are kept beyond this process: in its folder of the
    /// data directory, when there is one (a cluster node's own copies included).
    pub fn recordings_dir(&self, id: &str) -> Option<std::path::PathBuf> {
        match self {
            HeadStore::Dir(store)
            | HeadStore::Cluster {
                local: Some(store), ..
            } => Some(store.recordings_dir(id)),
            _ => None,
        }
    }

    /// A cluster node's local copies: what it puts back into the cluster's buckets.
    pub fn local_copies(&self) -> Option<&Store> {
        match self {
            HeadStore::Cluster { local, .. } => local.as_ref(),
            _ => None,
        }
    }
}
