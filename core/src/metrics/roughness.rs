//! Dihedral roughness (Wu et al. 2001, the thesis's section 3.2), the smoothness measure
//! the thesis compares its algorithms by.
//!
//! Two triangles sharing an edge have roughness `rho_d = 1 - nA.nB` (unit normals). For a
//! vertex `v`, walking its ordered fans (see [`crate::head::Topology::fans_of`]) gives one
//! `rho_d` per consecutive pair of triangles (closed rings include last -> first; open fans
//! on boundaries do not; fans are already split at non-manifold spokes, so pairs never cross
//! them): `G(v)` is their mean and `V(v)` their population variance (both 0 for a vertex with
//! no pair). A triangle `(v1, v2, v3)` scores `rho(T) = sum G(vi) V(vi) / sum V(vi)`, or the
//! mean of the three `G` when `sum V(vi) < 1e-12`.
//!
//! [`Roughness`] is built once per head and region: it resolves which triangle normals and
//! which fan pairs the region needs, and keeps every buffer, so a frame allocates nothing.
//! It computes in f64 from the f32 positions: `rho_d` of nearly parallel triangles is a small
//! difference, and f32 would leave it with a few digits only.
//!
//! Conventions the thesis leaves open:
//! - `rho_d` is evaluated as `|nA - nB|^2 / 2`, which equals `1 - nA.nB` for unit normals
//!   but has no cancellation (an exactly flat pair gives exactly 0).
//! - Normals are oriented per pair: when the two triangles wind their shared edge the same
//!   way (inconsistent winding), one normal is flipped, so a winding error is not mistaken
//!   for a fold.
//! - A triangle of zero area has no normal: pairs with it are skipped, like a missing pair.
//!   Non-finite positions are not skipped: they give NaN, which shows in every output.

use std::collections::HashMap;

use glam::{DVec3, Vec3};

use crate::head::{Head, Topology};

/// Below this `sum V(vi)`, `rho(T)` is the mean of its corners' `G` (the definition's floor).
pub const VARIANCE_FLOOR: f64 = 1e-12;

/// Marks a pair skipped in a frame (a triangle of zero area); real values are never negative.
const SKIPPED: f64 = -1.0;

/// What a roughness evaluator can refuse.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RoughnessError {
    #[error("region triangle {triangle} is out of range: the head has {count} triangles")]
    TriangleOutOfRange { triangle: u32, count: usize },
    #[error("triangle {triangle} has corner {vertex}, but the head has {count} vertices")]
    CornerOutOfRange {
        triangle: u32,
        vertex: u32,
        count: usize,
    },
    #[error("expected {expected} positions (one per head vertex), found {found}")]
    PositionCount { expected: usize, found: usize },
    #[error("expected an output of {expected} values (one per head vertex), found {found}")]
    OutputLength { expected: usize, found: usize },
}

/// Two triangles that follow each other around a vertex, as slots in the normal buffer.
/// Both ends of their shared spoke walk the pair, so it is stored (and evaluated) once.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct FanPair {
    first: u32,
    second: u32,
    /// The triangles wind their shared edge the same way: one normal must be flipped.
    flip: bool,
}

/// Per-frame roughness of a region of one head, with preallocated buffers.
#[derive(Debug, Clone)]
pub struct Roughness {
    vertex_count: usize,
    /// Corners (head vertices) of every triangle whose normal the region needs.
    normal_corners: Vec<[u32; 3]>,
    normals: Vec<DVec3>,
    /// The region's vertices (head vertices), ascending.
    vertices: Vec<u32>,
    pairs: Vec<FanPair>,
    /// `rho_d` of each pair in the current frame; [`SKIPPED`] when a triangle has no normal.
    pair_roughness: Vec<f64>,
    /// The pairs of `vertices[k]` are `vertex_pairs[pair_offsets[k]..pair_offsets[k + 1]]`.
    pair_offsets: Vec<u32>,
    vertex_pairs: Vec<u32>,
    vertex_mean: Vec<f64>,
    vertex_variance: Vec<f64>,
    /// The region's triangles (head triangles), ascending.
    triangles: Vec<u32>,
    /// Their corners as indexes into `vertices`.
    triangle_corners: Vec<[u32; 3]>,
    triangle_roughness: Vec<f64>,
}

impl Roughness {
    /// An evaluator for the head triangles `region` (any order; repeats are ignored).
    pub fn new(head: &Head, region: &[u32]) -> Result<Roughness, RoughnessError> {
        Roughness::for_mesh(&head.topology, &head.triangles, region)
    }

    /// An evaluator for every triangle of the head.
    pub fn whole_mesh(head: &Head) -> Result<Roughness, RoughnessError> {
        let all: Vec<u32> = (0..head.triangles.len() as u32).collect();
        Roughness::new(head, &all)
    }

    fn for_mesh(topology: &Topology, mesh: &[[u32; 3]], region: &[u32]) -> Result<Roughness, RoughnessError> {
        let vertex_count = topology.vertex_count;
        let mut triangles = region.to_vec();
        triangles.sort_unstable();
        triangles.dedup();
        let corners_of = |t: u32| -> Result<[u32; 3], RoughnessError> {
            let corners = *mesh.get(t as usize).ok_or(RoughnessError::TriangleOutOfRange {
                triangle: t,
                count: mesh.len(),
            })?;
            match corners.iter().find(|&&v| v as usize >= vertex_count) {
                Some(&vertex) => Err(RoughnessError::CornerOutOfRange {
                    triangle: t,
                    vertex,
                    count: vertex_count,
                }),
                None => Ok(corners),
            }
        };
        let region_corners = triangles
            .iter()
            .map(|&t| corners_of(t))
            .collect::<Result<Vec<_>, _>>()?;

        let mut vertices: Vec<u32> = region_corners.iter().flatten().copied().collect();
        vertices.sort_unstable();
        vertices.dedup();
        let mut vertex_slot = vec![u32::MAX; vertex_count];
        for (slot, &v) in vertices.iter().enumerate() {
            vertex_slot[v as usize] = slot as u32;
        }
        let triangle_corners = region_corners
            .iter()
            .map(|corners| corners.map(|v| vertex_slot[v as usize]))
            .collect();

        // Normal slots are handed out in first-use order while the fan pairs are listed.
        let mut normal_slot = vec![u32::MAX; mesh.len()];
        let mut normal_corners = Vec::new();
        let mut slot_of = |t: u32| -> Result<u32, RoughnessError> {
            if normal_slot[t as usize] == u32::MAX {
                normal_slot[t as usize] = normal_corners.len() as u32;
                normal_corners.push(corners_of(t)?);
            }
            Ok(normal_slot[t as usize])
        };
        let mut pair_offsets = Vec::with_capacity(vertices.len() + 1);
        let mut pairs = Vec::new();
        let mut pair_index = HashMap::new();
        let mut vertex_pairs = Vec::new();
        pair_offsets.push(0);
        for &v in &vertices {
            for fan in topology.fans_of(v) {
                let ring = topology.fan(fan);
                let wrap = if fan.closed { ring.first() } else { None };
                for (&a, &b) in ring.iter().zip(ring.iter().skip(1).chain(wrap)) {
                    let (first, second) = (slot_of(a)?, slot_of(b)?);
                    let index = *pair_index
                        .entry((first.min(second), first.max(second)))
                        .or_insert_with(|| {
                            pairs.push(FanPair {
                                first,
                                second,
                                flip: same_winding(mesh[a as usize], mesh[b as usize]),
                            });
                            pairs.len() as u32 - 1
                        });
                    vertex_pairs.push(index);
                }
            }
            pair_offsets.push(vertex_pairs.len() as u32);
        }

        Ok(Roughness {
            vertex_count,
            normals: vec![DVec3::ZERO; normal_corners.len()],
            normal_corners,
            vertex_mean: vec![0.0; vertices.len()],
            vertex_variance: vec![0.0; vertices.len()],
            vertices,
            pair_roughness: vec![0.0; pairs.len()],
            pairs,
            pair_offsets,
            vertex_pairs,
            triangle_roughness: vec![0.0; triangles.len()],
            triangles,
            triangle_corners,
        })
    }

    /// Computes `G`, `V` and `rho` for the region from one frame's head positions (head
    /// units, one per head vertex). Allocates nothing.
    pub fn evaluate(&mut self, positions: &[Vec3]) -> Result<(), RoughnessError> {
        self.update_vertices(positions)?;
        for (rho, corners) in self.triangle_roughness.iter_mut().zip(&self.triangle_corners) {
            let g = corners.map(|k| self.vertex_mean[k as usize]);
            let v = corners.map(|k| self.vertex_variance[k as usize]);
            let variance_sum = v[0] + v[1] + v[2];
            *rho = if variance_sum < VARIANCE_FLOOR {
                (g[0] + g[1] + g[2]) / 3.0
            } else {
                (g[0] * v[0] + g[1] * v[1] + g[2] * v[2]) / variance_sum
            };
        }
        Ok(())
    }

    /// The per-vertex value of a roughness heat-map: `G(v)`, the mean dihedral roughness
    /// around `v`, for the region's vertices, and 0 for every other head vertex. `out`
    /// holds one value per head vertex. Skips the triangle stage of [`Roughness::evaluate`]
    /// (build the evaluator with [`Roughness::whole_mesh`] for the whole face). Allocates
    /// nothing.
    pub fn face_vertex_roughness(
        &mut self,
        positions: &[Vec3],
        out: &mut [f32],
    ) -> Result<(), RoughnessError> {
        if out.len() != self.vertex_count {
            return Err(RoughnessError::OutputLength {
                expected: self.vertex_count,
                found: out.len(),
            });
        }
        self.update_vertices(positions)?;
        out.fill(0.0);
        for (&v, &g) in self.vertices.iter().zip(&self.vertex_mean) {
            out[v as usize] = g as f32;
        }
        Ok(())
    }

    /// Normals, then `G` and `V` of every region vertex.
    fn update_vertices(&mut self, positions: &[Vec3]) -> Result<(), RoughnessError> {
        if positions.len() != self.vertex_count {
            return Err(RoughnessError::PositionCount {
                expected: self.vertex_count,
                found: positions.len(),
            });
        }
        for (normal, corners) in self.normals.iter_mut().zip(&self.normal_corners) {
            *normal = unit_normal(corners.map(|v| positions[v as usize]));
        }
        for (rho, pair) in self.pair_roughness.iter_mut().zip(&self.pairs) {
            let a = self.normals[pair.first as usize];
            let b = self.normals[pair.second as usize];
            *rho = if a == DVec3::ZERO || b == DVec3::ZERO {
                SKIPPED
            } else {
                let gap = if pair.flip { a + b } else { a - b };
                0.5 * gap.length_squared()
            };
        }
        for (k, range) in self.pair_offsets.windows(2).enumerate() {
            // Sums, not Welford: no division in the loop. In f64 the cancellation in
            // `E[x^2] - E[x]^2` is far below the 1e-12 variance floor.
            let (mut count, mut sum, mut squares) = (0u32, 0.0f64, 0.0f64);
            for &pair in &self.vertex_pairs[range[0] as usize..range[1] as usize] {
                let rho = self.pair_roughness[pair as usize];
                // `rho < 0` only for SKIPPED; NaN is counted and shows.
                if rho < 0.0 {
                    continue;
                }
                count += 1;
                sum += rho;
                squares += rho * rho;
            }
            let (mean, variance) = if count > 0 {
                let mean = sum / f64::from(count);
                (mean, (squares / f64::from(count) - mean * mean).max(0.0))
            } else {
                (0.0, 0.0)
            };
            self.vertex_mean[k] = mean;
            self.vertex_variance[k] = variance;
        }
        Ok(())
    }

    /// The region's triangles (head triangle indexes), ascending.
    pub fn region_triangles(&self) -> &[u32] {
        &self.triangles
    }

    /// `rho(T)` of each region triangle after the last [`Roughness::evaluate`], in the order
    /// of [`Roughness::region_triangles`].
    pub fn triangle_roughness(&self) -> &[f64] {
        &self.triangle_roughness
    }

    /// The corners of the region's triangles (head vertex indexes), ascending.
    pub fn region_vertices(&self) -> &[u32] {
        &self.vertices
    }

    /// `G(v)` of each region vertex after the last evaluation, in the order of
    /// [`Roughness::region_vertices`].
    pub fn vertex_mean(&self) -> &[f64] {
        &self.vertex_mean
    }

    /// `V(v)` of each region vertex after the last evaluation, in the order of
    /// [`Roughness::region_vertices`].
    pub fn vertex_variance(&self) -> &[f64] {
        &self.vertex_variance
    }

    /// How many triangle normals a frame computes (the region's triangles and their
    /// corners' fans).
    pub fn normal_count(&self) -> usize {
        self.normal_corners.len()
    }
}

/// Unit normal in f64, or zero for a triangle of zero area.
fn unit_normal([a, b, c]: [Vec3; 3]) -> DVec3 {
    let a = a.as_dvec3();
    let n = (b.as_dvec3() - a).cross(c.as_dvec3() - a);
    let length = n.length();
    if length == 0.0 {
        DVec3::ZERO
    } else {
        n * length.recip()
    }
}

/// Whether two triangles that share an edge run along it in the same direction (so their
/// windings, and normals, disagree).
fn same_winding(a: [u32; 3], b: [u32; 3]) -> bool {
    let directed = |t: [u32; 3]| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])];
    directed(a).iter().any(|edge| directed(b).contains(edge))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn head(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Head {
        Head::new("test", positions, triangles)
    }

    fn evaluated(head: &Head) -> Roughness {
        let mut r = Roughness::whole_mesh(head).unwrap();
        r.evaluate(&head.positions).unwrap();
        r
    }

    /// Apex 0 at the origin, spokes to E N W S (1..=4) at unit distance; only E is raised
    /// (z = 1). Hand computation: the fan's normals are (-1,0,1)/sqrt2 for the two triangles
    /// touching E and (0,0,1) for the other two, so going round the apex the pairs give
    /// 1 - 1/sqrt2, 0, 1 - 1/sqrt2, 0.
    fn tent(raised: f32) -> Head {
        let p = vec![
            Vec3::ZERO,
            Vec3::new(1.0, 0.0, raised),
            Vec3::Y,
            Vec3::NEG_X,
            Vec3::NEG_Y,
        ];
        head(p, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]])
    }

    #[test]
    fn hand_computed_tent() {
        let h = tent(1.0);
        let r = evaluated(&h);
        let fold = 1.0 - 0.5f64.sqrt();
        // vertices ascending: apex, E, N, W, S
        let g_apex = fold / 2.0;
        let expected_g = [g_apex, 0.0, fold, 0.0, fold];
        let expected_v = [g_apex * g_apex, 0.0, 0.0, 0.0, 0.0];
        for k in 0..5 {
            assert!(
                (r.vertex_mean()[k] - expected_g[k]).abs() < 1e-12,
                "G {k}: {}",
                r.vertex_mean()[k]
            );
            assert!((r.vertex_variance()[k] - expected_v[k]).abs() < 1e-12, "V {k}");
        }
        // only the apex has variance, so every triangle takes the apex's G
        for &rho in r.triangle_roughness() {
            assert!((rho - g_apex).abs() < 1e-12, "{rho}");
        }
    }

    #[test]
    fn hinge_uses_the_mean_of_g_when_no_corner_varies() {
        // two triangles folded 90 degrees along edge 0-1: each hinge vertex has one pair
        // (rho_d = 1 - 0 = 1, variance 0); the wing tips have no pair.
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        let h = head(p, vec![[0, 1, 2], [1, 0, 3]]);
        let r = evaluated(&h);
        assert_eq!(r.vertex_mean(), &[1.0, 1.0, 0.0, 0.0]);
        assert_eq!(r.vertex_variance(), &[0.0; 4]);
        for &rho in r.triangle_roughness() {
            assert!((rho - 2.0 / 3.0).abs() < 1e-15, "{rho}");
        }
    }

    #[test]
    fn flipped_winding_is_not_a_fold() {
        let h = tent(1.0);
        let mut flipped = h.triangles.clone();
        flipped[1] = [0, 3, 2];
        let f = head(h.positions.clone(), flipped);
        let (a, b) = (evaluated(&h), evaluated(&f));
        for (x, y) in a.vertex_mean().iter().zip(b.vertex_mean()) {
            assert!((x - y).abs() < 1e-15);
        }
        assert_eq!(a.triangle_roughness(), b.triangle_roughness());
    }

    #[test]
    fn non_manifold_spokes_give_no_pair_and_bowtie_fans_both_count() {
        // three triangles on edge 0-1: nothing pairs, every value is 0
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::NEG_Y, Vec3::Z];
        let r = evaluated(&head(p, vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]]));
        assert!(r
            .vertex_mean()
            .iter()
            .chain(r.vertex_variance())
            .all(|&x| x == 0.0));
        assert!(r.triangle_roughness().iter().all(|&x| x == 0.0));

        // a bowtie: vertex 0 has two open fans, one folded 90 degrees (rho_d = 1), one
        // flat (rho_d = 0): G = 1/2, V = 1/4.
        let p = vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(0.0, -1.0, 0.0),
            Vec3::new(-1.0, -1.0, 0.0),
        ];
        let h = head(p, vec![[0, 1, 2], [1, 0, 3], [0, 4, 6], [0, 6, 5]]);
        assert_eq!(h.topology.fans_of(0).len(), 2);
        let r = evaluated(&h);
        assert_eq!(r.vertex_mean()[0], 0.5);
        assert_eq!(r.vertex_variance()[0], 0.25);
    }

    #[test]
    fn degenerate_triangles_are_skipped() {
        // the tent with E pulled onto the apex: the two triangles at E have no area
        let h = tent(0.0);
        let mut p = h.positions.clone();
        p[1] = Vec3::ZERO;
        let mut r = Roughness::whole_mesh(&h).unwrap();
        r.evaluate(&p).unwrap();
        // apex: pairs (T0,T1), (T3,T0) skipped, (T1,T2) and (T2,T3) flat
        assert_eq!(r.vertex_mean()[0], 0.0);
        assert!(r.triangle_roughness().iter().all(|x| x.is_finite()));
    }

    #[test]
    fn bad_sizes_are_errors_not_panics() {
        let h = tent(1.0);
        assert_eq!(
            Roughness::new(&h, &[4]).unwrap_err(),
            RoughnessError::TriangleOutOfRange {
                triangle: 4,
                count: 4
            }
        );
        let mut r = Roughness::whole_mesh(&h).unwrap();
        assert_eq!(
            r.evaluate(&h.positions[..4]).unwrap_err(),
            RoughnessError::PositionCount {
                expected: 5,
                found: 4
            }
        );
        let mut out = [0.0f32; 3];
        assert_eq!(
            r.face_vertex_roughness(&h.positions, &mut out).unwrap_err(),
            RoughnessError::OutputLength {
                expected: 5,
                found: 3
            }
        );
    }

    #[test]
    fn a_region_needs_the_fans_of_its_corners() {
        let h = tent(1.0);
        let mut part = Roughness::new(&h, &[0]).unwrap();
        assert_eq!(part.region_vertices(), &[0, 1, 2]);
        assert_eq!(part.normal_count(), 4);
        part.evaluate(&h.positions).unwrap();
        let whole = evaluated(&h);
        assert_eq!(part.triangle_roughness()[0], whole.triangle_roughness()[0]);
        let mut out = [9.0f32; 5];
        part.face_vertex_roughness(&h.positions, &mut out).unwrap();
        let fold = 1.0 - 0.5f32.sqrt();
        for (got, want) in out.iter().zip([fold / 2.0, 0.0, fold, 0.0, 0.0]) {
            assert!((got - want).abs() < 1e-7, "{out:?}");
        }
    }
}
