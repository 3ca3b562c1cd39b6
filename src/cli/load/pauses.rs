//! The machine's own pauses during a load run. A virtual machine's host can stop the
//! guest for tens or hundreds of milliseconds (the kernel counts that time as "steal");
//! every stream then stalls at once, whatever the server does. A thread wakes every
//! [`TICK`] and notes each wake-up more than [`LATE`] late, with the steal counted
//! meanwhile (/proc/stat), so that a report can tell the stalls such a pause explains from
//! those it does not. The host may also take one CPU and leave the other (the thread then
//! wakes on time): the steal of every CPU is added up per second of the run, for the
//! report to set beside the seconds with stalls.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use serde::Serialize;

/// How often the watching thread wakes.
pub const TICK: Duration = Duration::from_millis(5);
/// A wake-up this late is a pause.
pub const LATE: Duration = Duration::from_millis(20);
/// Most pauses one run keeps (later ones are not recorded).
const MAX_PAUSES: usize = 100_000;

/// A stretch of time in which the watching thread did not run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Pause {
    /// When the thread was due to wake, µs since the producers started.
    pub from_us: u64,
    /// When it woke.
    pub to_us: u64,
    /// What the host took from this machine meanwhile, ms per CPU (0 where /proc/stat
    /// cannot be read).
    pub steal_ms: f64,
}

impl Pause {
    pub fn length_ms(&self) -> f64 {
        self.to_us.saturating_sub(self.from_us) as f64 / 1e3
    }

    /// The host stopped the machine: steal of at least half the pause, on average over the
    /// CPUs. A
    /// pause without steal is this machine's own CPU starvation, which explains nothing.
    pub fn is_host(&self) -> bool {
        self.steal_ms >= 0.5 * self.length_ms()
    }
}

/// Whether a stall (no frame from `from_us` to `to_us`) would have stayed under
/// `stall_after_us` without the host's pauses in it.
pub fn explained_by_host(from_us: u64, to_us: u64, stall_after_us: u64, pauses: &[Pause]) -> bool {
    let paused: u64 = pauses
        .iter()
        .filter(|p| p.is_host())
        .map(|p| to_us.min(p.to_us).saturating_sub(from_us.max(p.from_us)))
        .sum();
    to_us.saturating_sub(from_us).saturating_sub(paused) <= stall_after_us
}

/// What the watching thread saw.
#[derive(Debug, Default)]
pub struct MachineTime {
    /// Pauses, oldest first.
    pub pauses: Vec<Pause>,
    /// Steal of all CPUs together in each second of the run (ms), at most [`MAX_SECONDS`].
    pub steal_ms_by_second: Vec<f64>,
}

impl MachineTime {
    /// Steal in seconds `second` and `second + 1` (a stall that begins in one second
    /// ends in it or the next), all CPUs, ms.
    pub fn steal_around(&self, second: u64) -> f64 {
        let at = |s: u64| self.steal_ms_by_second.get(s as usize).copied().unwrap_or(0.0);
        at(second) + at(second + 1)
    }
}

/// Seconds of steal kept: the longest run.
const MAX_SECONDS: usize = super::MAX_SECONDS as usize + 60;

/// The watching thread; [`PauseWatch::finish`] stops it and returns what it saw.
pub struct PauseWatch {
    stop: Arc<AtomicBool>,
    thread: JoinHandle<MachineTime>,
}

impl PauseWatch {
    /// Starts watching; times are measured from `start`.
    pub fn start(start: Instant) -> std::io::Result<PauseWatch> {
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::Builder::new()
            .name("pause-watch".into())
            .spawn(move || watch(start, &flag))?;
        Ok(PauseWatch { stop, thread })
    }

    /// Stops watching: what it saw.
    pub fn finish(self) -> MachineTime {
        self.stop.store(true, Ordering::Relaxed);
        self.thread.join().unwrap_or_default()
    }
}

fn watch(start: Instant, stop: &AtomicBool) -> MachineTime {
    let mut seen = MachineTime::default();
    let mut last = Instant::now();
    let mut steal = read_steal();
    while !stop.load(Ordering::Relaxed) {
        std::thread::sleep(TICK);
        let (now, steal_now) = (Instant::now(), read_steal());
        let (all_cpus_ms, per_cpu_ms) = (
            (steal_now.all_cpus_ms - steal.all_cpus_ms).max(0.0),
            (steal_now.per_cpu_ms() - steal.per_cpu_ms()).max(0.0),
        );
        let due = last + TICK;
        if now.saturating_duration_since(due) > LATE && seen.pauses.len() < MAX_PAUSES {
            let since = |t: Instant| t.saturating_duration_since(start).as_micros() as u64;
            seen.pauses.push(Pause {
                from_us: since(due),
                to_us: since(now),
                steal_ms: per_cpu_ms,
            });
        }
        let second = now.saturating_duration_since(start).as_secs() as usize;
        if now >= start && second < MAX_SECONDS {
            if seen.steal_ms_by_second.len() <= second {
                seen.steal_ms_by_second.resize(second + 1, 0.0);
            }
            seen.steal_ms_by_second[second] += all_cpus_ms;
        }
        (last, steal) = (now, steal_now);
    }
    seen
}

/// The steal so far.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Steal {
    /// Of all CPUs together, ms.
    all_cpus_ms: f64,
    cpus: usize,
}

impl Steal {
    fn per_cpu_ms(&self) -> f64 {
        self.all_cpus_ms / self.cpus.max(1) as f64
    }
}

fn read_steal() -> Steal {
    // SAFETY: sysconf only reads a configuration value.
    let ticks_per_second = unsafe { libc::sysconf(libc::_SC_CLK_TCK) };
    std::fs::read_to_string("/proc/stat")
        .ok()
        .and_then(|stat| parse_steal(&stat, ticks_per_second as f64))
        .unwrap_or_default()
}

/// From /proc/stat's text: the steal of all CPUs (the 8th number of the `cpu` line, in
/// clock ticks) in ms, and the number of `cpuN` lines.
fn parse_steal(stat: &str, ticks_per_second: f64) -> Option<Steal> {
    let ticks: f64 = stat
        .lines()
        .find(|l| l.starts_with("cpu "))?
        .split_whitespace()
        .nth(8)?
        .parse()
        .ok()?;
    let cpus = stat
        .lines()
        .filter(|l| {
            l.strip_prefix("cpu")
                .is_some_and(|r| r.starts_with(|c: char| c.is_ascii_digit()))
        })
        .count();
    (cpus > 0 && ticks_per_second > 0.0).then(|| Steal {
        all_cpus_ms: ticks * 1e3 / ticks_per_second,
        cpus,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pause(from_ms: u64, to_ms: u64, steal_ms: f64) -> Pause {
        Pause {
            from_us: from_ms * 1000,
            to_us: to_ms * 1000,
            steal_ms,
        }
    }

    #[test]
    fn steal_is_read_per_cpu_in_milliseconds() {
        let stat = "cpu  100 0 50 900 0 0 3 36 0 0\ncpu0 50 0 25 450 0 0 1 20 0 0\ncpu1 50 0 25 450 0 0 2 16 0 0\nintr 1\n";
        // 36 ticks of 10 ms over 2 CPUs.
        let steal = parse_steal(stat, 100.0).unwrap();
        assert_eq!((steal.all_cpus_ms, steal.per_cpu_ms()), (360.0, 180.0));
        assert_eq!(parse_steal("intr 1\n", 100.0), None);
    }

    #[test]
    fn steal_around_a_second_adds_it_and_the_next() {
        let seen = MachineTime {
            pauses: Vec::new(),
            steal_ms_by_second: vec![0.0, 30.0, 150.0],
        };
        assert_eq!(seen.steal_around(1), 180.0);
        assert_eq!(seen.steal_around(2), 150.0);
        assert_eq!(seen.steal_around(9), 0.0);
    }

    #[test]
    fn only_the_hosts_pauses_explain_a_stall() {
        // A 150 ms gap with a 90 ms host pause in it: 60 ms of its own, under 100.
        let host = [pause(1_020, 1_110, 80.0)];
        assert!(host[0].is_host());
        assert!(explained_by_host(1_000_000, 1_150_000, 100_000, &host));
        // The same pause without steal is this machine's own starvation.
        let starved = [pause(1_020, 1_110, 10.0)];
        assert!(!starved[0].is_host());
        assert!(!explained_by_host(1_000_000, 1_150_000, 100_000, &starved));
        // A 250 ms gap keeps 160 ms without the pause: still a stall.
        assert!(!explained_by_host(1_000_000, 1_250_000, 100_000, &host));
        // A pause outside the gap explains nothing.
        assert!(!explained_by_host(2_000_000, 2_150_000, 100_000, &host));
    }
}
