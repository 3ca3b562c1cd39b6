//! Command-line interface: one file per command, each a thin layer over the library.

mod fit;
mod inspect;
mod render;

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
    /// Summarize a mask (.wfm), head (.obj), fit (.fit.toml) or landmarks (.landmarks.toml).
    Inspect(inspect::Args),
    /// Solve a fit of the CANDIDE-3 mask to a head from landmark correspondences.
    Fit(fit::Args),
    /// Render a head, optionally with its fitted mask, to a PNG picture.
    Render(render::Args),
}

pub fn run(cli: Cli) -> CliResult {
    match cli.command {
        Command::Inspect(args) => inspect::run(args),
        Command::Fit(args) => fit::run(args),
        Command::Render(args) => render::run(args),
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

fn load_head(path: &Path) -> Result<Head, Box<dyn std::error::Error + Send + Sync>> {
    Ok(Head::load(path)?)
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
