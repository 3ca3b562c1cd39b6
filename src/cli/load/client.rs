//! The run's head: the embedded MakeHuman head registered for it (through the one
//! [`HeadClient`] the tests use too), and how long every node may take to have it ready.

use std::time::Duration;

use crate::cli::head_client::HeadClient;

/// How long a node may take to have the run's head ready (a cluster node follows the
/// registry).
pub(super) const READY_WITHIN: Duration = Duration::from_secs(30);

/// Registers the MakeHuman head (embedded) for the run and waits until it is ready.
pub(super) async fn register(
    client: &HeadClient,
) -> Result<String, Box<dyn std::error::Error + Send + Sync>> {
    let head = crate::server::demo::DEMO_HEADS
        .iter()
        .find(|h| h.id == "makehuman")
        .ok_or("the embedded MakeHuman head is missing")?;
    let (obj, fit) = (head.obj, head.fit);
    let id = format!("load-{}", std::process::id());
    let body = serde_json::json!({
        "id": id,
        "obj": String::from_utf8_lossy(obj),
        "fit": fit,
    });
    client.register(&id, &body).await?;
    client.wait_ready(&id, READY_WITHIN).await?;
    Ok(id)
}
