//! `facewire speech`: a voice in, a parameter stream out, offline: the WAV file goes
//! through the same causal viseme tracker the server runs on a producer's audio
//! (docs/SPEECH.md), and each frame of the written JSONL stream carries the viseme
//! decided nearest its time (`"viseme": {"oculus": NAME}`), which drives mouth, jaw and
//! tongue on every head as FAP 1.

use std::fmt::Write as _;
use std::sync::Arc;
use std::time::Instant;

use super::{load_mask, CliResult, FilePath};
use crate::atomic::write_atomic;
use crate::speech::{speech_frames, VisemeModel};
use crate::stream::visemes::VISEMES;
use crate::stream::{syllables, JsonlWriter};
use crate::voice::read_wav;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// The voice: a WAV file at 16, 24 or 48 kHz (mixed to mono).
    wav: FilePath,
    /// Where to write the stream (JSONL); an existing file is replaced atomically.
    #[arg(long)]
    out: FilePath,
    /// Frames per second of the written stream (at most 1000).
    #[arg(long, default_value_t = syllables::SHIPPED_FPS)]
    fps: f64,
    /// Also write every 10 ms decision as TSV: frame, centre time (s), viseme, and its
    /// probability.
    #[arg(long)]
    decisions: Option<FilePath>,
    /// A viseme model other than the shipped one (data/speech/train.py writes them).
    #[arg(long)]
    model: Option<FilePath>,
}

pub fn run(args: Args) -> CliResult {
    if !(args.fps.is_finite() && args.fps > 0.0 && args.fps <= 1000.0) {
        return Err(format!("--fps {}: expected a number above 0 and at most 1000", args.fps).into());
    }
    let model = match &args.model {
        Some(path) => {
            let bytes = std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
            VisemeModel::from_bytes(&bytes, &path.display().to_string())?
        }
        None => VisemeModel::embedded()?,
    };
    let file = args.wav.display().to_string();
    let reader = std::fs::File::open(&args.wav).map_err(|e| format!("cannot read {file}: {e}"))?;
    let voice = read_wav(std::io::BufReader::new(reader), &file)?;
    let started = Instant::now();
    let (frames, decisions) = speech_frames(&voice, Arc::new(model), args.fps)?;
    let took_s = started.elapsed().as_secs_f64();

    let mask = load_mask(None)?;
    let mut writer = JsonlWriter::new(Vec::new(), &mask);
    for frame in &frames {
        writer.write_frame(frame)?;
    }
    let bytes = writer.into_inner()?;
    write_atomic(&args.out, &bytes).map_err(|e| format!("cannot write {}: {e}", args.out.display()))?;
    if let Some(path) = &args.decisions {
        let mut tsv = String::from("frame\ttime_s\tviseme\tprobability\n");
        for d in &decisions {
            let name = VISEMES[usize::from(d.viseme)].oculus;
            let p = d.probability[usize::from(d.viseme)];
            let _ = writeln!(tsv, "{}\t{:.4}\t{name}\t{p:.3}", d.frame, d.time_s);
        }
        write_atomic(path, tsv.as_bytes()).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    let duration_s = voice.duration_s();
    println!(
        "wrote {} frames ({duration_s:.2} s at {} fps) to {}; {} visemes decided in {:.3} s ({:.0}x real time)",
        frames.len(),
        args.fps,
        args.out.display(),
        decisions.len(),
        took_s,
        duration_s / took_s.max(1e-9),
    );
    Ok(())
}
