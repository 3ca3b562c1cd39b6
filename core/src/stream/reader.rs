//! What the line-based stream readers (JSONL, AU text, `.fap`) share, so that each format's
//! file holds only how it parses its lines: reading one line at a time with the source's
//! name and line number for errors, counting frames, checking their order (`seq`
//! increasing, time not decreasing), and stopping at the first error.

use std::io::BufRead;
use std::sync::Arc;

use super::error::{Location, StreamError};
use super::frame::Frame;
use super::lines::{Decoding, LineReader};

/// One line-based file format: how its lines become frames.
pub trait LineFormat {
    /// How the format's text is decoded.
    const DECODING: Decoding;
    /// The fields that name a frame's sequence number and its time in order errors.
    const SEQ_FIELD: &'static str;
    const TIME_FIELD: &'static str;

    /// The next frame and the location that names it (its last line), reading lines from
    /// `lines` into `line`; `Ok(None)` at the end of the input. `frames_read` counts the
    /// frames read before this one.
    fn read_frame<R: BufRead>(
        &mut self,
        lines: &mut LineReader<R>,
        line: &mut String,
        frames_read: u64,
    ) -> Result<Option<(Frame, Location)>, StreamError>;
}

/// An iterator over the frames of a line-based format `F`, read from any [`BufRead`]; it
/// ends after the first error.
pub struct FrameReader<R, F> {
    lines: LineReader<R>,
    line: String,
    pub(super) format: F,
    frames_read: u64,
    previous: Option<(u64, f64)>,
    done: bool,
}

impl<R: BufRead, F: LineFormat> FrameReader<R, F> {
    pub(super) fn with_format(input: R, format: F) -> Self {
        FrameReader {
            lines: LineReader::new(input, F::DECODING),
            line: String::new(),
            format,
            frames_read: 0,
            previous: None,
            done: false,
        }
    }

    /// Names the source in error messages (usually the file path).
    pub fn with_source_name(mut self, name: impl Into<Arc<str>>) -> Self {
        self.lines.set_file(name.into());
        self
    }

    /// The format's state with the line reader, for what a format reads besides frames
    /// (a `.fap` header).
    pub(super) fn format_and_lines(&mut self) -> (&mut F, &mut LineReader<R>, &mut String) {
        (&mut self.format, &mut self.lines, &mut self.line)
    }

    fn read_frame(&mut self) -> Result<Option<Frame>, StreamError> {
        let read = self
            .format
            .read_frame(&mut self.lines, &mut self.line, self.frames_read)?;
        let Some((frame, at)) = read else {
            return Ok(None);
        };
        if let Some((previous_seq, previous_time)) = self.previous {
            if frame.seq <= previous_seq {
                return Err(StreamError::SeqNotIncreasing {
                    at,
                    field: F::SEQ_FIELD.to_string(),
                    seq: frame.seq,
                    previous: previous_seq,
                });
            }
            if frame.time_s < previous_time {
                return Err(StreamError::TimeBackwards {
                    at,
                    field: F::TIME_FIELD.to_string(),
                    time: frame.time_s,
                    previous: previous_time,
                });
            }
        }
        self.previous = Some((frame.seq, frame.time_s));
        self.frames_read += 1;
        Ok(Some(frame))
    }
}

impl<R: BufRead, F: LineFormat> Iterator for FrameReader<R, F> {
    type Item = Result<Frame, StreamError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let result = self.read_frame().transpose();
        self.done = !matches!(result, Some(Ok(_)));
        result
    }
}
