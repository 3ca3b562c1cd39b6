//! What binding produces and deforming consumes: per head vertex, a short list of terms.
//!
//! - **Linear** terms `w * delta_j`: a sparse weight matrix over the control displacements
//!   (point distance, renato, geometric, Kshirsagar, RBF).
//! - **Triangle** terms `w * (A' + a (B'-A') + b (C'-A') + c n' - P)`: local coordinates in
//!   a mask triangle's basis, re-evaluated on the moved mask (barycentric, SOFFD).
//! - **Bone** terms: planar bones' region bases (see `planar_bones`).
//!
//! A vertex's new position is `P + sum(linear) + sum(triangle) + sum(bone)`. Every term list
//! is stored in compressed rows; deforming walks them once and allocates nothing.
//!
//! An interpolating linear algorithm may add a [`SourceMap`]: a small dense matrix that
//! turns the control displacements into the values its linear terms blend, once per frame
//! (about 100 x 100 multiply-adds), so that the rows stay sparse.

use glam::{Vec3, Vec3A};

use super::bones::{BoneBases, BoneTerm, Region};
use super::normalize::Weighted;
use super::spec::AlgoSpec;
use super::triangle_basis::TriangleBasis;

/// Compressed rows: the items of row `v` are `items[offsets[v]..offsets[v + 1]]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Csr<T> {
    offsets: Vec<u32>,
    items: Vec<T>,
}

impl<T> Csr<T> {
    /// `rows` empty rows.
    pub fn empty(rows: usize) -> Csr<T> {
        Csr {
            offsets: vec![0; rows + 1],
            items: Vec::new(),
        }
    }

    pub fn from_rows(rows: Vec<Vec<T>>) -> Csr<T> {
        let mut offsets = Vec::with_capacity(rows.len() + 1);
        offsets.push(0u32);
        let total: usize = rows.iter().map(Vec::len).sum();
        let mut items = Vec::with_capacity(total);
        for row in rows {
            items.extend(row);
            offsets.push(items.len() as u32);
        }
        Csr { offsets, items }
    }

    pub fn rows(&self) -> usize {
        self.offsets.len() - 1
    }

    pub fn row(&self, v: usize) -> &[T] {
        &self.items[self.offsets[v] as usize..self.offsets[v + 1] as usize]
    }

    pub fn items(&self) -> &[T] {
        &self.items
    }

    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }
}

/// `weight * delta[control]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearTerm {
    pub control: u16,
    pub weight: f32,
}

impl Weighted for LinearTerm {
    fn weight_mut(&mut self) -> &mut f32 {
        &mut self.weight
    }
}

/// `weight * (basis_t'(coords) - P)`: follows mask triangle `t`'s basis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriangleTerm {
    pub triangle: u16,
    /// (a, b, c): `P - A = a (B - A) + b (C - A) + c n`, n the unit normal.
    pub coords: Vec3,
    pub weight: f32,
}

impl Weighted for TriangleTerm {
    fn weight_mut(&mut self) -> &mut f32 {
        &mut self.weight
    }
}

/// Per frame, `source_j = sum_k matrix[j][k] * delta_k` over the controls; the linear terms
/// then gather `source` instead of `delta`.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceMap {
    /// Mask vertex indices of the rows and columns, in order.
    controls: Vec<u16>,
    /// Column-major, `controls.len()` squared: column k is what control k's displacement
    /// adds to every source.
    matrix: Vec<f32>,
}

impl SourceMap {
    /// `matrix(row, column)` gives the entry for controls `controls[row]`, `controls[column]`.
    pub fn new(controls: Vec<u16>, matrix: impl Fn(usize, usize) -> f32) -> SourceMap {
        let m = controls.len();
        let matrix = (0..m * m).map(|i| matrix(i % m, i / m)).collect();
        SourceMap { controls, matrix }
    }

    /// Column by column, skipping the controls that do not move (in speech, most of them).
    fn apply(&self, deltas: &[Vec3A], sources: &mut [Vec3A]) {
        for &j in &self.controls {
            sources[j as usize] = Vec3A::ZERO;
        }
        let m = self.controls.len();
        for (&k, column) in self.controls.iter().zip(self.matrix.chunks_exact(m)) {
            let delta = deltas[k as usize];
            if delta == Vec3A::ZERO {
                continue;
            }
            for (&j, &weight) in self.controls.iter().zip(column) {
                sources[j as usize] += weight * delta;
            }
        }
    }
}

/// A bound algorithm: the terms of every head vertex.
#[derive(Debug, Clone)]
pub struct Binding {
    pub spec: AlgoSpec,
    pub linear: Csr<LinearTerm>,
    pub triangle_terms: Csr<TriangleTerm>,
    /// Bone terms of inside and edge regions (affine in the moved bone's basis).
    pub bones: Csr<BoneTerm>,
    /// Bone terms of corner regions, which also rescale their in-plane offset: kept apart
    /// so that only they pay the square root.
    pub corners: Csr<BoneTerm>,
    /// What the linear terms blend, when not the control displacements themselves.
    pub sources: Option<SourceMap>,
}

/// Per-frame buffers, allocated once per binding user.
#[derive(Debug, Clone, Default)]
pub struct DeformScratch {
    deltas: Vec<Vec3A>,
    sources: Vec<Vec3A>,
    bases: Vec<TriangleBasis>,
    bones: BoneBases,
}

impl Binding {
    pub fn new(
        spec: AlgoSpec,
        linear: Csr<LinearTerm>,
        triangle_terms: Csr<TriangleTerm>,
        bones: Csr<BoneTerm>,
    ) -> Binding {
        debug_assert!(linear.rows() == triangle_terms.rows() && triangle_terms.rows() == bones.rows());
        let split = |corner: bool| {
            Csr::from_rows(
                (0..bones.rows())
                    .map(|v| {
                        bones
                            .row(v)
                            .iter()
                            .filter(|t| matches!(t.region, Region::Corner(_)) == corner)
                            .copied()
                            .collect()
                    })
                    .collect(),
            )
        };
        Binding {
            spec,
            linear,
            triangle_terms,
            bones: split(false),
            corners: split(true),
            sources: None,
        }
    }

    /// A binding of linear terms only.
    pub fn linear(spec: AlgoSpec, rows: Vec<Vec<LinearTerm>>) -> Binding {
        let n = rows.len();
        Binding {
            spec,
            linear: Csr::from_rows(rows),
            triangle_terms: Csr::empty(n),
            bones: Csr::empty(n),
            corners: Csr::empty(n),
            sources: None,
        }
    }

    /// The same binding, its linear terms blending `sources` instead of the displacements.
    pub fn with_sources(self, sources: SourceMap) -> Binding {
        Binding {
            sources: Some(sources),
            ..self
        }
    }

    pub fn vertex_count(&self) -> usize {
        self.linear.rows()
    }

    /// Buffers sized for a mask of `mask_vertices` vertices and `mask_triangles` triangles.
    pub fn scratch(&self, mask_vertices: usize, mask_triangles: usize) -> DeformScratch {
        DeformScratch {
            deltas: vec![Vec3A::ZERO; mask_vertices],
            sources: vec![Vec3A::ZERO; mask_vertices],
            bases: vec![TriangleBasis::default(); mask_triangles],
            bones: BoneBases::with_capacity(mask_triangles),
        }
    }

    /// Deforms the head: `rest` its rest positions, `mask_rest` and `mask_now` the fitted
    /// mask at rest and in this frame (head units), `triangles` the mask's triangles.
    /// Writes every vertex of `out`. Allocates nothing.
    pub fn deform(
        &self,
        rest: &[Vec3],
        mask_rest: &[Vec3],
        mask_now: &[Vec3],
        triangles: &[[u32; 3]],
        scratch: &mut DeformScratch,
        out: &mut [Vec3],
    ) {
        debug_assert_eq!(rest.len(), self.vertex_count());
        debug_assert_eq!(out.len(), rest.len());
        for ((d, now), was) in scratch.deltas.iter_mut().zip(mask_now).zip(mask_rest) {
            *d = Vec3A::from(*now) - Vec3A::from(*was);
        }
        let blended = match &self.sources {
            Some(map) => {
                map.apply(&scratch.deltas, &mut scratch.sources);
                &scratch.sources
            }
            None => &scratch.deltas,
        };
        let has_triangle_terms = !self.triangle_terms.is_empty();
        if has_triangle_terms {
            for (basis, t) in scratch.bases.iter_mut().zip(triangles) {
                *basis = TriangleBasis::of(
                    mask_now[t[0] as usize],
                    mask_now[t[1] as usize],
                    mask_now[t[2] as usize],
                );
            }
        }
        let has_bones = !self.bones.is_empty() || !self.corners.is_empty();
        if has_bones {
            scratch.bones.update(mask_now, triangles);
        }
        for (v, (o, p)) in out.iter_mut().zip(rest).enumerate() {
            let p = Vec3A::from(*p);
            let mut moved = p;
            for term in self.linear.row(v) {
                moved += term.weight * blended[term.control as usize];
            }
            if has_triangle_terms {
                for term in self.triangle_terms.row(v) {
                    moved += term.weight * (scratch.bases[term.triangle as usize].point(term.coords) - p);
                }
            }
            if has_bones {
                for term in self.bones.row(v) {
                    moved += term.weight * (scratch.bones.affine_point(term) - p);
                }
                for term in self.corners.row(v) {
                    moved += term.weight * (scratch.bones.point(term) - p);
                }
            }
            *o = Vec3::from(moved);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sources_are_the_map_applied_to_the_displacements() {
        // Two controls (mask vertices 2 and 0) with weights [[2/3, 1/3], [1/3, 2/3]] at each
        // other's anchors: the inverse is [[2, -1], [-1, 2]], so moving only vertex 2 by x
        // gives sources 2x (vertex 2) and -x (vertex 0); vertex 1 is not a control.
        let map = SourceMap::new(vec![2, 0], |row, column| if row == column { 2.0 } else { -1.0 });
        let deltas = [Vec3A::ZERO, Vec3A::splat(9.0), Vec3A::X];
        let mut sources = [Vec3A::ONE; 3];
        map.apply(&deltas, &mut sources);
        assert_eq!(sources, [-Vec3A::X, Vec3A::ONE, 2.0 * Vec3A::X]);
        // A vertex halfway (weights 1/2, 1/2) then moves by x / 2, and an anchor exactly:
        // 2/3 * 2x + 1/3 * -x = x.
        assert_eq!(0.5 * sources[2] + 0.5 * sources[0], 0.5 * Vec3A::X);
        assert!((2.0 / 3.0 * sources[2] + 1.0 / 3.0 * sources[0] - Vec3A::X).length() < 1e-6);
        // Rows and columns kept apart: [[1, 2], [3, 4]] over controls (2, 0).
        let map = SourceMap::new(vec![2, 0], |row, column| (2 * row + column + 1) as f32);
        let deltas = [Vec3A::Y, Vec3A::ZERO, Vec3A::X];
        map.apply(&deltas, &mut sources);
        assert_eq!(sources[2], Vec3A::X + 2.0 * Vec3A::Y);
        assert_eq!(sources[0], 3.0 * Vec3A::X + 4.0 * Vec3A::Y);
    }
}
