//! Little-endian reads over a message that name the field on every short read, with byte
//! offsets counted from the start of the whole message, also inside a section's body.

use crate::varint;
use crate::DecodeError;

/// Little-endian reader over a byte slice that names the field on every short read.
pub(crate) struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
    /// Where `bytes` starts in the whole message.
    base: usize,
}

impl<'a> Reader<'a> {
    pub(crate) fn new(bytes: &'a [u8]) -> Reader<'a> {
        Reader::within(bytes, 0)
    }

    /// A reader over part of a message (a section's body) that starts at byte `base` of it.
    pub(crate) fn within(bytes: &'a [u8], base: usize) -> Reader<'a> {
        Reader { bytes, at: 0, base }
    }

    /// The next byte's offset in the whole message.
    pub(crate) fn position(&self) -> usize {
        self.base + self.at
    }

    pub(crate) fn take(&mut self, n: usize, field: &'static str) -> Result<&'a [u8], DecodeError> {
        let end =
            self.at
                .checked_add(n)
                .filter(|&e| e <= self.bytes.len())
                .ok_or(DecodeError::Truncated {
                    field,
                    at: self.position(),
                    end: self.position().saturating_add(n),
                    len: self.base + self.bytes.len(),
                })?;
        let slice = &self.bytes[self.at..end];
        self.at = end;
        Ok(slice)
    }

    /// The four-byte magic a message starts with, without consuming it.
    pub(crate) fn magic(bytes: &[u8]) -> Result<[u8; 4], DecodeError> {
        match bytes.get(..4) {
            Some(magic) => Ok(magic.try_into().expect("four bytes")),
            None => Err(DecodeError::Truncated {
                field: "magic",
                at: 0,
                end: 4,
                len: bytes.len(),
            }),
        }
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

    /// Refuses bytes after the last field.
    pub(crate) fn finish(&self) -> Result<(), DecodeError> {
        match self.remaining() {
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
        let at = self.position();
        let (value, used) = varint::decode(&self.bytes[self.at..]).ok_or(DecodeError::Invalid {
            field,
            at,
            problem: "truncated or over-long varint".into(),
        })?;
        self.at += used;
        Ok(value)
    }
}
