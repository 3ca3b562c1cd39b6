//! Needle triangles: a triangle far thinner than it is long moves as its long edge does.
//!
//! Scanned and generated heads carry triangles whose height is a few hundredths of their
//! longest edge (the mouth corners of most ICT identities: heights of 0.002-0.05 mm under
//! 0.5-1 mm edges). Such a triangle's normal is decided by its thin vertex's offset from the
//! long edge, and any field that is not exactly affine over it (every smooth field near
//! the crowded mouth anchors) moves that vertex across the edge by more than the height:
//! the triangle turns over while its neighbours barely bend (docs/METRICS.md section 11).
//!
//! The thin vertex (the apex over the longest edge) is therefore bound to move as the point
//! of the long edge it stands over: its row becomes the edge's two rows blended at that
//! point. The needle then keeps its rest shape up to the edge's own turn and stretch, and
//! the apex moves by no more than the field's change across a fraction of a millimetre.
//! The user's mesh is left as it is. A vertex that is the apex of several needles follows
//! the thinnest; chains (an apex on another needle's edge) are followed through, since each
//! row is built from rows already settled, thinnest needle last.

use glam::Vec3;

use super::binding::LinearTerm;
use super::row_merge::merge_by_control;

/// A triangle whose height over its longest edge is under this share of that edge is a
/// needle: its smallest angle is under about 3 degrees.
pub const NEEDLE_HEIGHT_SHARE: f32 = 0.05;

/// One needle: its apex follows `edge` at parameter `along` (0 at `edge[0]`).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Needle {
    apex: u32,
    edge: [u32; 2],
    along: f32,
    /// Height over the edge's length: thinner needles are settled later.
    thinness: f32,
}

/// `rows` with each needle apex's row replaced by its long edge's rows blended where it
/// stands (see the module docs), keeping its `k` largest terms ([`merge_by_control`]), but for
/// the apexes `pinned` says are held where they are bound (the anchors, which reproduce
/// their controls).
pub fn bind_needles(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    pinned: impl Fn(u32) -> bool,
    k: usize,
    mut rows: Vec<Vec<LinearTerm>>,
) -> Vec<Vec<LinearTerm>> {
    let mut thinnest: Vec<Option<Needle>> = vec![None; positions.len()];
    for t in triangles {
        let Some(needle) = needle_of(positions, *t).filter(|n| !pinned(n.apex)) else {
            continue;
        };
        let slot = &mut thinnest[needle.apex as usize];
        if slot.is_none_or(|n| needle.thinness < n.thinness) {
            *slot = Some(needle);
        }
    }
    let mut needles: Vec<Needle> = thinnest.into_iter().flatten().collect();
    // Thickest first: a thinner needle's apex may sit on a thicker one's edge, and so
    // follows the settled edge.
    needles.sort_by(|a, b| b.thinness.total_cmp(&a.thinness));
    for needle in needles {
        let [a, b] = needle.edge.map(|v| &rows[v as usize]);
        let mut terms: Vec<LinearTerm> = a
            .iter()
            .map(|t| LinearTerm {
                control: t.control,
                weight: (1.0 - needle.along) * t.weight,
            })
            .chain(b.iter().map(|t| LinearTerm {
                control: t.control,
                weight: needle.along * t.weight,
            }))
            .collect();
        let blended = merge_by_control(&mut terms, k);
        rows[needle.apex as usize] = blended;
    }
    rows
}

/// The needle triangle `t` is, if it is one (a triangle with no length is not).
fn needle_of(positions: &[Vec3], t: [u32; 3]) -> Option<Needle> {
    let p = t.map(|v| positions[v as usize]);
    let (longest, length) = (0..3)
        .map(|k| (k, p[k].distance(p[(k + 1) % 3])))
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    if length.is_nan() || length <= 0.0 {
        return None;
    }
    let [a, b, apex] = [longest, (longest + 1) % 3, (longest + 2) % 3];
    let edge = p[b] - p[a];
    let along = ((p[apex] - p[a]).dot(edge) / (length * length)).clamp(0.0, 1.0);
    let height = p[apex].distance(p[a] + along * edge);
    let thinness = height / length;
    (thinness < NEEDLE_HEIGHT_SHARE).then_some(Needle {
        apex: t[apex],
        edge: [t[a], t[b]],
        along,
        thinness,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn term(control: u16, weight: f32) -> LinearTerm {
        LinearTerm { control, weight }
    }

    #[test]
    fn a_needle_apex_follows_the_point_of_the_edge_below_it() {
        // Edge 0-1 of length 1 along x; vertex 2 stands 0.01 over it at x = 0.25.
        let positions = [
            Vec3::ZERO,
            Vec3::X,
            Vec3::new(0.25, 0.01, 0.0),
            Vec3::new(0.5, 1.0, 0.0),
        ];
        let triangles = [[0, 1, 2], [0, 3, 1]];
        let rows = vec![
            vec![term(0, 1.0)],
            vec![term(1, 1.0)],
            vec![term(2, 1.0)],
            vec![term(3, 1.0)],
        ];
        let bound = bind_needles(&positions, &triangles, |_| false, 8, rows.clone());
        assert_eq!(bound[2], vec![term(0, 0.75), term(1, 0.25)]);
        // The fat triangle 0-3-1 changes nothing: its vertices keep their rows.
        assert_eq!(bound[3], vec![term(3, 1.0)]);
        assert_eq!(bound[0], vec![term(0, 1.0)]);
        // A pinned apex keeps its own.
        assert_eq!(
            bind_needles(&positions, &triangles, |v| v == 2, 8, rows.clone()),
            rows
        );
    }

    #[test]
    fn a_thin_but_not_needle_triangle_is_left_alone() {
        // Height 0.06 over a unit edge: thinner than most, not a needle.
        let positions = [Vec3::ZERO, Vec3::X, Vec3::new(0.5, 0.06, 0.0)];
        let rows = vec![vec![term(0, 1.0)], vec![term(1, 1.0)], vec![term(2, 1.0)]];
        assert_eq!(
            bind_needles(&positions, &[[0, 1, 2]], |_| false, 8, rows.clone()),
            rows
        );
    }

    #[test]
    fn chained_needles_follow_the_settled_edge_and_the_thinnest_wins() {
        // Vertex 2 is the apex of a needle over 0-1 (thinness 0.04); vertex 3 the apex of
        // a thinner needle over 1-2 (0.01), and of a thicker one over 0-1 (0.03) too.
        let positions = [
            Vec3::ZERO,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(1.0, 0.08, 0.0),
            Vec3::new(1.5, 0.05, 0.0),
        ];
        let rows = vec![
            vec![term(0, 1.0)],
            vec![term(1, 1.0)],
            vec![term(2, 1.0)],
            vec![term(3, 1.0)],
        ];
        let needle = needle_of(&positions, [1, 2, 3]).unwrap();
        assert_eq!(needle.apex, 3);
        let rows = bind_needles(&positions, &[[0, 1, 2], [1, 2, 3], [0, 1, 3]], |_| false, 8, rows);
        // 2 follows the middle of 0-1; 3 stands over the middle of 1-2.
        assert_eq!(rows[2], vec![term(0, 0.5), term(1, 0.5)]);
        let sum: f32 = rows[3].iter().map(|t| t.weight).sum();
        assert!((sum - 1.0).abs() < 1e-6);
        assert!(rows[3].iter().all(|t| t.control < 2), "{:?}", rows[3]);
    }
}
