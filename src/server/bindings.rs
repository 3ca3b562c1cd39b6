//! The algorithms bound on one head: each bound once, off the async runtime, and shared by
//! every pipeline that uses it. At most `max_bindings_per_head` at once; past that, a
//! binding no pipeline holds is evicted, and when every one is in use a new algorithm is
//! refused.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use tokio::sync::OnceCell;

use super::error::ApiError;
use crate::animate::AnimatedHead;
use crate::deform::{bind, AlgoSpec, Binding};

type Slot = Arc<OnceCell<Arc<Binding>>>;

pub struct BindingCache {
    slots: Mutex<HashMap<String, Slot>>,
    limit: usize,
}

impl BindingCache {
    pub fn new(limit: usize) -> BindingCache {
        BindingCache {
            slots: Mutex::new(HashMap::new()),
            limit,
        }
    }

    /// The binding of `spec` on `head`, bound now if it is not cached.
    pub async fn get(&self, head: &Arc<AnimatedHead>, spec: &AlgoSpec) -> Result<Arc<Binding>, ApiError> {
        let slot = self.slot(spec)?;
        let head = head.clone();
        let spec = *spec;
        let binding = slot
            .get_or_try_init(|| async move {
                tokio::task::spawn_blocking(move || Arc::new(bind(&head.registration, &spec)))
                    .await
                    .map_err(ApiError::internal)
            })
            .await?;
        Ok(binding.clone())
    }

    fn slot(&self, spec: &AlgoSpec) -> Result<Slot, ApiError> {
        let key = spec.to_string();
        let mut slots = self.slots.lock().expect("bindings lock");
        if let Some(slot) = slots.get(&key) {
            return Ok(slot.clone());
        }
        if slots.len() >= self.limit {
            // Evict a bound algorithm nobody uses (the cache holds its only reference).
            let unused = slots
                .iter()
                .find(|(_, slot)| {
                    Arc::strong_count(slot) == 1 && slot.get().is_some_and(|b| Arc::strong_count(b) == 1)
                })
                .map(|(k, _)| k.clone());
            match unused {
                Some(k) => {
                    slots.remove(&k);
                }
                None => {
                    return Err(ApiError::LimitReached(format!(
                    "this head has {} algorithms in use, the most it binds at once; try one of them or later",
                    self.limit
                )))
                }
            }
        }
        let slot = Slot::default();
        slots.insert(key, slot.clone());
        Ok(slot)
    }

    /// Canonical specs of the algorithms bound now, sorted.
    pub fn bound(&self) -> Vec<String> {
        let mut specs: Vec<String> = self
            .slots
            .lock()
            .expect("bindings lock")
            .iter()
            .filter(|(_, slot)| slot.initialized())
            .map(|(s, _)| s.clone())
            .collect();
        specs.sort();
        specs
    }
}
