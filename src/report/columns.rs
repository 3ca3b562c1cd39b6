//! The columns of the algorithms table, named once: `algorithms.tsv`, the report's
//! Markdown table and `facewire compare`'s terminal table take their names, order, values
//! and rounding from here, so that they cannot drift apart.

use super::{AlgorithmSummary, Comparison};

/// One measured column of the algorithms table (after `letter` and `spec`).
pub struct Column {
    /// Its name in `algorithms.tsv` and in the JSON summary.
    pub key: &'static str,
    /// Its title in the report.
    pub title: &'static str,
    /// Its title on a terminal, where width is short.
    pub short: &'static str,
    /// Its value for one algorithm; `None` where there is none (no frame opens the mouth,
    /// no expression targets).
    pub value: fn(&AlgorithmSummary) -> Option<f64>,
    /// Its value for the head at rest, where it has one.
    pub rest: fn(&Comparison) -> Option<f64>,
    /// How the report and the terminal round it.
    pub rounded: fn(f64) -> String,
}

impl Column {
    /// The value as the report shows it, `-` where there is none.
    pub fn shown(&self, summary: &AlgorithmSummary) -> String {
        (self.value)(summary).map_or("-".into(), self.rounded)
    }

    /// Whether the column has values in `comparison`: the ground-truth column only when
    /// targets were measured, the contact columns only for a head with teeth.
    pub fn applies_to(&self, comparison: &Comparison) -> bool {
        match self.key {
            GROUND_TRUTH_KEY => !comparison.rest_ground_truth.is_empty(),
            LIPS_IN_TEETH_KEY | FV_GAP_KEY => comparison.rest_contact.is_some(),
            _ => true,
        }
    }
}

const GROUND_TRUTH_KEY: &str = "ground_truth_rms_mm";
const LIPS_IN_TEETH_KEY: &str = "lips_in_teeth";
const FV_GAP_KEY: &str = "fv_gap_mm";

/// The measured columns, in table order.
pub const ALGORITHM_COLUMNS: [Column; 11] = [
    Column {
        key: "roughness_mean",
        title: "roughness mean",
        short: "roughness",
        value: |s| Some(s.roughness_mean),
        rest: |c| Some(c.rest_roughness),
        rounded: |v| format!("{v:.5}"),
    },
    Column {
        key: "roughness_var",
        title: "roughness variance",
        short: "variance",
        value: |s| Some(s.roughness_var),
        rest: |_| None,
        rounded: |v| format!("{v:.2e}"),
    },
    Column {
        key: "control_err_mm",
        title: "control error (mm)",
        short: "ctrl mm",
        value: |s| Some(s.control_err_mm),
        rest: |_| None,
        rounded: |v| format!("{v:.2}"),
    },
    Column {
        key: "mouth_opening_ratio",
        title: "mouth opening ratio",
        short: "mouth",
        value: |s| s.mouth_opening_ratio,
        rest: |_| None,
        rounded: |v| format!("{v:.3}"),
    },
    Column {
        key: GROUND_TRUTH_KEY,
        title: "ground-truth RMS (mm)",
        short: "gt mm",
        value: |s| s.ground_truth_rms_mm,
        rest: |c| {
            let rows = &c.rest_ground_truth;
            (!rows.is_empty()).then(|| rows.iter().map(|r| r.rms_mm).sum::<f64>() / rows.len() as f64)
        },
        rounded: |v| format!("{v:.2}"),
    },
    Column {
        key: "crease",
        title: "face crease",
        short: "crease",
        value: |s| Some(s.crease),
        // The head at rest has no new crease, by definition.
        rest: |_| Some(0.0),
        rounded: |v| format!("{v:.3}"),
    },
    Column {
        key: "lip_folds",
        title: "lip folds",
        short: "lip folds",
        value: |s| Some(s.lip_folds as f64),
        // Nothing turns at rest.
        rest: |_| Some(0.0),
        rounded: |v| format!("{v:.0}"),
    },
    Column {
        key: "fold_deg",
        title: "sharpest fold (deg)",
        short: "fold deg",
        value: |s| Some(s.fold_deg),
        rest: |_| Some(0.0),
        rounded: |v| format!("{v:.1}"),
    },
    Column {
        key: LIPS_IN_TEETH_KEY,
        title: "lip vertices in teeth",
        short: "lips in teeth",
        value: |s| s.lips_in_teeth.map(|n| n as f64),
        rest: |c| c.rest_contact.map(|r| f64::from(r.lips_in_teeth)),
        rounded: |v| format!("{v:.0}"),
    },
    Column {
        key: FV_GAP_KEY,
        title: "f/v lip to teeth (mm)",
        short: "f/v mm",
        value: |s| s.fv_gap_mm,
        rest: |c| c.rest_contact.map(|r| f64::from(r.lower_lip_to_upper_teeth_mm)),
        rounded: |v| format!("{v:.1}"),
    },
    Column {
        key: "deform_us",
        title: "deform (us)",
        short: "deform us",
        value: |s| Some(s.deform_us),
        rest: |_| None,
        rounded: |v| format!("{v:.1}"),
    },
];
