//! Line-by-line reading with a length cap, shared by the text readers. An hour-long stream
//! is never loaded whole, and a file without line breaks cannot make a reader allocate
//! without bound: a line over [`MAX_LINE_BYTES`] is an error.

use std::io::{BufRead, ErrorKind};
use std::sync::Arc;

use super::error::{Location, StreamError};

/// The longest line a reader accepts, terminator excluded: 1 MiB. A JSONL frame with
/// control displacements for every CANDIDE vertex takes about 5 KiB.
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// How the bytes of a line become text.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Decoding {
    /// Strict UTF-8 (JSONL).
    Utf8,
    /// ISO-8859-1, one byte per `char`: never fails (`.fap` headers written on Windows).
    Latin1,
}

/// Reads lines from any [`BufRead`], counting them, stripping `\n` or `\r\n`.
pub struct LineReader<R> {
    input: R,
    decoding: Decoding,
    file: Option<Arc<str>>,
    line: u64,
    bytes: Vec<u8>,
}

impl<R: BufRead> LineReader<R> {
    pub(crate) fn new(input: R, decoding: Decoding) -> Self {
        LineReader {
            input,
            decoding,
            file: None,
            line: 0,
            bytes: Vec::new(),
        }
    }

    pub(crate) fn set_file(&mut self, file: Arc<str>) {
        self.file = Some(file);
    }

    /// The line last read; after the end of the input, the line the end was found on.
    pub(crate) fn location(&self) -> Location {
        Location::line(self.file.clone(), self.line)
    }

    /// Reads the next line into `out` (cleared first). Returns `false` at the end of the
    /// input.
    pub(crate) fn read_line(&mut self, out: &mut String) -> Result<bool, StreamError> {
        out.clear();
        self.bytes.clear();
        self.line += 1;
        let mut saw_anything = false;
        loop {
            let available = match self.input.fill_buf() {
                Ok(available) => available,
                Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                Err(source) => {
                    return Err(StreamError::Read {
                        at: self.location(),
                        source,
                    })
                }
            };
            if available.is_empty() {
                if !saw_anything {
                    return Ok(false);
                }
                break;
            }
            saw_anything = true;
            let (chunk, consumed, ended) = match available.iter().position(|&b| b == b'\n') {
                Some(newline) => (&available[..newline], newline + 1, true),
                None => (available, available.len(), false),
            };
            if self.bytes.len() + chunk.len() > MAX_LINE_BYTES {
                return Err(StreamError::LineTooLong {
                    at: self.location(),
                    limit: MAX_LINE_BYTES,
                });
            }
            self.bytes.extend_from_slice(chunk);
            self.input.consume(consumed);
            if ended {
                break;
            }
        }
        if self.bytes.last() == Some(&b'\r') {
            self.bytes.pop();
        }
        match self.decoding {
            Decoding::Utf8 => match std::str::from_utf8(&self.bytes) {
                Ok(text) => out.push_str(text),
                Err(e) => {
                    return Err(StreamError::NotUtf8 {
                        at: self.location(),
                        offset: e.valid_up_to(),
                    })
                }
            },
            Decoding::Latin1 => out.extend(self.bytes.iter().map(|&b| char::from(b))),
        }
        Ok(true)
    }

    /// Reads lines until one holds data: blank lines are skipped, and so are lines whose
    /// first non-blank character is `#` when `skip_comments` is set. Returns `false` at the
    /// end of the input.
    pub(crate) fn read_data_line(
        &mut self,
        out: &mut String,
        skip_comments: bool,
    ) -> Result<bool, StreamError> {
        while self.read_line(out)? {
            let trimmed = out.trim_start();
            if trimmed.is_empty() || (skip_comments && trimmed.starts_with('#')) {
                continue;
            }
            return Ok(true);
        }
        Ok(false)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(input: &[u8], decoding: Decoding) -> Vec<String> {
        let mut reader = LineReader::new(input, decoding);
        let mut out = Vec::new();
        let mut line = String::new();
        while reader.read_line(&mut line).unwrap() {
            out.push(line.clone());
        }
        out
    }

    #[test]
    fn strips_lf_and_crlf_and_keeps_a_last_line_without_terminator() {
        assert_eq!(lines(b"a\r\nb\n\nc", Decoding::Utf8), ["a", "b", "", "c"]);
    }

    #[test]
    fn latin1_never_fails_and_utf8_reports_the_byte() {
        assert_eq!(lines(b"J\xf6rgen\n", Decoding::Latin1), ["Jörgen"]);
        let mut reader = LineReader::new(&b"ok\nJ\xf6rgen\n"[..], Decoding::Utf8);
        let mut line = String::new();
        assert!(reader.read_line(&mut line).unwrap());
        let err = reader.read_line(&mut line).unwrap_err();
        assert_eq!(err.to_string(), "line 2: line is not valid UTF-8 (byte 1)");
    }

    #[test]
    fn a_line_over_the_cap_is_an_error_not_an_allocation() {
        let mut input = vec![b'x'; MAX_LINE_BYTES + 1];
        input.push(b'\n');
        // A small buffer makes the reader see the line in many chunks.
        let mut reader = LineReader::new(
            std::io::BufReader::with_capacity(4096, &input[..]),
            Decoding::Utf8,
        );
        let mut line = String::new();
        let err = reader.read_line(&mut line).unwrap_err();
        assert!(matches!(err, StreamError::LineTooLong { .. }), "{err}");
        assert!(reader.bytes.capacity() <= 2 * MAX_LINE_BYTES);
    }

    #[test]
    fn data_lines_skip_blanks_and_comments() {
        let mut reader = LineReader::new(&b"\n# c\n  \n x\n"[..], Decoding::Utf8);
        let mut line = String::new();
        assert!(reader.read_data_line(&mut line, true).unwrap());
        assert_eq!(line, " x");
        assert_eq!(reader.location(), Location::line(None, 4));
        assert!(!reader.read_data_line(&mut line, true).unwrap());
    }
}
