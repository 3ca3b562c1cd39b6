//! Per-frame lip roughness in the shape of the thesis's `dataMetrics.txt`: one row per lip
//! vertex with the min, max and mean of `rho(T)` over its triangles, then a summary row
//! (mask vertex -1) over the union of all lip triangles. Only the union's triangles (and
//! their corners' fans) are evaluated; a frame allocates nothing.

use glam::Vec3;

use super::lip_region::LipRegion;
use super::roughness::{Roughness, RoughnessError};
use crate::head::Head;
use crate::mask::LIP_VERTICES;

/// Rows per frame: the 18 lip vertices and the summary.
pub const LIP_ROWS: usize = LIP_VERTICES.len() + 1;

/// `mask_vertex` of the summary row.
pub const SUMMARY_MASK_VERTEX: i32 = -1;

/// One row of the per-frame lip roughness table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LipRoughnessRow {
    pub frame: u64,
    /// Frame time, seconds.
    pub time_s: f64,
    /// CANDIDE-3 lip vertex, or [`SUMMARY_MASK_VERTEX`] for the union.
    pub mask_vertex: i32,
    /// Min, max and mean of `rho(T)` over the row's triangles (dimensionless).
    pub min: f64,
    pub max: f64,
    pub mean: f64,
}

impl LipRoughnessRow {
    /// Whether this is the summary row over the union of the lip triangles.
    pub fn is_summary(&self) -> bool {
        self.mask_vertex == SUMMARY_MASK_VERTEX
    }
}

/// Lip roughness of one head and lip region, evaluated frame by frame.
#[derive(Debug, Clone)]
pub struct LipRoughness {
    roughness: Roughness,
    /// Row k's triangles are `slots[offsets[k]..offsets[k + 1]]`, as indexes into the
    /// evaluator's region (the union); the summary row uses the whole region.
    offsets: [u32; LIP_VERTICES.len() + 1],
    slots: Vec<u32>,
}

impl LipRoughness {
    pub fn new(head: &Head, region: &LipRegion) -> Result<LipRoughness, RoughnessError> {
        let roughness = Roughness::new(head, region.union())?;
        let union = roughness.region_triangles();
        let mut offsets = [0u32; LIP_VERTICES.len() + 1];
        let mut slots = Vec::new();
        for (k, (_, triangles)) in region.per_lip_vertex().enumerate() {
            // Every lip triangle is in the union, which the evaluator keeps sorted.
            slots.extend(
                triangles
                    .iter()
                    .filter_map(|t| union.binary_search(t).ok())
                    .map(|s| s as u32),
            );
            offsets[k + 1] = slots.len() as u32;
        }
        Ok(LipRoughness {
            roughness,
            offsets,
            slots,
        })
    }

    /// The frame's rows: the 18 lip vertices in [`LIP_VERTICES`] order, then the summary.
    /// `positions` are the deformed head's vertices (head units).
    pub fn rows(
        &mut self,
        positions: &[Vec3],
        frame: u64,
        time_s: f64,
    ) -> Result<[LipRoughnessRow; LIP_ROWS], RoughnessError> {
        self.roughness.evaluate(positions)?;
        let rho = self.roughness.triangle_roughness();
        let summary = row(frame, time_s, SUMMARY_MASK_VERTEX, rho.iter().copied());
        let mut rows = [summary; LIP_ROWS];
        for (k, &mask_vertex) in LIP_VERTICES.iter().enumerate() {
            let slots = &self.slots[self.offsets[k] as usize..self.offsets[k + 1] as usize];
            rows[k] = row(
                frame,
                time_s,
                mask_vertex as i32,
                slots.iter().map(|&s| rho[s as usize]),
            );
        }
        Ok(rows)
    }

    /// The evaluator behind the rows: per-triangle `rho` of the union after the last frame.
    pub fn roughness(&self) -> &Roughness {
        &self.roughness
    }
}

/// Min, max and mean of `values` (never empty: every lip vertex has triangles).
fn row(frame: u64, time_s: f64, mask_vertex: i32, values: impl Iterator<Item = f64>) -> LipRoughnessRow {
    let (mut min, mut max, mut sum, mut count) = (f64::INFINITY, f64::NEG_INFINITY, 0.0, 0.0);
    for x in values {
        min = min.min(x);
        max = max.max(x);
        sum += x;
        count += 1.0;
    }
    LipRoughnessRow {
        frame,
        time_s,
        mask_vertex,
        min,
        max,
        mean: sum / count,
    }
}
