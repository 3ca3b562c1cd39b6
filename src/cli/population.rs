//! `facewire population`: the automatic fit on a population of heads it was never tuned on
//! (ICT identities made on demand, MakeHuman, the scan, and their face cuts, low-poly,
//! turned, mirrored and rescaled variants), as a Markdown table with a summary per source
//! and for the held-out members (docs/FITTING.md, "On a population").

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::CliResult;
use crate::fit::FitFile;
use crate::head::{obj, Head};
use crate::mask::Mask;
use crate::population::{self, Maker, Member, Outcome};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// The project's data folder (holds heads/ict_identity/ and the shipped heads).
    #[arg(long, default_value = "data")]
    data: PathBuf,
    /// Only the sample CI runs (a third of the development members, a quarter of the
    /// held-out ones).
    #[arg(long)]
    sample: bool,
    /// Only members whose name contains this text.
    #[arg(long)]
    only: Option<String>,
    /// Print the outcomes as JSON lines instead of the table.
    #[arg(long)]
    json: bool,
    /// Write the members into this folder instead of measuring them, as a user would
    /// have them: `NAME.obj`, its parts (`NAME.teeth.obj`, ...) and, for the whole heads,
    /// the landmark fit (`NAME.fit.toml`).
    #[arg(long, conflicts_with = "animate")]
    write: Option<PathBuf>,
    /// Animate the whole heads (with their teeth, gums and tongue) through a stream
    /// instead of measuring the fit: lip folds, lips and tongue in the teeth, f/v gap,
    /// ground truth and deform time per head and fit.
    #[arg(long)]
    animate: bool,
    #[command(flatten)]
    animation: super::population_animation::Args,
}

pub fn run(args: Args) -> CliResult {
    if args.animate {
        return super::population_animation::run(
            &args.data,
            args.sample,
            args.only.as_deref(),
            args.json,
            &args.animation,
        );
    }
    let maker = Maker::new(&args.data)?;
    let mask = Mask::candide3();
    let specs = if args.sample {
        population::sample()
    } else {
        population::members()
    };
    let specs: Vec<_> = specs
        .into_iter()
        .filter(|s| args.only.as_deref().is_none_or(|only| s.name().contains(only)))
        .collect();
    if let Some(dir) = &args.write {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        for spec in &specs {
            let member = maker.make(spec)?;
            for path in write_member(&member, &mask, dir)? {
                println!("{}", path.display());
            }
        }
        return Ok(());
    }
    let mut outcomes = Vec::new();
    for (k, spec) in specs.iter().enumerate() {
        let member = maker.make(spec)?;
        let outcome = population::measure(&member, &mask);
        eprintln!("[{}/{}] {}", k + 1, specs.len(), line(&outcome));
        if args.json {
            println!("{}", serde_json::to_string(&outcome)?);
        }
        outcomes.push(outcome);
    }
    if !args.json {
        print!("{}", table(&outcomes));
    }
    Ok(())
}

/// `member` as files in `dir`, named after it; the paths written.
fn write_member(member: &Member, mask: &Mask, dir: &Path) -> Result<Vec<PathBuf>, String> {
    let stem: String = member
        .spec
        .name()
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect();
    let mut written = Vec::new();
    let mut write = |name: String, bytes: Vec<u8>| -> Result<(), String> {
        let path = dir.join(name);
        std::fs::write(&path, bytes).map_err(|e| format!("{}: {e}", path.display()))?;
        written.push(path);
        Ok(())
    };
    let obj = |head: &Head| -> Result<Vec<u8>, String> {
        let mut bytes = Vec::new();
        let header = [format!("facewire population member: {}", member.spec.name())];
        obj::write(&mut bytes, &header, &head.positions, &head.triangles).map_err(|e| e.to_string())?;
        Ok(bytes)
    };
    write(format!("{stem}.obj"), obj(&member.head)?)?;
    for part in &member.parts {
        write(format!("{stem}.{}.obj", part.name), obj(&part.mesh)?)?;
    }
    if let Some(fit) = &member.landmark_fit {
        let file = FitFile::from_fit(fit, mask, Some(format!("{stem}.obj")));
        write(format!("{stem}.fit.toml"), file.to_toml().into_bytes())?;
    }
    Ok(written)
}

fn line(o: &Outcome) -> String {
    match &o.result {
        Ok(m) => format!(
            "{}: landmarks {:.2} mm (max {:.1} at mask vertex {}), scale {:+.1} %, {:.2} s",
            o.member,
            m.landmark_mean_mm,
            m.landmark_max_mm,
            m.worst_vertex,
            100.0 * m.scale_error,
            o.seconds
        ),
        Err(e) => format!("{}: refused: {e}", o.member),
    }
}

/// Which outcomes a summary row counts.
type Keep = fn(&Outcome) -> bool;

/// The table, then a summary per source and for the held-out members.
pub fn table(outcomes: &[Outcome]) -> String {
    let mut out = String::new();
    out.push_str("| head | held out | vertices | refused | landmark vertices mean / max (mm) | scale error | mask to surface (mm) | face seen | off the marks (mm) | warned | time (s) |\n");
    out.push_str("|---|---|---|---|---|---|---|---|---|---|---|\n");
    for o in outcomes {
        let held = if o.held_out { "yes" } else { "" };
        let _ = match &o.result {
            Ok(m) => writeln!(
                out,
                "| {} | {held} | {} | | {:.2} / {:.1} | {:+.1} % | {:.2} | {:.2} | {:.2} | {} | {:.2} |",
                o.member,
                o.vertices,
                m.landmark_mean_mm,
                m.landmark_max_mm,
                100.0 * m.scale_error,
                m.surface_mm,
                m.face_probability,
                m.marks_mean_mm,
                if m.warnings.is_empty() { "" } else { "yes" },
                o.seconds
            ),
            Err(e) => writeln!(
                out,
                "| {} | {held} | {} | {} | | | | | | | {:.2} |",
                o.member,
                o.vertices,
                e.replace('|', "/"),
                o.seconds
            ),
        };
    }
    out.push_str("\n| members | heads | refused | mean over 5 mm (not warned) | warned | mean within 2 mm | mean within 3 mm | median mean (mm) | worst mean (mm) | scale within 5 % | slowest (s) |\n");
    out.push_str("|---|---|---|---|---|---|---|---|---|---|---|\n");
    let groups: [(&str, Keep); 5] = [
        ("all", |_| true),
        ("ict", |o| o.family == "ict" && !o.held_out),
        ("makehuman", |o| o.family == "makehuman" && !o.held_out),
        ("scan", |o| o.family == "scan" && !o.held_out),
        ("held out", |o| o.held_out),
    ];
    for (name, keep) in groups {
        let group: Vec<&Outcome> = outcomes.iter().filter(|o| keep(o)).collect();
        if group.is_empty() {
            continue;
        }
        let fitted: Vec<_> = group.iter().filter_map(|o| o.result.as_ref().ok()).collect();
        let mut means: Vec<f32> = fitted.iter().map(|m| m.landmark_mean_mm).collect();
        means.sort_by(f32::total_cmp);
        let count = |f: &dyn Fn(f32) -> bool| means.iter().filter(|&&m| f(m)).count();
        let median = means.get(means.len() / 2).copied().unwrap_or(f32::NAN);
        let worst = means.last().copied().unwrap_or(f32::NAN);
        let scale_ok = fitted.iter().filter(|m| m.scale_error.abs() <= 0.05).count();
        let warned = fitted.iter().filter(|m| !m.warnings.is_empty()).count();
        let over_5_silent = fitted
            .iter()
            .filter(|m| m.landmark_mean_mm > 5.0 && m.warnings.is_empty())
            .count();
        let slowest = group.iter().map(|o| o.seconds).fold(0.0, f64::max);
        let _ = writeln!(
            out,
            "| {name} | {} | {} | {} ({over_5_silent}) | {warned} | {} | {} | {median:.2} | {worst:.2} | {scale_ok} | {slowest:.2} |",
            group.len(),
            group.len() - fitted.len(),
            count(&|m| m > 5.0),
            count(&|m| m <= 2.0),
            count(&|m| m <= 3.0),
        );
    }
    out
}
