//! What every WebSocket session does the same way: JSON text messages, refusals (an
//! `error`, then a close with a code from [`CloseCode`]), and the closing handshake done
//! properly: the server sends its close frame and waits (briefly) for the client's, so the
//! close reaches every client that reads instead of being lost to a TCP reset.

use std::time::Duration;

use axum::extract::ws::{CloseFrame, Message, WebSocket};
use facewire_proto::codes::{CloseCode, ErrorCode};
use facewire_proto::messages::ServerMessage;
use tokio_tungstenite::tungstenite;

/// How long the server waits for the client's close frame after sending its own.
const CLOSE_WAIT: Duration = Duration::from_secs(2);

pub fn text(message: &ServerMessage) -> Message {
    Message::Text(serde_json::to_string(message).expect("messages serialize").into())
}

/// An `error` message with no frame to point at.
pub fn error(code: ErrorCode, message: impl Into<String>) -> ServerMessage {
    ServerMessage::Error {
        code,
        message: message.into(),
        seq: None,
        field: None,
    }
}

/// Sends a close frame and waits up to [`CLOSE_WAIT`] for the client's answer.
pub async fn close(socket: &mut WebSocket, code: CloseCode, reason: &str) {
    let frame = CloseFrame {
        code: code.code(),
        reason: truncate(reason, 120).into(),
    };
    if socket.send(Message::Close(Some(frame))).await.is_err() {
        return;
    }
    let _ = tokio::time::timeout(CLOSE_WAIT, async {
        while let Some(Ok(message)) = socket.recv().await {
            if matches!(message, Message::Close(_)) {
                break;
            }
        }
    })
    .await;
}

/// Sends `error` then closes with `code`.
pub async fn refuse(socket: &mut WebSocket, code: ErrorCode, close_code: CloseCode, message: String) {
    let _ = socket.send(text(&error(code, message.clone()))).await;
    close(socket, close_code, &message).await;
}

/// The close to answer a failed read with: 1009 for a message over the limit, 1007 for
/// text that is not UTF-8.
pub fn close_for(e: axum::Error, limit: usize) -> Option<(CloseCode, String)> {
    match e.into_inner().downcast::<tungstenite::Error>().map(|e| *e) {
        Ok(tungstenite::Error::Capacity(_)) => Some((
            CloseCode::MessageTooBig,
            format!("message_too_large: the limit is {limit} bytes"),
        )),
        Ok(tungstenite::Error::Utf8(_)) => {
            Some((CloseCode::InvalidPayload, "a text message is not UTF-8".into()))
        }
        Ok(tungstenite::Error::Protocol(p)) => Some((CloseCode::InvalidPayload, p.to_string())),
        _ => None,
    }
}

/// At most `max` bytes of `text`, cut at a character boundary.
fn truncate(text: &str, max: usize) -> &str {
    let mut end = text.len().min(max);
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    &text[..end]
}

#[cfg(test)]
mod tests {
    #[test]
    fn close_reasons_fit_a_control_frame() {
        assert_eq!(super::truncate("abc", 120), "abc");
        let long = "é".repeat(100);
        let cut = super::truncate(&long, 120);
        assert_eq!(cut.len(), 120);
        assert!(super::truncate(&long, 121).len() == 120);
    }
}
