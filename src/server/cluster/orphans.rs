//! Ends that always come: a stream fed from another node's producer ends for this node's
//! viewers when that producer's node vanishes without sending the end (killed, cut off).
//! Its lease then expires (`lease::TTL`); each node checks the leases of the streams it
//! relays once they fall silent, and ends those nobody holds with `producer_disconnected`.

use std::sync::Arc;
use std::time::Duration;

use tokio_util::sync::CancellationToken;

use super::lease::Leases;
use crate::server::registry::Registry;
use facewire_proto::codes::EndReason;

/// How often relayed streams are looked at.
const CHECK_EVERY: Duration = Duration::from_secs(1);
/// A relayed stream silent for less than this is not asked about: its end may be on the
/// way over the bus, after its last frame.
const SILENT_FOR: Duration = Duration::from_secs(1);

/// Checks relayed streams until `shutdown`.
pub async fn end_orphans(registry: Registry, leases: Arc<Leases>, shutdown: CancellationToken) {
    let mut ticks = tokio::time::interval(CHECK_EVERY);
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => return,
            _ = ticks.tick() => {}
        }
        let now = tokio::time::Instant::now();
        for head in registry.list() {
            for stream in head.streams() {
                if stream
                    .relay_silent_for(now)
                    .is_none_or(|silent| silent < SILENT_FOR)
                {
                    continue;
                }
                match leases.is_held(&head.id, &stream.name).await {
                    Ok(true) => {}
                    Ok(false) => {
                        tracing::info!(
                            head = %head.id,
                            stream = %stream.name,
                            "the producer's node went away without ending the stream; ending it"
                        );
                        stream.end(EndReason::ProducerDisconnected);
                    }
                    // The bus is away: nothing is known, nothing is ended.
                    Err(e) => tracing::debug!(error = %e, "lease not read"),
                }
            }
        }
    }
}
