//! Solving a fit from landmark correspondences: alternate between the similarity pose
//! (Umeyama, shape fixed) and the shape units (bounded linear least squares, pose fixed)
//! until the residual stops falling. Each step cannot raise the residual, so the
//! alternation settles; it is exact when the landmarks were made by a fit.

use glam::{DVec3, Vec3};

use super::umeyama::{umeyama, Similarity};
use crate::mask::{Mask, MaskPose};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveOptions {
    /// Shape-unit weights are kept in `[-bound, bound]`.
    pub shape_bound: f64,
    /// Ridge weight on the shape units (mask units squared per landmark, whatever the
    /// head's unit); keeps units that no landmark constrains at zero.
    pub regularization: f64,
    /// Solve shape units at all (false: similarity only).
    pub solve_shape: bool,
    pub max_iterations: usize,
    /// Stop when the RMS residual (target units) falls by less than this fraction.
    pub tolerance: f64,
}

impl Default for SolveOptions {
    fn default() -> Self {
        SolveOptions {
            shape_bound: 1.5,
            regularization: 1e-6,
            solve_shape: true,
            max_iterations: 500,
            tolerance: 1e-12,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct FitSolution {
    pub pose: MaskPose,
    pub shape: Vec<f32>,
    /// RMS distance between fitted landmark vertices and their targets, target units.
    pub rms: f64,
    pub iterations: usize,
    /// The same computed in f64, for callers that need more than f32 precision.
    pub similarity: Similarity,
    pub shape_f64: Vec<f64>,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SolveError {
    #[error("{0} landmark(s); at least 3 non-collinear ones are needed")]
    TooFew(usize),
    #[error("the landmarks are degenerate (collinear or coincident); no similarity fits them")]
    Degenerate,
}

/// Fits the mask to `pairs` of (mask vertex, target point in head units). `nudges` are
/// added to the mask (mask units) before fitting, as they will be when the fit is used.
pub fn solve_fit(
    mask: &Mask,
    pairs: &[(u32, DVec3)],
    nudges: &[(u32, Vec3)],
    options: &SolveOptions,
) -> Result<FitSolution, SolveError> {
    if pairs.len() < 3 {
        return Err(SolveError::TooFew(pairs.len()));
    }
    let mut neutral: Vec<DVec3> = mask.vertices.iter().map(|v| v.as_dvec3()).collect();
    for &(v, offset) in nudges {
        neutral[v as usize] += offset.as_dvec3();
    }
    let shape_columns = shape_columns(mask, pairs);
    let targets: Vec<DVec3> = pairs.iter().map(|p| p.1).collect();
    let mut shape = vec![0.0f64; mask.shape_units.len()];
    let mut previous_rms = f64::INFINITY;
    let mut similarity;
    let mut iterations = 0;
    // Alternation gets close quickly but crawls where pose and shape trade off (scale
    // against head height, say); a joint Gauss-Newton finishes the job.
    loop {
        iterations += 1;
        let sources = shaped_points(&neutral, pairs, &shape_columns, &shape);
        similarity = umeyama(&sources, &targets).ok_or(SolveError::Degenerate)?;
        if options.solve_shape {
            solve_shape(&neutral, pairs, &shape_columns, &similarity, options, &mut shape);
        }
        let sources = shaped_points(&neutral, pairs, &shape_columns, &shape);
        let rms = rms_residual(&sources, &targets, &similarity);
        let settled = previous_rms - rms <= options.tolerance * previous_rms.max(f64::MIN_POSITIVE);
        previous_rms = rms;
        if !options.solve_shape || settled || iterations >= ALTERNATIONS {
            break;
        }
    }
    if options.solve_shape {
        for _ in 0..options.max_iterations {
            iterations += 1;
            let (next_similarity, next_shape) =
                gauss_newton_step(&neutral, pairs, &shape_columns, &similarity, &shape, options);
            let sources = shaped_points(&neutral, pairs, &shape_columns, &next_shape);
            let rms = rms_residual(&sources, &targets, &next_similarity);
            if rms >= previous_rms {
                break;
            }
            let settled = previous_rms - rms <= options.tolerance * previous_rms.max(f64::MIN_POSITIVE);
            similarity = next_similarity;
            shape = next_shape;
            previous_rms = rms;
            if settled {
                break;
            }
        }
    }
    let rotation = similarity.rotation.as_mat3();
    Ok(FitSolution {
        pose: MaskPose::similarity(
            MaskPose::angles_of(rotation),
            similarity.scale as f32,
            similarity.translation.as_vec3(),
        ),
        shape: shape.iter().map(|&s| s as f32).collect(),
        rms: previous_rms,
        iterations,
        similarity,
        shape_f64: shape,
    })
}

/// Alternating rounds before the joint refinement takes over.
const ALTERNATIONS: usize = 30;

/// One Gauss-Newton step on all parameters at once: rotation (a small left-multiplied
/// rotation vector), scale, translation and shape units, with the ridge term as extra
/// residuals; shape units are clamped to their bounds afterwards.
fn gauss_newton_step(
    neutral: &[DVec3],
    pairs: &[(u32, DVec3)],
    columns: &[Vec<DVec3>],
    similarity: &Similarity,
    shape: &[f64],
    options: &SolveOptions,
) -> (Similarity, Vec<f64>) {
    let k = shape.len();
    let n = 7 + k;
    let mut jtj = nalgebra::DMatrix::<f64>::zeros(n, n);
    let mut jtr = nalgebra::DVector::<f64>::zeros(n);
    let sources = shaped_points(neutral, pairs, columns, shape);
    let mut row = vec![0.0f64; n];
    for ((&(_, target), source), col) in pairs.iter().zip(&sources).zip(columns) {
        let rotated = similarity.rotation * *source;
        let residual = similarity.apply(*source) - target;
        let scaled = similarity.scale * rotated;
        for axis in 0..3 {
            let e = DVec3::AXES[axis];
            row.iter_mut().for_each(|x| *x = 0.0);
            // d/d omega of (exp([omega]x) s R m) = -[s R m]x, row `axis`: e . (omega x sRm)
            let d_omega = scaled.cross(e); // e . (w x v) = w . (v x e)
            row[0] = d_omega.x;
            row[1] = d_omega.y;
            row[2] = d_omega.z;
            row[3] = rotated[axis];
            row[4 + axis] = 1.0;
            for (u, d) in col.iter().enumerate() {
                row[7 + u] = similarity.scale * (similarity.rotation * *d)[axis];
            }
            let r = residual[axis];
            for a in 0..n {
                jtr[a] += row[a] * r;
                for b in 0..n {
                    jtj[(a, b)] += row[a] * row[b];
                }
            }
        }
    }
    // The residuals are in head units, `scale` times the mask's: the ridge, given in mask
    // units as in `solve_shape`, is weighed by `scale^2` so that the fit does not depend on
    // the unit the head is written in.
    let ridge = options.regularization * similarity.scale * similarity.scale;
    for (u, &s) in shape.iter().enumerate() {
        jtj[(7 + u, 7 + u)] += ridge;
        jtr[7 + u] += ridge * s;
    }
    // A whisper of damping keeps unconstrained directions finite.
    for a in 0..n {
        jtj[(a, a)] += 1e-12 * (1.0 + jtj[(a, a)]);
    }
    let Some(step) = jtj.cholesky().map(|c| c.solve(&-jtr)) else {
        return (*similarity, shape.to_vec());
    };
    let omega = DVec3::new(step[0], step[1], step[2]);
    let turn = if omega.length() > 0.0 {
        glam::DMat3::from_axis_angle(omega.normalize(), omega.length())
    } else {
        glam::DMat3::IDENTITY
    };
    let next = Similarity {
        rotation: orthonormalize(turn * similarity.rotation),
        scale: similarity.scale + step[3],
        translation: similarity.translation + DVec3::new(step[4], step[5], step[6]),
    };
    let next_shape = shape
        .iter()
        .enumerate()
        .map(|(u, s)| (s + step[7 + u]).clamp(-options.shape_bound, options.shape_bound))
        .collect();
    (next, next_shape)
}

/// Nearest rotation (Gram-Schmidt on the columns) to undo rounding drift.
fn orthonormalize(m: glam::DMat3) -> glam::DMat3 {
    let x = m.x_axis.normalize();
    let y = (m.y_axis - x * x.dot(m.y_axis)).normalize();
    glam::DMat3::from_cols(x, y, x.cross(y))
}

/// For each landmark, the displacement of each shape unit at its mask vertex.
fn shape_columns(mask: &Mask, pairs: &[(u32, DVec3)]) -> Vec<Vec<DVec3>> {
    pairs
        .iter()
        .map(|&(v, _)| {
            mask.shape_units
                .iter()
                .map(|u| {
                    u.displacements
                        .iter()
                        .find(|(w, _)| *w == v)
                        .map_or(DVec3::ZERO, |(_, d)| d.as_dvec3())
                })
                .collect()
        })
        .collect()
}

fn shaped_points(
    neutral: &[DVec3],
    pairs: &[(u32, DVec3)],
    columns: &[Vec<DVec3>],
    shape: &[f64],
) -> Vec<DVec3> {
    pairs
        .iter()
        .zip(columns)
        .map(|(&(v, _), col)| {
            neutral[v as usize] + col.iter().zip(shape).map(|(d, s)| *d * *s).sum::<DVec3>()
        })
        .collect()
}

fn rms_residual(sources: &[DVec3], targets: &[DVec3], similarity: &Similarity) -> f64 {
    let sum: f64 = sources
        .iter()
        .zip(targets)
        .map(|(s, t)| similarity.apply(*s).distance_squared(*t))
        .sum();
    (sum / sources.len() as f64).sqrt()
}

/// Bounded ridge least squares for the shape units with the pose fixed, in the mask
/// frame: `min sum |g0_i + SU_i s - q_i|^2 + lambda |s|^2`, `|s_k| <= bound`, by projected
/// Gauss-Seidel on the normal equations (convex, so it converges to the optimum).
fn solve_shape(
    neutral: &[DVec3],
    pairs: &[(u32, DVec3)],
    columns: &[Vec<DVec3>],
    similarity: &Similarity,
    options: &SolveOptions,
    shape: &mut [f64],
) {
    let k = shape.len();
    let mut normal = vec![0.0f64; k * k];
    let mut rhs = vec![0.0f64; k];
    for (&(v, target), col) in pairs.iter().zip(columns) {
        let wanted = similarity.invert_point(target) - neutral[v as usize];
        for a in 0..k {
            rhs[a] += col[a].dot(wanted);
            for b in 0..k {
                normal[a * k + b] += col[a].dot(col[b]);
            }
        }
    }
    for a in 0..k {
        normal[a * k + a] += options.regularization;
    }
    for _ in 0..10_000 {
        let mut change = 0.0f64;
        for a in 0..k {
            if normal[a * k + a] <= 0.0 {
                shape[a] = 0.0;
                continue;
            }
            let off: f64 = (0..k)
                .filter(|&b| b != a)
                .map(|b| normal[a * k + b] * shape[b])
                .sum();
            let value = ((rhs[a] - off) / normal[a * k + a]).clamp(-options.shape_bound, options.shape_bound);
            change = change.max((value - shape[a]).abs());
            shape[a] = value;
        }
        if change < 1e-15 {
            break;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DMat3, EulerRot};

    #[test]
    fn recovers_a_known_fit_exactly() {
        let mask = Mask::candide3();
        let mut truth_shape = vec![0.0f64; mask.shape_units.len()];
        truth_shape[0] = 0.3; // head height
        truth_shape[5] = -0.2; // eye separation
        truth_shape[10] = 0.15; // mouth vertical position
        truth_shape[11] = 0.4; // mouth width
        let truth = Similarity {
            rotation: DMat3::from_euler(EulerRot::ZYX, 0.05, -0.2, 0.1),
            scale: 0.55,
            translation: DVec3::new(0.1, 7.3, 1.2),
        };
        let used = mask.used_vertices();
        let all: Vec<(u32, DVec3)> = (0..mask.vertices.len() as u32)
            .filter(|&v| used[v as usize])
            .map(|v| (v, DVec3::ZERO))
            .collect();
        let columns = shape_columns(&mask, &all);
        let neutral: Vec<DVec3> = mask.vertices.iter().map(|v| v.as_dvec3()).collect();
        let shaped = shaped_points(&neutral, &all, &columns, &truth_shape);
        let pairs: Vec<(u32, DVec3)> = all
            .iter()
            .zip(shaped)
            .map(|(&(v, _), p)| (v, truth.apply(p)))
            .collect();
        let options = SolveOptions {
            regularization: 0.0,
            ..SolveOptions::default()
        };
        let found = solve_fit(&mask, &pairs, &[], &options).unwrap();
        assert!(found.rms < 1e-9, "rms {}", found.rms);
        assert!((found.similarity.scale - truth.scale).abs() < 1e-6);
        assert!(found.similarity.rotation.abs_diff_eq(truth.rotation, 1e-6));
        assert!(found.similarity.translation.abs_diff_eq(truth.translation, 1e-6));
        for (a, b) in found.shape_f64.iter().zip(&truth_shape) {
            assert!((a - b).abs() < 1e-6, "{:?} vs {truth_shape:?}", found.shape_f64);
        }
    }

    #[test]
    fn too_few_landmarks_is_an_error() {
        let mask = Mask::candide3();
        let err = solve_fit(&mask, &[(5, DVec3::ZERO)], &[], &SolveOptions::default());
        assert_eq!(err, Err(SolveError::TooFew(1)));
    }
}
