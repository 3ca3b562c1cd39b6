//! Where registered heads are kept beyond this process: nowhere (the demo, tests), the
//! data directory (one node), or the cluster's shared registry (`bus = "nats://..."`).
//! The registry saves and deletes through this one interface.

use super::cluster::{ClusterHeads, SharedHeadError};
use super::error::ApiError;
use super::store::{HeadRecord, Store};

pub enum HeadStore {
    Memory,
    Dir(Store),
    Cluster(Box<ClusterHeads>),
}

impl HeadStore {
    /// Keeps `record`; hands it back (it goes to the blocking pool and returns, never
    /// copied).
    pub async fn save(&self, record: HeadRecord) -> Result<HeadRecord, ApiError> {
        match self {
            HeadStore::Memory => Ok(record),
            HeadStore::Dir(store) => {
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
            HeadStore::Cluster(heads) => match heads.save(&record).await {
                Ok(()) => Ok(record),
                Err(SharedHeadError::Exists(id)) => Err(ApiError::HeadExists(id)),
                Err(e) => Err(ApiError::BusUnavailable(e.to_string())),
            },
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
            HeadStore::Cluster(heads) => heads
                .delete(id)
                .await
                .map_err(|e| ApiError::BusUnavailable(e.to_string())),
        }
    }

    /// The data directory, when heads are kept there.
    pub fn dir(&self) -> Option<&Store> {
        match self {
            HeadStore::Dir(store) => Some(store),
            _ => None,
        }
    }
}
