//! Giving freed heap back to the system. glibc keeps freed memory in its arenas, so after
//! large buffers go (a head, a binding, a pipeline's job) the process would stay at its
//! peak; `malloc_trim` returns it. A trim walks every arena under its lock, so the
//! threads sending to viewers wait for it: fifty pipelines retiring together, one trim
//! each, delayed every other stream's frames by over 100 ms (docs/PERFORMANCE.md). The
//! [`Trimmer`] runs at most one trim per [`TRIM_INTERVAL`], however many are asked for,
//! and only after the interval: when many streams end together, the trim comes after the
//! last of their frames, not between them.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// How long a trim waits after the request that planned it (so also the shortest time
/// between two trims).
pub const TRIM_INTERVAL: Duration = Duration::from_secs(1);

/// Releases freed heap now. Blocking (milliseconds).
pub fn release_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only releases free memory at the top of glibc's heaps.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// Coalesces trim requests: a request plans a trim [`TRIM_INTERVAL`] later, and those
/// that come before it starts join it.
#[derive(Default)]
pub struct Trimmer {
    /// A trim is planned and has not started yet.
    pending: AtomicBool,
}

impl Trimmer {
    /// Asks for a trim, soon; must be called on the runtime.
    pub fn request(self: &Arc<Self>) {
        if self.pending.swap(true, Ordering::AcqRel) {
            return;
        }
        let trimmer = self.clone();
        tokio::spawn(async move {
            tokio::time::sleep(TRIM_INTERVAL).await;
            trimmer.pending.store(false, Ordering::Release);
            let _ = tokio::task::spawn_blocking(release_memory).await;
        });
    }
}
