//! Contact, not collision, inside the mouth: in each frame, whether the lips or the tongue
//! went into a tooth, whether the tongue came out past the teeth, and how close the lower
//! lip is to the upper teeth (labiodental f/v must close that gap). docs/METRICS.md,
//! section 9, "Contact inside the mouth".
//!
//! The teeth are the closed pieces of the head's skull and jaw parts ([`crate::head::solid`]:
//! each tooth of the ICT model is one; gums and tongue are open surfaces and never count as
//! solids). Everything is in the head's frame before the head's own motion, which moves
//! skin, teeth and tongue alike: skull pieces stay at rest, jaw pieces are moved by the
//! frame's jaw motion. Lengths come out in millimetres.

use glam::{Affine3A, Vec3};

use crate::head::{closed_pieces, surface_of, Head, Part, PartRole, Solid, SurfaceIndex};
use crate::mask::{MaskPose, LOWER_LIP};

use super::LipRegion;

/// Contact measures of one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactFrame {
    /// Lip vertices (the lip region's) inside a tooth.
    pub lips_in_teeth: u32,
    /// How deep the deepest of them is, mm (0 when none is inside).
    pub lips_depth_mm: f32,
    /// Vertices of the tongue proper (not the gums or floor a tongue mesh may hold) inside
    /// a tooth that are outside every tooth at rest (a model's tongue may rest against
    /// its teeth; that is not counted).
    pub tongue_in_teeth: u32,
    /// How deep the deepest of them is, mm (0 when none is inside).
    pub tongue_depth_mm: f32,
    /// How far the tongue's most forward point is in front of the upper teeth's most
    /// forward point, mm along the face's forward axis (negative: behind them).
    pub tongue_past_teeth_mm: f32,
    /// Shortest distance from a lower-lip vertex to the upper teeth and gums, mm.
    pub lower_lip_to_upper_teeth_mm: f32,
    /// Distance from the tongue's tip (feature point 6.1) to the upper
    /// gums (the open surfaces of the skull parts), mm: small when the tip touches the
    /// ridge behind the upper incisors (t, d). Infinite for a head without a tongue or
    /// without upper gums.
    pub tongue_tip_to_gums_mm: f32,
}

/// The tongue as the measures see it.
struct Tongue {
    rest: Vec<Vec3>,
    /// Whether each vertex counts: the tongue proper, outside every tooth at rest.
    counted: Vec<bool>,
    tip: usize,
}

/// The teeth, lips and tongue of one head, set up to measure contact frame after frame.
pub struct MouthContact {
    skull: Vec<Solid>,
    jaw: Vec<Solid>,
    /// Every skull part's surface (upper teeth and gums).
    upper_teeth: SurfaceIndex,
    /// The skull parts' open surfaces (the upper gums).
    upper_gums: Option<SurfaceIndex>,
    tongue: Option<Tongue>,
    /// The most forward point of the upper teeth, head units, and the face's forward
    /// direction in the head's frame.
    teeth_front: Vec3,
    forward: Vec3,
    lip_vertices: Vec<u32>,
    lower_lip_vertices: Vec<u32>,
    mm_per_unit: f32,
}

impl MouthContact {
    /// Sets up the measures for `head` (its lip region `lips`, the mask fitted with
    /// `pose`) and its parts (the tongue is the part with role tongue; `tongue` gives its
    /// tip vertex and which of its vertices are the tongue proper); `None` when no skull
    /// part has a closed piece (no upper teeth to touch).
    pub fn new(
        head: &Head,
        lips: &LipRegion,
        pose: &MaskPose,
        mm_per_unit: f32,
        parts: &[Part],
        tongue: Option<(usize, &[bool])>,
    ) -> Option<MouthContact> {
        let (mut skull, mut jaw, mut gums) = (Vec::new(), Vec::new(), Vec::new());
        for part in parts {
            let (closed, open) = closed_pieces(&part.mesh);
            match part.role {
                PartRole::Skull => {
                    skull.extend(closed);
                    gums.extend(open);
                }
                PartRole::Jaw => jaw.extend(closed),
                PartRole::Tongue | PartRole::Eyes => {}
            }
        }
        if skull.is_empty() {
            return None;
        }
        let upper: Vec<[Vec3; 3]> = skull
            .iter()
            .flat_map(|p| p.triangles.iter().copied())
            .chain(gums.iter().copied())
            .collect();
        let forward = (pose.rotation() * Vec3::Z).normalize();
        let teeth_front = skull
            .iter()
            .flat_map(|p| p.triangles.iter().flatten())
            .copied()
            .max_by(|a, b| a.dot(forward).total_cmp(&b.dot(forward)))
            .unwrap_or(Vec3::ZERO);
        let mut contact = MouthContact {
            upper_teeth: surface_of(&upper)?,
            upper_gums: surface_of(&gums),
            tongue: None,
            skull,
            jaw,
            teeth_front,
            forward,
            lip_vertices: lips.head_vertices(head, |_| true),
            lower_lip_vertices: lips.head_vertices(head, |j| LOWER_LIP.contains(&j)),
            mm_per_unit,
        };
        contact.tongue = parts.iter().find(|p| p.role == PartRole::Tongue).map(|part| {
            let rest = part.mesh.positions.clone();
            let (tip, free) = tongue.unwrap_or((0, &[]));
            let counted = rest
                .iter()
                .enumerate()
                .map(|(v, &p)| {
                    free.get(v).copied().unwrap_or(true)
                        && contact.depth_in_teeth(p, &Affine3A::IDENTITY).is_none()
                })
                .collect();
            Tongue {
                tip: tip.min(rest.len().saturating_sub(1)),
                rest,
                counted,
            }
        });
        Some(contact)
    }

    /// How deep `p` is inside a tooth (head units), `None` when it is outside them all.
    fn depth_in_teeth(&self, p: Vec3, jaw_inverse: &Affine3A) -> Option<f32> {
        if let Some(piece) = self.skull.iter().find(|piece| piece.contains(p)) {
            return Some(piece.distance(p));
        }
        let in_jaw = jaw_inverse.transform_point3(p);
        self.jaw
            .iter()
            .find(|piece| piece.contains(in_jaw))
            .map(|piece| piece.distance(in_jaw))
    }

    /// The measures of one frame: the deformed skin (head units, before the head's
    /// motion), the jaw's motion, and the tongue's deltas (before the jaw's motion; `None`
    /// for a tongue at rest or no tongue).
    pub fn measure(&self, skin: &[Vec3], jaw: Affine3A, tongue_deltas: Option<&[Vec3]>) -> ContactFrame {
        let jaw_inverse = jaw.inverse();
        let mut frame = ContactFrame {
            lips_in_teeth: 0,
            lips_depth_mm: 0.0,
            tongue_in_teeth: 0,
            tongue_depth_mm: 0.0,
            tongue_past_teeth_mm: f32::NEG_INFINITY,
            lower_lip_to_upper_teeth_mm: self
                .to_upper_teeth_mm(self.lower_lip_vertices.iter().map(|&v| skin[v as usize])),
            tongue_tip_to_gums_mm: f32::INFINITY,
        };
        for &v in &self.lip_vertices {
            if let Some(depth) = self.depth_in_teeth(skin[v as usize], &jaw_inverse) {
                frame.lips_in_teeth += 1;
                frame.lips_depth_mm = frame.lips_depth_mm.max(depth * self.mm_per_unit);
            }
        }
        if let Some(tongue) = &self.tongue {
            let at = |v: usize| {
                let delta = tongue_deltas.map_or(Vec3::ZERO, |d| d[v]);
                jaw.transform_point3(tongue.rest[v] + delta)
            };
            let mut front = f32::NEG_INFINITY;
            for v in 0..tongue.rest.len() {
                let p = at(v);
                front = front.max((p - self.teeth_front).dot(self.forward));
                if !tongue.counted[v] {
                    continue;
                }
                if let Some(depth) = self.depth_in_teeth(p, &jaw_inverse) {
                    frame.tongue_in_teeth += 1;
                    frame.tongue_depth_mm = frame.tongue_depth_mm.max(depth * self.mm_per_unit);
                }
            }
            frame.tongue_past_teeth_mm = front * self.mm_per_unit;
            if let Some(gums) = &self.upper_gums {
                let tip = at(tongue.tip);
                frame.tongue_tip_to_gums_mm = gums
                    .closest_point(tip)
                    .map_or(f32::INFINITY, |hit| hit.distance * self.mm_per_unit);
            }
        }
        frame
    }

    /// The shortest distance from `points` to the upper teeth and gums, mm.
    fn to_upper_teeth_mm(&self, points: impl Iterator<Item = Vec3>) -> f32 {
        points
            .filter_map(|p| self.upper_teeth.closest_point(p))
            .map(|hit| hit.distance)
            .fold(f32::INFINITY, f32::min)
            * self.mm_per_unit
    }
}
