//! `facewire syllables`: writes the generated 27-syllable stream as JSONL, the input that
//! integration tests, benchmarks and demos replay (docs/STREAMS.md section 6).

use super::{load_mask, CliResult, FilePath};
use crate::atomic::write_atomic;
use crate::stream::{syllables, JsonlWriter};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Where to write the stream (JSONL); an existing file is replaced atomically.
    #[arg(long)]
    out: FilePath,
    /// Frames per second (at most 1000).
    #[arg(long, default_value_t = syllables::SHIPPED_FPS)]
    fps: f64,
}

pub fn run(args: Args) -> CliResult {
    let mask = load_mask(None)?;
    let frames = syllables::generate(args.fps)?;
    let mut writer = JsonlWriter::new(Vec::new(), &mask);
    for frame in &frames {
        writer.write_frame(frame)?;
    }
    let bytes = writer.into_inner()?;
    write_atomic(&args.out, &bytes).map_err(|e| format!("cannot write {}: {e}", args.out.display()))?;
    let duration_s = frames.last().map_or(0.0, |f| f.time_s);
    println!(
        "wrote {} frames ({duration_s} s at {} fps) to {}",
        frames.len(),
        args.fps,
        args.out.display()
    );
    Ok(())
}
