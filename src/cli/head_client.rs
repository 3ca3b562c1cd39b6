//! A client of one facewire server's head resources over HTTP: URLs with the token in
//! their query, registering a head, and waiting until a head is ready (on a cluster node
//! that is still following the registry, unknown at first). The load generator uses it,
//! and so do the integration tests, so both wait the same way.

use std::time::Duration;

/// How often a head's status is asked for while waiting.
const POLL: Duration = Duration::from_millis(50);

#[derive(Debug, thiserror::Error)]
pub enum HeadClientError {
    #[error("cannot reach {base}: {source}")]
    Unreachable { base: String, source: reqwest::Error },
    #[error("{base}: registering head {id}: {status} {body}")]
    Refused {
        base: String,
        id: String,
        status: u16,
        body: String,
    },
    #[error("head {id} failed on {base}: {error}")]
    Failed { base: String, id: String, error: String },
    #[error("head {id} was not ready on {base} within {within:?}")]
    NotReady {
        base: String,
        id: String,
        within: Duration,
    },
}

/// The head resources of the server at `base` (`http://HOST:PORT`), with a token if any.
#[derive(Debug, Clone)]
pub struct HeadClient {
    http: reqwest::Client,
    base: String,
    token: Option<String>,
}

impl HeadClient {
    pub fn new(base: &str, token: Option<&str>) -> HeadClient {
        HeadClient {
            http: reqwest::Client::new(),
            base: base.trim_end_matches('/').to_string(),
            token: token.map(str::to_string),
        }
    }

    /// `url` (any scheme) with the token added to its query.
    pub fn with_token(&self, url: &str) -> String {
        match (&self.token, url.contains('?')) {
            (None, _) => url.to_string(),
            (Some(t), true) => format!("{url}&token={t}"),
            (Some(t), false) => format!("{url}?token={t}"),
        }
    }

    /// The server's `path` (`/v1/...`), with the token.
    pub fn url(&self, path: &str) -> String {
        self.with_token(&format!("{}{path}", self.base))
    }

    /// Posts `body` (a head registration, docs: PROTOCOL.md) to `/v1/heads`; the status the
    /// server accepted it with (202).
    pub async fn register(&self, id: &str, body: &serde_json::Value) -> Result<u16, HeadClientError> {
        let response = self
            .http
            .post(self.url("/v1/heads"))
            .json(body)
            .send()
            .await
            .map_err(|source| self.unreachable(source))?;
        let status = response.status().as_u16();
        if !response.status().is_success() {
            return Err(HeadClientError::Refused {
                base: self.base.clone(),
                id: id.to_string(),
                status,
                body: response.text().await.unwrap_or_default(),
            });
        }
        Ok(status)
    }

    /// Head `id`'s info (`GET /v1/heads/{id}`) once it is ready, asked for every
    /// [`POLL`] for `within` at most. A head the server does not know yet is waited for:
    /// a cluster node registers another node's head when it follows the registry.
    pub async fn wait_ready(&self, id: &str, within: Duration) -> Result<serde_json::Value, HeadClientError> {
        let started = std::time::Instant::now();
        loop {
            let response = self
                .http
                .get(self.url(&format!("/v1/heads/{id}")))
                .send()
                .await
                .map_err(|source| self.unreachable(source))?;
            if response.status().is_success() {
                let info: serde_json::Value =
                    response.json().await.map_err(|source| self.unreachable(source))?;
                match info["status"].as_str() {
                    Some("ready") => return Ok(info),
                    Some("failed") => {
                        return Err(HeadClientError::Failed {
                            base: self.base.clone(),
                            id: id.to_string(),
                            error: info["error"].to_string(),
                        })
                    }
                    _ => {}
                }
            }
            if started.elapsed() >= within {
                return Err(HeadClientError::NotReady {
                    base: self.base.clone(),
                    id: id.to_string(),
                    within,
                });
            }
            tokio::time::sleep(POLL).await;
        }
    }

    fn unreachable(&self, source: reqwest::Error) -> HeadClientError {
        HeadClientError::Unreachable {
            base: self.base.clone(),
            source,
        }
    }
}
