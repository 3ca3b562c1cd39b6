//! One budget of vertices and triangles for a head and all its parts together, spent as
//! each OBJ is read and before any topology or index is built from it: what a registration
//! holds in memory is bounded by the budget, not by how the upload is split into parts.

use super::obj::ObjMesh;

/// Vertices and triangles left to spend.
#[derive(Debug, Clone, Copy)]
pub struct MeshBudget {
    max_vertices: usize,
    max_triangles: usize,
    vertices: usize,
    triangles: usize,
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "{mesh} brings the {kind} to {count}; this server takes at most {limit} {kind} for a head \
     and its parts together"
)]
pub struct OverBudget {
    /// The file that went over: `head.obj`, `parts/teeth.obj`, ...
    pub mesh: String,
    /// `vertices` or `triangles`.
    pub kind: &'static str,
    pub count: usize,
    pub limit: usize,
}

impl MeshBudget {
    pub fn new(max_vertices: usize, max_triangles: usize) -> MeshBudget {
        MeshBudget {
            max_vertices,
            max_triangles,
            vertices: 0,
            triangles: 0,
        }
    }

    /// Spends `mesh`'s vertices and triangles, or names `name` as the file that went over.
    pub fn spend(&mut self, name: &str, mesh: &ObjMesh) -> Result<(), OverBudget> {
        let over = |kind, count, limit| OverBudget {
            mesh: name.to_string(),
            kind,
            count,
            limit,
        };
        let vertices = self.vertices + mesh.positions.len();
        if vertices > self.max_vertices {
            return Err(over("vertices", vertices, self.max_vertices));
        }
        let triangles = self.triangles + mesh.triangles.len();
        if triangles > self.max_triangles {
            return Err(over("triangles", triangles, self.max_triangles));
        }
        (self.vertices, self.triangles) = (vertices, triangles);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    fn mesh(vertices: usize, triangles: usize) -> ObjMesh {
        ObjMesh {
            positions: vec![Vec3::ZERO; vertices],
            triangles: vec![[0, 0, 0]; triangles],
            texture: None,
        }
    }

    #[test]
    fn the_head_and_its_parts_share_one_budget() {
        let mut budget = MeshBudget::new(10, 20);
        assert_eq!(budget.spend("head.obj", &mesh(6, 8)), Ok(()));
        assert_eq!(budget.spend("parts/teeth.obj", &mesh(4, 12)), Ok(()));
        let over = budget.spend("parts/tongue.obj", &mesh(1, 0)).unwrap_err();
        assert_eq!(
            over,
            OverBudget {
                mesh: "parts/tongue.obj".into(),
                kind: "vertices",
                count: 11,
                limit: 10
            }
        );
        assert_eq!(
            over.to_string(),
            "parts/tongue.obj brings the vertices to 11; this server takes at most 10 vertices \
             for a head and its parts together"
        );
        let mut budget = MeshBudget::new(10, 20);
        let over = budget.spend("head.obj", &mesh(3, 21)).unwrap_err();
        assert_eq!((over.kind, over.count, over.limit), ("triangles", 21, 20));
    }
}
