//! `facewire fit`: solve a fit and write it as `.fit.toml`. From landmarks it prints how far
//! the mask lies from the head before (similarity only) and after (with shape units); with
//! no landmarks it finds the face itself and says what it found and guessed.

use serde::Serialize;

use super::{format_mm_per_unit, load_head, load_mask, print_json, CliResult, FilePath};
use crate::atomic::write_atomic;
use crate::fit::limits::{in_range, MM_PER_UNIT_RANGE};
use crate::fit::{
    fit_automatically, fit_from_landmarks, report, residuals, solve_fit, AutomaticFit, EyeKind, Fit, FitFile,
    FitReport, FittedMask, FoundFeatures, Landmarks, MouthCorners, Residuals, SolveOptions,
    PUPILS_RELATIVE_SD, UNIT_SNAP,
};
use crate::head::Head;
use crate::mask::Mask;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// The head mesh: OBJ, or a glTF binary avatar (`.glb`: its skin, in metres).
    #[arg(long)]
    head: FilePath,
    /// Landmark correspondences (.landmarks.toml). Without them the face is found
    /// automatically, in any orientation and unit.
    #[arg(long)]
    landmarks: Option<FilePath>,
    /// Where to write the fit (.fit.toml).
    #[arg(long)]
    out: FilePath,
    /// A CANDIDE-3 .wfm to fit instead of the embedded one.
    #[arg(long)]
    mask: Option<FilePath>,
    /// Millimetres per head unit (default: from the landmarks file, else 63 mm pupils).
    #[arg(long)]
    mm_per_unit: Option<f32>,
    /// Print the result as JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Serialize)]
struct Report {
    fit: FitFile,
    mm_per_unit_source: &'static str,
    iterations: usize,
    /// Similarity only (shape units at zero).
    before: Residuals,
    /// Similarity and shape units.
    after: Residuals,
    report: FitReport,
}

pub fn run(args: Args) -> CliResult {
    let mask = load_mask(args.mask.as_deref())?;
    let head = load_head(&args.head)?;
    match &args.landmarks {
        Some(landmarks) => from_landmarks(&args, landmarks, &head, &mask),
        None => automatic(&args, &head, &mask),
    }
}

#[derive(Serialize)]
struct AutomaticReport {
    fit: FitFile,
    mm_per_unit_source: &'static str,
    /// The unit `mm_per_unit` is near, when it is near one.
    unit_guess: Option<&'static str>,
    /// What 63 mm pupils gave, when the unit was guessed (`mm_per_unit` is the standard
    /// unit within 15 % of it, when there is one).
    pupils_mm_per_unit: Option<f32>,
    /// Its uncertainty when it was guessed: 1 sd as a share of it (people's pupils differ).
    pupils_relative_sd: Option<f32>,
    /// The direction the face looks, head frame.
    forward: [f32; 3],
    /// The nose tip found, head units.
    nose_tip: [f32; 3],
    /// The eyes and mouth corners found and pinned.
    found: FoundFeatures,
    report: FitReport,
}

fn automatic(args: &Args, head: &Head, mask: &Mask) -> CliResult {
    let given = args
        .mm_per_unit
        .map(|mm| in_range("--mm-per-unit", mm, MM_PER_UNIT_RANGE))
        .transpose()?;
    let from_format = format_mm_per_unit(&args.head);
    let found: AutomaticFit = fit_automatically(head, mask, given.or(from_format))?;
    let notes: Vec<String> = found.warnings.iter().map(|w| w.message()).collect();
    let report = fit_report(head, mask, &found.fit).with_fit_notes(&notes);
    let file = write_fit(args, &found.fit, mask, notes)?;
    let source = match (found.mm_per_unit_from_pupils, given) {
        (true, _) => "63 mm pupil separation",
        (false, Some(_)) => "command line",
        (false, None) => "the file's format (glTF: metres)",
    };
    if args.json {
        return print_json(&AutomaticReport {
            fit: file,
            mm_per_unit_source: source,
            unit_guess: found.unit_name(),
            pupils_mm_per_unit: found.pupils_mm_per_unit,
            pupils_relative_sd: found.pupils_mm_per_unit.map(|_| PUPILS_RELATIVE_SD),
            forward: found.forward.to_array(),
            nose_tip: found.nose_tip.to_array(),
            found: found.found,
            report,
        });
    }
    let [fx, fy, fz] = found.forward.to_array();
    let [nx, ny, nz] = found.nose_tip.to_array();
    println!(
        "fit {} to {} with no landmarks: the face looks along ({fx:.2}, {fy:.2}, {fz:.2}), nose tip at \
         ({nx:.3}, {ny:.3}, {nz:.3}) head units",
        mask_name(&args.mask),
        args.head.display(),
    );
    let unit = match (found.pupils_mm_per_unit, found.unit_name()) {
        (Some(measured), Some(name)) if measured != found.fit.mm_per_unit => {
            let (sd, within) = (PUPILS_RELATIVE_SD * 100.0, UNIT_SNAP * 100.0);
            format!(
                " gave {measured:.4} +/- {sd:.0} % (1 sd), within {within:.0} % of {name}: taken as {name}"
            )
        }
        (Some(measured), None) => {
            let sd = PUPILS_RELATIVE_SD * 100.0;
            format!(" gave {measured:.4} +/- {sd:.0} % (1 sd), near no standard unit")
        }
        (_, Some(name)) => format!(", so the head is probably in {name}"),
        (_, None) => String::new(),
    };
    println!(
        "mm per head unit: {:.4} ({source}{unit}); scale {:.5} head units per mask unit",
        found.fit.mm_per_unit, found.fit.pose.scale.x
    );
    println!("found: {}", found_in_words(&found.found));
    print_report(&report);
    println!("wrote {}", args.out.display());
    Ok(())
}

/// What the automatic fit found, as `facewire fit` prints it.
fn found_in_words(found: &FoundFeatures) -> String {
    // One eye's kind, and both eyes'.
    let names = |kind: EyeKind| match kind {
        EyeKind::Opening => ("an opening", "openings"),
        EyeKind::ClosedLids => ("closed lids", "closed lids"),
        EyeKind::Dome => ("a dome", "domes"),
    };
    let eyes = match found.eyes {
        None => "no eyes (left to the surface)".to_string(),
        Some([left, right]) => {
            let kinds = if left == right {
                format!("both eyes as {}", names(left).1)
            } else {
                format!(
                    "the left eye as {}, the right as {}",
                    names(left).0,
                    names(right).0
                )
            };
            let corners = if found.outer_eye_corners_on_skin {
                "their corners pinned, the outer ones held to the skin (they had sunk into the openings)"
            } else if found.eye_corners_pinned {
                "their corners pinned"
            } else {
                "their corners left to the surface"
            };
            format!("{kinds}, {corners}")
        }
    };
    let mouth = match found.mouth_corners {
        MouthCorners::AtBothEnds => "mouth corners where the lips' fissure ends (its ends' mean width)",
        MouthCorners::Mirrored => {
            "mouth corners at the fissure's farther end, mirrored (it fades early on one side)"
        }
        MouthCorners::NotFound => "mouth corners left to the surface (no fissure at the mouth)",
    };
    format!("{eyes}; {mouth}")
}

/// The report of `fit` on `head`.
fn fit_report(head: &Head, mask: &Mask, fit: &Fit) -> FitReport {
    report(head, &FittedMask::new(mask.clone(), fit.clone()))
}

/// The report as a table of regions and a list of warnings.
fn print_report(report: &FitReport) {
    println!(
        "{:<34} {:>10} {:>10} {:>8}",
        "mask to head surface (mm)", "mean", "max", "worst"
    );
    let row = |name: &str, d: &crate::fit::DistanceStats| {
        println!(
            "  {:<32} {:>10.3} {:>10.3} {:>8}",
            name, d.mean_mm, d.max_mm, d.worst_mask_vertex
        );
    };
    row("all", &report.surface);
    for region in &report.regions {
        row(region.region.name(), &region.distances);
    }
    println!("inner lips apart at rest: {:.2} mm", report.inner_lip_gap_mm);
    for warning in &report.warnings {
        println!("warning: {}", warning.message);
    }
}

/// Writes `fit` to `--out` and returns what was written.
fn write_fit(
    args: &Args,
    fit: &Fit,
    mask: &Mask,
    warnings: Vec<String>,
) -> Result<FitFile, Box<dyn std::error::Error + Send + Sync>> {
    let head_name = args.head.file_name().map(|n| n.to_string_lossy().into_owned());
    let file = FitFile {
        warnings,
        ..FitFile::from_fit(fit, mask, head_name)
    };
    write_atomic(&args.out, file.to_toml().as_bytes())
        .map_err(|e| format!("cannot write {}: {e}", args.out.display()))?;
    Ok(file)
}

fn from_landmarks(args: &Args, landmarks_path: &FilePath, head: &Head, mask: &Mask) -> CliResult {
    let mut landmarks = Landmarks::load(landmarks_path)?;
    let source = match (args.mm_per_unit, landmarks.mm_per_unit) {
        (Some(mm), _) => {
            landmarks.mm_per_unit = Some(in_range("--mm-per-unit", mm, MM_PER_UNIT_RANGE)?);
            "command line"
        }
        (None, Some(_)) => "landmarks file",
        (None, None) => match format_mm_per_unit(&args.head) {
            Some(mm) => {
                landmarks.mm_per_unit = Some(mm);
                "the file's format (glTF: metres)"
            }
            None => "63 mm pupil separation",
        },
    };
    let origin = landmarks_path.display().to_string();
    let solved = fit_from_landmarks(head, &landmarks, &origin, mask)?;
    let after = &solved.fit;
    let mm_per_unit = after.mm_per_unit;
    // The similarity alone, for comparison: how much the shape units add.
    let pairs = landmarks.targets(head);
    let similarity_only = SolveOptions {
        solve_shape: false,
        ..SolveOptions::default()
    };
    let before = solve_fit(mask, &pairs, &[], &similarity_only)?;
    let index_pairs: Vec<(u32, u32)> = landmarks
        .landmarks
        .iter()
        .map(|l| (l.mask_vertex, l.head_vertex))
        .collect();

    let used = mask.used_vertices();
    let measure = |shape: &[f32], pose| {
        let fit = Fit {
            pose,
            shape: shape.to_vec(),
            nudges: Vec::new(),
            mm_per_unit,
        };
        let fitted = FittedMask::new(mask.clone(), fit);
        (
            residuals::measure(head, &fitted.neutral, &used, &index_pairs, mm_per_unit),
            fitted.fit,
        )
    };
    let (before_residuals, _) = measure(&before.shape, before.pose);
    let (after_residuals, fit) = measure(&after.shape, after.pose);

    let file = write_fit(args, &fit, mask, Vec::new())?;
    if args.json {
        return print_json(&Report {
            fit: file,
            mm_per_unit_source: source,
            iterations: solved.iterations,
            before: before_residuals,
            after: after_residuals,
            report: fit_report(head, mask, &fit),
        });
    }
    println!(
        "fit {} to {} with {} landmarks ({} iterations)",
        mask_name(&args.mask),
        args.head.display(),
        pairs.len(),
        solved.iterations
    );
    println!(
        "mm per head unit: {mm_per_unit:.4} ({source}); scale {:.5} head units per mask unit",
        fit.pose.scale.x
    );
    println!(
        "{:<34} {:>10} {:>10} {:>8}",
        "residual (mm)", "mean", "max", "worst"
    );
    for (label, r) in [
        ("before (similarity only)", before_residuals),
        ("after (with shape units)", after_residuals),
    ] {
        println!("{label}");
        println!(
            "  {:<32} {:>10.3} {:>10.3} {:>8}",
            "mask vertices to head surface", r.surface.mean_mm, r.surface.max_mm, r.surface.worst_mask_vertex
        );
        println!(
            "  {:<32} {:>10.3} {:>10.3} {:>8}",
            "landmarks to their head vertex",
            r.landmarks.mean_mm,
            r.landmarks.max_mm,
            r.landmarks.worst_mask_vertex
        );
    }
    print_report(&fit_report(head, mask, &fit));
    println!("wrote {}", args.out.display());
    Ok(())
}

fn mask_name(path: &Option<FilePath>) -> String {
    path.as_ref()
        .map_or_else(|| "CANDIDE-3.1.6".to_string(), |p| p.display().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_found_line_says_when_the_outer_eye_corners_were_held_to_the_skin() {
        let mut found = FoundFeatures {
            eyes: Some([EyeKind::Opening; 2]),
            eye_corners_pinned: true,
            outer_eye_corners_on_skin: false,
            mouth_corners: MouthCorners::AtBothEnds,
        };
        assert_eq!(
            found_in_words(&found),
            "both eyes as openings, their corners pinned; mouth corners where the lips' fissure ends (its ends' mean width)"
        );
        found.outer_eye_corners_on_skin = true;
        assert_eq!(
            found_in_words(&found),
            "both eyes as openings, their corners pinned, the outer ones held to the skin (they had sunk \
             into the openings); mouth corners where the lips' fissure ends (its ends' mean width)"
        );
    }
}
