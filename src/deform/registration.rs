//! Everything binding needs about one head and its fit, computed once: the anchors, the
//! surface distance (mm) from every control anchor to every head vertex, and each head
//! vertex's projection onto the fitted mask.
//!
//! The distance table is dense (controls x head vertices, f32): 104 x 8,838 is 3.7 MB,
//! 104 x 100k is 42 MB. Its rows are computed in parallel, one Dijkstra per control.

use glam::Vec3;
use rayon::prelude::*;

use super::projection::{project, Projection};
use crate::fit::{anchor_mask, Anchors, FittedMask};
use crate::head::{Head, SurfaceDistance};

/// A head with a fitted mask, ready to bind any algorithm to.
#[derive(Debug, Clone)]
pub struct Registration {
    pub head: Head,
    pub fitted: FittedMask,
    pub anchors: Anchors,
    /// Mask vertices used by a triangle: the control points.
    pub controls: Vec<u32>,
    pub is_control: Vec<bool>,
    /// `distance[j * n + v]`: surface distance in mm from the anchor of mask vertex `j` to
    /// head vertex `v`; infinite for non-controls and unreachable vertices.
    distance: Vec<f32>,
    /// One per head vertex.
    pub projections: Vec<Projection>,
    /// Longest edge of each mask triangle on the fitted neutral mask, mm.
    pub longest_edge_mm: Vec<f32>,
}

impl Registration {
    pub fn new(head: Head, fitted: FittedMask) -> Registration {
        let mm = fitted.fit.mm_per_unit;
        let anchors = anchor_mask(&head, &fitted.neutral, mm);
        let is_control = fitted.mask.used_vertices();
        let controls: Vec<u32> = (0..is_control.len() as u32)
            .filter(|&j| is_control[j as usize])
            .collect();
        let n = head.positions.len();
        let m = fitted.mask.vertices.len();

        let mut distance = vec![f32::INFINITY; m * n];
        distance
            .par_chunks_mut(n)
            .enumerate()
            .filter(|(j, _)| is_control[*j])
            .for_each_init(
                || SurfaceDistance::new(n),
                |search, (j, row)| {
                    search.run(&head.topology, &[(anchors.vertex[j], 0.0)], f32::INFINITY);
                    for &v in search.reached() {
                        row[v as usize] = search.distance(v) * mm;
                    }
                },
            );

        let longest_edge_mm = fitted
            .mask
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| fitted.neutral[v as usize]);
                a.distance(b).max(b.distance(c)).max(c.distance(a)) * mm
            })
            .collect();

        let mut registration = Registration {
            head,
            fitted,
            anchors,
            controls,
            is_control,
            distance,
            projections: Vec::new(),
            longest_edge_mm,
        };
        registration.projections = (0..n as u32)
            .into_par_iter()
            .map(|v| project(&registration, v))
            .collect();
        registration
    }

    pub fn vertex_count(&self) -> usize {
        self.head.positions.len()
    }

    /// Millimetres per head unit.
    pub fn mm_per_unit(&self) -> f32 {
        self.fitted.fit.mm_per_unit
    }

    /// Surface distance (mm) from the anchor of mask vertex `j` to head vertex `v`.
    pub fn distance_to_control(&self, j: u32, v: u32) -> f32 {
        self.distance[j as usize * self.vertex_count() + v as usize]
    }

    /// Surface distance (mm) from head vertex `v` to mask triangle `t`: the distance to
    /// its nearest corner's anchor (the thesis's rule), and that corner.
    pub fn distance_to_triangle(&self, t: usize, v: u32) -> (f32, u32) {
        self.fitted.mask.triangles[t]
            .iter()
            .map(|&j| (self.distance_to_control(j, v), j))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .expect("triangles have three corners")
    }

    /// The fitted neutral mask (head units).
    pub fn mask_rest(&self) -> &[Vec3] {
        &self.fitted.neutral
    }

    pub fn mask_triangles(&self) -> &[[u32; 3]] {
        &self.fitted.mask.triangles
    }
}
