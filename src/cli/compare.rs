//! `facewire compare`: run many interpolation algorithms over one stream on one head and
//! write the comparison (tables, charts, report) that the default algorithm is chosen from.
//! A thin layer over [`crate::report`]: arguments, loading, a progress bar, the summary.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::fitted_head::FittedHeadArgs;
use super::part_arg::{describe_parts, load_parts};
use super::{has_suffix, load_glb_skin, print_json, CliResult, FilePath};
use crate::animate::AnimatedHead;
use crate::report::{
    compare, every_preset, parse_algorithms, write_report, AlgorithmSummary, Column, CompareInput,
    Comparison, Progress, ReportContext, Stage, ALGORITHM_COLUMNS,
};
use crate::stream::{open_stream, ArkitBasis};
use crate::targets::ExpressionTarget;

/// The shipped heads whose expression targets ship beside them: (head file, folder of
/// targets relative to the head's folder).
const SHIPPED_TARGETS: [(&str, &str); 2] = [
    ("makehuman_head.obj", "makehuman_arkit"),
    ("ict_head.obj", "ict_targets/skin"),
];

#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    fitted: FittedHeadArgs,
    /// Parameter stream (.jsonl, .fap, .fau).
    #[arg(long)]
    stream: FilePath,
    /// Output directory (created if missing).
    #[arg(long)]
    out: FilePath,
    /// Comma-separated specs or preset letters (`A,C,T`, `G,rbf:kernel=gaussian,r_mm=30`);
    /// default: every preset A-V. Specs that are not presets are labelled X1, X2, ...
    #[arg(long)]
    algos: Option<String>,
    /// Folder of the head's expression targets (*.target) for the ground-truth error;
    /// default: a glTF avatar's morph targets, and for the shipped heads that have them,
    /// `makehuman_arkit/` beside makehuman_head.obj and `ict_targets/skin/` beside
    /// ict_head.obj.
    #[arg(long)]
    targets: Option<FilePath>,
    /// A part mesh (teeth, gums, tongue) in the head's units and frame, as `PATH` (its
    /// role, skull or jaw, inferred) or `ROLE:PATH` (skull, jaw, tongue or eyes). Repeatable.
    /// With teeth, the report measures contact inside the mouth (`contact.tsv`).
    #[arg(long = "part", value_name = "[ROLE:]PATH")]
    parts: Vec<String>,
    /// Print the algorithms table as JSON on stdout.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> CliResult {
    let algorithms = match &args.algos {
        Some(list) => parse_algorithms(list)?,
        None => every_preset(),
    };
    let parts = load_parts(&args.parts)?;
    let (head, fitted) = args.fitted.load()?;
    // Fail before the slow part when the stream cannot be opened.
    drop(open_stream(&args.stream, &fitted.mask)?);
    let targets = load_targets(&args, head.positions.len())?;
    let animated = AnimatedHead::with_parts(args.fitted.register(head, fitted)?, parts)
        .map_err(|e| format!("{}: {e}", args.fitted.head.display()))?;
    describe_parts(&animated);

    let basis = ArkitBasis::shipped();
    let animated = Arc::new(animated);
    let input = CompareInput {
        head: &animated,
        stream: &args.stream,
        basis: &basis,
        algorithms: &algorithms,
        targets: targets.as_ref().map_or(&[], |t| t.targets.as_slice()),
    };
    let mut bar = ProgressBar::new(std::io::stderr().is_terminal());
    let comparison = compare(&input, &mut |p| bar.update(p))?;
    bar.clear();

    let command = command_line(&args);
    let machine = machine();
    let display = |p: &Path| p.display().to_string();
    let targets_dir = targets.as_ref().map(|t| display(&t.dir));
    let context = ReportContext {
        command: &command,
        machine: &machine,
        head: &display(&args.fitted.head),
        fit: &display(&args.fitted.fit),
        stream: &display(&args.stream),
        targets: targets_dir.as_deref(),
    };
    let written = write_report(&args.out, &comparison, &context)?;
    eprintln!("wrote {} files to {}", written.len(), args.out.display());

    let summaries: Vec<&AlgorithmSummary> = comparison.algorithms.iter().map(|a| &a.summary).collect();
    if args.json {
        return print_json(&summaries);
    }
    print_table(&comparison);
    Ok(())
}

/// Expression targets with the folder (or glTF file) they came from.
struct Targets {
    dir: PathBuf,
    targets: Vec<ExpressionTarget>,
}

/// The targets to score against: `--targets` must load; a shipped head's own folder
/// ([`SHIPPED_TARGETS`]) is used when it loads for this head and skipped otherwise.
fn load_targets(
    args: &Args,
    vertex_count: usize,
) -> Result<Option<Targets>, Box<dyn std::error::Error + Send + Sync>> {
    if let Some(dir) = &args.targets {
        let targets = ExpressionTarget::load_dir(dir, vertex_count)?;
        if targets.is_empty() {
            return Err(format!("{}: no .target files", dir.display()).into());
        }
        return Ok(Some(Targets {
            dir: dir.clone(),
            targets,
        }));
    }
    if has_suffix(&args.fitted.head, ".glb") {
        // A glTF avatar's morph targets are its expression targets.
        let skin = load_glb_skin(&args.fitted.head)?;
        let targets: Vec<ExpressionTarget> = skin
            .targets
            .into_iter()
            .map(|t| ExpressionTarget::from_displacements(&t.name, t.offsets))
            .filter(|t| !t.listed.is_empty())
            .collect();
        if targets.is_empty() {
            eprintln!(
                "no ground truth: {} has no morph targets",
                args.fitted.head.display()
            );
            return Ok(None);
        }
        return Ok(Some(Targets {
            dir: args.fitted.head.clone(),
            targets,
        }));
    }
    let head_file = args
        .fitted
        .head
        .file_name()
        .map(|n| n.to_string_lossy().to_lowercase());
    let Some((_, folder)) = SHIPPED_TARGETS
        .iter()
        .find(|(head, _)| head_file.as_deref() == Some(*head))
    else {
        return Ok(None);
    };
    let dir = args.fitted.head.parent().unwrap_or(Path::new("")).join(folder);
    match ExpressionTarget::load_dir(&dir, vertex_count) {
        Ok(targets) if !targets.is_empty() => Ok(Some(Targets { dir, targets })),
        Ok(_) => {
            eprintln!("no ground truth: {} has no .target files", dir.display());
            Ok(None)
        }
        Err(e) => {
            eprintln!("no ground truth: {e}");
            Ok(None)
        }
    }
}

/// The command as a user would type it, from the arguments given.
fn command_line(args: &Args) -> String {
    let mut words = vec!["facewire".to_string(), "compare".to_string()];
    let mut push = |flag: &str, value: &str| {
        words.push(flag.to_string());
        words.push(shell_word(value));
    };
    for (flag, value) in args.fitted.words() {
        push(flag, &value);
    }
    push("--stream", &args.stream.display().to_string());
    push("--out", &args.out.display().to_string());
    if let Some(list) = &args.algos {
        push("--algos", list);
    }
    if let Some(dir) = &args.targets {
        push("--targets", &dir.display().to_string());
    }
    for part in &args.parts {
        push("--part", part);
    }
    words.join(" ")
}

/// `text` quoted for a POSIX shell when it needs quoting.
fn shell_word(text: &str) -> String {
    let plain = |c: char| c.is_ascii_alphanumeric() || "_./:=,+-".contains(c);
    if !text.is_empty() && text.chars().all(plain) {
        text.to_string()
    } else {
        format!("'{}'", text.replace('\'', r"'\''"))
    }
}

/// CPU model and core count, for the report's timings.
fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|info| {
            info.lines().find_map(|l| {
                l.strip_prefix("model name")?
                    .split_once(':')
                    .map(|(_, m)| m.trim().to_string())
            })
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    format!(
        "{cpu}, {cores} cores, {} {}",
        std::env::consts::OS,
        std::env::consts::ARCH
    )
}

fn print_table(comparison: &Comparison) {
    // Each column as wide as its title or 9, whichever is wider.
    let width = |column: &Column| column.short.len().max(9);
    let mut header = format!("{:<3} {:<58}", "", "spec");
    let columns: Vec<&Column> = ALGORITHM_COLUMNS
        .iter()
        .filter(|c| c.applies_to(comparison))
        .collect();
    for column in &columns {
        header += &format!(" {:>w$}", column.short, w = width(column));
    }
    println!("{header}");
    for a in &comparison.algorithms {
        let s = &a.summary;
        let mut row = format!("{:<3} {:<58}", s.letter, s.spec);
        for column in &columns {
            row += &format!(" {:>w$}", column.shown(s), w = width(column));
        }
        println!("{row}");
    }
    println!(
        "{:<3} {:<58} {:>9.5}",
        "", "(head at rest)", comparison.rest_roughness
    );
}

/// `[########........] 7/22 algorithms (G), frame 120/487` on a terminal, redrawn in
/// place; one line per finished algorithm otherwise (logs, pipes).
struct ProgressBar {
    terminal: bool,
    drawn: bool,
}

impl ProgressBar {
    const WIDTH: usize = 24;

    fn new(terminal: bool) -> ProgressBar {
        ProgressBar {
            terminal,
            drawn: false,
        }
    }

    fn update(&mut self, p: Progress<'_>) {
        let mut err = std::io::stderr().lock();
        if !self.terminal {
            if p.stage == Stage::Finished {
                let _ = writeln!(err, "[{}/{}] {} measured", p.algorithm + 1, p.algorithms, p.label);
            }
            return;
        }
        let (within, detail) = match p.stage {
            Stage::Binding => (0.0, format!("binding {}", p.label)),
            Stage::Frames { done, total } => {
                // Redraw every 16 frames: drawing is slower than measuring a frame.
                if done % 16 != 0 && done != total {
                    return;
                }
                (
                    done as f64 / total as f64,
                    format!("{}, frame {done}/{total}", p.label),
                )
            }
            Stage::Targets { done, total } => (1.0, format!("{}, target {done}/{total}", p.label)),
            Stage::Finished => (1.0, format!("{} done", p.label)),
        };
        let fraction = (p.algorithm as f64 + within) / p.algorithms as f64;
        let filled = ((fraction * Self::WIDTH as f64).round() as usize).min(Self::WIDTH);
        let _ = write!(
            err,
            "\r[{}{}] {}/{} algorithms ({detail})\x1b[K",
            "#".repeat(filled),
            ".".repeat(Self::WIDTH - filled),
            p.algorithm + 1,
            p.algorithms
        );
        let _ = err.flush();
        self.drawn = true;
    }

    /// Erases the bar so later messages start on a clean line.
    fn clear(&mut self) {
        if self.drawn {
            eprint!("\r\x1b[K");
            self.drawn = false;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::shell_word;

    #[test]
    fn shell_words_are_quoted_when_needed() {
        assert_eq!(shell_word("data/heads/a.obj"), "data/heads/a.obj");
        assert_eq!(
            shell_word("bary2:weights=distance,r_mm=10"),
            "bary2:weights=distance,r_mm=10"
        );
        assert_eq!(shell_word("my head.obj"), "'my head.obj'");
        assert_eq!(shell_word("it's"), r"'it'\''s'");
    }
}
