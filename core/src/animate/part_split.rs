//! A part mesh that holds both rows of teeth (as the ICT Face Model ships them, and many
//! avatar kits) must move as two: the upper row with the skull, the lower with the jaw.
//! Left whole, its role is one or the other and the lower teeth stay still while the jaw
//! opens (or the upper ones fall with it).
//!
//! A piece is a set of triangles joined by shared vertices (a tooth, or a row fused into
//! one). In the fitted mask's frame (+y up), two rows are two bands of pieces one above
//! the other. The pieces, sorted by their centroids' heights, are cut where consecutive
//! centroids step furthest apart; that cut is the two rows when every piece above it
//! reaches higher than every piece below it by over [`ROW_STEP`] of the median piece's
//! height. Cut at its largest step, a single row's two halves reach about as high as
//! each other (incisors and molars share a row's edge). Over the 51 ICT heads of the test
//! population (`facewire population`), the two rows of each head's teeth clear that test
//! by 0.46-0.69 of a tooth's height, and each row alone fails it (-0.34 to 0.04). The
//! split is made only when the part's role is left to be inferred. The mouth line of
//! [`super::infer_role`] cannot split rows: the lower incisors' crowns rise above the
//! inner-lip corners.

use crate::fit::FittedMask;
use crate::head::{Head, Pieces, NO_PIECE};

/// Every piece of the upper row reaches higher than every piece of the lower row by more
/// than this share of the median piece's height.
pub const ROW_STEP: f32 = 0.25;

/// A part cut into its two rows: `upper` moves with the skull, `lower` with the jaw.
#[derive(Debug, Clone)]
pub struct RowSplit {
    pub upper: Head,
    pub lower: Head,
    /// Connected pieces on each side.
    pub upper_pieces: usize,
    pub lower_pieces: usize,
}

/// `mesh` (the part `name`) cut into its upper and lower row, named `{name}_upper` and
/// `{name}_lower`; `None` when it holds one row.
pub fn split_rows(mesh: &Head, name: &str, fitted: &FittedMask) -> Option<RowSplit> {
    let pieces = Pieces::of(mesh);
    if pieces.count < 2 {
        return None;
    }
    let to_mask = fitted.fit.pose.affine().inverse();
    let mut sum = vec![0.0f32; pieces.count];
    let mut size = vec![0u32; pieces.count];
    let mut low = vec![f32::INFINITY; pieces.count];
    let mut high = vec![f32::NEG_INFINITY; pieces.count];
    for (v, &piece) in pieces.of_vertex.iter().enumerate() {
        if piece != NO_PIECE {
            let y = to_mask.transform_point3(mesh.positions[v]).y;
            let k = piece as usize;
            sum[k] += y;
            size[k] += 1;
            low[k] = low[k].min(y);
            high[k] = high[k].max(y);
        }
    }
    let centre: Vec<f32> = (0..pieces.count).map(|k| sum[k] / size[k] as f32).collect();
    let mut heights: Vec<f32> = (0..pieces.count).map(|k| high[k] - low[k]).collect();
    heights.sort_by(f32::total_cmp);
    let median_height = heights[heights.len() / 2];
    let mut sorted = centre.clone();
    sorted.sort_by(f32::total_cmp);
    let at = sorted
        .windows(2)
        .max_by(|a, b| (a[1] - a[0]).total_cmp(&(b[1] - b[0])))
        .map(|w| (w[0] + w[1]) / 2.0)?;
    let above: Vec<bool> = centre.iter().map(|&c| c > at).collect();
    let above = &above;
    let high = &high;
    let top = |upper: bool| {
        (0..pieces.count)
            .filter(move |&k| above[k] == upper)
            .map(move |k| high[k])
    };
    let lowest_upper_top = top(true).fold(f32::INFINITY, f32::min);
    let highest_lower_top = top(false).fold(f32::NEG_INFINITY, f32::max);
    if lowest_upper_top - highest_lower_top <= ROW_STEP * median_height {
        return None;
    }
    let upper_pieces = above.iter().filter(|&&a| a).count();
    let side = |upper: bool| {
        let triangles: Vec<[u32; 3]> = mesh
            .triangles
            .iter()
            .filter(|t| above[pieces.of_vertex[t[0] as usize] as usize] == upper)
            .copied()
            .collect();
        let suffix = if upper { "upper" } else { "lower" };
        Head::compacted(&format!("{name}_{suffix}"), &mesh.positions, &triangles)
    };
    Some(RowSplit {
        upper: side(true),
        lower: side(false),
        upper_pieces,
        lower_pieces: pieces.count - upper_pieces,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::Fit;
    use crate::mask::{Mask, MaskPose};
    use glam::Vec3;

    /// A tetrahedron of size `s` whose lowest corner is at `at` (head units).
    fn tetrahedron(at: Vec3, s: f32, base: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let p = vec![at, at + Vec3::X * s, at + Vec3::Z * s, at + Vec3::Y * s];
        let t = vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]];
        (p, t.into_iter().map(|t| t.map(|v| v + base)).collect())
    }

    #[test]
    fn two_rows_part_ways_and_one_row_stays_whole() {
        let mask = Mask::candide3();
        let fit = Fit {
            pose: MaskPose::IDENTITY,
            shape: vec![0.0; mask.shape_units.len()],
            nudges: Vec::new(),
            mm_per_unit: 100.0,
        };
        let fitted = FittedMask::new(mask, fit);
        let mouth = -0.47;
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        // Two pieces in a row above, two in a row below (mask units: the identity fit),
        // each 0.04 tall: the rows' centroids step by 0.105, within a row by 0.005.
        for (k, y) in [mouth + 0.05, mouth + 0.045, mouth - 0.06, mouth - 0.065]
            .into_iter()
            .enumerate()
        {
            let (p, t) = tetrahedron(Vec3::new(0.1 * k as f32, y, 0.3), 0.04, positions.len() as u32);
            positions.extend(p);
            triangles.extend(t);
        }
        // A vertex no triangle uses goes nowhere.
        positions.push(Vec3::ZERO);
        let teeth = Head::new("teeth", positions, triangles);
        let split = split_rows(&teeth, "teeth", &fitted).expect("split");
        assert_eq!((split.upper_pieces, split.lower_pieces), (2, 2));
        assert_eq!(
            (split.upper.name.as_str(), split.lower.name.as_str()),
            ("teeth_upper", "teeth_lower")
        );
        assert_eq!((split.upper.positions.len(), split.upper.triangles.len()), (8, 8));
        assert_eq!((split.lower.positions.len(), split.lower.triangles.len()), (8, 8));
        assert!(split.lower.positions.iter().all(|p| p.y < mouth));
        assert!(split.lower.triangles.iter().flatten().all(|&v| v < 8));

        // One row: no step stands out, nothing to split.
        let upper_only = Head::new(
            "teeth_upper",
            split.upper.positions.clone(),
            split.upper.triangles.clone(),
        );
        assert!(split_rows(&upper_only, "teeth_upper", &fitted).is_none());
    }
}
