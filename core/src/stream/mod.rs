//! Parameter streams: where animation frames come from and go to when they are files or
//! byte streams rather than live sockets. Every format reads into the same [`Frame`]:
//! facewire's JSONL, MPEG-4 `.fap` files, the legacy tool's AU text, and the generated
//! syllable stream. Readers are iterators over any `BufRead` that read one line at a time
//! (an hour-long file is never loaded whole) and stop at the first error, which names the
//! file, line and field. Every reader, and the binary `FWP1` path, runs the same check on
//! what a frame's values mean and how large they may be ([`Frame::check`]). ARKit blendshape weights reach the mask through a retarget basis
//! ([`arkit`]). The formats are specified in `docs/STREAMS.md`.
//!
//! Plain synchronous Rust: the service wraps these in its own tasks.

pub mod arkit;
mod arkit_targets;
pub mod au_text;
mod blendshapes;
mod check;
mod error;
pub mod expressions;
pub mod fap_file;
mod frame;
pub mod idle_eyes;
pub mod jsonl;
mod lines;
pub mod mouth_shapes;
mod poser;
mod reader;
mod strict_json;
pub mod summary;
pub mod syllable_phonemes;
pub mod syllables;
pub mod visemes;

use std::fs::File;
use std::io::BufReader;
use std::path::Path;
use std::sync::Arc;

pub use arkit::{ArkitBasis, ArkitBasisError};
pub use arkit_targets::{arkit_target_name, ArkitTargetName, ArkitTargets, Side};
pub use au_text::{AuTextOptions, AuTextReader, AuTextWriter};
pub use blendshapes::{arkit_index, ARKIT_BLENDSHAPES, ARKIT_LOOK_RAD};
pub use check::{
    MAX_CONTROL, MAX_FAP_ANGLE_COUNT, MAX_FAP_COUNT, MAX_FPS, MAX_LABEL_BYTES, MAX_ROTATION_RAD, MAX_SEQ,
    MAX_TIME_S, MAX_TRANSLATION, MAX_WEIGHT, MIN_FPS,
};
pub use error::{Location, StreamError};
pub use fap_file::{FapHeader, FapReader, FapWriter};
pub use frame::{ExpressionFap, Frame, VisemeFap, HEAD_ROTATION_FAPS, RADIANS_PER_ANGLE_COUNT};
pub use idle_eyes::IdleEyes;
pub use jsonl::{JsonlReader, JsonlWriter};
pub use lines::MAX_LINE_BYTES;
pub use poser::{animation_weights, mask_offsets, FramePoser};
pub use summary::{summarize, StreamSummary};

use crate::mask::Mask;

/// A stream of frames from any source, ending at its first error.
pub type FrameStream<'m> = Box<dyn Iterator<Item = Result<Frame, StreamError>> + Send + 'm>;

/// The file formats, told apart by extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StreamFormat {
    /// `.jsonl`
    Jsonl,
    /// `.fap`
    Fap,
    /// `.fau`, `.au.txt` or `.txt`
    AuText,
}

impl StreamFormat {
    /// The format of a path by its extension, case-insensitively.
    pub fn from_path(path: &Path) -> Result<StreamFormat, StreamError> {
        let extension = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        match extension.as_str() {
            "jsonl" => Ok(StreamFormat::Jsonl),
            "fap" => Ok(StreamFormat::Fap),
            "fau" | "txt" => Ok(StreamFormat::AuText),
            _ => Err(StreamError::UnknownFormat {
                path: path.display().to_string(),
                extension,
            }),
        }
    }
}

/// Opens a stream file, choosing the reader by extension ([`StreamFormat::from_path`]).
/// AU text is read with [`AuTextOptions::default`]. `mask` resolves unit names.
pub fn open_stream<'m>(path: &Path, mask: &'m Mask) -> Result<FrameStream<'m>, StreamError> {
    let format = StreamFormat::from_path(path)?;
    let file = File::open(path).map_err(|source| StreamError::Open {
        path: path.display().to_string(),
        source,
    })?;
    let input = BufReader::new(file);
    let name: Arc<str> = path.display().to_string().into();
    Ok(match format {
        StreamFormat::Jsonl => Box::new(JsonlReader::new(input, mask).with_source_name(name)),
        StreamFormat::Fap => Box::new(FapReader::new(input).with_source_name(name)),
        StreamFormat::AuText => {
            Box::new(AuTextReader::new(input, mask, AuTextOptions::default())?.with_source_name(name))
        }
    })
}
