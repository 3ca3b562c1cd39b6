//! How well a fit lays the mask on a head, in millimetres: distance from each fitted mask
//! vertex to the head surface, and from each landmark's mask vertex to its head vertex.

use glam::Vec3;
use serde::Serialize;

use crate::head::Head;

/// Mean and max of a set of distances (mm), and where the max is.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DistanceStats {
    pub mean_mm: f32,
    pub max_mm: f32,
    /// The mask vertex with the largest distance.
    pub worst_mask_vertex: u32,
    pub count: usize,
}

impl DistanceStats {
    /// The stats of (mask vertex, distance mm) pairs.
    pub fn of(distances: impl Iterator<Item = (u32, f32)>) -> DistanceStats {
        let (mut sum, mut count, mut max, mut worst) = (0.0f64, 0usize, 0.0f32, 0u32);
        for (v, d) in distances {
            sum += f64::from(d);
            count += 1;
            if d >= max {
                max = d;
                worst = v;
            }
        }
        DistanceStats {
            mean_mm: if count > 0 {
                (sum / count as f64) as f32
            } else {
                0.0
            },
            max_mm: max,
            worst_mask_vertex: worst,
            count,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Residuals {
    /// Fitted mask vertices (those used by a triangle) to the head surface.
    pub surface: DistanceStats,
    /// Landmark mask vertices to their head vertices.
    pub landmarks: DistanceStats,
}

/// Measures `fitted` (the posed neutral mask, head units) against `head`.
/// `used[j]` says whether mask vertex j belongs to a triangle; `landmarks` pairs mask
/// vertices with head vertices.
pub fn measure(
    head: &Head,
    fitted: &[Vec3],
    used: &[bool],
    landmarks: &[(u32, u32)],
    mm_per_unit: f32,
) -> Residuals {
    let surface = DistanceStats::of(
        fitted
            .iter()
            .enumerate()
            .filter(|(j, _)| used[*j])
            .map(|(j, &p)| {
                let d = head
                    .surface
                    .closest_point(p)
                    .map_or(f32::INFINITY, |s| s.distance);
                (j as u32, d * mm_per_unit)
            }),
    );
    let landmarks = DistanceStats::of(landmarks.iter().map(|&(m, h)| {
        (
            m,
            fitted[m as usize].distance(head.positions[h as usize]) * mm_per_unit,
        )
    }));
    Residuals { surface, landmarks }
}
