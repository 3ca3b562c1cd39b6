//! Command-line interface: one file per command, each a thin layer over the library.

mod algos;
mod arkit_basis;
mod compare;
mod deform;
mod demo;
mod fit;
mod fitted_head;
pub mod head_client;
mod inspect;
mod load;
mod part_arg;
mod play;
mod population;
mod population_animation;
mod render;
mod serve;
mod speech;
mod syllables;
mod watch;

use std::path::{Path, PathBuf};

use clap::{Parser, Subcommand};

use crate::fit::{Fit, FitFile};
use crate::head::Head;
use crate::mask::Mask;

/// Errors reach the user as text; each command builds them with enough context.
pub type CliResult = Result<(), Box<dyn std::error::Error + Send + Sync>>;

#[derive(Debug, Parser)]
#[command(
    name = "facewire",
    version,
    about = "Animate real 3D heads from CANDIDE-3 / MPEG-4 parameter streams"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the demo: the service with the three shipped heads and a looping syllable stream.
    Demo(demo::Args),
    /// Run the service.
    Serve(serve::Args),
    /// Push a stream file to a producer WebSocket in real time.
    Play(play::Args),
    /// Watch a stream headlessly: fps, latency per hop, bytes per frame.
    Watch(watch::Args),
    /// Load a running service: S producers and V viewers on loopback, with latency,
    /// skips, stalls and the server's CPU and memory.
    Load(load::Args),
    /// Summarize a mask (.wfm), head (.obj), fit (.fit.toml), landmarks (.landmarks.toml)
    /// or parameter stream (.jsonl, .fap, .fau, .txt).
    Inspect(inspect::Args),
    /// Solve a fit of the CANDIDE-3 mask to a head, from landmarks or automatically.
    Fit(fit::Args),
    /// Render a head, optionally with its fitted mask, to a PNG picture.
    Render(render::Args),
    /// Write the generated 27-syllable parameter stream as JSONL.
    Syllables(syllables::Args),
    /// Derive the ARKit retarget basis from a head's expression targets and its fit.
    ArkitBasis(arkit_basis::Args),
    /// List every interpolation variant (preset letters A-V) with its spec.
    Algos(algos::Args),
    /// Deform a head with one algorithm over a stream, writing OBJ frames and control.tsv.
    Deform(deform::Args),
    /// Compare algorithms on a head over a stream: roughness, fidelity and speed, written as
    /// TSV tables, SVG charts and a Markdown report.
    Compare(compare::Args),
    /// Fit a population of heads automatically (ICT identities, MakeHuman, the scan and
    /// their variants) and print how close each lies to its landmark fit.
    Population(population::Args),
    /// Derive a parameter stream from a voice alone: the WAV file's visemes, every 10 ms,
    /// as a JSONL stream.
    Speech(speech::Args),
}

pub fn run(cli: Cli) -> CliResult {
    match cli.command {
        Command::Demo(args) => demo::run(args),
        Command::Serve(args) => serve::run(args),
        Command::Play(args) => play::run(args),
        Command::Watch(args) => watch::run(args),
        Command::Load(args) => load::run(args),
        Command::Inspect(args) => inspect::run(args),
        Command::Fit(args) => fit::run(args),
        Command::Render(args) => render::run(args),
        Command::Syllables(args) => syllables::run(args),
        Command::ArkitBasis(args) => arkit_basis::run(args),
        Command::Algos(args) => algos::run(args),
        Command::Deform(args) => deform::run(args),
        Command::Compare(args) => compare::run(args),
        Command::Population(args) => population::run(args),
        Command::Speech(args) => speech::run(args),
    }
}

/// The mask to use: a `.wfm` file if given, else the embedded CANDIDE-3.1.6.
fn load_mask(path: Option<&Path>) -> Result<Mask, Box<dyn std::error::Error + Send + Sync>> {
    Ok(match path {
        Some(p) => Mask::load(p)?,
        None => Mask::candide3(),
    })
}

/// Loads and resolves a `.fit.toml`.
fn load_fit(path: &Path, mask: &Mask) -> Result<Fit, Box<dyn std::error::Error + Send + Sync>> {
    let origin = path.display().to_string();
    Ok(FitFile::load(path)?.resolve(&origin, mask)?)
}

/// A head file: an OBJ, or the skin of a glTF binary avatar (`.glb`, in metres; its
/// skin told from its parts by their names, `head::glb_head`).
fn load_head(path: &Path) -> Result<Head, Box<dyn std::error::Error + Send + Sync>> {
    if !has_suffix(path, ".glb") {
        return Ok(Head::load(path)?);
    }
    let skin = load_glb_skin(path)?;
    Ok(Head::new(
        &path.display().to_string(),
        skin.positions,
        skin.triangles,
    ))
}

/// Every mesh a glTF binary avatar's scene places (`head::read_glb`).
fn load_glb(path: &Path) -> Result<Vec<crate::head::GlbMesh>, Box<dyn std::error::Error + Send + Sync>> {
    let bytes = crate::input::read_file(path, crate::input::MAX_HEAD_BYTES)?;
    Ok(crate::head::read_glb(&bytes).map_err(|e| format!("{}: {e}", path.display()))?)
}

/// The skin of a glTF binary avatar, with its morph targets.
fn load_glb_skin(path: &Path) -> Result<crate::head::GlbMesh, Box<dyn std::error::Error + Send + Sync>> {
    let head = crate::head::glb_head(load_glb(path)?, &[]).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(head.skin)
}

/// Millimetres per head unit when a head file's format says it (glTF: metres).
fn format_mm_per_unit(path: &Path) -> Option<f32> {
    has_suffix(path, ".glb").then_some(crate::head::MM_PER_METRE)
}

/// `name.fit.toml` -> true for the compound extension.
fn has_suffix(path: &Path, suffix: &str) -> bool {
    path.file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase().ends_with(suffix))
        .unwrap_or(false)
}

/// Prints a serializable value as pretty JSON.
fn print_json(value: &impl serde::Serialize) -> CliResult {
    println!("{}", serde_json::to_string_pretty(value)?);
    Ok(())
}

/// A path argument, for clap.
type FilePath = PathBuf;
