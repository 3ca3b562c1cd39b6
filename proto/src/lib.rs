//! facewire's wire protocol: the message types that the server, the CLI clients and the
//! tests share, so that all of them agree on every field and byte. `PROTOCOL.md` beside
//! this crate describes the same messages for clients written in other languages.
//!
//! - [`codes`]: error codes, WebSocket close codes and end-of-stream reasons.
//! - [`messages`]: JSON control messages (snapshots, acks, errors, end of stream).
//! - [`frame`]: the binary per-frame message a viewer receives (quantized vertex deltas
//!   plus roughness).
//! - [`mesh`]: the binary rest mesh a viewer downloads once.
//! - [`params`]: the binary per-frame message a producer may send instead of JSON.

pub mod codes;
pub mod frame;
pub mod mesh;
pub mod messages;
pub mod params;
mod varint;

/// The protocol version, the first segment of every HTTP and WebSocket path (`/v1/...`).
pub const PROTOCOL_VERSION: &str = "v1";

/// Errors decoding a binary message: what is wrong and at which byte.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum DecodeError {
    #[error("message too short: {field} needs bytes {at}..{end}, the message has {len}")]
    Truncated {
        field: &'static str,
        at: usize,
        end: usize,
        len: usize,
    },
    #[error("bad magic {found:?}: expected {expected:?}")]
    Magic { found: [u8; 4], expected: [u8; 4] },
    #[error("byte {at}: {field}: {problem}")]
    Invalid {
        field: &'static str,
        at: usize,
        problem: String,
    },
    #[error("{extra} unexpected byte(s) after the message")]
    Trailing { extra: usize },
}

impl DecodeError {
    /// The field of the layout that is wrong (`flags`, `au weight`, `delta block`), as
    /// PROTOCOL.md names it; `None` for a bad magic or bytes after the message.
    pub fn field(&self) -> Option<&'static str> {
        match self {
            DecodeError::Truncated { field, .. } | DecodeError::Invalid { field, .. } => Some(field),
            DecodeError::Magic { .. } | DecodeError::Trailing { .. } => None,
        }
    }
}

/// Little-endian reader over a byte slice that names the field on every short read.
pub(crate) struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    pub(crate) fn new(bytes: &'a [u8]) -> Reader<'a> {
        Reader { bytes, at: 0 }
    }

    pub(crate) fn position(&self) -> usize {
        self.at
    }

    pub(crate) fn take(&mut self, n: usize, field: &'static str) -> Result<&'a [u8], DecodeError> {
        let end =
            self.at
                .checked_add(n)
                .filter(|&e| e <= self.bytes.len())
                .ok_or(DecodeError::Truncated {
                    field,
                    at: self.at,
                    end: self.at.saturating_add(n),
                    len: self.bytes.len(),
                })?;
        let slice = &self.bytes[self.at..end];
        self.at = end;
        Ok(slice)
    }

    pub(crate) fn array<const N: usize>(&mut self, field: &'static str) -> Result<[u8; N], DecodeError> {
        Ok(self.take(N, field)?.try_into().expect("take returned N bytes"))
    }

    pub(crate) fn u8(&mut self, field: &'static str) -> Result<u8, DecodeError> {
        Ok(self.array::<1>(field)?[0])
    }

    pub(crate) fn u16(&mut self, field: &'static str) -> Result<u16, DecodeError> {
        Ok(u16::from_le_bytes(self.array(field)?))
    }

    pub(crate) fn u32(&mut self, field: &'static str) -> Result<u32, DecodeError> {
        Ok(u32::from_le_bytes(self.array(field)?))
    }

    pub(crate) fn u64(&mut self, field: &'static str) -> Result<u64, DecodeError> {
        Ok(u64::from_le_bytes(self.array(field)?))
    }

    pub(crate) fn f32(&mut self, field: &'static str) -> Result<f32, DecodeError> {
        Ok(f32::from_le_bytes(self.array(field)?))
    }

    pub(crate) fn f64(&mut self, field: &'static str) -> Result<f64, DecodeError> {
        Ok(f64::from_le_bytes(self.array(field)?))
    }

    pub(crate) fn finish(&self) -> Result<(), DecodeError> {
        match self.bytes.len() - self.at {
            0 => Ok(()),
            extra => Err(DecodeError::Trailing { extra }),
        }
    }

    pub(crate) fn remaining(&self) -> usize {
        self.bytes.len() - self.at
    }

    /// A label: u8 length, then that many UTF-8 bytes.
    pub(crate) fn label(&mut self) -> Result<String, DecodeError> {
        let len = self.u8("label length")? as usize;
        let at = self.position();
        let text = self.take(len, "label")?;
        String::from_utf8(text.to_vec()).map_err(|_| DecodeError::Invalid {
            field: "label",
            at,
            problem: "not UTF-8".into(),
        })
    }

    pub(crate) fn varint(&mut self, field: &'static str) -> Result<u64, DecodeError> {
        let at = self.at;
        let (value, used) = varint::decode(&self.bytes[self.at..]).ok_or(DecodeError::Invalid {
            field,
            at,
            problem: "truncated or over-long varint".into(),
        })?;
        self.at += used;
        Ok(value)
    }
}
