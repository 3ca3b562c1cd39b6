//! `biharmonic` (not in the thesis; preset V and the default, docs/ALGORITHMS.md,
//! "Biharmonic"): the displacement field `d` of least bi-Laplacian energy `d^T L M^-1 L d`
//! over the head at rest ([`CotanLaplacian`]) that equals each
//! control's displacement at its anchor and zero on the held region: the vertices beyond
//! the reach of their nearest anchor along the surface, and those no anchor reaches. An
//! eye control's anchor reaches `eyes_hold_mm`, every other one `hold_mm` (the part of
//! the face is the control's [`FaceRegion`]).
//!
//! The field is linear in the control displacements, so binding solves once for one weight
//! field per anchor, `W = -Q_ff^-1 Q_fc` with `Q = L M^-1 L` over the free vertices f and
//! the anchors c, by sparse Cholesky. Each free vertex keeps its `k` largest weights (by
//! magnitude), corrected to the sum of all of them (the dropped sum shared in proportion
//! to magnitude), so that moving every control alike still moves the vertex as the full
//! field would; deforming is then the same sparse gather as the other linear variants. Controls sharing an anchor share its constraint: the mean of
//! their displacements.
//!
//! With nothing held the method overshoots where the surface folds (the upper eyelid);
//! holding the far head still fixes that and keeps every weight field local. The eyelids
//! want a short reach and the mouth and jaw a long one; the nearest anchor decides, so
//! that the mouth's long reach does not free the eyelids again.

use faer::prelude::Solve;
use faer::sparse::{SparseColMat, Triplet};
use faer::{Mat, Side};
use rayon::prelude::*;

use super::anchor_system::{centres, Centre};
use super::binding::{Binding, LinearTerm};
use super::lip_seam::without_seam;
use super::lip_smoothing::smooth_over_lips;
use super::needles::bind_needles;
use super::row_merge::keep_largest;
use super::spec::AlgoSpec;
use super::Registration;
use crate::head::CotanLaplacian;
use crate::mask::FaceRegion;

/// How far along the surface the anchors reach, mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reach {
    /// The eye controls' anchors' reach.
    pub eyes_mm: f32,
    /// Every other anchor's.
    pub other_mm: f32,
}

impl Reach {
    /// The reach of control `j`'s anchor, mm.
    fn of(&self, reg: &Registration, j: u32) -> f32 {
        match FaceRegion::of(reg.fitted.mask.vertices[j as usize]) {
            FaceRegion::Eyes => self.eyes_mm,
            _ => self.other_mm,
        }
    }
}

/// Added to `Q_ff`'s diagonal, relative to its largest entry: keeps the factorization
/// positive definite where rounding alone would not, far below any effect on the weights.
const RIDGE: f64 = 1e-12;

/// What the minimization does with a head vertex.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Role {
    /// Solved for; its index among the free vertices.
    Free(u32),
    /// The anchor of one or more controls; its index among the anchors.
    Anchor(u32),
    /// Held still.
    Held,
}

/// Binds the field, smooths it over the lips within `smooth_lips` of the mouth's width
/// ([`smooth_over_lips`]) and binds the needle triangles' thin vertices to their long
/// edges ([`bind_needles`]); `smooth_lips` 0 keeps the exact field, needles and all.
pub fn bind(reg: &Registration, spec: AlgoSpec, reach: Reach, k: u32, smooth_lips: f32) -> Binding {
    let centres = centres(reg);
    let roles = roles(reg, &centres, reach);
    let free_count = roles.iter().filter(|r| matches!(r, Role::Free(_))).count();
    // A head whose operator cannot be factored (never seen on a checked head) is held still
    // rather than moved wrongly; its anchors still move exactly.
    let fields = weight_fields(reg, &roles, free_count, centres.len());
    let rows: Vec<Vec<LinearTerm>> = roles
        .par_iter()
        .map(|role| match *role {
            Role::Held => Vec::new(),
            Role::Anchor(c) => spread(&centres[c as usize], 1.0),
            Role::Free(f) => match &fields {
                Some(fields) => strongest(fields, f as usize, &centres, k as usize),
                None => Vec::new(),
            },
        })
        .collect();
    if smooth_lips == 0.0 {
        return Binding::linear(spec, rows);
    }
    // The needles are bound on the smoothed field only: on the exact one they folded the
    // ICT head's lips (86 triangle-frames of the syllable stream, against none).
    let rows = smooth_over_lips(reg, rows, smooth_lips, k as usize);
    let rows = bind_needles(
        &reg.head.positions,
        &reg.head.triangles,
        |v| matches!(roles[v as usize], Role::Anchor(_)),
        k as usize,
        rows,
    );
    Binding::linear(spec, rows)
}

/// Every vertex's role: anchors first, then the vertices within reach of their nearest
/// anchor (along the surface) are free, numbered in vertex order; the rest are held.
fn roles(reg: &Registration, centres: &[Centre], reach: Reach) -> Vec<Role> {
    let reach_mm: Vec<f32> = reg.controls.iter().map(|&j| reach.of(reg, j)).collect();
    let mut roles = vec![Role::Held; reg.vertex_count()];
    for (c, centre) in centres.iter().enumerate() {
        roles[centre.vertex as usize] = Role::Anchor(c as u32);
    }
    let mut free = 0;
    for (v, role) in roles.iter_mut().enumerate() {
        let near = reg
            .controls
            .iter()
            .zip(&reach_mm)
            .map(|(&j, &reach)| (reg.distance_to_control(j, v as u32), reach))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .is_some_and(|(distance, reach)| distance <= reach);
        if *role == Role::Held && near {
            *role = Role::Free(free);
            free += 1;
        }
    }
    roles
}

/// `W = -Q_ff^-1 Q_fc`: column c is anchor c's weight field over the free vertices. `None`
/// when the factorization fails.
fn weight_fields(
    reg: &Registration,
    roles: &[Role],
    free_count: usize,
    anchor_count: usize,
) -> Option<Mat<f64>> {
    let mut fields = Mat::<f64>::zeros(free_count, anchor_count);
    if free_count == 0 {
        return Some(fields);
    }
    let triangles = without_seam(reg);
    let laplacian = CotanLaplacian::new(&reg.head.positions, &triangles);
    // Q = L M^-1 L, summed over the middle vertex m: Q_ij += L_im L_mj / M_m for i and j in
    // m's closed ring. Only Q_ff's lower triangle is kept; Q_fc goes to the right-hand side.
    let mut lower: Vec<Triplet<usize, usize, f64>> = Vec::new();
    let mut diagonal = vec![0.0f64; free_count];
    let mut ring: Vec<(u32, f64)> = Vec::new();
    for m in 0..laplacian.vertex_count() {
        let mass = laplacian.mass[m];
        if mass <= 0.0 {
            continue;
        }
        ring.clear();
        ring.push((m as u32, laplacian.diagonal[m]));
        ring.extend_from_slice(&laplacian.neighbors[m]);
        for &(i, l_im) in &ring {
            let Role::Free(fi) = roles[i as usize] else {
                continue;
            };
            let fi = fi as usize;
            for &(j, l_mj) in &ring {
                let q = l_im * l_mj / mass;
                match roles[j as usize] {
                    Role::Free(fj) if fj as usize == fi => diagonal[fi] += q,
                    Role::Free(fj) if (fj as usize) < fi => lower.push(Triplet::new(fi, fj as usize, q)),
                    Role::Anchor(c) => fields.col_as_slice_mut(c as usize)[fi] -= q,
                    Role::Free(_) | Role::Held => {}
                }
            }
        }
    }
    let ridge = RIDGE * diagonal.iter().fold(0.0f64, |a, &d| a.max(d));
    lower.extend(
        diagonal
            .iter()
            .enumerate()
            .map(|(f, &d)| Triplet::new(f, f, d + ridge)),
    );
    let q_ff = SparseColMat::<usize, f64>::try_new_from_triplets(free_count, free_count, &lower).ok()?;
    let factor = q_ff.sp_cholesky(Side::Lower).ok()?;
    factor.solve_in_place(fields.as_mut());
    let finite = (0..anchor_count).all(|c| fields.col_as_slice(c).iter().all(|w| w.is_finite()));
    finite.then_some(fields)
}

/// Free vertex `f`'s `k` largest anchor weights, corrected to the sum of all its weights,
/// spread over each anchor's controls.
fn strongest(fields: &Mat<f64>, f: usize, centres: &[Centre], k: usize) -> Vec<LinearTerm> {
    let mut weights: Vec<(usize, f64)> = (0..centres.len())
        .map(|c| (c, fields.col_as_slice(c)[f]))
        .filter(|&(_, w)| w != 0.0)
        .collect();
    keep_largest(&mut weights, k);
    weights.sort_by_key(|&(c, _)| c);
    weights
        .iter()
        .flat_map(|&(c, w)| spread(&centres[c], w))
        .collect()
}

/// An anchor's weight shared by its controls, which it moves by their mean displacement.
fn spread(centre: &Centre, weight: f64) -> Vec<LinearTerm> {
    let share = (weight / centre.members.len() as f64) as f32;
    centre
        .members
        .iter()
        .map(|&j| LinearTerm {
            control: j as u16,
            weight: share,
        })
        .collect()
}
