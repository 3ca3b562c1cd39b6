//! The parameter-stream formats end to end: the real Xface `.fap` file, round trips through
//! every writer, one error per kind of bad input (each naming its line and field), and the
//! shipped syllable stream. One module per format, plus the syllables and the command line.
//!
//! `FACEWIRE_BLESS=1 cargo test --test core streams::` rewrites `data/streams/syllables.jsonl`
//! from the generator.

mod au_text;
mod cli;
mod fap;
mod jsonl;
mod syllables;

use std::path::PathBuf;

use crate::common::repo_path;
use facewire::stream::{Frame, StreamError};

fn xface_joy() -> PathBuf {
    repo_path("data/candide3/xface_joy.fap")
}

fn fap_value(frame: &Frame, fap: u8) -> Option<f32> {
    frame.faps.iter().find(|(f, _)| *f == fap).map(|(_, v)| *v)
}

fn read_all(stream: impl Iterator<Item = Result<Frame, StreamError>>) -> Vec<Frame> {
    stream.collect::<Result<_, _>>().unwrap()
}
