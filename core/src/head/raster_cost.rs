//! What rasterizing a head costs, known before any of it is drawn, so that a mesh built to
//! be expensive (a few thousand vertices joined by a million triangles that each span the
//! head) is refused with its figure instead of holding a core for minutes.
//!
//! The automatic fit's range images visit every cell of each triangle's bounding box on a
//! grid of N cells along the longer side of the head's projected extent L. A triangle with
//! longest edge e projects into a box at most e across, so it visits at most
//! (N e / L + 1)^2 cells. L is at least b / sqrt(2) for any view, b the second longest side
//! of the head's bounding box: the plane of the box's two longest sides meets every view
//! plane in a line, and the box holds a chord at least b long along it. Every image of
//! every view therefore visits at most N^2 C + 2 N sqrt(C T) + T cells, T the triangle
//! count and C = sum of 2 (e / b)^2: the **coverage**, how many head-sized images the
//! triangles' boxes could fill. It does not grow with resolution: a mesh of well-shaped
//! triangles (e^2 about 2.3 times a triangle's area) measures about 4.6 A / b^2, A its
//! area, which for a head with its ears, eye sockets and mouth socket is 18.2 to 37.8
//! (median 27.6) over the 82 heads of `facewire population --write DIR`: ICT identities
//! developed on and held out, face cuts, low-poly, turned, rescaled, Z-up and in mm,
//! MakeHuman and the scan; slivers raise it, and triangles that each span the head add
//! about one apiece.

use glam::Vec3;

use super::Bounds;

/// The most coverage a head may have: five times any head's surface. The automatic fit
/// draws 72 range images of 96 cells and three of 512, at most 1.45 million cell visits
/// per unit of coverage; measured on one core, each unit adds 2.5 to 9 ms to a fit (ICT's
/// head with 3,000 spanning triangles added: 8.5 s against 1.1 s), so this holds the fit's
/// drawing under two seconds.
pub const MAX_RASTER_COVERAGE: f64 = 200.0;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RasterCostError {
    #[error(
        "its bounding box is {size:?} head units: no extent in two directions (a point or a \
         line), no surface to draw"
    )]
    NoExtent { size: [f32; 3] },
    #[error(
        "its triangles' bounds would fill {coverage:.0} head-sized images (a head's surface fills \
         18 to 38; at most {MAX_RASTER_COVERAGE} are drawn): triangle {widest} alone spans \
         {widest_share:.0} % of the head. Is this a surface mesh?"
    )]
    TooCostly {
        coverage: f64,
        widest: usize,
        widest_share: f64,
    },
}

/// The coverage of a mesh: the sum over triangles of 2 (e / b)^2 (module docs).
pub fn coverage(positions: &[Vec3], triangles: &[[u32; 3]]) -> Result<f64, RasterCostError> {
    Ok(measure(positions, triangles)?.0)
}

/// Refuses a mesh whose coverage exceeds [`MAX_RASTER_COVERAGE`], naming its widest
/// triangle.
pub fn check(positions: &[Vec3], triangles: &[[u32; 3]]) -> Result<(), RasterCostError> {
    let (coverage, widest, widest_edge, b) = measure(positions, triangles)?;
    if coverage <= MAX_RASTER_COVERAGE {
        return Ok(());
    }
    Err(RasterCostError::TooCostly {
        coverage,
        widest,
        widest_share: 100.0 * widest_edge / b,
    })
}

/// Coverage, the widest triangle's index and longest edge, and b (head units, f64).
fn measure(positions: &[Vec3], triangles: &[[u32; 3]]) -> Result<(f64, usize, f64, f64), RasterCostError> {
    let size = Bounds::of(positions).size();
    let mut sides = size.as_dvec3().to_array();
    sides.sort_by(|a, b| b.total_cmp(a));
    let b = sides[1];
    if !(b > 0.0 && b.is_finite()) {
        return Err(RasterCostError::NoExtent {
            size: size.to_array(),
        });
    }
    let (mut sum, mut widest, mut widest_edge) = (0.0_f64, 0, 0.0_f64);
    for (i, t) in triangles.iter().enumerate() {
        let [p, q, r] = t.map(|v| positions[v as usize].as_dvec3());
        let edge = p.distance(q).max(q.distance(r)).max(r.distance(p));
        sum += 2.0 * (edge / b).powi(2);
        if edge > widest_edge {
            (widest, widest_edge) = (i, edge);
        }
    }
    Ok((sum, widest, widest_edge, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_square_cut_in_two_covers_four_images_of_itself() {
        // A unit square in z = 0: b = 1; each triangle's longest edge is the diagonal,
        // sqrt(2), so each adds 2 * 2 = 4.
        let positions = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let triangles = [[0, 1, 2], [0, 2, 3]];
        let c = coverage(&positions, &triangles).unwrap();
        assert!((c - 8.0).abs() < 1e-9, "{c}");
        assert_eq!(check(&positions, &triangles), Ok(()));
    }

    #[test]
    fn a_line_has_no_extent_and_wide_triangles_are_refused_by_name() {
        let line = [Vec3::ZERO, Vec3::X, 2.0 * Vec3::X];
        assert!(matches!(
            check(&line, &[[0, 1, 2]]),
            Err(RasterCostError::NoExtent { .. })
        ));
        let positions = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        assert_eq!(check(&positions, &vec![[0, 1, 2]; 49]), Ok(())); // 49 * 4 = 196
        let error = check(&positions, &vec![[0, 1, 2]; 51]).unwrap_err();
        assert!(
            matches!(error, RasterCostError::TooCostly { widest: 0, .. }),
            "{error}"
        );
        assert!(
            error.to_string().contains("fill 204 head-sized images"),
            "{error}"
        );
    }
}
