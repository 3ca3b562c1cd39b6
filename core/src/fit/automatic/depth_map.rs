//! A range image of a head seen from one horizontal direction: for each cell of a grid laid
//! across the view, how far forward the surface comes there. The automatic fit looks for
//! the nose on it (the point that stands out most from the surface beside it) and reads
//! the face's width at the nose.
//!
//! All lengths are head units. The view's axes are `lateral` (the face's left, CANDIDE's
//! +x), `up` (+y of the head) and `forward` (out of the face, CANDIDE's +z).

use glam::{Vec2, Vec3};

/// Directions of a view: a right-handed frame with `lateral = up x forward`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    pub lateral: Vec3,
    pub up: Vec3,
    pub forward: Vec3,
}

impl View {
    /// Looking at the head from `yaw` radians about +y: yaw 0 sees a face that looks along +z.
    #[cfg(test)]
    pub fn horizontal(yaw: f32) -> View {
        let forward = Vec3::new(yaw.sin(), 0.0, yaw.cos());
        let up = Vec3::Y;
        View {
            lateral: up.cross(forward),
            up,
            forward,
        }
    }

    /// Looking along `forward` with `lateral` (unit, perpendicular to it) as the face's
    /// left: up is `forward x lateral`.
    pub fn with_lateral(forward: Vec3, lateral: Vec3) -> View {
        View {
            lateral,
            up: forward.cross(lateral),
            forward,
        }
    }

    /// The same view turned upside down (up and lateral negated; still right-handed).
    pub fn upside_down(self) -> View {
        View {
            lateral: -self.lateral,
            up: -self.up,
            forward: self.forward,
        }
    }

    /// The view along a mask pose's axes: CANDIDE's x, y and z in the head frame.
    pub fn of_rotation(rotation: glam::Mat3) -> View {
        View {
            lateral: rotation.x_axis.normalize(),
            up: rotation.y_axis.normalize(),
            forward: rotation.z_axis.normalize(),
        }
    }

    pub fn project(&self, p: Vec3) -> (Vec2, f32) {
        (
            Vec2::new(p.dot(self.lateral), p.dot(self.up)),
            p.dot(self.forward),
        )
    }

    pub fn point(&self, across: Vec2, depth: f32) -> Vec3 {
        across.x * self.lateral + across.y * self.up + depth * self.forward
    }
}

/// +1 when `triangles` mostly wind counter-clockwise seen from outside (their normals
/// point away from the mesh's centre), -1 otherwise.
pub fn outward_winding(positions: &[Vec3], triangles: &[[u32; 3]]) -> f32 {
    let centre = positions.iter().copied().sum::<Vec3>() / positions.len().max(1) as f32;
    let outwardness: f32 = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| positions[v as usize]);
            (b - a).cross(c - a).dot((a + b + c) / 3.0 - centre)
        })
        .sum();
    if outwardness >= 0.0 {
        1.0
    } else {
        -1.0
    }
}

/// Where the nose seems to be in one view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoseCandidate {
    /// The nose tip, head units.
    pub tip: Vec3,
    /// How far the tip stands out of the surface around it (the nearest of the four
    /// points `radius` away to its left, right, above and below), as a fraction of `radius`.
    pub prominence: f32,
    /// The width of the surface across the view at the tip's height, head units.
    pub width_at_tip: f32,
}

#[derive(Debug, Clone)]
pub struct DepthMap {
    view: View,
    /// Lower-left corner of the grid (lateral, up), head units.
    origin: Vec2,
    cell: f32,
    columns: usize,
    rows: usize,
    /// Row-major, `f32::NEG_INFINITY` where no surface covers the cell.
    depth: Vec<f32>,
}

impl DepthMap {
    /// Rasterizes the triangles of `triangles` that face the viewer on a grid whose longer
    /// side has `cells` cells, keeping the surface that comes furthest forward in each cell.
    /// `winding` is +1 when the triangles wind counter-clockwise seen from outside, -1 when
    /// clockwise ([`outward_winding`]). Faces turned away (the inside of a mouth seen from
    /// behind a face-only mesh, say) are not drawn.
    pub fn render(
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        view: View,
        cells: usize,
        winding: f32,
    ) -> DepthMap {
        let (mut low, mut high) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
        for &p in positions {
            let (a, _) = view.project(p);
            low = low.min(a);
            high = high.max(a);
        }
        let extent = (high - low).max_element().max(f32::MIN_POSITIVE);
        let cell = extent / cells as f32;
        let columns = (((high.x - low.x) / cell) as usize + 1).min(cells + 1);
        let rows = (((high.y - low.y) / cell) as usize + 1).min(cells + 1);
        Self::render_grid(positions, triangles, view, (low, cell), (columns, rows), winding)
    }

    /// Like [`DepthMap::render`] on a square window of the view: `cells` by `cells` cells of
    /// `side / cells` (head units) from `low` (the window's lower-left corner, lateral and
    /// up). Cell (column, row) covers the window's point `low + (column, row) * cell`.
    pub fn render_window(
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        view: View,
        (low, side): (Vec2, f32),
        cells: usize,
        winding: f32,
    ) -> DepthMap {
        let cell = side.max(f32::MIN_POSITIVE) / cells as f32;
        Self::render_grid(positions, triangles, view, (low, cell), (cells, cells), winding)
    }

    fn render_grid(
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        view: View,
        (origin, cell): (Vec2, f32),
        (columns, rows): (usize, usize),
        winding: f32,
    ) -> DepthMap {
        let mut map = DepthMap {
            view,
            origin,
            cell,
            columns,
            rows,
            depth: vec![f32::NEG_INFINITY; columns * rows],
        };
        for t in triangles {
            let [a, b, c] = t.map(|v| positions[v as usize]);
            if winding * (b - a).cross(c - a).dot(view.forward) <= 0.0 {
                continue;
            }
            map.rasterize([a, b, c].map(|p| view.project(p)));
        }
        map
    }

    fn rasterize(&mut self, corners: [(Vec2, f32); 3]) {
        let grid = corners.map(|(a, d)| ((a - self.origin) / self.cell, d));
        let [(a, da), (b, db), (c, dc)] = grid;
        let area = (b - a).perp_dot(c - a);
        if area.abs() <= f32::EPSILON {
            return;
        }
        let low = a.min(b).min(c);
        let high = a.max(b).max(c);
        let first_column = low.x.ceil().max(0.0) as usize;
        let last_column = (high.x.floor() as isize).min(self.columns as isize - 1);
        let first_row = low.y.ceil().max(0.0) as usize;
        let last_row = (high.y.floor() as isize).min(self.rows as isize - 1);
        for row in first_row as isize..=last_row {
            for column in first_column as isize..=last_column {
                let p = Vec2::new(column as f32, row as f32);
                let wa = (b - p).perp_dot(c - p) / area;
                let wb = (c - p).perp_dot(a - p) / area;
                let wc = 1.0 - wa - wb;
                if wa < -1e-6 || wb < -1e-6 || wc < -1e-6 {
                    continue;
                }
                let depth = wa * da + wb * db + wc * dc;
                let slot = &mut self.depth[row as usize * self.columns + column as usize];
                *slot = slot.max(depth);
            }
        }
    }

    /// The depth of the surface at `across` (lateral, up; head units), from the nearest
    /// cell, if a surface covers it.
    pub fn depth_at(&self, across: Vec2) -> Option<f32> {
        let cell = ((across - self.origin) / self.cell).round();
        self.at(cell.x as isize, cell.y as isize)
    }

    /// The grid's size, columns and rows.
    pub fn cells(&self) -> (usize, usize) {
        (self.columns, self.rows)
    }

    /// The depth at cell (column, row) (row 0 at the bottom), if a surface covers it.
    pub fn at(&self, column: isize, row: isize) -> Option<f32> {
        if column < 0 || row < 0 || column as usize >= self.columns || row as usize >= self.rows {
            return None;
        }
        let d = self.depth[row as usize * self.columns + column as usize];
        d.is_finite().then_some(d)
    }

    /// Up to `count` places that could be a nose tip seen from the front, the one that
    /// stands out most first, each at least `radius` (head units) across the view from those
    /// before it: cells within `radius` of the most forward one, standing out from the
    /// surface `radius` to their left, right, above and below (empty when no cell has
    /// surface on all four sides). The nose of a face whose jaw is open at rest can stand
    /// out less than its chin, so the caller tries more than one.
    pub fn noses(&self, radius: f32, count: usize) -> Vec<NoseCandidate> {
        let reach = ((radius / self.cell).round() as isize).max(1);
        // A nose tip is the front of the face: no more than `radius` behind the most forward
        // point (a chin lowered by an open jaw stands out of its surroundings, further back).
        let front = self.depth.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        let mut bumps: Vec<(f32, isize, isize, f32)> = Vec::new();
        for row in 0..self.rows as isize {
            for column in 0..self.columns as isize {
                // A nose has surface all round it: cheeks beside, the bridge above, the lip
                // below (an edge of the mesh, such as a cut neck, does not).
                let (Some(d), Some(left), Some(right), Some(above), Some(below)) = (
                    self.at(column, row),
                    self.at(column - reach, row),
                    self.at(column + reach, row),
                    self.at(column, row + reach),
                    self.at(column, row - reach),
                ) else {
                    continue;
                };
                if d < front - radius {
                    continue;
                }
                bumps.push((d - left.max(right).max(above).max(below), column, row, d));
            }
        }
        // Most prominent first; ties in scan order, as the single best was always taken.
        bumps.sort_by(|a, b| b.0.total_cmp(&a.0));
        let mut kept: Vec<(f32, isize, isize, f32)> = Vec::with_capacity(count);
        for bump in bumps {
            if kept.len() == count {
                break;
            }
            let apart = |k: &(f32, isize, isize, f32)| {
                let (dc, dr) = (k.1 - bump.1, k.2 - bump.2);
                dc * dc + dr * dr >= reach * reach
            };
            if kept.iter().all(apart) {
                kept.push(bump);
            }
        }
        kept.into_iter()
            .map(|(prominence, column, row, depth)| {
                let across = self.origin + Vec2::new(column as f32, row as f32) * self.cell;
                NoseCandidate {
                    tip: self.view.point(across, depth),
                    prominence: prominence / radius,
                    width_at_tip: self.width_of_row(row),
                }
            })
            .collect()
    }

    /// Distance between the first and the last covered cell of `row`, head units.
    fn width_of_row(&self, row: isize) -> f32 {
        let covered: Vec<isize> = (0..self.columns as isize)
            .filter(|&c| self.at(c, row).is_some())
            .collect();
        match (covered.first(), covered.last()) {
            (Some(first), Some(last)) => (last - first) as f32 * self.cell,
            _ => 0.0,
        }
    }

    /// The longer side of the view, head units.
    pub fn extent(&self) -> f32 {
        self.cell * self.columns.max(self.rows) as f32
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A flat square at depth 0 facing +z with a pyramid of height 1 rising from its middle.
    fn plate_with_a_peak() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let positions = vec![
            Vec3::new(-5.0, -5.0, 0.0),
            Vec3::new(5.0, -5.0, 0.0),
            Vec3::new(5.0, 5.0, 0.0),
            Vec3::new(-5.0, 5.0, 0.0),
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
        ];
        let triangles = vec![
            [0, 1, 5],
            [0, 5, 4],
            [1, 2, 6],
            [1, 6, 5],
            [2, 3, 7],
            [2, 7, 6],
            [3, 0, 4],
            [3, 4, 7],
            [4, 5, 8],
            [5, 6, 8],
            [6, 7, 8],
            [7, 4, 8],
        ];
        (positions, triangles)
    }

    #[test]
    fn the_view_is_right_handed_and_yaw_zero_looks_along_z() {
        let view = View::horizontal(0.0);
        assert!(view.forward.distance(Vec3::Z) < 1e-6);
        assert!(view.lateral.distance(Vec3::X) < 1e-6);
        let turned = View::horizontal(std::f32::consts::FRAC_PI_2);
        assert!(turned.forward.distance(Vec3::X) < 1e-6);
        assert!(turned.lateral.distance(-Vec3::Z) < 1e-6);
    }

    #[test]
    fn the_peak_is_the_nose_seen_from_its_side() {
        let (positions, triangles) = plate_with_a_peak();
        let map = DepthMap::render(&positions, &triangles, View::horizontal(0.0), 100, 1.0);
        let nose = map.noses(2.0, 1)[0];
        assert!(
            nose.tip.distance(Vec3::new(0.0, 0.0, 1.0)) < 0.11,
            "{:?}",
            nose.tip
        );
        assert!((nose.prominence - 0.5).abs() < 0.06, "{}", nose.prominence);
        assert!((nose.width_at_tip - 10.0).abs() < 0.11, "{}", nose.width_at_tip);
        assert!((map.extent() - 10.0).abs() < 0.2);
    }

    /// A 20 x 20 plate facing +z, raised by `height(x, y)`, as a 41 x 41 grid.
    fn raised_plate(height: impl Fn(f32, f32) -> f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        grid_plate([41, 41], Vec2::new(-10.0, -10.0), 0.5, height)
    }

    /// A plate facing +z: a grid of `columns x rows` vertices `spacing` apart from `corner`,
    /// raised by `height(x, y)`, two triangles a cell, counter-clockwise seen from +z.
    pub(crate) fn grid_plate(
        [columns, rows]: [u32; 2],
        corner: Vec2,
        spacing: f32,
        height: impl Fn(f32, f32) -> f32,
    ) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let positions = (0..columns * rows)
            .map(|k| {
                let x = corner.x + (k % columns) as f32 * spacing;
                let y = corner.y + (k / columns) as f32 * spacing;
                Vec3::new(x, y, height(x, y))
            })
            .collect();
        let mut triangles = Vec::new();
        for row in 0..rows - 1 {
            for column in 0..columns - 1 {
                let k = row * columns + column;
                triangles.push([k, k + 1, k + columns + 1]);
                triangles.push([k, k + columns + 1, k + columns]);
            }
        }
        (positions, triangles)
    }

    #[test]
    fn a_second_bump_is_the_second_nose_and_the_first_ones_slopes_are_not() {
        let cone = |x: f32, y: f32, cx: f32, cy: f32| (1.0 - (x - cx).hypot(y - cy) / 1.5).max(0.0);
        let (positions, triangles) = raised_plate(|x, y| cone(x, y, 0.0, -4.0) + 0.8 * cone(x, y, 0.0, 4.0));
        let map = DepthMap::render(&positions, &triangles, View::horizontal(0.0), 100, 1.0);
        let noses = map.noses(2.0, 3);
        assert!(noses.len() >= 2, "{noses:?}");
        assert!(
            noses[0].tip.distance(Vec3::new(0.0, -4.0, 1.0)) < 0.3,
            "{:?}",
            noses[0].tip
        );
        assert!(
            noses[1].tip.distance(Vec3::new(0.0, 4.0, 0.8)) < 0.3,
            "{:?}",
            noses[1].tip
        );
        assert!(noses[0].prominence > noses[1].prominence);
        // The third is neither bump, and stands out less than both.
        for other in &noses[2..] {
            assert!(other.prominence < noses[1].prominence, "{other:?}");
        }
        assert_eq!(map.noses(2.0, 1), noses[..1]);
    }

    #[test]
    fn from_behind_the_plate_shows_no_peak() {
        let (positions, triangles) = plate_with_a_peak();
        let map = DepthMap::render(
            &positions,
            &triangles,
            View::horizontal(std::f32::consts::PI),
            100,
            1.0,
        );
        let nose = map.noses(2.0, 1).first().copied();
        assert!(nose.is_none_or(|n| n.prominence < 0.05), "{nose:?}");
    }
}
