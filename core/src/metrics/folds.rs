//! Folds (ALGORITHMS.md section 3, docs/METRICS.md): what the averaged roughness and crease
//! measures miss, a skin that bends sharply or turns over. Per pose, over a region of head
//! triangles: the largest increase of an interior edge's dihedral angle over its rest
//! value, and the triangles whose normal turned more than 60 and 90 degrees from rest.
//!
//! Turning is measured after the region's own rigid motion is taken out (the rotation that
//! best carries the region's rest vertices onto their posed positions, Kabsch), so a rigid
//! motion scores 0 and 0. A triangle that collapses to no area in the pose counts as
//! turned over 60 and 90 degrees; one with no area at rest is left out.

use std::collections::HashMap;

use glam::{DMat3, DVec3, Vec3};

use super::RegionError;
use crate::fit::umeyama::umeyama_pairs;
use crate::head::Head;

/// A normal turned more than this is a fold, degrees.
pub const FOLD_DEG: f64 = 60.0;
/// A normal turned more than this faces away, degrees.
pub const FLIP_DEG: f64 = 90.0;

/// Header of the per-frame folds table `facewire deform` writes (`folds.tsv`): the lip
/// region's folds, then the face's (the face vertices' triangles).
pub const FOLDS_TSV_HEADER: &str = "frame\ttime_s\tlip_turned_over_60\tlip_turned_over_90\tlip_max_dihedral_increase_deg\tface_turned_over_60\tface_turned_over_90\tface_max_dihedral_increase_deg";

/// The folds of one pose over a region.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Folds {
    /// The largest increase of an interior edge's dihedral angle over rest, degrees (0 when
    /// none increased).
    pub max_dihedral_increase_deg: f64,
    /// Triangles turned more than [`FOLD_DEG`] from rest.
    pub turned_over_60: u32,
    /// Triangles turned more than [`FLIP_DEG`] from rest.
    pub turned_over_90: u32,
}

/// Measures [`Folds`] over one region of one head; built once, allocation-free per pose.
#[derive(Debug, Clone)]
pub struct FoldMeter {
    /// The region's triangles (head vertex indexes) with a rest area.
    triangles: Vec<[u32; 3]>,
    /// Interior edges: the two triangles (indexes into `triangles`) that share each.
    edges: Vec<[u32; 2]>,
    /// Unit normals at rest, one per triangle.
    rest_normals: Vec<DVec3>,
    /// Dihedral angles at rest, degrees, and their cosines, one per interior edge.
    rest_angles: Vec<f64>,
    rest_cosines: Vec<f64>,
    /// The region's vertices, for its rigid motion.
    vertices: Vec<u32>,
    rest_positions: Vec<DVec3>,
    /// Unit normals of the pose being measured (zero for a collapsed triangle).
    normals: Vec<DVec3>,
    /// The cosine of how far each triangle turned in the last pose measured (-1 for a
    /// collapsed one): angles are taken (`acos`) only when asked for, per vertex.
    turn_cosines: Vec<f64>,
    /// The head's vertex count, which every pose must have.
    head_vertices: usize,
}

impl FoldMeter {
    /// Over the head triangles `region` (indexes into `head.triangles`).
    pub fn new(head: &Head, region: &[u32]) -> Result<FoldMeter, RegionError> {
        let rest = head.positions.as_slice();
        let mut triangles = Vec::with_capacity(region.len());
        for &t in region {
            let triangle = *head
                .triangles
                .get(t as usize)
                .ok_or(RegionError::TriangleOutOfRange {
                    triangle: t,
                    triangles: head.triangles.len(),
                })?;
            if normal(rest, triangle) != DVec3::ZERO {
                triangles.push(triangle);
            }
        }
        let mut sharing: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
        for (k, t) in triangles.iter().enumerate() {
            for i in 0..3 {
                let (a, b) = (t[i], t[(i + 1) % 3]);
                sharing.entry((a.min(b), a.max(b))).or_default().push(k as u32);
            }
        }
        let mut edges: Vec<[u32; 2]> = sharing
            .into_values()
            .filter_map(|pair| <[u32; 2]>::try_from(pair).ok())
            .collect();
        edges.sort_unstable();
        let rest_normals: Vec<DVec3> = triangles.iter().map(|&t| normal(rest, t)).collect();
        let rest_cosines: Vec<f64> = edges
            .iter()
            .map(|&[a, b]| cosine(rest_normals[a as usize], rest_normals[b as usize]))
            .collect();
        let rest_angles = rest_cosines.iter().map(|&c| degrees(c)).collect();
        let mut vertices: Vec<u32> = triangles.iter().flatten().copied().collect();
        vertices.sort_unstable();
        vertices.dedup();
        let rest_positions = vertices.iter().map(|&v| rest[v as usize].as_dvec3()).collect();
        Ok(FoldMeter {
            normals: vec![DVec3::ZERO; triangles.len()],
            turn_cosines: vec![1.0; triangles.len()],
            triangles,
            edges,
            rest_normals,
            rest_angles,
            rest_cosines,
            vertices,
            rest_positions,
            head_vertices: rest.len(),
        })
    }

    /// Triangles measured (those of the region with an area at rest).
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Interior edges measured.
    pub fn edge_count(&self) -> usize {
        self.edges.len()
    }

    /// The folds of the pose `positions` (every head vertex, head units).
    pub fn measure(&mut self, positions: &[Vec3]) -> Result<Folds, RegionError> {
        if positions.len() != self.head_vertices {
            return Err(RegionError::PoseLength {
                found: positions.len(),
                expected: self.head_vertices,
            });
        }
        for (n, &t) in self.normals.iter_mut().zip(&self.triangles) {
            *n = normal(positions, t);
        }
        // Only an edge whose cosine fell can have bent further, so only those take an acos.
        let mut max_dihedral_increase_deg = 0.0f64;
        for ((&[a, b], &rest), &rest_cosine) in
            self.edges.iter().zip(&self.rest_angles).zip(&self.rest_cosines)
        {
            let (na, nb) = (self.normals[a as usize], self.normals[b as usize]);
            if na == DVec3::ZERO || nb == DVec3::ZERO {
                continue;
            }
            let now = cosine(na, nb);
            if now < rest_cosine {
                max_dihedral_increase_deg = max_dihedral_increase_deg.max(degrees(now) - rest);
            }
        }
        let rotation = umeyama_pairs(|| {
            self.rest_positions
                .iter()
                .zip(&self.vertices)
                .map(|(&r, &v)| (r, positions[v as usize].as_dvec3()))
        })
        .map_or(DMat3::IDENTITY, |s| s.rotation);
        // A turn over t degrees is a cosine under cos t: no acos per triangle.
        let (fold_cosine, flip_cosine) = (FOLD_DEG.to_radians().cos(), FLIP_DEG.to_radians().cos());
        let (mut turned_over_60, mut turned_over_90) = (0, 0);
        for ((&now, &rest), turn) in self
            .normals
            .iter()
            .zip(&self.rest_normals)
            .zip(&mut self.turn_cosines)
        {
            let turned = if now == DVec3::ZERO {
                -1.0
            } else {
                cosine(now, rotation * rest)
            };
            *turn = turned;
            turned_over_60 += u32::from(turned < fold_cosine);
            turned_over_90 += u32::from(turned < flip_cosine);
        }
        Ok(Folds {
            max_dihedral_increase_deg,
            turned_over_60,
            turned_over_90,
        })
    }
}

impl FoldMeter {
    /// Whether each of the region's triangles turned more than [`FOLD_DEG`] in the last
    /// pose [`FoldMeter::measure`]d, in the region's triangle order: two poses' folds
    /// compared triangle by triangle.
    pub fn turned_past_fold(&self) -> impl Iterator<Item = bool> + '_ {
        let fold_cosine = FOLD_DEG.to_radians().cos();
        self.turn_cosines.iter().map(move |&c| c < fold_cosine)
    }

    /// Per head vertex, the largest turn (degrees) of its triangles in the region in the
    /// last pose [`FoldMeter::measure`]d; 0 for vertices outside the region. `out` has one
    /// slot per head vertex. Allocates nothing.
    pub fn vertex_turns_deg(&self, out: &mut [f32]) {
        out.fill(0.0);
        for (t, &turn_cosine) in self.triangles.iter().zip(&self.turn_cosines) {
            let turn = degrees(turn_cosine);
            for &v in t {
                if let Some(slot) = out.get_mut(v as usize) {
                    *slot = slot.max(turn as f32);
                }
            }
        }
    }
}

/// Unit normal of triangle `t`, or zero when it has no area.
fn normal(positions: &[Vec3], t: [u32; 3]) -> DVec3 {
    let [a, b, c] = t.map(|v| positions[v as usize].as_dvec3());
    (b - a).cross(c - a).normalize_or_zero()
}

/// Cosine of the angle between two unit vectors, clamped to [-1, 1].
fn cosine(a: DVec3, b: DVec3) -> f64 {
    a.dot(b).clamp(-1.0, 1.0)
}

/// The angle whose cosine is `cosine`, degrees.
fn degrees(cosine: f64) -> f64 {
    cosine.acos().to_degrees()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 4 x 4 grid of unit squares in z = 0, two triangles each (32 triangles).
    fn grid() -> Head {
        crate::head::flat_grid(4)
    }

    fn every_triangle(head: &Head) -> Vec<u32> {
        (0..head.triangles.len() as u32).collect()
    }

    #[test]
    fn vertex_turns_are_the_largest_turn_of_their_triangles() {
        let head = grid();
        let mut meter = FoldMeter::new(&head, &every_triangle(&head)).unwrap();
        let mut turns = vec![9.0f32; head.positions.len()];
        meter.measure(&head.positions).unwrap();
        meter.vertex_turns_deg(&mut turns);
        assert!(turns.iter().all(|&t| t == 0.0));
        // Push the middle vertex (2, 2) far through the plane: its triangles tilt, the
        // grid's corners do not move.
        let mut pushed = head.positions.clone();
        let middle = pushed
            .iter()
            .position(|p| *p == Vec3::new(2.0, 2.0, 0.0))
            .unwrap();
        pushed[middle].z = -3.0;
        let folds = meter.measure(&pushed).unwrap();
        meter.vertex_turns_deg(&mut turns);
        assert!(turns[middle] > 60.0, "{}", turns[middle]);
        let corner = pushed.iter().position(|p| *p == Vec3::ZERO).unwrap();
        assert!(turns[corner] < turns[middle]);
        let over_60 = turns.iter().filter(|&&t| t > 60.0).count();
        assert!(over_60 >= 1 && folds.turned_over_60 > 0, "{folds:?}");
    }

    #[test]
    fn the_rest_pose_and_rigid_motions_count_nothing() {
        let head = grid();
        let mut meter = FoldMeter::new(&head, &every_triangle(&head)).unwrap();
        assert_eq!(meter.triangle_count(), 32);
        // Interior edges of a 4 x 4 grid: 3 x 4 vertical + 4 x 3 horizontal + 16 diagonals.
        assert_eq!(meter.edge_count(), 40);
        assert_eq!(meter.measure(&head.positions).unwrap(), Folds::default());
        let rotation = glam::Quat::from_euler(glam::EulerRot::XYZ, 1.1, -0.4, 2.5);
        let moved: Vec<Vec3> = head
            .positions
            .iter()
            .map(|&p| rotation * p + Vec3::new(3.0, -7.0, 2.0))
            .collect();
        let folds = meter.measure(&moved).unwrap();
        assert!(folds.max_dihedral_increase_deg < 1e-3, "{folds:?}");
        assert_eq!((folds.turned_over_60, folds.turned_over_90), (0, 0));
    }

    #[test]
    fn a_hand_built_fold_is_counted() {
        // Fold the last column of squares (x from 3 to 4) up and over by 150 degrees about
        // the line x = 3: its 8 triangles turn by 150 degrees, the 4 edges on the line bend
        // by 150, and the other 24 triangles stay (the region's best rigid fit barely moves,
        // 20 of its 25 vertices being still).
        let head = grid();
        let mut meter = FoldMeter::new(&head, &every_triangle(&head)).unwrap();
        let angle = 150f32.to_radians();
        let folded: Vec<Vec3> = head
            .positions
            .iter()
            .map(|&p| {
                let d = p.x - 3.0;
                if d <= 0.0 {
                    p
                } else {
                    Vec3::new(3.0 + d * angle.cos(), p.y, d * angle.sin())
                }
            })
            .collect();
        let folds = meter.measure(&folded).unwrap();
        assert!(
            (folds.max_dihedral_increase_deg - 150.0).abs() < 1e-3,
            "{folds:?}"
        );
        assert_eq!((folds.turned_over_60, folds.turned_over_90), (8, 8), "{folds:?}");
    }

    #[test]
    fn a_single_flipped_triangle_counts_over_90_and_a_collapsed_one_too() {
        let head = grid();
        let mut meter = FoldMeter::new(&head, &every_triangle(&head)).unwrap();
        // Push the centre vertex (2, 2) 3 units below the plane: its 6 triangles tilt by
        // atan(3 / d), d from 0.71 to 1 the distance to their far edge: 72 to 77 degrees.
        // The rest of the grid stays, so the rigid fit stays near the identity.
        let mut poked = head.positions.clone();
        poked[12] = Vec3::new(2.0, 2.0, -3.0);
        let folds = meter.measure(&poked).unwrap();
        assert_eq!(folds.turned_over_60, 6, "{folds:?}");
        assert_eq!(folds.turned_over_90, 0, "{folds:?}");
        // Move it across its neighbours instead: the triangles around it turn over.
        let mut flipped = head.positions.clone();
        flipped[12] = Vec3::new(3.6, 3.6, 0.0);
        let folds = meter.measure(&flipped).unwrap();
        assert!(folds.turned_over_90 >= 2, "{folds:?}");
        assert!(folds.max_dihedral_increase_deg > 170.0, "{folds:?}");
        // Collapse triangle (0, 1, 6) onto the line x = 1: it counts as turned over; its
        // neighbour (0, 6, 5) keeps its orientation.
        let mut collapsed = head.positions.clone();
        collapsed[0] = Vec3::new(1.0, 0.5, 0.0);
        let folds = meter.measure(&collapsed).unwrap();
        assert_eq!((folds.turned_over_60, folds.turned_over_90), (1, 1), "{folds:?}");
        assert!(matches!(
            meter.measure(&collapsed[1..]),
            Err(RegionError::PoseLength {
                found: 24,
                expected: 25
            })
        ));
    }
}
