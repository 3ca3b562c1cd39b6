//! ARKit-52 input: a retarget basis that turns ARKit blendshape weights into motion of the
//! CANDIDE-3 mask, so a frame from an iPhone, Live Link Face or any ARKit-named rig poses
//! the mask like CANDIDE parameters do.
//!
//! The basis holds, for every blendshape, one offset per mask vertex in **mask units**,
//! added to the mask before the fit's pose (`FittedMask::pose_with_offsets_into`), so it
//! carries over to any head through that head's fit. It is derived once from artist-made
//! expressions: the Face Units targets (ARKit names, CC0) of the MakeHuman head, sampled at
//! the anchor of every control vertex of the head's fitted mask and taken back into mask
//! units by the inverse of the fit's rotation and scale ([`ArkitBasis::derive`]). The
//! result ships as `data/arkit/basis.tsv` and is embedded ([`ArkitBasis::shipped`]).
//! Applying it allocates nothing. Format and numbers: `docs/STREAMS.md`.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::ops::Range;
use std::path::Path;

use glam::Vec3;

use super::blendshapes::{arkit_index, ARKIT_BLENDSHAPES};
use crate::fit::{Anchors, FittedMask};
use crate::input::{read_text, ReadError, MAX_TEXT_BYTES};
use crate::quote::quote;
use crate::targets::{ExpressionTarget, TargetError};
use crate::text_table::{self, FieldProblem, Row};

/// The shipped basis (`data/arkit/basis.tsv`), derived from the MakeHuman head's targets.
pub const SHIPPED_BASIS_TSV: &str = include_str!("../../../data/arkit/basis.tsv");

/// The command that regenerates the shipped basis; its header names it.
pub const SHIPPED_BASIS_COMMAND: &str = "facewire arkit-basis --head data/heads/makehuman_head.obj \
     --fit data/heads/makehuman_head.fit.toml --targets data/heads/makehuman_arkit --out data/arkit/basis.tsv";

/// The shipped basis's sources, as its header credits them.
const SHIPPED_BASIS_SOURCES: &str =
    "# Derived from the Face Units expression targets by Mika Suominen (CC0 1.0) on the\n\
     # MakeHuman hm08 base mesh (MakeHuman team / Data Collection AB, CC0 1.0); see\n\
     # data/heads/LICENSES.md (no attribution required; this is a courtesy credit).\n\
     # Each offset is a target's displacement d at the anchor of a mask vertex used by a\n\
     # triangle, taken into mask units with the MakeHuman fit's pose: S^-1 R^T d.\n";

/// Decimal places of the offsets written by [`ArkitBasis::to_tsv`]: 1e-6 mask units, about
/// 1e-4 mm on an adult face.
pub const OFFSET_DECIMALS: usize = 6;

/// Columns of a basis row.
const COLUMNS: [&str; 5] = ["arkit_name", "mask_vertex", "dx", "dy", "dz"];

/// A basis file that cannot be read, or inputs a basis cannot be derived from.
#[derive(Debug, thiserror::Error)]
pub enum ArkitBasisError {
    #[error(transparent)]
    Read(#[from] ReadError),
    #[error("{origin}: line {line}: expected 5 fields `arkit_name mask_vertex dx dy dz`, found {found}")]
    FieldCount {
        origin: String,
        line: usize,
        found: usize,
    },
    /// `name` is quoted and cut by [`quote`].
    #[error("{origin}: line {line}: arkit_name: unknown ARKit blendshape {name}; valid: {valid}")]
    UnknownBlendshape {
        origin: String,
        line: usize,
        name: String,
        valid: String,
    },
    /// `found` is quoted and cut (see [`text_table::FieldProblem`]).
    #[error("{origin}: line {line}: {field}: {found} {problem}")]
    Field {
        origin: String,
        line: usize,
        field: &'static str,
        found: String,
        problem: &'static str,
    },
    #[error("{origin}: line {line}: {blendshape} mask_vertex {vertex} is listed again (first on line {first_line})")]
    Repeated {
        origin: String,
        line: usize,
        blendshape: &'static str,
        vertex: u32,
        first_line: usize,
    },
    #[error("target {name:?} is not an ARKit blendshape name; valid: {valid}")]
    UnknownTarget { name: String, valid: String },
    #[error("target {name:?} is given twice")]
    DuplicateTarget { name: String },
    #[error("target {name}: {source}")]
    Target { name: String, source: TargetError },
    #[error("the anchors cover {found} mask vertices, the mask has {expected}")]
    AnchorCount { expected: usize, found: usize },
    #[error("the fit's scale {scale:?} cannot be inverted (every component must be finite and non-zero)")]
    Scale { scale: [f32; 3] },
}

/// ARKit blendshapes as offsets of the mask vertices (mask units per unit weight).
///
/// Only the vertices a blendshape moves are stored: in memory as one list of (mask
/// vertex, offset) grouped by blendshape in ARKit order, ascending vertex within a group.
#[derive(Debug, Clone, PartialEq)]
pub struct ArkitBasis {
    offsets: Vec<(u32, Vec3)>,
    /// `offsets[ranges[k]]` belong to blendshape `k` (empty when it moves nothing).
    ranges: [Range<usize>; 52],
}

impl ArkitBasis {
    /// The embedded shipped basis (`data/arkit/basis.tsv`, [`SHIPPED_BASIS_TSV`]).
    pub fn shipped() -> ArkitBasis {
        ArkitBasis::parse("data/arkit/basis.tsv", SHIPPED_BASIS_TSV)
            .expect("the embedded data/arkit/basis.tsv parses")
    }

    /// Reads a basis file.
    pub fn load(path: &Path) -> Result<ArkitBasis, ArkitBasisError> {
        let origin = path.display().to_string();
        let text = read_text(path, MAX_TEXT_BYTES)?;
        ArkitBasis::parse(&origin, &text)
    }

    /// Parses a basis's text: `#` comment lines and blank lines are skipped; every other
    /// line is `arkit_name mask_vertex dx dy dz` separated by whitespace (names
    /// case-insensitive, offsets in mask units). A blendshape or vertex that has no row
    /// does not move. `origin` names the text in errors, which also give the 1-based line
    /// and the field.
    pub fn parse(origin: &str, text: &str) -> Result<ArkitBasis, ArkitBasisError> {
        let mut rows = Vec::new();
        let mut first_lines: HashMap<(u8, u32), usize> = HashMap::new();
        for Row { line, fields } in text_table::rows(text) {
            let &[name, vertex, dx, dy, dz] = fields.as_slice() else {
                return Err(ArkitBasisError::FieldCount {
                    origin: origin.to_string(),
                    line,
                    found: fields.len(),
                });
            };
            let shape = arkit_index(name).ok_or_else(|| ArkitBasisError::UnknownBlendshape {
                origin: origin.to_string(),
                line,
                name: quote(name),
                valid: ARKIT_BLENDSHAPES.join(", "),
            })?;
            let field_error = |p: FieldProblem| ArkitBasisError::Field {
                origin: origin.to_string(),
                line,
                field: p.field,
                found: p.found,
                problem: p.problem,
            };
            let vertex =
                text_table::index(COLUMNS[1], vertex, "is not a mask vertex index").map_err(field_error)?;
            let offset =
                text_table::vec3([COLUMNS[2], COLUMNS[3], COLUMNS[4]], [dx, dy, dz]).map_err(field_error)?;
            if let Some(&first_line) = first_lines.get(&(shape, vertex)) {
                return Err(ArkitBasisError::Repeated {
                    origin: origin.to_string(),
                    line,
                    blendshape: ARKIT_BLENDSHAPES[usize::from(shape)],
                    vertex,
                    first_line,
                });
            }
            first_lines.insert((shape, vertex), line);
            rows.push((shape, vertex, offset));
        }
        Ok(ArkitBasis::from_rows(rows))
    }

    /// Derives the basis from expression targets of one head: for every target (named
    /// after its ARKit blendshape) and every mask vertex a triangle uses, the target's
    /// displacement `d` at the vertex's anchor (head units), taken into mask units as
    /// `S^-1 R^T d` with the fit's rotation `R` and scale `S`. Posing the fitted mask with
    /// these offsets moves each control vertex by exactly the target's displacement at its
    /// anchor. Offsets are kept exact; [`ArkitBasis::to_tsv`] rounds them.
    pub fn derive(
        fitted: &FittedMask,
        anchors: &Anchors,
        targets: &[ExpressionTarget],
    ) -> Result<ArkitBasis, ArkitBasisError> {
        let used = fitted.mask.used_vertices();
        if anchors.vertex.len() != used.len() {
            return Err(ArkitBasisError::AnchorCount {
                expected: used.len(),
                found: anchors.vertex.len(),
            });
        }
        let scale = fitted.fit.pose.scale;
        if !(scale.is_finite() && scale.cmpne(Vec3::ZERO).all()) {
            return Err(ArkitBasisError::Scale {
                scale: scale.to_array(),
            });
        }
        let to_mask_units = fitted.fit.pose.rotation().transpose();
        let mut seen = [false; 52];
        let mut displacements = vec![Vec3::ZERO; used.len()];
        let mut rows = Vec::new();
        for target in targets {
            let shape = arkit_index(&target.name).ok_or_else(|| ArkitBasisError::UnknownTarget {
                name: target.name.clone(),
                valid: ARKIT_BLENDSHAPES.join(", "),
            })?;
            if std::mem::replace(&mut seen[usize::from(shape)], true) {
                return Err(ArkitBasisError::DuplicateTarget {
                    name: target.name.clone(),
                });
            }
            target
                .controls_into(anchors, 1.0, &mut displacements)
                .map_err(|source| ArkitBasisError::Target {
                    name: target.name.clone(),
                    source,
                })?;
            for ((vertex, &d), _) in (0u32..)
                .zip(&displacements)
                .zip(&used)
                .filter(|(_, &is_used)| is_used)
            {
                if d != Vec3::ZERO {
                    rows.push((shape, vertex, to_mask_units * d / scale));
                }
            }
        }
        Ok(ArkitBasis::from_rows(rows))
    }

    /// This basis for the blendshapes in `own` (indices into [`ARKIT_BLENDSHAPES`]; a
    /// blendshape listed there with no offsets moves nothing), `fallback`'s for the others:
    /// a head's own targets where it has them, the shipped basis elsewhere.
    pub fn completed_by(&self, own: &[u8], fallback: &ArkitBasis) -> ArkitBasis {
        let mut rows = Vec::new();
        for shape in 0..52u8 {
            let from = if own.contains(&shape) { self } else { fallback };
            rows.extend(
                from.blendshape_offsets(shape)
                    .iter()
                    .map(|&(vertex, offset)| (shape, vertex, offset)),
            );
        }
        ArkitBasis::from_rows(rows)
    }

    /// The largest mask vertex index any blendshape moves, if any moves one.
    pub fn max_vertex(&self) -> Option<u32> {
        self.offsets.iter().map(|&(vertex, _)| vertex).max()
    }

    fn from_rows(mut rows: Vec<(u8, u32, Vec3)>) -> ArkitBasis {
        rows.sort_by_key(|&(shape, vertex, _)| (shape, vertex));
        let mut ranges: [Range<usize>; 52] = std::array::from_fn(|_| 0..0);
        let mut start = 0;
        for (shape, range) in (0u8..).zip(ranges.iter_mut()) {
            let end = start + rows[start..].iter().take_while(|row| row.0 == shape).count();
            *range = start..end;
            start = end;
        }
        ArkitBasis {
            offsets: rows
                .into_iter()
                .map(|(_, vertex, offset)| (vertex, offset))
                .collect(),
            ranges,
        }
    }

    /// The (mask vertex, offset in mask units) pairs of blendshape `shape` (an index into
    /// [`ARKIT_BLENDSHAPES`]), ascending by vertex; empty for a blendshape that moves
    /// nothing or an index beyond 51.
    pub fn blendshape_offsets(&self, shape: u8) -> &[(u32, Vec3)] {
        self.ranges
            .get(usize::from(shape))
            .map_or(&[], |range| &self.offsets[range.clone()])
    }

    /// Adds `sum_k w_k B_k` to `out`, one offset per mask vertex in mask units, for the
    /// (blendshape index, weight) pairs of `weights` (a frame's `arkit`). Indices beyond 51
    /// and vertices beyond `out` are left out. Allocates nothing.
    pub fn apply(&self, weights: &[(u8, f32)], out: &mut [Vec3]) {
        for &(shape, weight) in weights {
            for &(vertex, offset) in self.blendshape_offsets(shape) {
                if let Some(slot) = out.get_mut(vertex as usize) {
                    *slot += weight * offset;
                }
            }
        }
    }

    /// The shipped basis's text ([`ArkitBasis::to_tsv_from`] with the MakeHuman targets'
    /// credit).
    pub fn to_tsv(&self, generator_command: &str) -> String {
        self.to_tsv_from(SHIPPED_BASIS_SOURCES, generator_command)
    }

    /// The basis as the documented text file: a header (what it is, then `sources`: where
    /// the targets came from and their licence, `#` lines, and `generator_command`), then one
    /// tab-separated row `arkit_name mask_vertex dx dy dz` per stored offset, numbers rounded
    /// to [`OFFSET_DECIMALS`] places. Rows that round to zero are left out.
    pub fn to_tsv_from(&self, sources: &str, generator_command: &str) -> String {
        let mut out = String::from(
            "# facewire ARKit retarget basis: each ARKit blendshape at weight 1 as offsets of the\n\
             # CANDIDE-3.1.6 mask vertices, in mask units (+x the face's left, +y up, +z out of the\n\
             # face), added to the mask before the fit's pose. Format and numbers: docs/STREAMS.md.\n\
             #\n",
        );
        out.push_str(sources);
        let still: Vec<&str> = (0u8..)
            .zip(ARKIT_BLENDSHAPES)
            .filter(|&(shape, _)| self.rows_of(shape).next().is_none())
            .map(|(_, name)| name)
            .collect();
        if !still.is_empty() {
            let _ = writeln!(
                out,
                "# Blendshapes with no rows (they move nothing): {}.",
                still.join(", ")
            );
        }
        let _ = writeln!(out, "#\n# generator: {generator_command}");
        let _ = writeln!(
            out,
            "# columns: {} (tab-separated; offsets rounded to 1e-{OFFSET_DECIMALS}, zero rows left out)",
            COLUMNS.join(" ")
        );
        for (shape, name) in (0u8..).zip(ARKIT_BLENDSHAPES) {
            for (vertex, [dx, dy, dz]) in self.rows_of(shape) {
                let _ = writeln!(out, "{name}\t{vertex}\t{dx}\t{dy}\t{dz}");
            }
        }
        out
    }

    /// The rows [`ArkitBasis::to_tsv`] writes for one blendshape: rounded offsets as text,
    /// without those that round to zero.
    fn rows_of(&self, shape: u8) -> impl Iterator<Item = (u32, [String; 3])> + '_ {
        self.blendshape_offsets(shape)
            .iter()
            .map(|&(vertex, offset)| (vertex, offset.to_array().map(rounded_decimal)))
            .filter(|(_, texts)| texts.iter().any(|t| t != "0"))
    }
}

/// `x` with [`OFFSET_DECIMALS`] places, trailing zeros dropped, and `0` for zero of
/// either sign (`0.1234`, `-0.000012`, `0`).
fn rounded_decimal(x: f32) -> String {
    let fixed = format!("{:.*}", OFFSET_DECIMALS, f64::from(x));
    let trimmed = fixed.trim_end_matches('0').trim_end_matches('.');
    match trimmed {
        "-0" | "" => "0".to_string(),
        other => other.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_basis_parses_and_opens_the_jaw() {
        let basis = ArkitBasis::shipped();
        let jaw_open = arkit_index("jawOpen").unwrap();
        let lower_lip_middle = basis
            .blendshape_offsets(jaw_open)
            .iter()
            .find(|(vertex, _)| *vertex == 8)
            .map(|(_, offset)| *offset)
            .unwrap();
        assert!(lower_lip_middle.y < -0.05, "{lower_lip_middle}");
        assert!(basis
            .blendshape_offsets(arkit_index("tongueOut").unwrap())
            .is_empty());
    }

    #[test]
    fn applies_weighted_sums_and_skips_what_does_not_fit() {
        let basis = ArkitBasis::parse(
            "b",
            "# c\n\njawOpen 1 0 -1 0\nJAWOPEN\t0 0.5 0 0\nmouthClose 1 0 0.25 0\ncheekPuff 9 1 1 1\n",
        )
        .unwrap();
        let mut out = [Vec3::ONE; 2];
        basis.apply(&[(17, 0.5), (18, 2.0), (46, 1.0), (200, 1.0)], &mut out);
        assert_eq!(out, [Vec3::new(1.25, 1.0, 1.0), Vec3::new(1.0, 1.0, 1.0)]);
        assert_eq!(
            basis.blendshape_offsets(17),
            [(0, Vec3::new(0.5, 0.0, 0.0)), (1, -Vec3::Y)]
        );
        assert!(basis.blendshape_offsets(52).is_empty());
    }

    #[test]
    fn errors_name_the_line_and_field() {
        let error = |text: &str| ArkitBasis::parse("b.tsv", text).unwrap_err().to_string();
        assert_eq!(
            error("# c\njawOpen 1 0 0\n"),
            "b.tsv: line 2: expected 5 fields `arkit_name mask_vertex dx dy dz`, found 4"
        );
        assert!(error("jawOpn 1 0 0 0\n").starts_with(
            "b.tsv: line 1: arkit_name: unknown ARKit blendshape \"jawOpn\"; valid: eyeBlinkLeft, "
        ),);
        assert_eq!(
            error("jawOpen -1 0 0 0\n"),
            "b.tsv: line 1: mask_vertex: \"-1\" is not a mask vertex index"
        );
        assert_eq!(
            error("jawOpen 1 0 x 0\n"),
            "b.tsv: line 1: dy: \"x\" is not a number"
        );
        assert_eq!(
            error("jawOpen 1 0 0 1e39\n"),
            "b.tsv: line 1: dz: \"1e39\" is not a finite number"
        );
        assert_eq!(
            error("jawOpen 1 0 0 0\n\njawopen 1 0 0 1\n"),
            "b.tsv: line 3: jawOpen mask_vertex 1 is listed again (first on line 1)"
        );
    }

    #[test]
    fn derives_offsets_in_mask_units_from_the_targets() {
        use crate::fit::Fit;
        use crate::mask::{Mask, MaskPose};

        let mask = Mask::candide3();
        let pose = MaskPose::similarity(Vec3::new(0.0, 0.0, std::f32::consts::FRAC_PI_2), 2.0, Vec3::ONE);
        let fit = Fit {
            pose,
            shape: vec![0.0; mask.shape_units.len()],
            nudges: Vec::new(),
            mm_per_unit: 10.0,
        };
        let fitted = FittedMask::new(mask, fit);
        // Mask vertex 8 anchored on head vertex 1, everything else on head vertex 0;
        // vertex 4 (used by no triangle) on head vertex 1 too.
        let mut anchors = Anchors {
            vertex: vec![0; fitted.mask.vertices.len()],
            distance: vec![0.0; fitted.mask.vertices.len()],
        };
        anchors.vertex[8] = 1;
        anchors.vertex[4] = 1;
        let target = |name: &str| ExpressionTarget::parse(name, name, "1 0.4 0 0\n", 2).unwrap();
        let basis = ArkitBasis::derive(&fitted, &anchors, &[target("jawOpen")]).unwrap();
        // R rolls +x onto +y, so R^T takes head +x back to mask -y; then halved.
        let rows = basis.blendshape_offsets(17);
        assert_eq!(rows.len(), 1);
        assert_eq!(rows[0].0, 8);
        assert!(
            rows[0].1.abs_diff_eq(Vec3::new(0.0, -0.2, 0.0), 1e-7),
            "{}",
            rows[0].1
        );
        let mut offsets = vec![Vec3::ZERO; fitted.mask.vertices.len()];
        basis.apply(&[(17, 1.0)], &mut offsets);
        let mut posed = offsets.clone();
        fitted.pose_with_offsets_into(&[], &offsets, &mut posed);
        assert!((posed[8] - fitted.neutral[8]).abs_diff_eq(Vec3::new(0.4, 0.0, 0.0), 1e-6));

        let error = |anchors: &Anchors, targets: &[ExpressionTarget]| {
            ArkitBasis::derive(&fitted, anchors, targets)
                .unwrap_err()
                .to_string()
        };
        assert!(error(&anchors, &[target("smile")])
            .starts_with("target \"smile\" is not an ARKit blendshape name; valid: "));
        assert_eq!(
            error(&anchors, &[target("jawOpen"), target("JAWOPEN")]),
            "target \"JAWOPEN\" is given twice"
        );
        anchors.vertex[8] = 5;
        let beyond = error(&anchors, &[target("jawOpen")]);
        assert!(beyond.starts_with("target jawOpen: "), "{beyond}");
        anchors.vertex.pop();
        let short = error(&anchors, &[target("jawOpen")]);
        assert_eq!(short, "the anchors cover 112 mask vertices, the mask has 113");
    }

    #[test]
    fn a_head_s_own_blendshapes_replace_the_fallback_s_and_only_those() {
        let own = ArkitBasis::parse("own", "jawOpen 3 1 0 0\nmouthClose 4 0 1 0\n").unwrap();
        let shipped = ArkitBasis::parse(
            "shipped",
            "jawOpen 3 9 9 9\njawOpen 5 9 0 0\neyeBlinkLeft 2 0 0 7\n",
        )
        .unwrap();
        // The head's own jawOpen and mouthClose; tongueOut listed as its own but moving
        // nothing; eyeBlinkLeft from the fallback.
        let (jaw, close, blink, tongue) = (17, 18, 0, 51);
        let merged = own.completed_by(&[jaw, close, tongue], &shipped);
        assert_eq!(merged.blendshape_offsets(jaw), [(3, Vec3::X)]);
        assert_eq!(merged.blendshape_offsets(close), [(4, Vec3::Y)]);
        assert_eq!(merged.blendshape_offsets(blink), [(2, Vec3::new(0.0, 0.0, 7.0))]);
        assert_eq!(merged.blendshape_offsets(tongue), []);
        assert_eq!(merged.max_vertex(), Some(4));
        // Without own blendshapes it is the fallback.
        let fallback_only = own.completed_by(&[], &shipped);
        assert_eq!(fallback_only.blendshape_offsets(jaw).len(), 2);
        assert_eq!(fallback_only.blendshape_offsets(close), []);
        assert_eq!(fallback_only.max_vertex(), Some(5));
    }

    #[test]
    fn written_rows_are_rounded_and_read_back() {
        let basis =
            ArkitBasis::parse("b", "jawOpen 3 0.1234564 -0.0000004 -2\nmouthClose 0 1e-9 0 0\n").unwrap();
        let text = basis.to_tsv("facewire arkit-basis ...");
        assert!(text.contains("\njawOpen\t3\t0.123456\t0\t-2\n"), "{text}");
        assert!(!text.contains("mouthClose\t"), "{text}");
        assert!(text.contains("# generator: facewire arkit-basis ...\n"), "{text}");
        assert!(
            text.contains("no rows (they move nothing): eyeBlinkLeft, "),
            "{text}"
        );
        let again = ArkitBasis::parse("again", &text).unwrap();
        assert_eq!(
            again.blendshape_offsets(17),
            [(3, Vec3::new(0.123456, 0.0, -2.0))]
        );
        assert!(again.blendshape_offsets(18).is_empty());
        assert_eq!(rounded_decimal(-0.0), "0");
        assert_eq!(rounded_decimal(2.5), "2.5");
    }
}
