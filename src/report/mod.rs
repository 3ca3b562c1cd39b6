//! Comparing interpolation algorithms on one head and one parameter stream: the library
//! behind `facewire compare` and the reports in `docs/reports/`. The thesis judged its
//! algorithms on lip roughness alone, and its smoothest one squashed the mouth; this module
//! runs every algorithm through the same frames, measures roughness and fidelity together
//! (docs/METRICS.md) and writes them as TSV tables, SVG charts and a Markdown report, so the
//! default algorithm is chosen from numbers anyone can regenerate.
//!
//! [`compare`] measures; [`write_report`] writes the files.

mod algorithms;
mod charts;
mod columns;
mod compare;
mod error;
mod markdown;
mod population;
mod tables;

use std::path::{Path, PathBuf};

pub use algorithms::{every_preset, parse_algorithms, Candidate};
pub use charts::{bar_chart, scatter, Reference, Ticks};
pub use columns::{Column, ALGORITHM_COLUMNS};
pub use compare::{
    compare, AlgorithmResult, AlgorithmSummary, CompareInput, Comparison, ContactRow, Progress, Stage,
    SyllableRow, TargetRow, TongueContact, UNLABELLED,
};
pub use error::CompareError;
pub use markdown::{pareto_front, ReportContext};
pub use population::{animate, AnimationMeasures, AnimationOutcome, FitSource, TargetLipFolds};
pub use tables::{
    algorithms_header, algorithms_tsv, contact_tsv, face_tsv, ground_truth_tsv, syllables_tsv,
    CONTACT_HEADER, FACE_HEADER, GROUND_TRUTH_HEADER, REST_LETTER, REST_SPEC, SYLLABLES_HEADER,
};

/// The file names a report is written under, relative to its folder.
#[derive(Debug, Clone, PartialEq)]
pub struct Files {
    pub algorithms: &'static str,
    pub syllables: &'static str,
    pub face: &'static str,
    /// `None` without ground truth.
    pub ground_truth: Option<&'static str>,
    /// `None` for a head without teeth.
    pub contact: Option<&'static str>,
    pub charts: Vec<Chart>,
    pub report: &'static str,
}

/// The charts of a report.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Chart {
    RoughnessMean,
    RoughnessVariance,
    Crease,
    RoughnessVsControlError,
    RoughnessVsGroundTruth,
}

impl Chart {
    pub fn file(self) -> &'static str {
        match self {
            Chart::RoughnessMean => "roughness_mean.svg",
            Chart::RoughnessVariance => "roughness_variance.svg",
            Chart::Crease => "crease.svg",
            Chart::RoughnessVsControlError => "roughness_vs_control_error.svg",
            Chart::RoughnessVsGroundTruth => "roughness_vs_ground_truth.svg",
        }
    }

    /// What it shows (the image's alternative text).
    pub fn alt(self) -> &'static str {
        match self {
            Chart::RoughnessMean => "lip roughness per algorithm: mean over syllables",
            Chart::RoughnessVariance => "lip roughness per algorithm: variance over syllables",
            Chart::Crease => "sharpest new crease on the face per algorithm: median over frames",
            Chart::RoughnessVsControlError => "roughness against control error, one point per algorithm",
            Chart::RoughnessVsGroundTruth => {
                "roughness against ground-truth RMS error, one point per algorithm"
            }
        }
    }

    /// The chart's SVG text.
    pub fn draw(self, comparison: &Comparison) -> Result<String, String> {
        let summaries: Vec<&AlgorithmSummary> = comparison.algorithms.iter().map(|a| &a.summary).collect();
        let rest = Reference {
            name: "head at rest",
            value: comparison.rest_roughness,
        };
        let roughness = "lip roughness (mean over syllables)";
        let bars = |value: fn(&AlgorithmSummary) -> f64| -> Vec<(&str, f64)> {
            summaries.iter().map(|s| (s.letter.as_str(), value(s))).collect()
        };
        let points = |x: fn(&AlgorithmSummary) -> f64| -> Vec<(&str, f64, f64)> {
            summaries
                .iter()
                .map(|s| (s.letter.as_str(), x(s), s.roughness_mean))
                .collect()
        };
        match self {
            Chart::RoughnessMean => bar_chart(
                "Lip roughness: mean over syllables",
                roughness,
                Ticks::Decimals(3),
                &bars(|s| s.roughness_mean),
                Some(rest),
            ),
            Chart::RoughnessVariance => bar_chart(
                "Lip roughness: variance over syllables",
                "population variance of the syllable means",
                Ticks::Scientific,
                &bars(|s| s.roughness_var),
                None,
            ),
            Chart::Crease => bar_chart(
                "Sharpest new crease on the face: median over frames",
                "largest rise of a face triangle's roughness",
                Ticks::Decimals(2),
                &bars(|s| s.crease),
                None,
            ),
            Chart::RoughnessVsControlError => scatter(
                "Smoothness against fidelity to the mask",
                "control error at the anchors (mm, mean)",
                roughness,
                (Ticks::Decimals(1), Ticks::Decimals(4)),
                &points(|s| s.control_err_mm),
                Some(rest),
            ),
            Chart::RoughnessVsGroundTruth => scatter(
                "Smoothness against fidelity to the artist's targets",
                "ground-truth RMS error over the face (mm, mean over targets)",
                roughness,
                (Ticks::Decimals(2), Ticks::Decimals(4)),
                &points(|s| s.ground_truth_rms_mm.unwrap_or(f64::NAN)),
                Some(rest),
            ),
        }
    }
}

impl Files {
    fn of(comparison: &Comparison) -> Files {
        let has_gt = !comparison.rest_ground_truth.is_empty();
        let mut charts = vec![
            Chart::RoughnessMean,
            Chart::RoughnessVariance,
            Chart::Crease,
            Chart::RoughnessVsControlError,
        ];
        if has_gt {
            charts.push(Chart::RoughnessVsGroundTruth);
        }
        Files {
            algorithms: "algorithms.tsv",
            syllables: "syllables.tsv",
            face: "face.tsv",
            ground_truth: has_gt.then_some("ground_truth.tsv"),
            contact: comparison.rest_contact.is_some().then_some("contact.tsv"),
            charts,
            report: "report.md",
        }
    }
}

/// Writes the tables, charts and `report.md` into `dir` (created if missing), each file
/// atomically. Returns the paths written.
pub fn write_report(
    dir: &Path,
    comparison: &Comparison,
    context: &ReportContext<'_>,
) -> Result<Vec<PathBuf>, CompareError> {
    std::fs::create_dir_all(dir).map_err(|source| CompareError::CreateDir {
        path: dir.display().to_string(),
        source,
    })?;
    let files = Files::of(comparison);
    let mut contents: Vec<(&str, String)> = vec![
        (files.algorithms, algorithms_tsv(comparison)),
        (files.syllables, syllables_tsv(comparison)),
        (files.face, face_tsv(comparison)),
    ];
    if let (Some(name), Some(text)) = (files.ground_truth, ground_truth_tsv(comparison)) {
        contents.push((name, text));
    }
    if let Some(name) = files.contact {
        contents.push((name, contact_tsv(comparison)));
    }
    for &chart in &files.charts {
        let svg = chart.draw(comparison).map_err(|message| CompareError::Chart {
            path: dir.join(chart.file()).display().to_string(),
            message,
        })?;
        contents.push((chart.file(), svg));
    }
    contents.push((files.report, markdown::render(comparison, context, &files)));

    let mut written = Vec::with_capacity(contents.len());
    for (name, text) in contents {
        let path = dir.join(name);
        crate::atomic::write_atomic(&path, text.as_bytes()).map_err(|source| CompareError::Write {
            path: path.display().to_string(),
            source,
        })?;
        written.push(path);
    }
    Ok(written)
}
