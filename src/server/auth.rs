//! Who may do what. Every route has one [`Access`] level (PROTOCOL.md, "Tokens", has the
//! table); a route layer checks the token before anything else runs, WebSocket upgrades
//! included. Tokens come in `?token=` or `Authorization: Bearer`. The admin token is
//! accepted everywhere; a head's own producer token replaces the global producer token for
//! that head. Tokens are compared as SHA-256 digests in constant time, and per-head tokens
//! are stored only as digests.

use std::collections::HashMap;

use axum::extract::{Path, Request, State};
use axum::http::HeaderMap;
use axum::middleware::Next;
use axum::response::Response;
use sha2::{Digest, Sha256};

use super::error::ApiError;
use super::AppState;

/// A token's SHA-256 digest.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TokenDigest([u8; 32]);

impl TokenDigest {
    pub fn of(token: &str) -> TokenDigest {
        TokenDigest(Sha256::digest(token.as_bytes()).into())
    }

    /// Lowercase hex, as `head.json` stores it.
    pub fn to_hex(self) -> String {
        self.0.iter().map(|b| format!("{b:02x}")).collect()
    }

    pub fn from_hex(text: &str) -> Option<TokenDigest> {
        if text.len() != 64 {
            return None;
        }
        let mut bytes = [0u8; 32];
        for (i, byte) in bytes.iter_mut().enumerate() {
            *byte = u8::from_str_radix(text.get(2 * i..2 * i + 2)?, 16).ok()?;
        }
        Some(TokenDigest(bytes))
    }

    /// Constant time: every byte is compared whatever the first difference.
    fn matches(self, other: TokenDigest) -> bool {
        self.0.iter().zip(other.0).fold(0u8, |acc, (a, b)| acc | (a ^ b)) == 0
    }
}

/// What a route needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    /// Head data and viewing: the viewer token (when one is set) or the admin token.
    Viewer,
    /// Producing on a head's streams: the head's own token if it has one, else the
    /// producer token (when one is set); or the admin token.
    Producer,
    /// Registering and deleting heads, `/metrics`: the admin token (when one is set).
    Admin,
}

/// The token a request presents, if any: `?token=` first, then `Authorization: Bearer`.
fn presented(request: &Request) -> Option<String> {
    let from_query = axum::extract::Query::<TokenQuery>::try_from_uri(request.uri())
        .ok()
        .and_then(|q| q.0.token);
    from_query.or_else(|| bearer(request.headers()))
}

#[derive(serde::Deserialize)]
struct TokenQuery {
    token: Option<String>,
}

fn bearer(headers: &HeaderMap) -> Option<String> {
    headers
        .get(axum::http::header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "))
        .map(str::to_string)
}

/// Whether `given` opens `access` on the head with producer-token digest `head_token`.
pub fn allows(
    state: &AppState,
    access: Access,
    head_token: Option<TokenDigest>,
    given: Option<&str>,
) -> bool {
    let given = given.map(TokenDigest::of);
    let is = |expected: Option<TokenDigest>| matches!((expected, given), (Some(e), Some(g)) if e.matches(g));
    let auth = &state.tokens;
    if is(auth.admin) {
        return true;
    }
    let role = match access {
        Access::Viewer => auth.viewer,
        Access::Producer => head_token.or(auth.producer),
        Access::Admin => auth.admin,
    };
    role.is_none() || is(role)
}

/// The configured tokens, as digests.
#[derive(Debug, Clone, Copy, Default)]
pub struct Tokens {
    pub producer: Option<TokenDigest>,
    pub viewer: Option<TokenDigest>,
    pub admin: Option<TokenDigest>,
}

impl Tokens {
    pub fn new(auth: &super::config::Auth) -> Tokens {
        let digest = |t: &Option<String>| t.as_deref().filter(|t| !t.is_empty()).map(TokenDigest::of);
        Tokens {
            producer: digest(&auth.producer_token),
            viewer: digest(&auth.viewer_token),
            admin: digest(&auth.admin_token),
        }
    }
}

fn role_name(access: Access) -> &'static str {
    match access {
        Access::Viewer => "viewer",
        Access::Producer => "producer",
        Access::Admin => "admin",
    }
}

async fn check(
    state: &AppState,
    access: Access,
    head: Option<&str>,
    request: Request,
    next: Next,
) -> Result<Response, ApiError> {
    let head_token = match (access, head) {
        (Access::Producer, Some(id)) => state.registry.get(id).and_then(|h| h.producer_token()),
        _ => None,
    };
    if allows(state, access, head_token, presented(&request).as_deref()) {
        Ok(next.run(request).await)
    } else {
        Err(ApiError::Unauthorized {
            role: role_name(access),
        })
    }
}

pub async fn viewer(
    State(state): State<AppState>,
    request: Request,
    next: Next,
) -> Result<Response, ApiError> {
    check(&state, Access::Viewer, None, request, next).await
}

pub async fn admin(
    State(state): State<AppState>,
    request: Request,
    next: Next,
) -> Result<Response, ApiError> {
    check(&state, Access::Admin, None, request, next).await
}

pub async fn producer(
    State(state): State<AppState>,
    Path(params): Path<HashMap<String, String>>,
    request: Request,
    next: Next,
) -> Result<Response, ApiError> {
    check(
        &state,
        Access::Producer,
        params.get("id").map(String::as_str),
        request,
        next,
    )
    .await
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn digests_round_trip_through_hex() {
        let d = TokenDigest::of("secret");
        assert_eq!(
            d.to_hex(),
            "2bb80d537b1da3e38bd30361aa855686bde0eacd7162fef6a25fe97bf527a25b"
        );
        assert_eq!(TokenDigest::from_hex(&d.to_hex()), Some(d));
        assert_eq!(TokenDigest::from_hex("zz"), None);
        assert!(d.matches(TokenDigest::of("secret")));
        assert!(!d.matches(TokenDigest::of("secreT")));
    }

    #[test]
    fn query_tokens_are_percent_decoded_and_come_before_the_header() {
        let request = |uri: &str| {
            Request::builder()
                .uri(uri)
                .header("authorization", "Bearer header")
                .body(axum::body::Body::empty())
                .unwrap()
        };
        assert_eq!(
            presented(&request("/x?a=1&token=a%20b+c%2Fd")).as_deref(),
            Some("a b c/d")
        );
        assert_eq!(presented(&request("/x?a=1")).as_deref(), Some("header"));
    }
}
