//! What this process costs the machine, read from Linux's `/proc/self`: CPU time (user and
//! system) and resident memory. Exported on `/metrics`, where the load generator
//! (`facewire load`) and operators read them. On a system without `/proc` both read 0.

/// CPU seconds this process has used, user and system.
pub fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // The command name (field 2) is in parentheses and may hold spaces; count from after it.
    let Some(rest) = stat.rfind(')').map(|i| &stat[i + 1..]) else {
        return 0.0;
    };
    let fields: Vec<&str> = rest.split_whitespace().collect();
    // Fields 14 and 15 of the file (utime, stime): indexes 11 and 12 after the name,
    // which ends field 2.
    let ticks = |i: usize| fields.get(i).and_then(|f| f.parse::<u64>().ok()).unwrap_or(0);
    // SAFETY: sysconf only reads a configuration value.
    let per_second = unsafe { libc::sysconf(libc::_SC_CLK_TCK) };
    if per_second <= 0 {
        return 0.0;
    }
    (ticks(11) + ticks(12)) as f64 / per_second as f64
}

/// Resident memory of this process, bytes.
pub fn resident_bytes() -> u64 {
    let Ok(statm) = std::fs::read_to_string("/proc/self/statm") else {
        return 0;
    };
    let pages: u64 = statm
        .split_whitespace()
        .nth(1)
        .and_then(|p| p.parse().ok())
        .unwrap_or(0);
    // SAFETY: sysconf only reads a configuration value.
    let page = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
    pages * page.max(0) as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_time_grows_with_work_and_memory_is_counted() {
        // Spin until the process has used 0.1 s more CPU, however busy the machine is (with
        // other tests on the cores a fixed 0.3 s of wall time got as little as 0.06 s).
        let before = cpu_seconds();
        let started = std::time::Instant::now();
        let mut x = 0u64;
        while cpu_seconds() - before < 0.1 {
            for _ in 0..100_000 {
                x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
            }
            assert!(
                started.elapsed().as_secs() < 20,
                "CPU time did not grow by 0.1 s in 20 s of spinning: {} s",
                cpu_seconds() - before
            );
        }
        std::hint::black_box(x);
        let used = cpu_seconds() - before;
        assert!(used < 5.0, "{used} s of CPU counted for about 0.1 s of spinning");
        assert!(resident_bytes() > 1 << 20, "{} bytes resident", resident_bytes());
    }
}
