//! `report.md`: the comparison's tables with what they mean (units, definitions, how to
//! read the trade-off between smoothness and fidelity), the command and machine that made
//! it, and links to the charts and TSV files beside it.

use std::fmt::Write;

use super::{
    algorithms_header, AlgorithmResult, Column, Comparison, Files, ALGORITHM_COLUMNS, CONTACT_HEADER,
};
use crate::metrics::{FACE_RADIUS_MM, FOLD_DEG, LIP_RADIUS_MM, MIN_MASK_OPENING_MM};

/// Where a report came from, for its header.
#[derive(Debug, Clone, Copy)]
pub struct ReportContext<'a> {
    /// The command line that made it, as a user would type it.
    pub command: &'a str,
    /// The machine (CPU, cores), for the timings.
    pub machine: &'a str,
    /// Head, fit and stream as given.
    pub head: &'a str,
    pub fit: &'a str,
    pub stream: &'a str,
    /// The expression-target folder, when ground truth was measured.
    pub targets: Option<&'a str>,
}

/// The indexes of the points no other point beats in every coordinate (lower is better in
/// each), sorted by the first coordinate. Points with a NaN are never on the front.
pub fn pareto_front<const K: usize>(points: &[[f64; K]]) -> Vec<usize> {
    let beats = |p: &[f64; K], q: &[f64; K]| p.iter().zip(q).all(|(a, b)| a <= b) && p != q;
    let mut front: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].iter().all(|v| v.is_finite()))
        .filter(|&i| !points.iter().any(|p| beats(p, &points[i])))
        .collect();
    front.sort_by(|&i, &j| points[i][0].total_cmp(&points[j][0]));
    front
}

pub fn render(comparison: &Comparison, context: &ReportContext<'_>, files: &Files) -> String {
    let mut out = String::new();
    let c = comparison;
    let algos = &c.algorithms;
    let has_gt = !c.rest_ground_truth.is_empty();
    let rest_gt_mean = mean(c.rest_ground_truth.iter().map(|r| r.rms_mm));

    let _ = writeln!(out, "# Interpolation algorithms compared on `{}`\n", context.head);
    let _ = writeln!(
        out,
        "Every algorithm below was bound once to the head and driven through every frame of \
         the stream; each deformed frame was scored for lip **roughness** (how smooth) and \
         **fidelity** (how faithfully the head does what the mask asks){}. The definitions \
         are in [docs/METRICS.md](../../METRICS.md), the algorithms in \
         [docs/ALGORITHMS.md](../../ALGORITHMS.md).\n",
        if has_gt {
            ", and then asked to reproduce each artist-made expression target"
        } else {
            ""
        }
    );
    let _ = writeln!(out, "```sh\n{}\n```\n", context.command);
    let _ = writeln!(out, "| input | |\n|---|---|");
    let _ = writeln!(
        out,
        "| head | `{}`: {} vertices, {} mm per unit; {} lip triangles (within {} mm of the 18 lip anchors) |",
        context.head,
        thousands(c.head_vertices),
        c.mm_per_unit,
        c.lip_triangles,
        LIP_RADIUS_MM
    );
    let _ = writeln!(out, "| fit | `{}` |", context.fit);
    let _ = writeln!(
        out,
        "| stream | `{}`: {} frames, {} syllables; {} frames move a control, {} open the mask's mouth {} mm or more |",
        context.stream, c.frames, c.syllables, c.moving_frames, c.open_frames, MIN_MASK_OPENING_MM
    );
    if let Some(targets) = context.targets.filter(|_| has_gt) {
        let _ = writeln!(
            out,
            "| targets | `{}`: {} expressions, scored over {} face vertices (within {} mm of a used anchor) |",
            targets,
            c.rest_ground_truth.len(),
            thousands(c.face_vertices),
            FACE_RADIUS_MM
        );
    }
    let _ = writeln!(
        out,
        "| machine | {} (`facewire {}`, release build) |\n",
        context.machine,
        env!("CARGO_PKG_VERSION")
    );

    // The table.
    let _ = writeln!(out, "## Algorithms\n");
    let columns: Vec<&Column> = ALGORITHM_COLUMNS
        .iter()
        .filter(|column| column.applies_to(c))
        .collect();
    let _ = write!(out, "| | spec |");
    for column in &columns {
        let _ = write!(out, " {} |", column.title);
    }
    let _ = writeln!(out, "\n|---|---|{}", "---:|".repeat(columns.len()));
    for a in algos {
        let s = &a.summary;
        let _ = write!(out, "| **{}** | `{}` |", s.letter, s.spec);
        for column in &columns {
            let _ = write!(out, " {} |", column.shown(s));
        }
        out.push('\n');
    }
    let _ = write!(out, "| rest | the head not moving |");
    for column in &columns {
        match (column.rest)(c) {
            // A crease of exactly 0 reads better as `0` than as `0.000`.
            Some(0.0) => out.push_str(" 0 |"),
            Some(v) => {
                let _ = write!(out, " {} |", (column.rounded)(v));
            }
            None => out.push_str(" |"),
        }
    }
    out.push_str("\n\n");

    let _ = writeln!(out, "What the columns mean:\n");
    let _ = writeln!(
        out,
        "- **roughness mean** (dimensionless; lower is smoother): the thesis's lip roughness. \
         Per frame, the mean of the triangle roughness `rho(T)` (dihedral angles around each \
         corner, Wu et al.) over the {} lip triangles: the summary row (`mask_vertex = -1`) \
         of `facewire deform`'s `metrics.tsv`. Per syllable, the mean over its frames \
         (`syllables.tsv`); here, the mean over the {} syllables (the thesis's table E.1). A \
         flat mesh scores 0; this head's lips score {:.5} at rest.",
        c.lip_triangles, c.syllables, c.rest_roughness
    );
    let _ = writeln!(
        out,
        "- **roughness variance**: the population variance of the syllable means: how much the \
         smoothness changes from one syllable to the next."
    );
    let _ = writeln!(
        out,
        "- **control error** (mm; lower is more faithful): at the anchor of each moving control \
         (a mask vertex used by a triangle), the distance between the head's displacement and \
         the mask vertex's; the mean over the moving controls, then over the {} frames that \
         move one. 0 means the head goes exactly where the mask goes at the anchors.",
        c.moving_frames
    );
    let _ = writeln!(
        out,
        "- **mouth opening ratio** (1 is right): the distance between the inner-lip midpoint \
         anchors (mask vertices 87 above, 40 below) on the deformed head, over the same \
         distance on the moved mask; the mean over the {} frames where the mask opens {} mm or \
         more. A head whose anchors move exactly with the mask scores {}: not 1, because the \
         head's lips are apart at rest while the mask's touch. Below that the head's mouth \
         opens less than asked (the \"squashed mouth\" of the thesis's smoothest algorithm); \
         above it, more.",
        c.open_frames,
        MIN_MASK_OPENING_MM,
        c.exact_mouth_opening_ratio
            .map_or("no ratio (no frame opens the mask)".into(), |r| format!(
                "**{r:.3}**"
            ))
    );
    if has_gt {
        let _ = writeln!(
            out,
            "- **ground-truth RMS** (mm; lower is more faithful): each of the {} artist-made \
             expression targets of this head is sampled at the anchors as the control \
             displacements, the algorithm deforms the head from them, and the RMS distance to \
             the target itself is taken over the {} face vertices; the column is the mean over \
             the targets. Not moving at all scores {:.2} mm (the `rest` row). Every pair is in \
             `ground_truth.tsv` (RMS and max, with a `rest` row per target, and the lip \
             triangles turned past 60 degrees by the algorithm, by the target itself and by \
             the algorithm where the target does not turn them).",
            c.rest_ground_truth.len(),
            thousands(c.face_vertices),
            rest_gt_mean
        );
    }
    let _ = writeln!(
        out,
        "- **face crease** (dimensionless; lower is better): the lip roughness sees only the \
         5 mm around the lips, so this looks at the whole face: the {} triangles of the face \
         vertices (within {} mm of a used anchor). In each frame, the largest rise of one \
         triangle's `rho(T)` above its value at rest, the sharpest new crease or fold; the \
         column is the median over frames, so one odd frame does not decide it. Around 0.1 \
         is a gentle bend spread over many triangles; 0.5 and more is a fold a viewer sees. \
         `face.tsv` also has the mean `rho(T)` over the face ({:.5} at rest).",
        thousands(c.face_triangles),
        FACE_RADIUS_MM,
        c.rest_face_roughness
    );
    let _ = writeln!(
        out,
        "- **lip folds** (count; lower is better, 0 is the goal): in each frame, the lip \
         triangles whose normal turned more than {FOLD_DEG} degrees from rest once the lip \
         region's own rigid motion is taken out; the column sums them over the frames \
         (triangle-frames). A skin that folds over near the mouth shows here even when the \
         averages above stay low.\n\
         - **sharpest fold** (degrees; lower is better): the largest increase of the angle \
         between two adjacent face triangles over its rest value, in any frame: 0 for a face \
         that only stretches and bends smoothly, 90 and more for a visible ridge or kink."
    );
    if let Some(rest) = &c.rest_contact {
        let _ = writeln!(
            out,
            "- **lip vertices in teeth** (count; 0 is the goal): the lip region's vertices that \
             end inside a tooth (a closed piece of the skull or jaw parts, the jaw's moved by \
             the frame's jaw motion), summed over the frames; {} at rest.\n\
             - **f/v lip to teeth** (mm; under 1.5 is the goal): in each syllable whose label \
             starts with f or v, the lower lip's closest approach to the upper teeth; the \
             column is the widest of those. {:.1} mm at rest.",
            rest.lips_in_teeth, rest.lower_lip_to_upper_teeth_mm
        );
        if let Some(tongue) = &c.tongue {
            let _ = writeln!(
                out,
                "- **the tongue** (the same under every algorithm: the jaw carries it, the \
                 tongue FAPs shape it): it grazed a tooth in {} frames (at most {} vertices, \
                 at most {:.1} mm deep; `contact.tsv` has every frame); its most forward \
                 point came at most {:.1} mm {} the upper teeth's front ({:.1} mm behind at \
                 rest).",
                tongue.frames_in_teeth,
                tongue.max_in_teeth,
                tongue.max_depth_mm,
                tongue.max_past_teeth_mm.abs(),
                if tongue.max_past_teeth_mm > 0.0 {
                    "in front of"
                } else {
                    "behind"
                },
                -rest.tongue_past_teeth_mm
            );
        }
    }
    let _ = writeln!(
        out,
        "- **deform** (microseconds): the median wall time of one deform call over the stream, \
         one thread, on the machine above. It varies by machine and load; every other number \
         here is deterministic.\n"
    );

    // How to read it.
    let _ = writeln!(out, "## Reading the trade-off\n");
    let _ = writeln!(
        out,
        "Roughness alone rewards doing little: the head at rest scores {:.5}, and an algorithm \
         that moves the lips less than asked, or spreads their motion thinly, looks smooth \
         while missing the expression (watch the mouth opening ratio and the control error). \
         Fidelity alone ignores creases, and the lip roughness ignores everything beyond the \
         lips (watch the face crease). So read them together: an algorithm is worth \
         considering when no other one is better on every measure at once (the Pareto fronts \
         below), and among those, prefer lip roughness near the rest value, a control error \
         well under a millimetre, the exact mouth opening ratio and a small crease.\n",
        c.rest_roughness
    );
    let gt = |a: &AlgorithmResult| a.summary.ground_truth_rms_mm.unwrap_or(f64::NAN);
    let by_control: Vec<[f64; 2]> = algos
        .iter()
        .map(|a| [a.summary.control_err_mm, a.summary.roughness_mean])
        .collect();
    let _ = writeln!(
        out,
        "- Pareto front, control error and lip roughness: {}.",
        list(algos, &pareto_front(&by_control))
    );
    if has_gt {
        let by_gt: Vec<[f64; 2]> = algos.iter().map(|a| [gt(a), a.summary.roughness_mean]).collect();
        let _ = writeln!(
            out,
            "- Pareto front, ground-truth RMS and lip roughness: {}.",
            list(algos, &pareto_front(&by_gt))
        );
    }
    let all: Vec<[f64; 4]> = algos
        .iter()
        .map(|a| {
            let s = &a.summary;
            [
                s.roughness_mean,
                s.control_err_mm,
                s.crease,
                if has_gt { gt(a) } else { 0.0 },
            ]
        })
        .collect();
    let _ = writeln!(
        out,
        "- Pareto front, lip roughness, control error{} and face crease together: {}.",
        if has_gt { ", ground-truth RMS" } else { "" },
        list(algos, &pareto_front(&all))
    );
    let ranked = |key: &dyn Fn(&AlgorithmResult) -> f64| {
        let mut order: Vec<usize> = (0..algos.len()).filter(|&i| key(&algos[i]).is_finite()).collect();
        order.sort_by(|&i, &j| key(&algos[i]).total_cmp(&key(&algos[j])));
        order
    };
    let smooth = ranked(&|a| a.summary.roughness_mean);
    let creases = ranked(&|a| a.summary.crease);
    let faithful = ranked(&|a| a.summary.control_err_mm);
    let _ = writeln!(
        out,
        "- Smoothest: {}; roughest: {}.",
        list(algos, &smooth[..smooth.len().min(3)]),
        list(algos, &smooth[smooth.len().saturating_sub(3)..])
    );
    let _ = writeln!(
        out,
        "- Smallest control error: {}; largest: {}.",
        list(algos, &faithful[..faithful.len().min(3)]),
        list(algos, &faithful[faithful.len().saturating_sub(3)..])
    );
    if has_gt {
        let gt = ranked(&gt);
        let _ = writeln!(
            out,
            "- Smallest ground-truth RMS: {}; largest: {}.",
            list(algos, &gt[..gt.len().min(3)]),
            list(algos, &gt[gt.len().saturating_sub(3)..])
        );
    }
    let _ = writeln!(
        out,
        "- Fewest creases: {}; most: {}.",
        list(algos, &creases[..creases.len().min(3)]),
        list(algos, &creases[creases.len().saturating_sub(3)..])
    );
    let _ = writeln!(out);

    // Charts.
    let _ = writeln!(out, "## Charts\n");
    for chart in &files.charts {
        let _ = writeln!(out, "![{}]({})\n", chart.alt(), chart.file());
    }

    // Files.
    let _ = writeln!(out, "## Files\n");
    let _ = writeln!(
        out,
        "- [`{}`]({}): the table above (`{}`, full precision; `NaN` where no frame opens the \
         mouth or no target was measured).",
        files.algorithms,
        files.algorithms,
        algorithms_header().replace('\t', " ")
    );
    let _ = writeln!(
        out,
        "- [`{}`]({}): one row per algorithm and syllable (`letter spec syllable frames \
         roughness_mean`), syllables in stream order.",
        files.syllables, files.syllables
    );
    let _ = writeln!(
        out,
        "- [`{}`]({}): one row per algorithm (`letter spec face_roughness_mean crease`), then \
         the head at rest.",
        files.face, files.face
    );
    if let Some(gt) = &files.ground_truth {
        let _ = writeln!(
            out,
            "- [`{gt}`]({gt}): one row per algorithm and target (`letter spec target rms_mm \
             max_mm`), then the head at rest against each target (`- rest`)."
        );
    }
    if let Some(contact) = &files.contact {
        let _ = writeln!(
            out,
            "- [`{contact}`]({contact}): one row per algorithm and frame (`{}`).",
            CONTACT_HEADER.replace('\t', " ")
        );
    }
    out
}

/// `**A** (`bary1`), **T** (`rbf`)`.
fn list(algos: &[AlgorithmResult], indexes: &[usize]) -> String {
    if indexes.is_empty() {
        return "none".into();
    }
    indexes
        .iter()
        .map(|&i| format!("**{}** (`{}`)", algos[i].summary.letter, algos[i].summary.spec))
        .collect::<Vec<_>>()
        .join(", ")
}

fn mean(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, count) = values.fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    if count > 0 {
        sum / count as f64
    } else {
        f64::NAN
    }
}

/// `8838` -> `8,838`.
fn thousands(n: usize) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, ch) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(ch);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_front_keeps_the_undominated() {
        let points = [
            (1.0, 5.0),
            (2.0, 2.0),
            (3.0, 3.0),
            (0.5, 9.0),
            (f64::NAN, 0.0),
            (2.0, 2.0),
        ];
        // (3, 3) is beaten by (2, 2); the twin (2, 2) points do not beat each other.
        let points = points.map(|(a, b)| [a, b]);
        assert_eq!(pareto_front(&points), [3, 0, 1, 5]);
        // a third criterion brings (3, 3) back when it wins there
        let three = [[1.0, 5.0, 1.0], [2.0, 2.0, 1.0], [3.0, 3.0, 0.0]];
        assert_eq!(pareto_front(&three), [0, 1, 2]);
        assert_eq!(thousands(8838), "8,838");
        assert_eq!(thousands(512), "512");
        assert_eq!(thousands(1234567), "1,234,567");
    }
}
