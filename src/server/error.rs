//! HTTP errors as an enum of causes. Each answers a status, a code a client can branch on
//! ([`ErrorCode`]) and a message a person can act on, as JSON
//! (`{"error":"unknown_head","message":"no head \"x\""}`). Server faults log their cause
//! under the request's id and answer only `internal` with that id, never internal text
//! such as file paths. A socket refused before its session closes with
//! [`ApiError::close_code`].

use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use axum::Json;
use facewire_proto::codes::{CloseCode, ErrorCode};
use facewire_proto::messages::ErrorBody;

use crate::quote::quote;

tokio::task_local! {
    /// The id of the request being handled (set by [`super::app`]'s request-id layer).
    pub static REQUEST_ID: String;
}

#[derive(Debug, thiserror::Error)]
pub enum ApiError {
    #[error("{0}")]
    BadRequest(String),
    #[error("{what} {} is not valid: use 1-64 lowercase letters, digits, '-' or '_'", quote(.id))]
    BadId { what: &'static str, id: String },
    #[error("{0}")]
    BadLandmarks(String),
    /// A head that cannot be fitted automatically (no face found, an OBJ that does not parse).
    #[error("{0}")]
    BadHead(String),
    #[error("{0}")]
    BadFrame(String),
    #[error("{0}")]
    BadAlgorithm(String),
    #[error("the body is larger than {limit} bytes")]
    TooLarge { limit: usize },
    #[error("more than {limit} frames in one batch")]
    TooManyFrames { limit: usize },
    #[error("the batch spans {duration_s} s; at most {limit_s} s")]
    TooLong { duration_s: f64, limit_s: f64 },
    #[error("a valid {role} token is required (?token= or Authorization: Bearer)")]
    Unauthorized { role: &'static str },
    #[error("no head {}", quote(.0))]
    UnknownHead(String),
    #[error("stream {} of head {} has no producer", quote(.stream), quote(.head))]
    NoProducer { head: String, stream: String },
    #[error("no such resource: {}", quote(.0))]
    NotFound(String),
    #[error("method {} is not allowed on {}", quote(.method), quote(.path))]
    MethodNotAllowed { method: String, path: String },
    #[error("head {} is already registered", quote(.0))]
    HeadExists(String),
    #[error("stream {} already has a producer; one at a time", quote(.0))]
    ProducerBusy(String),
    #[error("head {} failed to register: {error}", quote(.id))]
    RegistrationFailed { id: String, error: String },
    #[error("head {} is still registering ({percent:.0} %)", quote(.id))]
    Registering { id: String, percent: f32 },
    #[error("{0}")]
    LimitReached(String),
    #[error("the request took longer than {0} s")]
    Timeout(f64),
    #[error("the server is shutting down")]
    ShuttingDown,
    #[error("the cluster bus is unreachable now ({0}); try again, or another node")]
    BusUnavailable(String),
    #[error("internal error: {0}")]
    Internal(#[source] Box<dyn std::error::Error + Send + Sync>),
}

impl ApiError {
    pub fn internal(cause: impl Into<Box<dyn std::error::Error + Send + Sync>>) -> ApiError {
        ApiError::Internal(cause.into())
    }

    pub fn status(&self) -> StatusCode {
        match self {
            ApiError::BadRequest(_)
            | ApiError::BadId { .. }
            | ApiError::BadLandmarks(_)
            | ApiError::BadHead(_)
            | ApiError::BadFrame(_)
            | ApiError::BadAlgorithm(_) => StatusCode::BAD_REQUEST,
            ApiError::TooLarge { .. } | ApiError::TooManyFrames { .. } | ApiError::TooLong { .. } => {
                StatusCode::PAYLOAD_TOO_LARGE
            }
            ApiError::Unauthorized { .. } => StatusCode::UNAUTHORIZED,
            ApiError::UnknownHead(_) | ApiError::NoProducer { .. } | ApiError::NotFound(_) => {
                StatusCode::NOT_FOUND
            }
            ApiError::MethodNotAllowed { .. } => StatusCode::METHOD_NOT_ALLOWED,
            ApiError::HeadExists(_) | ApiError::ProducerBusy(_) | ApiError::RegistrationFailed { .. } => {
                StatusCode::CONFLICT
            }
            ApiError::LimitReached(_) => StatusCode::TOO_MANY_REQUESTS,
            ApiError::Timeout(_) => StatusCode::REQUEST_TIMEOUT,
            ApiError::Registering { .. } | ApiError::ShuttingDown | ApiError::BusUnavailable(_) => {
                StatusCode::SERVICE_UNAVAILABLE
            }
            ApiError::Internal(_) => StatusCode::INTERNAL_SERVER_ERROR,
        }
    }

    pub fn code(&self) -> ErrorCode {
        match self {
            ApiError::BadRequest(_) => ErrorCode::BadRequest,
            ApiError::BadId { .. } => ErrorCode::BadId,
            ApiError::BadLandmarks(_) => ErrorCode::BadLandmarks,
            ApiError::BadHead(_) => ErrorCode::BadHead,
            ApiError::BadFrame(_) => ErrorCode::BadFrame,
            ApiError::BadAlgorithm(_) => ErrorCode::BadAlgorithm,
            ApiError::TooLarge { .. } => ErrorCode::TooLarge,
            ApiError::TooManyFrames { .. } => ErrorCode::TooManyFrames,
            ApiError::TooLong { .. } => ErrorCode::TooLong,
            ApiError::Unauthorized { .. } => ErrorCode::Unauthorized,
            ApiError::UnknownHead(_) => ErrorCode::UnknownHead,
            ApiError::NoProducer { .. } => ErrorCode::UnknownStream,
            ApiError::NotFound(_) | ApiError::MethodNotAllowed { .. } => ErrorCode::NotFound,
            ApiError::HeadExists(_) => ErrorCode::HeadExists,
            ApiError::ProducerBusy(_) => ErrorCode::ProducerBusy,
            ApiError::RegistrationFailed { .. } => ErrorCode::RegistrationFailed,
            ApiError::Registering { .. } => ErrorCode::Registering,
            ApiError::LimitReached(_) => ErrorCode::LimitReached,
            ApiError::Timeout(_) => ErrorCode::Timeout,
            ApiError::ShuttingDown => ErrorCode::ShuttingDown,
            ApiError::BusUnavailable(_) => ErrorCode::BusUnavailable,
            ApiError::Internal(_) => ErrorCode::Internal,
        }
    }

    /// The WebSocket close code of a viewer or producer refused with this error before
    /// its session starts (proto/PROTOCOL.md, "Close codes"): what to do next, as the
    /// status is for HTTP. Whatever a client cannot fix by asking otherwise is "try later".
    pub fn close_code(&self) -> CloseCode {
        match self {
            // No such head, or no such recording of it (a replay).
            ApiError::UnknownHead(_) | ApiError::NotFound(_) => CloseCode::UnknownHead,
            ApiError::RegistrationFailed { .. } => CloseCode::RegistrationFailed,
            ApiError::BadAlgorithm(_) | ApiError::BadId { .. } | ApiError::BadRequest(_) => {
                CloseCode::BadRequest
            }
            ApiError::ProducerBusy(_) => CloseCode::ProducerBusy,
            ApiError::ShuttingDown => CloseCode::GoingAway,
            _ => CloseCode::TryLater,
        }
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let status = self.status();
        let request_id = REQUEST_ID.try_with(Clone::clone).ok();
        let body = match &self {
            ApiError::Internal(cause) => {
                tracing::error!(request_id = request_id.as_deref().unwrap_or("-"), error = %cause, "request failed");
                ErrorBody {
                    error: ErrorCode::Internal,
                    message: "internal error; the server's log has the cause under this request_id".into(),
                    request_id,
                }
            }
            refused => {
                tracing::debug!(code = %refused.code(), message = %refused, "request refused");
                ErrorBody {
                    error: refused.code(),
                    message: refused.to_string(),
                    request_id: None,
                }
            }
        };
        (status, Json(body)).into_response()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn client_values_are_quoted_short() {
        let long = "x".repeat(6 << 20);
        let message = ApiError::HeadExists(long.clone()).to_string();
        assert!(message.len() < 120, "{} bytes", message.len());
        assert!(message.contains("6291456 bytes"), "{message}");
        assert_eq!(
            ApiError::UnknownHead("scan".into()).to_string(),
            "no head \"scan\""
        );
        assert!(
            ApiError::BadId {
                what: "stream name",
                id: long
            }
            .to_string()
            .len()
                < 200
        );
    }

    #[tokio::test]
    async fn internal_errors_carry_the_request_id_and_no_cause() {
        let response = REQUEST_ID
            .scope("r-7".to_string(), async {
                ApiError::internal(std::io::Error::other("/srv/facewire-data/heads: disk full"))
                    .into_response()
            })
            .await;
        assert_eq!(response.status(), StatusCode::INTERNAL_SERVER_ERROR);
        let bytes = axum::body::to_bytes(response.into_body(), 1 << 16).await.unwrap();
        let body: ErrorBody = serde_json::from_slice(&bytes).unwrap();
        assert_eq!(body.error, ErrorCode::Internal);
        assert_eq!(body.request_id.as_deref(), Some("r-7"));
        assert!(!body.message.contains("/srv"), "{}", body.message);
    }
}
