//! Errors of the stream readers and writers. A reader error always says where it happened
//! (file when known, 1-based line) and which field was wrong, so that a producer can fix
//! its file from the message alone; a writer error names the frame and the field.
//!
//! Fields that repeat input (a key in a field path, a value found, a name) are cut when
//! displayed ([`clip_message`]): every reader builds them, and one place cuts them all.

use std::fmt;
use std::sync::Arc;

use crate::mask::UnknownUnit;
use crate::quote::clip_message as cut;

/// Where a reader or [`crate::stream::Frame::check`] found a problem.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Location {
    /// A line of a text stream: the file or message when known, and the 1-based line.
    Line { file: Option<Arc<str>>, line: u64 },
    /// A frame that is not a line of text (a binary `FWP1` message, a frame built in
    /// code), named by its sequence number.
    Frame { seq: u64 },
}

impl Location {
    /// Line `line` of `file`.
    pub fn line(file: Option<Arc<str>>, line: u64) -> Location {
        Location::Line { file, line }
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line {
                file: Some(file),
                line,
            } => write!(f, "{file}: line {line}"),
            Location::Line { file: None, line } => write!(f, "line {line}"),
            Location::Frame { seq } => write!(f, "frame {seq}"),
        }
    }
}

/// Everything that can go wrong while reading or writing a parameter stream.
///
/// Readers stop at their first error: the iterator yields it once and then ends.
#[derive(Debug, thiserror::Error)]
pub enum StreamError {
    #[error("cannot open {path}: {source}")]
    Open { path: String, source: std::io::Error },
    #[error("{path}: unknown stream format {extension:?}; expected .jsonl, .fap, .fau, .au.txt or .txt")]
    UnknownFormat { path: String, extension: String },
    #[error("{at}: cannot read: {source}")]
    Read { at: Location, source: std::io::Error },
    #[error("{at}: line is longer than {limit} bytes")]
    LineTooLong { at: Location, limit: usize },
    #[error("{at}: line is not valid UTF-8 (byte {offset})")]
    NotUtf8 { at: Location, offset: usize },
    #[error("{at}: {}: file ends early, expected {expected}", cut(.field))]
    Truncated {
        at: Location,
        field: String,
        expected: String,
    },
    #[error("{at}: {}: {}", cut(.field), cut(.message))]
    Syntax {
        at: Location,
        field: String,
        message: String,
    },
    #[error("{at}: {}: {} is not {expected}", cut(.field), cut(.found))]
    NotANumber {
        at: Location,
        field: String,
        found: String,
        expected: &'static str,
    },
    #[error("{at}: {}: {} is not a finite number", cut(.field), cut(.found))]
    NotFinite {
        at: Location,
        field: String,
        found: String,
    },
    #[error("{at}: {}: {} is out of range (expected {expected})", cut(.field), cut(.found))]
    OutOfRange {
        at: Location,
        field: String,
        found: String,
        expected: String,
    },
    #[error("{at}: {}: has {found} entries, expected {expected}", cut(.field))]
    WrongLength {
        at: Location,
        field: String,
        found: usize,
        expected: String,
    },
    #[error("{at}: {}: {source}", cut(.field))]
    UnknownUnit {
        at: Location,
        field: String,
        source: Box<UnknownUnit>,
    },
    #[error("{at}: {}: unknown {what} {}; valid: {valid}", cut(.field), cut(&format!("{:?}", .name)))]
    UnknownName {
        at: Location,
        field: String,
        what: &'static str,
        name: String,
        valid: String,
    },
    #[error("{at}: {}: names the same {what} as {}", cut(.field), cut(.other))]
    Duplicate {
        at: Location,
        field: String,
        what: &'static str,
        other: String,
    },
    #[error("{at}: {}: time {time} s is before the previous frame's {previous} s", cut(.field))]
    TimeBackwards {
        at: Location,
        field: String,
        time: f64,
        previous: f64,
    },
    #[error("{at}: {}: {seq} does not increase on the previous frame's {previous}", cut(.field))]
    SeqNotIncreasing {
        at: Location,
        field: String,
        seq: u64,
        previous: u64,
    },
    #[error("{at}: data after the {frames} frames the header announces")]
    TrailingData { at: Location, frames: u64 },
    #[error("frame {seq}: {field}: {reason}")]
    InvalidFrame { seq: u64, field: String, reason: String },
    #[error("frame {seq}: {field}: the {format} format cannot carry it")]
    Unrepresentable {
        seq: u64,
        field: String,
        format: &'static str,
    },
    #[error("the header announces {announced} frames but {written} were written")]
    FrameCountMismatch { announced: u64, written: u64 },
    #[error("cannot write: {source}")]
    Write { source: std::io::Error },
    #[error("{option} must be {expected}, got {found}")]
    InvalidOption {
        option: &'static str,
        expected: &'static str,
        found: String,
    },
}

impl StreamError {
    /// A [`StreamError::Syntax`] at `at` in `field`.
    pub(crate) fn syntax(at: &Location, field: &str, message: impl Into<String>) -> StreamError {
        StreamError::Syntax {
            at: at.clone(),
            field: field.to_string(),
            message: message.into(),
        }
    }

    /// The field that is wrong, as a producer names it: the frame's top-level JSONL key
    /// (`au` for an error in `au.jaw_drop`, `controls` for `controls[3][1]`, `t`, `seq`,
    /// `json` for text that is not JSON) or, in `.fap` and AU text files, the part of
    /// the file (`header fps`, `mask`, `values`, `column 2 (jaw_drop)`). The message
    /// ([`std::fmt::Display`]) names the member or index too. `None` when no field is at
    /// fault (the file cannot be read, a line is too long).
    pub fn field(&self) -> Option<&str> {
        let field = match self {
            StreamError::Truncated { field, .. }
            | StreamError::Syntax { field, .. }
            | StreamError::NotANumber { field, .. }
            | StreamError::NotFinite { field, .. }
            | StreamError::OutOfRange { field, .. }
            | StreamError::WrongLength { field, .. }
            | StreamError::UnknownUnit { field, .. }
            | StreamError::UnknownName { field, .. }
            | StreamError::Duplicate { field, .. }
            | StreamError::TimeBackwards { field, .. }
            | StreamError::SeqNotIncreasing { field, .. }
            | StreamError::InvalidFrame { field, .. }
            | StreamError::Unrepresentable { field, .. } => field.as_str(),
            StreamError::InvalidOption { option, .. } => option,
            StreamError::Open { .. }
            | StreamError::UnknownFormat { .. }
            | StreamError::Read { .. }
            | StreamError::LineTooLong { .. }
            | StreamError::NotUtf8 { .. }
            | StreamError::TrailingData { .. }
            | StreamError::FrameCountMismatch { .. }
            | StreamError::Write { .. } => return None,
        };
        field.split(['.', '[']).next()
    }
}

impl From<std::io::Error> for StreamError {
    /// Only writers convert I/O errors implicitly; readers attach a [`Location`].
    fn from(source: std::io::Error) -> Self {
        StreamError::Write { source }
    }
}

/// Parses a finite `f32` or `f64`, straight from the decimal text (so a value written with
/// `{}` reads back bit for bit).
pub(crate) fn parse_finite<T>(at: &Location, text: &str, field: &str) -> Result<T, StreamError>
where
    T: std::str::FromStr + Into<f64> + Copy,
{
    let value: T = text.parse().map_err(|_| StreamError::NotANumber {
        at: at.clone(),
        field: field.to_string(),
        found: format!("{text:?}"),
        expected: "a number",
    })?;
    if value.into().is_finite() {
        Ok(value)
    } else {
        Err(StreamError::NotFinite {
            at: at.clone(),
            field: field.to_string(),
            found: text.to_string(),
        })
    }
}
