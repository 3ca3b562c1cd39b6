//! The server's own account of what it spends, read from its `/metrics`
//! (`facewire_process_cpu_seconds`, `facewire_process_resident_bytes`) before and after a
//! run, summed over the nodes of a cluster.

use serde::Serialize;

use super::report::ServerUse;

#[derive(Debug, Clone, Copy, Serialize)]
pub struct ServerSample {
    pub cpu_seconds: f64,
    pub resident_bytes: f64,
}

/// Reads `/metrics`; `None` when it cannot be read or lacks the process metrics.
async fn sample(
    http: &reqwest::Client,
    base: &str,
    with_token: &impl Fn(&str) -> String,
) -> Option<ServerSample> {
    let text = http
        .get(with_token(&format!("{base}/metrics")))
        .send()
        .await
        .ok()?
        .text()
        .await
        .ok()?;
    Some(ServerSample {
        cpu_seconds: value(&text, "facewire_process_cpu_seconds")?,
        resident_bytes: value(&text, "facewire_process_resident_bytes")?,
    })
}

/// The sum over the nodes at `bases` (a cluster on one machine); `None` when any cannot
/// be read.
pub async fn sample_nodes(
    http: &reqwest::Client,
    bases: &[String],
    with_token: &impl Fn(&str) -> String,
) -> Option<ServerSample> {
    let mut total = ServerSample {
        cpu_seconds: 0.0,
        resident_bytes: 0.0,
    };
    for base in bases {
        let one = sample(http, base, with_token).await?;
        total.cpu_seconds += one.cpu_seconds;
        total.resident_bytes += one.resident_bytes;
    }
    Some(total)
}

/// The value of an unlabelled metric in Prometheus text.
fn value(text: &str, name: &str) -> Option<f64> {
    text.lines()
        .filter(|line| !line.starts_with('#'))
        .find_map(|line| {
            let (metric, value) = line.split_once(' ')?;
            (metric == name).then(|| value.trim().parse().ok()).flatten()
        })
}

impl ServerSample {
    /// CPU percent of one core over `seconds`, and memory before and after.
    pub fn usage(
        before: Option<ServerSample>,
        after: Option<ServerSample>,
        seconds: f64,
    ) -> Option<ServerUse> {
        let (before, after) = (before?, after?);
        Some(ServerUse {
            cpu_percent: 100.0 * (after.cpu_seconds - before.cpu_seconds) / seconds.max(1e-9),
            resident_mib_before: before.resident_bytes / (1 << 20) as f64,
            resident_mib_after: after.resident_bytes / (1 << 20) as f64,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_read_by_exact_name() {
        let text = "# HELP facewire_process_cpu_seconds CPU\n\
                    facewire_process_cpu_seconds_extra 9\n\
                    facewire_process_cpu_seconds 12.5\n\
                    facewire_process_resident_bytes 1048576\n";
        assert_eq!(value(text, "facewire_process_cpu_seconds"), Some(12.5));
        assert_eq!(value(text, "facewire_process_resident_bytes"), Some(1048576.0));
        assert_eq!(value(text, "facewire_heads"), None);
        let before = ServerSample {
            cpu_seconds: 10.0,
            resident_bytes: 2.0 * 1048576.0,
        };
        let after = ServerSample {
            cpu_seconds: 13.0,
            resident_bytes: 3.0 * 1048576.0,
        };
        let usage = ServerSample::usage(Some(before), Some(after), 6.0).unwrap();
        assert_eq!(usage.cpu_percent, 50.0);
        assert_eq!((usage.resident_mib_before, usage.resident_mib_after), (2.0, 3.0));
    }
}
