//! Whether a head can carry the mask's motion at all. Loading only reports problems (a
//! user judges a scan); registering refuses, with the reason, a head that cannot hold a
//! face: a lone triangle, thousands of copies of one point, a box of zero extent. Such
//! heads parse fine and then give anchors that all coincide and distances that are all
//! zero or infinite.

use std::collections::HashSet;

use super::{Bounds, Head};

/// Fewest vertices, and fewest distinct positions among them, of an animatable head:
/// about the size of the CANDIDE-3 mask itself (113 vertices, 104 of them on triangles),
/// whose control points each need a head vertex of their own.
pub const MIN_VERTICES: usize = 100;

/// Fewest triangles with an area (the mask has 184).
pub const MIN_TRIANGLES: usize = 100;

/// Two positions closer than this fraction of the bounding-box diagonal count as one.
pub const COINCIDENT_FRACTION: f32 = 1e-6;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AnimatableError {
    #[error("{name}: {count} vertices; a face needs at least {min}")]
    TooFewVertices { name: String, count: usize, min: usize },
    #[error("{name}: the bounding box has no usable extent (size {size:?} head units)")]
    ZeroExtent { name: String, size: [f32; 3] },
    #[error(
        "{name}: only {distinct} distinct vertex positions among {count} vertices (closer than {COINCIDENT_FRACTION:e} of the head's size counts as one); a face needs at least {min}"
    )]
    Coincident {
        name: String,
        distinct: usize,
        count: usize,
        min: usize,
    },
    #[error("{name}: {count} of {total} triangles have an area; a face needs at least {min}")]
    TooFewTriangles {
        name: String,
        count: usize,
        total: usize,
        min: usize,
    },
}

/// Refuses a head that cannot be animated: fewer than [`MIN_VERTICES`] vertices or
/// distinct positions, a bounding box of zero extent, fewer than [`MIN_TRIANGLES`]
/// triangles with an area. Linear in the head's size.
pub fn check_animatable(head: &Head) -> Result<(), AnimatableError> {
    let name = || head.name.clone();
    let count = head.positions.len();
    if count < MIN_VERTICES {
        return Err(AnimatableError::TooFewVertices {
            name: name(),
            count,
            min: MIN_VERTICES,
        });
    }
    let bounds = Bounds::of(&head.positions);
    let diagonal = bounds.size().length();
    if !(diagonal.is_finite() && diagonal > 0.0) {
        return Err(AnimatableError::ZeroExtent {
            name: name(),
            size: bounds.size().to_array(),
        });
    }

    // Distinct positions on a grid of COINCIDENT_FRACTION of the diagonal; stop counting
    // once there are enough.
    let cell = diagonal * COINCIDENT_FRACTION;
    let mut cells = HashSet::with_capacity(MIN_VERTICES);
    for p in &head.positions {
        let key = ((*p - bounds.min) / cell).round().as_uvec3().to_array();
        cells.insert(key);
        if cells.len() >= MIN_VERTICES {
            break;
        }
    }
    if cells.len() < MIN_VERTICES {
        return Err(AnimatableError::Coincident {
            name: name(),
            distinct: cells.len(),
            count,
            min: MIN_VERTICES,
        });
    }

    // Same threshold as the loader's zero_area_triangles report.
    let area_epsilon = 1e-12 * diagonal * diagonal;
    let with_area = head
        .triangles
        .iter()
        .filter(|t| {
            let [a, b, c] = t.map(|v| head.positions[v as usize]);
            0.5 * (b - a).cross(c - a).length() > area_epsilon
        })
        .take(MIN_TRIANGLES)
        .count();
    if with_area < MIN_TRIANGLES {
        return Err(AnimatableError::TooFewTriangles {
            name: name(),
            count: with_area,
            total: head.triangles.len(),
            min: MIN_TRIANGLES,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    /// A `side` x `side` grid of vertices in the z = 0 plane, two triangles per cell.
    fn sheet(side: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let positions = (0..side * side)
            .map(|i| Vec3::new((i % side) as f32, (i / side) as f32, 0.0))
            .collect();
        let mut triangles = Vec::new();
        for y in 0..side - 1 {
            for x in 0..side - 1 {
                let v = y * side + x;
                triangles.push([v, v + 1, v + side]);
                triangles.push([v + 1, v + side + 1, v + side]);
            }
        }
        (positions, triangles)
    }

    #[test]
    fn a_sheet_of_cells_is_animatable() {
        let (p, t) = sheet(12);
        assert_eq!(check_animatable(&Head::new("sheet", p, t)), Ok(()));
    }

    #[test]
    fn one_triangle_is_refused() {
        let head = Head::new("one.obj", vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
        assert_eq!(
            check_animatable(&head).unwrap_err().to_string(),
            "one.obj: 3 vertices; a face needs at least 100"
        );
    }

    #[test]
    fn five_thousand_identical_vertices_are_refused() {
        let mut triangles = Vec::new();
        for v in (0..4_998).step_by(3) {
            triangles.push([v, v + 1, v + 2]);
        }
        let head = Head::new("same.obj", vec![Vec3::splat(3.0); 5_000], triangles.clone());
        assert!(matches!(
            check_animatable(&head),
            Err(AnimatableError::ZeroExtent { .. })
        ));
        // One vertex elsewhere gives the box an extent; the others still coincide.
        let mut positions = vec![Vec3::splat(3.0); 5_000];
        positions[4_999] = Vec3::ONE;
        let head = Head::new("almost.obj", positions, triangles);
        let err = check_animatable(&head).unwrap_err();
        assert!(
            matches!(
                err,
                AnimatableError::Coincident {
                    distinct: 2,
                    count: 5_000,
                    ..
                }
            ),
            "{err}"
        );
    }

    #[test]
    fn a_line_of_vertices_has_no_triangle_with_an_area() {
        let positions: Vec<Vec3> = (0..300).map(|i| Vec3::new(i as f32, 0.0, 0.0)).collect();
        let triangles: Vec<[u32; 3]> = (0..298).map(|v| [v, v + 1, v + 2]).collect();
        let head = Head::new("line.obj", positions, triangles);
        assert_eq!(
            check_animatable(&head).unwrap_err().to_string(),
            "line.obj: 0 of 298 triangles have an area; a face needs at least 100"
        );
    }
}
