//! Reading the files a user names: regular files only, under a size cap, and text decoded
//! with the position of the first bad byte.
//!
//! `std::fs::read` on `/dev/zero` reads until memory runs out, on a FIFO it waits for a
//! writer, and on a directory it fails with a message that does not say why; a fit whose
//! `head` points at any of them must be refused at once. The kind of file is checked
//! before opening, and the read stops one byte past the cap in case the file grows.

use std::io::Read;
use std::path::Path;

use crate::quote::clip_message;

/// Largest head (OBJ) file read: 1 GiB. The most vertices and triangles the reader takes
/// ([`crate::head::obj::MAX_ELEMENTS`] each) fill about 350 MB; the rest is room for
/// normals, texture coordinates and comments.
pub const MAX_HEAD_BYTES: u64 = 1 << 30;

/// Largest small text file read (fits, landmarks, masks, expression targets, ARKit
/// bases): 64 MiB, thousands of times the shipped ones.
pub const MAX_TEXT_BYTES: u64 = 64 << 20;

#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error("cannot read {path}: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("cannot read {path}: it is {kind}, not a regular file")]
    NotAFile { path: String, kind: &'static str },
    #[error("cannot read {path}: it has more than {limit} bytes")]
    TooLarge { path: String, limit: u64 },
    #[error("{path}: line {line}, column {column}: not valid UTF-8 (byte {offset})")]
    NotUtf8 {
        path: String,
        line: usize,
        column: usize,
        offset: usize,
    },
}

/// The bytes of the regular file `path`, refusing directories, devices, FIFOs and
/// sockets, and files longer than `limit` bytes.
pub fn read_file(path: &Path, limit: u64) -> Result<Vec<u8>, ReadError> {
    let name = || path.display().to_string();
    let io = |source| ReadError::Io { path: name(), source };
    let kind = std::fs::metadata(path).map_err(io)?.file_type();
    if !kind.is_file() {
        return Err(ReadError::NotAFile {
            path: name(),
            kind: describe(&kind),
        });
    }
    let file = std::fs::File::open(path).map_err(io)?;
    let mut bytes = Vec::new();
    file.take(limit + 1).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > limit {
        return Err(ReadError::TooLarge { path: name(), limit });
    }
    Ok(bytes)
}

/// The regular file `path` as UTF-8 text (at most `limit` bytes).
pub fn read_text(path: &Path, limit: u64) -> Result<String, ReadError> {
    let bytes = read_file(path, limit)?;
    utf8(&path.display().to_string(), &bytes)?;
    Ok(String::from_utf8(bytes).expect("checked just above"))
}

/// `bytes` as UTF-8, or where the first invalid byte is (1-based line and column, 0-based
/// byte offset); `origin` names the source in the error.
pub fn utf8<'a>(origin: &str, bytes: &'a [u8]) -> Result<&'a str, ReadError> {
    std::str::from_utf8(bytes).map_err(|e| {
        let offset = e.valid_up_to();
        let (line, column) = line_column(&bytes[..offset], offset);
        ReadError::NotUtf8 {
            path: origin.to_string(),
            line,
            column,
            offset,
        }
    })
}

/// A TOML error as `line L, column C: message`, the message with long input cut (the
/// toml crate's own text repeats the whole offending line).
pub fn toml_error(text: &str, error: &toml::de::Error) -> String {
    let message = clip_message(error.message().trim());
    match error.span() {
        Some(span) => {
            let (line, column) = line_column(text.as_bytes(), span.start);
            format!("line {line}, column {column}: {message}")
        }
        None => message,
    }
}

/// 1-based line and column (in characters) of byte `offset` in `text`.
fn line_column(text: &[u8], offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line_start = before.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let column = String::from_utf8_lossy(&before[line_start..]).chars().count() + 1;
    (line, column)
}

fn describe(kind: &std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if kind.is_dir() {
        "a directory"
    } else if kind.is_char_device() {
        "a character device"
    } else if kind.is_block_device() {
        "a block device"
    } else if kind.is_fifo() {
        "a FIFO"
    } else if kind.is_socket() {
        "a socket"
    } else {
        "a special file"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_and_directories_are_refused_before_reading() {
        let err = read_file(Path::new("/dev/zero"), MAX_HEAD_BYTES).unwrap_err();
        assert_eq!(
            err.to_string(),
            "cannot read /dev/zero: it is a character device, not a regular file"
        );
        let dir = tempfile::tempdir().unwrap();
        let err = read_file(dir.path(), MAX_TEXT_BYTES).unwrap_err();
        assert!(
            err.to_string().ends_with("it is a directory, not a regular file"),
            "{err}"
        );
        let fifo = dir.path().join("fifo");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status().unwrap();
        assert!(made.success());
        let err = read_file(&fifo, MAX_TEXT_BYTES).unwrap_err();
        assert!(
            err.to_string().ends_with("it is a FIFO, not a regular file"),
            "{err}"
        );
    }

    #[test]
    fn files_over_the_limit_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.obj");
        std::fs::write(&path, vec![b'#'; 101]).unwrap();
        assert_eq!(read_file(&path, 101).unwrap().len(), 101);
        let err = read_file(&path, 100).unwrap_err();
        assert!(err.to_string().ends_with("it has more than 100 bytes"), "{err}");
    }

    #[test]
    fn bad_utf8_names_line_and_column() {
        let err = utf8("f.toml", b"scale = 1\nhead = \"h\xe9\"\n").unwrap_err();
        assert_eq!(
            err.to_string(),
            "f.toml: line 2, column 10: not valid UTF-8 (byte 19)"
        );
    }
}
