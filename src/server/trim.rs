//! Giving freed heap back to the system. glibc keeps freed memory in its arenas, so after
//! large buffers go (a head, a binding, a pipeline's job) the process would stay at its
//! peak; `malloc_trim` returns it. A trim walks every arena under its lock, so the
//! threads sending to viewers wait for it: fifty pipelines retiring together, one trim
//! each, delayed every other stream's frames by over 100 ms (docs/PERFORMANCE.md). The
//! [`Trimmer`] runs at most one trim per [`TRIM_INTERVAL`], however many are asked for.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The shortest time between two coalesced trims.
pub const TRIM_INTERVAL: Duration = Duration::from_secs(1);

/// Releases freed heap now. Blocking (milliseconds).
pub fn release_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only releases free memory at the top of glibc's heaps.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// Coalesces trim requests: the first runs at once, those that come while it runs or
/// within [`TRIM_INTERVAL`] after it make one more trim at the end of the interval.
#[derive(Default)]
pub struct Trimmer {
    state: Mutex<TrimState>,
}

#[derive(Default)]
struct TrimState {
    /// A trim is planned and has not started yet.
    pending: bool,
    last: Option<Instant>,
}

impl Trimmer {
    /// Asks for a trim, soon; must be called on the runtime.
    pub fn request(self: &Arc<Self>) {
        let wait = {
            let mut state = self.state.lock().expect("trim lock");
            if state.pending {
                return;
            }
            state.pending = true;
            state.last.map_or(Duration::ZERO, |last| {
                TRIM_INTERVAL.saturating_sub(last.elapsed())
            })
        };
        let trimmer = self.clone();
        tokio::spawn(async move {
            tokio::time::sleep(wait).await;
            {
                let mut state = trimmer.state.lock().expect("trim lock");
                state.pending = false;
                state.last = Some(Instant::now());
            }
            let _ = tokio::task::spawn_blocking(release_memory).await;
        });
    }
}
