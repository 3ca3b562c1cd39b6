//! A flag that long blocking work (an automatic fit, a registration) asks between its
//! steps: is the result still wanted? The service sets it when the request that started the
//! work ends (its client went away, its deadline passed) or the server shuts down, so the
//! work stops within a step instead of running on, holding memory and a core, for nobody.
//! Plain atomics: the core stays free of async.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Shared between the work and whoever may stop it; cloning shares the flag.
#[derive(Debug, Clone, Default)]
pub struct Cancel(Arc<AtomicBool>);

impl Cancel {
    /// A flag nobody has set yet.
    pub fn new() -> Cancel {
        Cancel::default()
    }

    pub fn cancel(&self) {
        self.0.store(true, Ordering::Release);
    }

    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Acquire)
    }

    /// A guard that sets the flag when it is dropped: held by a request's future, it stops
    /// the request's work when the future is dropped (the request timed out or its client
    /// left) as well as when it returns.
    pub fn on_drop(&self) -> CancelOnDrop {
        CancelOnDrop(self.clone())
    }
}

/// Sets its [`Cancel`] when dropped.
#[derive(Debug)]
pub struct CancelOnDrop(Cancel);

impl Drop for CancelOnDrop {
    fn drop(&mut self) {
        self.0.cancel();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clones_share_the_flag_and_the_guard_sets_it_when_dropped() {
        let cancel = Cancel::new();
        let seen_by_work = cancel.clone();
        let guard = cancel.on_drop();
        assert!(!seen_by_work.is_cancelled());
        drop(guard);
        assert!(seen_by_work.is_cancelled());
        let direct = Cancel::new();
        direct.clone().cancel();
        assert!(direct.is_cancelled());
    }
}
