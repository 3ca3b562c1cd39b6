//! facewire's wire protocol: the message types that the server, the CLI clients and the
//! tests share, so that all of them agree on every field and byte. `PROTOCOL.md` beside
//! this crate describes the same messages for clients written in other languages.

/// The protocol version, the first segment of every HTTP and WebSocket path (`/v1/...`).
pub const PROTOCOL_VERSION: &str = "v1";
