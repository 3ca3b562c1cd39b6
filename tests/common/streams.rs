//! The first error each stream reader finds in a bad text: what the stream-format tests
//! check, line and field.

use facewire::mask::Mask;
use facewire::stream::{AuTextOptions, AuTextReader, FapReader, JsonlReader, StreamError};

pub fn jsonl_error(text: &str) -> StreamError {
    JsonlReader::new(text.as_bytes(), &Mask::candide3())
        .find_map(Result::err)
        .expect("the input is bad")
}

pub fn fap_error(text: &str) -> StreamError {
    FapReader::new(text.as_bytes())
        .find_map(Result::err)
        .expect("the input is bad")
}

/// The first error of an AU text read with `options`, whether the header or a line.
pub fn au_error(text: &str, options: AuTextOptions) -> StreamError {
    match AuTextReader::new(text.as_bytes(), &Mask::candide3(), options) {
        Ok(mut reader) => reader.find_map(Result::err).expect("the input is bad"),
        Err(e) => e,
    }
}
