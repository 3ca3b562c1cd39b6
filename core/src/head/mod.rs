//! A dense head mesh: positions in **head units** (whatever the OBJ file uses), triangles,
//! connectivity, spatial indexes and surface distances. Built once per registered head.

pub mod animatable;
pub mod budget;
pub mod geodesic;
pub mod glb;
pub mod glb_parts;
pub mod laplacian;
pub mod obj;
pub mod part;
pub mod raster_cost;
pub mod solid;
pub mod spatial;
pub mod subdivide;
pub mod topology;
pub mod validate;

use std::path::Path;

use glam::Vec3;
use serde::Serialize;

use crate::input::{read_file, ReadError, MAX_HEAD_BYTES};

pub use animatable::{check_animatable, AnimatableError};
pub use budget::{MeshBudget, OverBudget};
pub use geodesic::SurfaceDistance;
pub use glb::{read_glb, BaseColour, GlbError, GlbMesh, MorphTarget, MM_PER_METRE};
pub use glb_parts::{glb_head, GlbHead, GlbPartsError, MeshRole};
pub use laplacian::CotanLaplacian;
pub use obj::ObjError;
pub use part::{check_part_names, Part, PartListError, PartRole, PartRoleError, MAX_PARTS};
pub use raster_cost::RasterCostError;
pub use solid::{closed_piece_count, closed_pieces, surface_of, Pieces, Solid, NO_PIECE};
pub use spatial::{closest_point_on_triangle, SurfaceIndex, SurfacePoint, VertexIndex};
pub use topology::{Edge, Fan, Topology};
pub use validate::Problem;

#[derive(Debug, thiserror::Error)]
pub enum HeadError {
    #[error(transparent)]
    Read(#[from] ReadError),
    #[error("{path}: {source}")]
    Obj { path: String, source: ObjError },
}

/// A triangle mesh with its topology and nearest-point indexes.
#[derive(Debug, Clone)]
pub struct Head {
    /// Where it came from (file name or upload name), for messages.
    pub name: String,
    /// Vertex positions in head units, in file order.
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    pub topology: Topology,
    pub vertices: VertexIndex,
    pub surface: SurfaceIndex,
    /// Problems found while loading (empty for a clean mesh).
    pub problems: Vec<Problem>,
}

/// Axis-aligned bounds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Bounds {
    pub min: Vec3,
    pub max: Vec3,
}

impl Bounds {
    pub fn of(points: &[Vec3]) -> Bounds {
        let (min, max) = points.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), &p| (lo.min(p), hi.max(p)),
        );
        Bounds { min, max }
    }

    pub fn size(&self) -> Vec3 {
        self.max - self.min
    }

    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }
}

impl Head {
    /// Loads an OBJ file: a regular file of at most [`MAX_HEAD_BYTES`].
    pub fn load(path: &Path) -> Result<Head, HeadError> {
        let bytes = read_file(path, MAX_HEAD_BYTES)?;
        let name = path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        Head::from_obj_bytes(&name, &bytes).map_err(|source| HeadError::Obj {
            path: path.display().to_string(),
            source,
        })
    }

    /// Parses OBJ bytes (UTF-8 or Latin-1 comments are both fine: only ASCII records are read).
    pub fn from_obj_bytes(name: &str, bytes: &[u8]) -> Result<Head, ObjError> {
        let text = String::from_utf8_lossy(bytes);
        let mesh = obj::parse(&text)?;
        Ok(Head::new(name, mesh.positions, mesh.triangles))
    }

    /// Builds topology, indexes and the problem report. `triangles` must index `positions`.
    pub fn new(name: &str, positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Head {
        let topology = Topology::new(&positions, &triangles);
        let diagonal = Bounds::of(&positions).size().length();
        let problems = validate::check(&positions, &triangles, &topology, 1e-12 * diagonal * diagonal);
        let vertices = VertexIndex::new(&positions);
        let surface = SurfaceIndex::new(&positions, &triangles);
        Head {
            name: name.to_string(),
            positions,
            triangles,
            topology,
            vertices,
            surface,
            problems,
        }
    }

    pub fn bounds(&self) -> Bounds {
        Bounds::of(&self.positions)
    }

    /// The vertices of `positions` that `triangles` use, renumbered in the order the
    /// triangles first use them: a part of a mesh as a mesh of its own.
    pub fn compacted(name: &str, positions: &[Vec3], triangles: &[[u32; 3]]) -> Head {
        let mut renumber = vec![u32::MAX; positions.len()];
        let mut kept = Vec::new();
        for &v in triangles.iter().flatten() {
            if renumber[v as usize] == u32::MAX {
                renumber[v as usize] = kept.len() as u32;
                kept.push(positions[v as usize]);
            }
        }
        let triangles = triangles
            .iter()
            .map(|t| t.map(|v| renumber[v as usize]))
            .collect();
        Head::new(name, kept, triangles)
    }
}

/// The closed box between `min` and `max`, 12 triangles wound outward, for the
/// hand-checked tests of contact with teeth.
#[cfg(test)]
pub(crate) fn box_mesh(min: Vec3, max: Vec3) -> Head {
    let corner = |i: usize| {
        Vec3::new(
            if i & 1 == 0 { min.x } else { max.x },
            if i & 2 == 0 { min.y } else { max.y },
            if i & 4 == 0 { min.z } else { max.z },
        )
    };
    let triangles = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ]
    .iter()
    .flat_map(|q: &[u32; 4]| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
    .collect();
    Head::new("box", (0..8).map(corner).collect(), triangles)
}

/// A flat grid of `squares` x `squares` unit squares in z = 0, two triangles each, for the
/// hand-checked tests of mesh measures.
#[cfg(test)]
pub(crate) fn flat_grid(squares: u32) -> Head {
    let side = squares + 1;
    let positions = (0..side)
        .flat_map(|y| (0..side).map(move |x| Vec3::new(x as f32, y as f32, 0.0)))
        .collect();
    let mut triangles = Vec::new();
    for y in 0..squares {
        for x in 0..squares {
            let v = y * side + x;
            triangles.push([v, v + 1, v + side + 1]);
            triangles.push([v, v + side + 1, v + side]);
        }
    }
    Head::new("grid", positions, triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn problems_are_counted_with_examples() {
        let text =
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 2 2\nv 0 0 1\nf 1 2 3\nf 1 3 2\nf 1 2 2\nf 1 2 5\nf 1 2 5\n";
        let head = Head::from_obj_bytes("t.obj", text.as_bytes()).unwrap();
        let kinds: Vec<(&str, usize)> = head.problems.iter().map(|p| (p.kind, p.count)).collect();
        assert!(kinds.contains(&("repeated_corner_triangles", 1)), "{kinds:?}");
        assert!(kinds.contains(&("duplicate_triangles", 2)), "{kinds:?}");
        assert!(kinds.contains(&("non_manifold_edges", 1)), "{kinds:?}");
        assert!(kinds.contains(&("unreferenced_vertices", 1)), "{kinds:?}");
        assert!(kinds.contains(&("inconsistent_winding_edges", 2)), "{kinds:?}");
        let unused = head
            .problems
            .iter()
            .find(|p| p.kind == "unreferenced_vertices")
            .unwrap();
        assert_eq!(unused.examples, vec!["3"]);
    }

    #[test]
    fn thirty_two_thousand_duplicate_faces_are_counted() {
        // Took 11.6 s in `facewire inspect` when fans were chained quadratically.
        let text = format!("v 0 0 0\nv 1 0 0\nv 0 1 0\n{}", "f 1 2 3\n".repeat(32_000));
        let head = Head::from_obj_bytes("dup.obj", text.as_bytes()).unwrap();
        let count = |kind: &str| head.problems.iter().find(|p| p.kind == kind).map(|p| p.count);
        assert_eq!(count("duplicate_triangles"), Some(31_999));
        assert_eq!(count("non_manifold_edges"), Some(3));
        assert_eq!(head.topology.fans_of(0).len(), 32_000);
    }
}
