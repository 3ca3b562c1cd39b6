//! The run's HTTP side of the server: registering the head it loads (the embedded MakeHuman
//! head) and waiting until every node has it ready.

use std::time::Duration;

/// Registers the MakeHuman head (embedded) for the run and waits until it is ready.
pub(super) async fn register(
    http: &reqwest::Client,
    base: &str,
    with_token: &impl Fn(&str) -> String,
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
    let response = http
        .post(with_token(&format!("{base}/v1/heads")))
        .json(&body)
        .send()
        .await
        .map_err(|e| format!("cannot reach {base}: {e}"))?;
    if !response.status().is_success() {
        return Err(format!(
            "registering the MakeHuman head: {} {}",
            response.status(),
            response.text().await?
        )
        .into());
    }
    wait_ready(http, base, &id, with_token).await?;
    Ok(id)
}

/// Waits (30 s at most) until the node at `base` has head `id` ready; a node of a cluster
/// may not know it yet (404) while it follows the registry.
pub(super) async fn wait_ready(
    http: &reqwest::Client,
    base: &str,
    id: &str,
    with_token: &impl Fn(&str) -> String,
) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    for _ in 0..600 {
        let info: serde_json::Value = http
            .get(with_token(&format!("{base}/v1/heads/{id}")))
            .send()
            .await
            .map_err(|e| format!("cannot reach {base}: {e}"))?
            .json()
            .await?;
        match info["status"].as_str() {
            Some("ready") => return Ok(()),
            Some("failed") => return Err(format!("head {id} failed on {base}: {}", info["error"]).into()),
            _ => tokio::time::sleep(Duration::from_millis(50)).await,
        }
    }
    Err(format!("head {id} was not ready on {base} within 30 s").into())
}
