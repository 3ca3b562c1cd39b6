//! Labiodental contact: on f and v the lower lip is drawn up and back until it rests
//! against the upper incisors. The mouth shape that asks for it (the syllable generator's
//! `f`, viseme FF) moves the mask's lower lip by a fixed amount in mask units, but where
//! the head's own upper teeth are is the head's: on one head the lip reaches them, on
//! another it stops 2 mm short and a lip-reader sees an open mouth where a lip should meet
//! teeth. So after the deform, as far as the frame asks for the shape, the lower lip is
//! brought to the upper teeth, its neighbours following with a smooth falloff.
//!
//! How much a frame asks: the lower lip's retraction (FAP 16 `push_b_lip`, negative), as
//! a share of the one the labiodental shape itself asks for (the FF viseme's, the only
//! shape of the table that draws the lower lip back), clamped to `0..=1`. Every way a
//! frame can ask for it counts alike, since it is read from the posed animation weights:
//! the syllable stream's units, FAP 16 in counts, FAP 1's FF viseme, a speech-derived
//! track. ARKit weights retarget into mask offsets, not units, and have no labiodental
//! channel of their own: they do not ask.
//!
//! Per frame with a share `w > 0`: each lower-lip vertex has the point `q` of the upper
//! teeth (every surface of the parts that move with the skull, open or closed, so
//! open-shell teeth count) nearest it at rest; the teeth do not move in the head's frame,
//! so `q` stays a point the lip can touch. The vertex nearest its `q`, at gap `g`, is
//! moved toward it by
//! `w · fade(g) · (g - margin)` (margin [`super::CONTACT_MARGIN_MM`]), and every vertex
//! within the falloff over the surface by `(1 - (s / falloff)²)²` of that. Both lengths
//! are the head's own, read from its fit: the falloff is half the mouth's width at rest
//! (the corners do not move), and `fade` goes from 1 at a gap of an eighth of that width
//! to 0 at a quarter (a wide-open jaw is not pulled shut, and no pull is longer than half
//! the distance it is spread over). The teeth contact runs after this one and keeps every
//! lip vertex out of the teeth. Nothing is allocated per frame: the search buffers are
//! sized at construction.

use glam::Vec3;

use super::CONTACT_MARGIN_MM;
use crate::deform::Registration;
use crate::head::{surface_of, Part, PartRole, SurfaceDistance, Topology};
use crate::mask::LOWER_LIP;
use crate::metrics::LipRegion;
use crate::stream::mouth_shapes::CHANNELS;
use crate::stream::visemes::VISEMES;

/// The lower lip and the upper teeth of one head: built once per head, shared by its jobs
/// (each keeps a [`LabiodentalScratch`]).
#[derive(Debug, Clone)]
pub struct LabiodentalContact {
    /// The skin's lower-lip vertices (those of the lip region's lower-lip triangles).
    lower_lip: Vec<u32>,
    /// For each, the point of the upper teeth (every surface of the skull's parts, teeth
    /// and gums) nearest it at rest, head units. The upper teeth do not move in the head's
    /// frame, so the distance to this point is a gap the lip can close.
    teeth_point: Vec<Vec3>,
    /// The mask's animation unit of FAP 16 and the weight of it that asks fully.
    retraction_unit: usize,
    full_retraction: f32,
    lengths: Lengths,
}

/// The head's own lengths the contact works with, head units.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Lengths {
    /// How far over the surface a pull reaches: half the mouth's width at rest.
    falloff: f32,
    /// The widest gap closed: half the falloff.
    reach: f32,
    /// Where the pulled vertex stops: [`CONTACT_MARGIN_MM`] from the teeth.
    margin: f32,
}

/// Per-job buffers of [`LabiodentalContact::apply`].
#[derive(Debug, Clone)]
pub struct LabiodentalScratch {
    distances: SurfaceDistance,
}

/// What one frame's labiodental contact did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LabiodentalApplied {
    /// How far the nearest lower-lip vertex was moved, head units (0: not asked, or
    /// already at the teeth, or out of reach).
    pub moved: f32,
}

/// The labiodental shape's lower-lip retraction (FAP 16 weight, mask units, negative)
/// and its animation unit: the FF viseme's value in the channel of `fap16_push_b_lip`.
fn labiodental_retraction() -> Option<(usize, f32)> {
    let channel = CHANNELS.iter().position(|c| c.key == "fap16_push_b_lip")?;
    let ff = VISEMES.iter().find(|v| v.oculus == "FF")?;
    let full = ff.shape[channel];
    (full < 0.0).then_some((usize::from(CHANNELS[channel].unit), full))
}

impl LabiodentalContact {
    /// The contact for `registration`'s skin (its lip region `lips`) against the parts
    /// among `parts` that move with the skull; `None` without such parts or without a
    /// lower lip in the lip region.
    pub fn new(registration: &Registration, lips: &LipRegion, parts: &[Part]) -> Option<LabiodentalContact> {
        let upper_teeth: Vec<[Vec3; 3]> = parts
            .iter()
            .filter(|p| p.role == PartRole::Skull)
            .flat_map(|p| {
                p.mesh
                    .triangles
                    .iter()
                    .map(|t| t.map(|v| p.mesh.positions[v as usize]))
            })
            .collect();
        let skin = &registration.head;
        let lower_lip = lips.head_vertices(skin, |j| LOWER_LIP.contains(&j));
        let falloff = registration.mouth_width() / 2.0;
        let lengths = Lengths {
            falloff,
            reach: falloff / 2.0,
            margin: CONTACT_MARGIN_MM / registration.mm_per_unit(),
        };
        LabiodentalContact::with_lengths(&skin.positions, &upper_teeth, lower_lip, lengths)
    }

    /// The contact of the `lower_lip` vertices of `skin` at rest with the `upper_teeth`
    /// triangles (head units); `None` without either.
    fn with_lengths(
        skin: &[Vec3],
        upper_teeth: &[[Vec3; 3]],
        lower_lip: Vec<u32>,
        lengths: Lengths,
    ) -> Option<LabiodentalContact> {
        if lower_lip.is_empty() {
            return None;
        }
        let surface = surface_of(upper_teeth)?;
        let teeth_point = lower_lip
            .iter()
            .map(|&v| surface.closest_point(skin[v as usize]).map(|hit| hit.point))
            .collect::<Option<_>>()?;
        let (retraction_unit, full_retraction) = labiodental_retraction()?;
        Some(LabiodentalContact {
            lower_lip,
            teeth_point,
            retraction_unit,
            full_retraction,
            lengths,
        })
    }

    /// Buffers for one job on a skin of `vertices` vertices, reserved for the largest
    /// search a frame can make (nothing grows per frame).
    pub fn scratch(&self, vertices: usize) -> LabiodentalScratch {
        let mut distances = SurfaceDistance::new(vertices);
        distances.reserve(vertices);
        LabiodentalScratch { distances }
    }

    /// How much a frame whose posed animation weights are `weights` asks for the
    /// labiodental shape, `0..=1`.
    pub fn share(&self, weights: &[f32]) -> f32 {
        let asked = weights.get(self.retraction_unit).copied().unwrap_or(0.0);
        (asked / self.full_retraction).clamp(0.0, 1.0)
    }

    /// Brings the lower lip of `skin` (deformed, head units, before the head's motion;
    /// `topology` its mesh's) toward the upper teeth as far as `share` asks.
    pub fn apply(
        &self,
        topology: &Topology,
        skin: &mut [Vec3],
        share: f32,
        scratch: &mut LabiodentalScratch,
    ) -> LabiodentalApplied {
        if share <= 0.0 {
            return LabiodentalApplied::default();
        }
        let Some((nearest, toward)) = self.nearest_lower_lip_vertex(skin) else {
            return LabiodentalApplied::default();
        };
        let gap = toward.length();
        let by = share * self.fade(gap) * (gap - self.lengths.margin);
        if by <= 0.0 {
            return LabiodentalApplied::default();
        }
        let pull = toward * (by / gap);
        let falloff = self.lengths.falloff;
        scratch.distances.run(topology, &[(nearest, 0.0)], falloff);
        let distances = &scratch.distances;
        for &u in distances.reached() {
            let s = distances.distance(u) / falloff;
            skin[u as usize] += pull * (1.0 - s * s).powi(2);
        }
        LabiodentalApplied { moved: by }
    }

    /// 1 up to half the reach, 0 from the whole reach, smooth between.
    fn fade(&self, gap: f32) -> f32 {
        let half = 0.5 * self.lengths.reach;
        let t = ((gap - half) / half).clamp(0.0, 1.0);
        1.0 - t * t * (3.0 - 2.0 * t)
    }

    /// The lower-lip vertex nearest its point of the upper teeth, and the way from it to
    /// that point (head units); `None` when one is on it.
    fn nearest_lower_lip_vertex(&self, skin: &[Vec3]) -> Option<(u32, Vec3)> {
        let (v, toward) = self
            .lower_lip
            .iter()
            .zip(&self.teeth_point)
            .map(|(&v, &q)| (v, q - skin[v as usize]))
            .min_by(|a, b| a.1.length_squared().total_cmp(&b.1.length_squared()))?;
        (toward != Vec3::ZERO).then_some((v, toward))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::head::{box_mesh, flat_grid};

    /// The 12 triangles of the box between `min` and `max`.
    fn box_triangles(min: Vec3, max: Vec3) -> Vec<[Vec3; 3]> {
        let mesh = box_mesh(min, max);
        mesh.triangles
            .iter()
            .map(|t| t.map(|v| mesh.positions[v as usize]))
            .collect()
    }

    const LENGTHS: Lengths = Lengths {
        falloff: 3.0,
        reach: 8.0,
        margin: 0.2,
    };

    /// A 10 x 10 grid of unit squares at z = 0, its middle vertex (5, 5) `gap` below a
    /// small tooth, the whole grid its lower lip.
    fn grid_under_a_tooth(gap: f32) -> (crate::head::Head, LabiodentalContact) {
        let skin = flat_grid(10);
        let tooth = box_triangles(Vec3::new(4.5, 4.5, gap), Vec3::new(5.5, 5.5, gap + 1.0));
        let lower_lip = (0..skin.positions.len() as u32).collect();
        let contact = LabiodentalContact::with_lengths(&skin.positions, &tooth, lower_lip, LENGTHS).unwrap();
        (skin, contact)
    }

    const MIDDLE: usize = 5 * 11 + 5;

    #[test]
    fn the_labiodental_shape_is_the_one_that_draws_the_lower_lip_back() {
        let (unit, full) = labiodental_retraction().expect("the FF viseme retracts the lower lip");
        assert_eq!(unit, 24, "CANDIDE-3's FAP 16 unit");
        assert_eq!(full, -0.015);
        let channel = CHANNELS.iter().position(|c| usize::from(c.unit) == unit).unwrap();
        for viseme in VISEMES.iter().filter(|v| v.oculus != "FF") {
            assert!(
                viseme.shape[channel] >= 0.0,
                "{} draws the lower lip back",
                viseme.oculus
            );
        }
    }

    #[test]
    fn the_share_is_the_retraction_asked_over_the_labiodental_shapes() {
        let (_, contact) = grid_under_a_tooth(2.0);
        let mut weights = vec![0.0; 65];
        for (asked, share) in [
            (-0.0075, 0.5),
            (-0.015, 1.0),
            (-0.04, 1.0),
            (0.03, 0.0),
            (0.0, 0.0),
        ] {
            weights[24] = asked;
            assert_eq!(contact.share(&weights), share, "FAP 16 weight {asked}");
        }
        assert_eq!(contact.share(&[]), 0.0, "a mask without the unit asks nothing");
    }

    #[test]
    fn a_full_share_brings_the_nearest_vertex_to_the_teeth_and_its_neighbours_follow() {
        let (skin, contact) = grid_under_a_tooth(2.0);
        let mut scratch = contact.scratch(skin.positions.len());
        let mut moved = skin.positions.clone();
        let applied = contact.apply(&skin.topology, &mut moved, 1.0, &mut scratch);
        assert!((applied.moved - 1.8).abs() < 1e-5, "{applied:?}");
        assert!(
            (moved[MIDDLE].z - 1.8).abs() < 1e-5,
            "ends 0.2 below the tooth: {}",
            moved[MIDDLE]
        );
        // One edge away: (1 - 1/9)^2 of the pull; three away (the falloff): nothing.
        let one = (1.0f32 - 1.0 / 9.0).powi(2) * 1.8;
        assert!((moved[MIDDLE + 1].z - one).abs() < 1e-5, "{}", moved[MIDDLE + 1]);
        assert_eq!(moved[MIDDLE + 3].z, 0.0);
        assert_eq!(moved[0], skin.positions[0]);
        // Straight up: nothing slides sideways.
        assert!(moved
            .iter()
            .zip(&skin.positions)
            .all(|(a, b)| a.x == b.x && a.y == b.y));
    }

    #[test]
    fn a_partial_share_closes_that_share_of_the_gap() {
        let (skin, contact) = grid_under_a_tooth(2.0);
        let mut scratch = contact.scratch(skin.positions.len());
        let mut moved = skin.positions.clone();
        contact.apply(&skin.topology, &mut moved, 0.5, &mut scratch);
        assert!((moved[MIDDLE].z - 0.9).abs() < 1e-5, "{}", moved[MIDDLE]);
        let mut unmoved = skin.positions.clone();
        assert_eq!(
            contact
                .apply(&skin.topology, &mut unmoved, 0.0, &mut scratch)
                .moved,
            0.0
        );
        assert_eq!(unmoved, skin.positions);
    }

    #[test]
    fn a_gap_wider_than_the_reach_is_left_open_and_fades_in_below_it() {
        for (gap, fade) in [(9.0, 0.0), (8.0, 0.0), (6.0, 0.5), (4.0, 1.0)] {
            let (skin, contact) = grid_under_a_tooth(gap);
            let mut scratch = contact.scratch(skin.positions.len());
            let mut moved = skin.positions.clone();
            let applied = contact.apply(&skin.topology, &mut moved, 1.0, &mut scratch);
            let expected = fade * (gap - 0.2);
            assert!((applied.moved - expected).abs() < 1e-4, "gap {gap}: {applied:?}");
            assert!((moved[MIDDLE].z - expected).abs() < 1e-4, "gap {gap}");
        }
    }

    #[test]
    fn open_shell_teeth_are_met_as_well_as_closed_ones() {
        // One triangle above the grid's middle, as a game asset's teeth may be: a surface
        // with no inside.
        let skin = flat_grid(10);
        let tooth = [[
            Vec3::new(4.8, 4.8, 2.0),
            Vec3::new(5.2, 4.8, 2.0),
            Vec3::new(5.0, 5.2, 2.0),
        ]];
        let lower_lip = (0..skin.positions.len() as u32).collect();
        let contact = LabiodentalContact::with_lengths(&skin.positions, &tooth, lower_lip, LENGTHS).unwrap();
        let mut scratch = contact.scratch(skin.positions.len());
        let mut moved = skin.positions.clone();
        contact.apply(&skin.topology, &mut moved, 1.0, &mut scratch);
        assert!((moved[MIDDLE].z - 1.8).abs() < 1e-5, "{}", moved[MIDDLE]);
    }

    #[test]
    fn a_lip_already_at_the_teeth_stays() {
        let (skin, contact) = grid_under_a_tooth(0.1);
        let mut scratch = contact.scratch(skin.positions.len());
        let mut moved = skin.positions.clone();
        assert_eq!(
            contact.apply(&skin.topology, &mut moved, 1.0, &mut scratch).moved,
            0.0
        );
        assert_eq!(moved, skin.positions);
    }
}
