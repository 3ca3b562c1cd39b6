//! The comparison as tab-separated tables: `algorithms.tsv`, `syllables.tsv`, `face.tsv`
//! and `ground_truth.tsv`. Numbers are in Rust's shortest round-trip form, so a reader gets
//! back the exact values; a missing value (no mouth-opening frame) is `NaN`.

use std::fmt::Write;

use super::Comparison;

/// Header of `algorithms.tsv`.
pub const ALGORITHMS_HEADER: &str =
    "letter\tspec\troughness_mean\troughness_var\tcontrol_err_mm\tmouth_opening_ratio\tdeform_us";
/// Header of `syllables.tsv`.
pub const SYLLABLES_HEADER: &str = "letter\tspec\tsyllable\tframes\troughness_mean";
/// Header of `face.tsv`.
pub const FACE_HEADER: &str = "letter\tspec\tface_roughness_mean\tcrease";
/// Header of `ground_truth.tsv`.
pub const GROUND_TRUTH_HEADER: &str = "letter\tspec\ttarget\trms_mm\tmax_mm";

/// `letter` and `spec` of the ground-truth rows of the head at rest (not moving).
pub const REST_LETTER: &str = "-";
pub const REST_SPEC: &str = "rest";

/// One row per algorithm, in the order compared.
pub fn algorithms_tsv(comparison: &Comparison) -> String {
    let mut out = format!("{ALGORITHMS_HEADER}\n");
    for a in &comparison.algorithms {
        let s = &a.summary;
        let _ = writeln!(
            out,
            "{}\t{}\t{}\t{}\t{}\t{}\t{}",
            s.letter,
            s.spec,
            s.roughness_mean,
            s.roughness_var,
            s.control_err_mm,
            s.mouth_opening_ratio.unwrap_or(f64::NAN),
            s.deform_us
        );
    }
    out
}

/// One row per (algorithm, syllable), syllables in order of their first frame.
pub fn syllables_tsv(comparison: &Comparison) -> String {
    let mut out = format!("{SYLLABLES_HEADER}\n");
    for a in &comparison.algorithms {
        for s in &a.syllables {
            let _ = writeln!(
                out,
                "{}\t{}\t{}\t{}\t{}",
                a.summary.letter, a.summary.spec, s.syllable, s.frames, s.roughness_mean
            );
        }
    }
    out
}

/// One row per algorithm: roughness over the whole face and the median sharpest crease,
/// then a `rest` row (the head not moving; its crease is 0 by definition).
pub fn face_tsv(comparison: &Comparison) -> String {
    let mut out = format!("{FACE_HEADER}\n");
    for a in &comparison.algorithms {
        let s = &a.summary;
        let _ = writeln!(
            out,
            "{}\t{}\t{}\t{}",
            s.letter, s.spec, s.face_roughness_mean, s.crease
        );
    }
    let _ = writeln!(
        out,
        "{REST_LETTER}\t{REST_SPEC}\t{}\t0",
        comparison.rest_face_roughness
    );
    out
}

/// One row per (algorithm, target), then one per target for the head at rest; `None`
/// when the comparison had no targets.
pub fn ground_truth_tsv(comparison: &Comparison) -> Option<String> {
    if comparison.rest_ground_truth.is_empty() {
        return None;
    }
    let mut out = format!("{GROUND_TRUTH_HEADER}\n");
    let rows = comparison
        .algorithms
        .iter()
        .flat_map(|a| {
            a.ground_truth
                .iter()
                .map(|r| (a.summary.letter.as_str(), a.summary.spec.as_str(), r))
        })
        .chain(
            comparison
                .rest_ground_truth
                .iter()
                .map(|r| (REST_LETTER, REST_SPEC, r)),
        );
    for (letter, spec, r) in rows {
        let _ = writeln!(out, "{letter}\t{spec}\t{}\t{}\t{}", r.target, r.rms_mm, r.max_mm);
    }
    Some(out)
}
