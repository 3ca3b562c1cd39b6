//! The comparison as tab-separated tables: `algorithms.tsv`, `syllables.tsv`, `face.tsv`
//! and `ground_truth.tsv`. Numbers are in Rust's shortest round-trip form, so a reader gets
//! back the exact values; a missing value (no mouth-opening frame, no targets) is `NaN`.

use std::fmt::Write;

use super::{Comparison, ALGORITHM_COLUMNS};

/// Header of `syllables.tsv`.
pub const SYLLABLES_HEADER: &str = "letter\tspec\tsyllable\tframes\troughness_mean";
/// Header of `face.tsv`.
pub const FACE_HEADER: &str = "letter\tspec\tface_roughness_mean\tcrease";
/// Header of `ground_truth.tsv`.
pub const GROUND_TRUTH_HEADER: &str =
    "letter\tspec\ttarget\trms_mm\tmax_mm\tlip_folds\ttarget_lip_folds\tlip_folds_not_in_target";

/// Header of `contact.tsv`.
pub const CONTACT_HEADER: &str =
    "letter\tspec\tframe\tlabel\tlips_in_teeth\tlips_depth_mm\tlower_lip_to_upper_teeth_mm\ttongue_in_teeth\ttongue_depth_mm\ttongue_past_teeth_mm\ttongue_tip_to_gums_mm";

/// `letter` and `spec` of the ground-truth rows of the head at rest (not moving).
pub const REST_LETTER: &str = "-";
pub const REST_SPEC: &str = "rest";

/// Header of `algorithms.tsv`: `letter`, `spec`, then every [`ALGORITHM_COLUMNS`] key.
pub fn algorithms_header() -> String {
    let keys = ALGORITHM_COLUMNS.iter().map(|c| c.key);
    ["letter", "spec"]
        .into_iter()
        .chain(keys)
        .collect::<Vec<_>>()
        .join("\t")
}

/// One row per algorithm, in the order compared.
pub fn algorithms_tsv(comparison: &Comparison) -> String {
    let mut out = algorithms_header();
    out.push('\n');
    for a in &comparison.algorithms {
        let s = &a.summary;
        let _ = write!(out, "{}\t{}", s.letter, s.spec);
        for column in &ALGORITHM_COLUMNS {
            let _ = write!(out, "\t{}", (column.value)(s).unwrap_or(f64::NAN));
        }
        out.push('\n');
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
        let _ = writeln!(
            out,
            "{letter}\t{spec}\t{}\t{}\t{}\t{}\t{}\t{}",
            r.target, r.rms_mm, r.max_mm, r.lip_folds, r.target_lip_folds, r.lip_folds_not_in_target
        );
    }
    Some(out)
}

/// One row per (algorithm, frame) of a head with teeth: the contact measures
/// (`tongue_past_teeth_mm` is `-inf` and `tongue_tip_to_gums_mm` `inf` for a head
/// without a tongue).
pub fn contact_tsv(comparison: &Comparison) -> String {
    let mut out = format!("{CONTACT_HEADER}\n");
    for a in &comparison.algorithms {
        for row in &a.contact {
            let c = &row.contact;
            let _ = writeln!(
                out,
                "{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}",
                a.summary.letter,
                a.summary.spec,
                row.frame,
                row.label,
                c.lips_in_teeth,
                c.lips_depth_mm,
                c.lower_lip_to_upper_teeth_mm,
                c.tongue_in_teeth,
                c.tongue_depth_mm,
                c.tongue_past_teeth_mm,
                c.tongue_tip_to_gums_mm
            );
        }
    }
    out
}
