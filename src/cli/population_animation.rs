//! `facewire population --animate`: the whole heads of the population, with their teeth,
//! gums, tongue and eyes, animated through the syllable stream by one algorithm (the default)
//! from their landmark fits and their automatic fits, as a Markdown table with a summary
//! per fit and for the held-out members (docs/METRICS.md, "On a population").

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::CliResult;
use crate::mask::Mask;
use crate::population::{self, Maker, MemberSpec};
use crate::report::{
    animate, parse_algorithms, AnimationMeasures, AnimationOutcome, FitSource, TargetLipFolds,
};
use crate::targets::ExpressionTarget;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// With --animate: the parameter stream (default: the shipped syllable stream).
    #[arg(long)]
    stream: Option<PathBuf>,
    /// With --animate: the algorithm (a spec or preset letter).
    #[arg(long, default_value = crate::deform::spec::DEFAULT_ALGORITHM)]
    algo: String,
    /// With --animate: which fits to start from.
    #[arg(long, value_enum, default_value = "both")]
    fits: Fits,
}

#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum Fits {
    Landmarks,
    Automatic,
    Both,
}

impl Fits {
    fn sources(self) -> &'static [FitSource] {
        match self {
            Fits::Landmarks => &[FitSource::Landmarks],
            Fits::Automatic => &[FitSource::Automatic],
            Fits::Both => &[FitSource::Landmarks, FitSource::Automatic],
        }
    }
}

pub fn run(data: &Path, sample: bool, only: Option<&str>, json: bool, args: &Args) -> CliResult {
    let maker = Maker::new(data)?;
    let mask = Mask::candide3();
    let algorithm = parse_algorithms(&args.algo)?
        .into_iter()
        .next()
        .ok_or_else(|| format!("--algo {:?}: no algorithm", args.algo))?;
    let stream = args
        .stream
        .clone()
        .unwrap_or_else(|| data.join("streams/syllables.jsonl"));
    let specs: Vec<MemberSpec> = if sample {
        population::whole_heads_sample()
    } else {
        population::whole_heads()
    }
    .into_iter()
    .filter(|s| only.is_none_or(|only| s.name().contains(only)))
    .collect();
    let mut targets: Vec<(&str, Vec<ExpressionTarget>)> = Vec::new();
    let mut outcomes = Vec::new();
    for (k, spec) in specs.iter().enumerate() {
        let member = maker.make(spec)?;
        let dir = spec.source.targets_dir();
        if let Some(dir) = dir.filter(|d| !targets.iter().any(|(t, _)| t == d)) {
            let loaded =
                ExpressionTarget::load_dir(&data.join("heads").join(dir), member.head.positions.len())?;
            targets.push((dir, loaded));
        }
        let head_targets = dir
            .and_then(|d| targets.iter().find(|(t, _)| *t == d))
            .map_or(&[][..], |(_, t)| t.as_slice());
        for &fit in args.fits.sources() {
            let outcome = animate(&member, fit, &mask, &stream, &algorithm, head_targets);
            eprintln!("[{}/{}] {}", k + 1, specs.len(), line(&outcome));
            if json {
                println!("{}", serde_json::to_string(&outcome)?);
            }
            outcomes.push(outcome);
        }
    }
    if !json {
        print!("{}", table(&outcomes));
    }
    Ok(())
}

fn line(o: &AnimationOutcome) -> String {
    match &o.result {
        Ok(m) => format!(
            "{} ({}): {} lip folds, lips in teeth {}, tongue {}, f/v {}, ground truth {}, {:.0} us, lids in eyes {} / {}, {:.1} s",
            o.member,
            o.fit.name(),
            m.lip_folds,
            option(m.lips_in_teeth, |v| v.to_string()),
            option(m.tongue_depth_mm, |d| format!("{d:.2} mm")),
            option(m.fv_gap_mm, |d| format!("{d:.2} mm")),
            option(m.ground_truth_rms_mm, |d| format!("{d:.3} mm")),
            m.deform_us,
            option(m.lids_in_eyes_unconstrained, |v| v.to_string()),
            option(m.lids_in_eyes, |v| v.to_string()),
            o.seconds
        ),
        Err(e) => format!("{} ({}): not animated: {e}", o.member, o.fit.name()),
    }
}

fn option<T: Copy>(value: Option<T>, show: impl Fn(T) -> String) -> String {
    value.map_or_else(|| "-".into(), show)
}

/// The table, then a summary per fit for the development and the held-out members.
pub fn table(outcomes: &[AnimationOutcome]) -> String {
    let mut out = String::new();
    out.push_str("| head | held out | fit | lip folds (triangle-frames) | sharpest fold (deg) | lips in teeth at rest / beyond rest (vertex-frames) | tongue in teeth (frames, deepest mm) | f/v gap (mm) | ground truth (mm) | lip folds on the targets: the algorithm / the targets / the algorithm's not the target's | deform (us) | lids in eyes without / with the constraint (vertex-frames) |\n");
    out.push_str("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for o in outcomes {
        let held = if o.held_out { "yes" } else { "" };
        let _ = match &o.result {
            Ok(m) => writeln!(
                out,
                "| {} | {held} | {} | {} | {:.0} | {} / {} | {} | {} | {} | {} | {:.0} | {} |",
                o.member,
                o.fit.name(),
                m.lip_folds,
                m.fold_deg,
                option(m.lips_in_teeth_at_rest, |v| v.to_string()),
                option(m.lips_in_teeth, |v| v.to_string()),
                match (m.tongue_frames_in_teeth, m.tongue_depth_mm) {
                    (Some(f), Some(d)) => format!("{f}, {d:.2}"),
                    _ => "-".into(),
                },
                option(m.fv_gap_mm, |d| format!("{d:.2}")),
                option(m.ground_truth_rms_mm, |d| format!("{d:.3}")),
                option(m.target_lip_folds, |f| format!(
                    "{} / {} / {}",
                    f.algorithm, f.targets, f.algorithm_not_in_target
                )),
                m.deform_us,
                match (m.lids_in_eyes_unconstrained, m.lids_in_eyes) {
                    (Some(without), Some(with)) => format!("{without} / {with}"),
                    _ => "-".into(),
                },
            ),
            Err(e) => writeln!(
                out,
                "| {} | {held} | {} | not animated: {} | | | | | | | | |",
                o.member,
                o.fit.name(),
                e.replace('|', "/")
            ),
        };
    }
    out.push_str("\n| heads | fit | animated | with lip folds | lip folds (sum) | with lips in teeth beyond rest | tongue deeper than 0.5 mm | f/v gap over 1.5 mm | worst ground truth (mm) | lip folds on the targets (sums): the algorithm / the targets / the algorithm's not the target's | median deform (us) | with lids in eyes, without / with the constraint |\n");
    out.push_str("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (group, held) in [("development", false), ("held out", true)] {
        for fit in [FitSource::Landmarks, FitSource::Automatic] {
            let rows: Vec<&AnimationOutcome> = outcomes
                .iter()
                .filter(|o| o.held_out == held && o.fit == fit)
                .collect();
            if rows.is_empty() {
                continue;
            }
            let done: Vec<&AnimationMeasures> = rows.iter().filter_map(|o| o.result.as_ref().ok()).collect();
            let count = |f: &dyn Fn(&AnimationMeasures) -> bool| done.iter().filter(|m| f(m)).count();
            let worst_truth = done
                .iter()
                .filter_map(|m| m.ground_truth_rms_mm)
                .fold(f64::NAN, f64::max);
            let mut deform: Vec<f64> = done.iter().map(|m| m.deform_us).collect();
            deform.sort_by(f64::total_cmp);
            let _ = writeln!(
                out,
                "| {group} ({}) | {} | {} | {} | {} | {} | {} | {} | {worst_truth:.3} | {} | {:.0} | {} / {} |",
                rows.len(),
                fit.name(),
                done.len(),
                count(&|m| m.lip_folds > 0),
                done.iter().map(|m| m.lip_folds).sum::<u64>(),
                count(&|m| m.lips_in_teeth.is_some_and(|v| v > 0)),
                count(&|m| m.tongue_depth_mm.is_some_and(|d| d > 0.5)),
                count(&|m| m.fv_gap_mm.is_some_and(|d| d > 1.5)),
                {
                    let sum = |f: fn(&TargetLipFolds) -> u64| {
                        done.iter().filter_map(|m| m.target_lip_folds.as_ref()).map(f).sum::<u64>()
                    };
                    format!(
                        "{} / {} / {}",
                        sum(|f| f.algorithm),
                        sum(|f| f.targets),
                        sum(|f| f.algorithm_not_in_target)
                    )
                },
                deform.get(deform.len() / 2).copied().unwrap_or(f64::NAN),
                count(&|m| m.lids_in_eyes_unconstrained.is_some_and(|v| v > 0)),
                count(&|m| m.lids_in_eyes.is_some_and(|v| v > 0)),
            );
        }
    }
    out
}
