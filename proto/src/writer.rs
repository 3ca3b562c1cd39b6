//! Little-endian writes onto a message buffer, the counterpart of [`crate::Reader`]: fixed
//! fields, labels, and u32 slots written now and filled in once their value is known.

use crate::varint;

/// Appends little-endian fields to a byte buffer.
pub(crate) trait Writer {
    fn put_u8(&mut self, x: u8);
    fn put_u16(&mut self, x: u16);
    fn put_u32(&mut self, x: u32);
    fn put_u64(&mut self, x: u64);
    fn put_f32(&mut self, x: f32);
    fn put_f64(&mut self, x: f64);
    fn put_f32s(&mut self, xs: &[f32]);
    /// A label of at most 255 bytes, cut at a character boundary: u8 length, UTF-8 bytes.
    fn put_label(&mut self, label: &str);
    fn put_varint(&mut self, x: u64);
    /// A u32 written as 0 now; returns where, for [`Writer::fill_u32`].
    fn slot_u32(&mut self) -> usize;
    fn fill_u32(&mut self, slot: usize, x: u32);
}

impl Writer for Vec<u8> {
    fn put_u8(&mut self, x: u8) {
        self.push(x);
    }

    fn put_u16(&mut self, x: u16) {
        self.extend_from_slice(&x.to_le_bytes());
    }

    fn put_u32(&mut self, x: u32) {
        self.extend_from_slice(&x.to_le_bytes());
    }

    fn put_u64(&mut self, x: u64) {
        self.extend_from_slice(&x.to_le_bytes());
    }

    fn put_f32(&mut self, x: f32) {
        self.extend_from_slice(&x.to_le_bytes());
    }

    fn put_f64(&mut self, x: f64) {
        self.extend_from_slice(&x.to_le_bytes());
    }

    fn put_f32s(&mut self, xs: &[f32]) {
        for &x in xs {
            self.put_f32(x);
        }
    }

    fn put_label(&mut self, label: &str) {
        let mut end = label.len().min(255);
        while !label.is_char_boundary(end) {
            end -= 1;
        }
        self.push(end as u8);
        self.extend_from_slice(&label.as_bytes()[..end]);
    }

    fn put_varint(&mut self, x: u64) {
        varint::encode(x, self);
    }

    fn slot_u32(&mut self) -> usize {
        self.put_u32(0);
        self.len() - 4
    }

    fn fill_u32(&mut self, slot: usize, x: u32) {
        self[slot..slot + 4].copy_from_slice(&x.to_le_bytes());
    }
}
