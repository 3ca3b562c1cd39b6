//! Every machine-readable code the service answers with: error codes (HTTP bodies and
//! WebSocket `error` messages), WebSocket close codes, and the reasons a stream ends. One
//! table each, so the server, its clients, the page (`web/codes.js`, checked against this
//! file by a test) and `PROTOCOL.md` cannot drift apart.

use serde::{Deserialize, Serialize};

/// What went wrong, as a client can branch on it. Serialized in `snake_case`
/// (`ErrorCode::UnknownHead` is `"unknown_head"`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ErrorCode {
    /// The request is malformed (bad JSON, missing field, wrong combination).
    BadRequest,
    /// A head or stream id is not 1-64 of `a-z 0-9 - _`.
    BadId,
    /// The landmarks given for registration are invalid.
    BadLandmarks,
    /// A fit or head file given for registration is invalid.
    BadHead,
    /// A parameter frame was refused (its `field` and `seq` say where).
    BadFrame,
    /// The algorithm spec is invalid or not allowed on this server.
    BadAlgorithm,
    /// `seq` did not increase or `t` went back.
    OutOfOrder,
    /// More frames per second than `max_fps`.
    RateLimited,
    /// A WebSocket message over `max_message_bytes`.
    MessageTooLarge,
    /// A body over `max_upload_bytes`.
    TooLarge,
    /// A batch with more than `max_batch_frames` frames.
    TooManyFrames,
    /// A batch longer than `max_batch_duration_s`.
    TooLong,
    /// A missing or wrong token.
    Unauthorized,
    /// No such head.
    UnknownHead,
    /// No such stream, or it has no producer to cancel.
    UnknownStream,
    /// No such path or method.
    NotFound,
    /// The head id is taken.
    HeadExists,
    /// Another producer holds the stream.
    ProducerBusy,
    /// The head failed to register (its `error` says why).
    RegistrationFailed,
    /// The head is still registering.
    Registering,
    /// A limit on streams, algorithms, viewers, connections or registrations is reached.
    LimitReached,
    /// The producer sent nothing for `producer_idle_s`.
    Idle,
    /// The request took longer than `request_timeout_s`.
    Timeout,
    /// The server is shutting down.
    ShuttingDown,
    /// The cluster bus (NATS) cannot be reached now: retry, or use another node.
    BusUnavailable,
    /// A fault on the server; the answer carries a `request_id` the log also has.
    Internal,
}

impl ErrorCode {
    /// Every code, in the order of `PROTOCOL.md`'s table.
    pub const ALL: [ErrorCode; 26] = [
        ErrorCode::BadRequest,
        ErrorCode::BadId,
        ErrorCode::BadLandmarks,
        ErrorCode::BadHead,
        ErrorCode::BadFrame,
        ErrorCode::BadAlgorithm,
        ErrorCode::OutOfOrder,
        ErrorCode::RateLimited,
        ErrorCode::MessageTooLarge,
        ErrorCode::TooLarge,
        ErrorCode::TooManyFrames,
        ErrorCode::TooLong,
        ErrorCode::Unauthorized,
        ErrorCode::UnknownHead,
        ErrorCode::UnknownStream,
        ErrorCode::NotFound,
        ErrorCode::HeadExists,
        ErrorCode::ProducerBusy,
        ErrorCode::RegistrationFailed,
        ErrorCode::Registering,
        ErrorCode::LimitReached,
        ErrorCode::Idle,
        ErrorCode::Timeout,
        ErrorCode::ShuttingDown,
        ErrorCode::BusUnavailable,
        ErrorCode::Internal,
    ];

    /// The code as it appears on the wire.
    pub fn as_str(self) -> &'static str {
        match self {
            ErrorCode::BadRequest => "bad_request",
            ErrorCode::BadId => "bad_id",
            ErrorCode::BadLandmarks => "bad_landmarks",
            ErrorCode::BadHead => "bad_head",
            ErrorCode::BadFrame => "bad_frame",
            ErrorCode::BadAlgorithm => "bad_algorithm",
            ErrorCode::OutOfOrder => "out_of_order",
            ErrorCode::RateLimited => "rate_limited",
            ErrorCode::MessageTooLarge => "message_too_large",
            ErrorCode::TooLarge => "too_large",
            ErrorCode::TooManyFrames => "too_many_frames",
            ErrorCode::TooLong => "too_long",
            ErrorCode::Unauthorized => "unauthorized",
            ErrorCode::UnknownHead => "unknown_head",
            ErrorCode::UnknownStream => "unknown_stream",
            ErrorCode::NotFound => "not_found",
            ErrorCode::HeadExists => "head_exists",
            ErrorCode::ProducerBusy => "producer_busy",
            ErrorCode::RegistrationFailed => "registration_failed",
            ErrorCode::Registering => "registering",
            ErrorCode::LimitReached => "limit_reached",
            ErrorCode::Idle => "idle",
            ErrorCode::Timeout => "timeout",
            ErrorCode::ShuttingDown => "shutting_down",
            ErrorCode::BusUnavailable => "bus_unavailable",
            ErrorCode::Internal => "internal",
        }
    }
}

impl std::fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// WebSocket close codes the server uses. 1000-1011 are RFC 6455's; 4000-4999 are
/// facewire's, 4000 + the HTTP status they resemble.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u16)]
pub enum CloseCode {
    /// The session is over as agreed (the producer sent `end`).
    Normal = 1000,
    /// The server is shutting down; reconnect later (to another node if there is one).
    GoingAway = 1001,
    /// A text message that is not UTF-8.
    InvalidPayload = 1007,
    /// A message over the server's size limit (`max_message_bytes`).
    MessageTooBig = 1009,
    /// The request cannot be served as asked (a bad algorithm spec): do not retry.
    BadRequest = 4400,
    /// The head does not exist: do not retry.
    UnknownHead = 4404,
    /// The producer sent nothing for `producer_idle_s`.
    Idle = 4408,
    /// Another producer holds the stream: retry when it is done.
    ProducerBusy = 4409,
    /// The head was deleted while the socket was open; a head registered again under the
    /// same id is a new head: reconnect to see it.
    HeadDeleted = 4410,
    /// The head failed to register: do not retry.
    RegistrationFailed = 4422,
    /// The producer's stream was cancelled (`DELETE .../producer`).
    Cancelled = 4499,
    /// The server is full or the head is still registering: retry later.
    TryLater = 4503,
}

impl CloseCode {
    /// Every close code, in the order of `PROTOCOL.md`'s table.
    pub const ALL: [CloseCode; 12] = [
        CloseCode::Normal,
        CloseCode::GoingAway,
        CloseCode::InvalidPayload,
        CloseCode::MessageTooBig,
        CloseCode::BadRequest,
        CloseCode::UnknownHead,
        CloseCode::Idle,
        CloseCode::ProducerBusy,
        CloseCode::HeadDeleted,
        CloseCode::RegistrationFailed,
        CloseCode::Cancelled,
        CloseCode::TryLater,
    ];

    pub fn code(self) -> u16 {
        self as u16
    }

    /// The name `web/codes.js` and `PROTOCOL.md` use.
    pub fn name(self) -> &'static str {
        match self {
            CloseCode::Normal => "normal",
            CloseCode::GoingAway => "going_away",
            CloseCode::InvalidPayload => "invalid_payload",
            CloseCode::MessageTooBig => "message_too_big",
            CloseCode::BadRequest => "bad_request",
            CloseCode::UnknownHead => "unknown_head",
            CloseCode::Idle => "idle",
            CloseCode::ProducerBusy => "producer_busy",
            CloseCode::HeadDeleted => "head_deleted",
            CloseCode::RegistrationFailed => "registration_failed",
            CloseCode::Cancelled => "cancelled",
            CloseCode::TryLater => "try_later",
        }
    }

    /// Whether a client should give up rather than reconnect.
    pub fn is_final(self) -> bool {
        matches!(
            self,
            CloseCode::BadRequest | CloseCode::UnknownHead | CloseCode::RegistrationFailed
        )
    }
}

/// Why a stream ended: the `reason` of an `end` message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EndReason {
    /// The producer sent `{"type":"end"}`.
    ProducerEnded,
    /// An HTTP batch played its last frame.
    BatchFinished,
    /// The producer's connection closed without `end`.
    ProducerDisconnected,
    /// The producer sent nothing for `producer_idle_s` and was closed.
    ProducerIdle,
    /// The producer (socket or batch) was cancelled with `DELETE .../producer`.
    ProducerCancelled,
    /// The head was deleted.
    HeadDeleted,
    /// The server is shutting down.
    ServerShutdown,
}

impl EndReason {
    pub const ALL: [EndReason; 7] = [
        EndReason::ProducerEnded,
        EndReason::BatchFinished,
        EndReason::ProducerDisconnected,
        EndReason::ProducerIdle,
        EndReason::ProducerCancelled,
        EndReason::HeadDeleted,
        EndReason::ServerShutdown,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            EndReason::ProducerEnded => "producer_ended",
            EndReason::BatchFinished => "batch_finished",
            EndReason::ProducerDisconnected => "producer_disconnected",
            EndReason::ProducerIdle => "producer_idle",
            EndReason::ProducerCancelled => "producer_cancelled",
            EndReason::HeadDeleted => "head_deleted",
            EndReason::ServerShutdown => "server_shutdown",
        }
    }

    /// A sentence for people.
    pub fn message(self) -> &'static str {
        match self {
            EndReason::ProducerEnded => "the producer ended the stream",
            EndReason::BatchFinished => "the batch finished",
            EndReason::ProducerDisconnected => "the producer disconnected",
            EndReason::ProducerIdle => "the producer went idle and was closed",
            EndReason::ProducerCancelled => "the producer was cancelled",
            EndReason::HeadDeleted => "the head was deleted",
            EndReason::ServerShutdown => "the server is shutting down",
        }
    }
}

impl std::fmt::Display for EndReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wire_names_are_the_serde_names() {
        for code in ErrorCode::ALL {
            assert_eq!(
                serde_json::to_string(&code).unwrap(),
                format!("\"{}\"", code.as_str())
            );
        }
        for reason in EndReason::ALL {
            assert_eq!(
                serde_json::to_string(&reason).unwrap(),
                format!("\"{}\"", reason.as_str())
            );
        }
    }

    #[test]
    fn close_codes_are_distinct_and_in_range() {
        let mut seen = std::collections::HashSet::new();
        for code in CloseCode::ALL {
            assert!(seen.insert(code.code()), "{code:?} twice");
            assert!(
                (1000..=1011).contains(&code.code()) || (4000..=4999).contains(&code.code()),
                "{code:?}"
            );
        }
    }
}
