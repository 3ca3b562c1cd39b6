//! The lids close over the eyeballs, never through them. After the deform, a skin vertex
//! near an eyeball that went inside it (a blink drawing the upper lid down over the
//! cornea) is put back just outside its surface along the line from the eyeball's centre:
//! the lid slides over the eye as a real one does. The eyeball's surface is its
//! [`RadialProfile`] in its own turned frame, so the cornea moves with the gaze.
//!
//! A vertex inside an eyeball at rest (a model whose lids rest on the eye) may go as deep
//! as it rests, no deeper. A push is radial, onto a surface that is round about the eye's
//! axis: neighbours that stay outside need not follow, so no falloff is needed and the
//! lid keeps the eyeball's smooth shape where it touches it. Nothing is allocated per
//! frame; [`EyelidContact::measure`] reports what is left, on any deformed skin.

use glam::Vec3;

use super::{Eyeball, RadialProfile, RigidMotion, CONTACT_MARGIN_MM};
use crate::head::Head;

/// Skin vertices this close to an eyeball's surface at rest are watched, mm: further than
/// a lid moves in a blink.
pub const LID_WATCH_MM: f32 = 12.0;

/// What is left of the lids in the eyes in one frame.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LidsInEyes {
    /// Skin vertices deeper in an eyeball than they rest (beyond [`INSIDE_TOLERANCE_MM`]).
    pub vertices: u32,
    /// The deepest of them beyond its rest, mm (0 for none).
    pub deepest_mm: f32,
}

/// Deeper than this beyond its rest a vertex counts as inside, mm: a hundredth of a
/// millimetre, far below what a viewer's quantization (0.04 mm) shows.
pub const INSIDE_TOLERANCE_MM: f32 = 0.01;

/// One eyeball and the skin vertices watched near it.
#[derive(Debug, Clone)]
struct WatchedEye {
    centre: Vec3,
    forward: Vec3,
    profile: RadialProfile,
    vertices: Vec<u32>,
    /// How deep each may be (head units): 0, or its depth at rest.
    allowed: Vec<f32>,
}

impl WatchedEye {
    /// How far `p` is inside the eyeball turned by `motion` (negative outside), head units.
    fn depth(&self, p: Vec3, motion: &RigidMotion) -> (f32, Vec3) {
        let offset = p - self.centre;
        let in_eye = motion.rotation.inverse() * offset;
        let r = in_eye.length();
        let cos = if r > 0.0 {
            in_eye.dot(self.forward) / r
        } else {
            1.0
        };
        (self.profile.radius_at(cos) - r, offset)
    }
}

/// The eyeballs of one head and the skin that must stay out of them: built once per head,
/// shared by its jobs.
#[derive(Debug, Clone)]
pub struct EyelidContact {
    eyes: Vec<WatchedEye>,
    /// [`CONTACT_MARGIN_MM`] in head units.
    margin: f32,
    mm_per_unit: f32,
}

impl EyelidContact {
    /// The constraint for `skin` (head units, `mm_per_unit` mm each) and `eyes`, in order
    /// (the motions [`EyelidContact::apply`] takes follow it); `None` without eyes.
    pub fn new(skin: &Head, eyes: &[Eyeball], mm_per_unit: f32) -> Option<EyelidContact> {
        if eyes.is_empty() {
            return None;
        }
        let watch = LID_WATCH_MM / mm_per_unit;
        let eyes = eyes
            .iter()
            .map(|eye| {
                let mut watched = WatchedEye {
                    centre: eye.centre,
                    forward: eye.forward,
                    profile: eye.profile.clone(),
                    vertices: Vec::new(),
                    allowed: Vec::new(),
                };
                for (v, &p) in skin.positions.iter().enumerate() {
                    let (depth, _) = watched.depth(p, &RigidMotion::IDENTITY);
                    if depth > -watch {
                        watched.vertices.push(v as u32);
                        watched.allowed.push(depth.max(0.0));
                    }
                }
                watched
            })
            .collect();
        Some(EyelidContact {
            eyes,
            margin: CONTACT_MARGIN_MM / mm_per_unit,
            mm_per_unit,
        })
    }

    /// Skin vertices watched near each eye.
    pub fn watched(&self) -> impl Iterator<Item = usize> + '_ {
        self.eyes.iter().map(|e| e.vertices.len())
    }

    /// Puts `skin` (deformed, head units, before the head's motion) back out of the eyes,
    /// each turned by its `motions` entry; returns the vertices pushed.
    pub fn apply(&self, skin: &mut [Vec3], motions: &[RigidMotion]) -> u32 {
        let mut pushed = 0;
        for (eye, motion) in self.eyes.iter().zip(motions) {
            for (&v, &allowed) in eye.vertices.iter().zip(&eye.allowed) {
                let p = &mut skin[v as usize];
                let (depth, offset) = eye.depth(*p, motion);
                if depth > allowed {
                    let r = offset.length();
                    let target = match allowed > 0.0 {
                        true => r + depth - allowed,
                        false => r + depth + self.margin,
                    };
                    if r > 0.0 {
                        *p = eye.centre + offset * (target / r);
                        pushed += 1;
                    }
                }
            }
        }
        pushed
    }

    /// How much of `skin` (deformed) is deeper in the eyes, turned by `motions`, than
    /// `rest` (the same vertices at rest) is: every vertex is checked, watched or not.
    pub fn measure(&self, rest: &[Vec3], skin: &[Vec3], motions: &[RigidMotion]) -> LidsInEyes {
        let tolerance = INSIDE_TOLERANCE_MM / self.mm_per_unit;
        let mut found = LidsInEyes::default();
        for (eye, motion) in self.eyes.iter().zip(motions) {
            for (&at_rest, &now) in rest.iter().zip(skin) {
                let allowed = eye.depth(at_rest, &RigidMotion::IDENTITY).0.max(0.0);
                let beyond = eye.depth(now, motion).0 - allowed;
                if beyond > tolerance {
                    found.vertices += 1;
                    found.deepest_mm = found.deepest_mm.max(beyond * self.mm_per_unit);
                }
            }
        }
        found
    }
}

#[cfg(test)]
mod tests {
    use super::super::eyeball::tests::{eyeball, identity_fit};
    use super::super::Gaze;
    use super::*;
    use crate::head::flat_grid;

    /// A lid: a flat grid of 0.01-unit squares in front of an eyeball of radius 0.12 about
    /// the origin (identity fit, mask units = head units, 100 mm each).
    fn lid_and_eye() -> (Head, Vec<Eyeball>) {
        let grid = flat_grid(20);
        let positions = grid
            .positions
            .iter()
            .map(|p| Vec3::new(0.3 + (p.x - 10.0) * 0.01, (p.y - 10.0) * 0.01, 0.13))
            .collect();
        let lid = Head::new("lid", positions, grid.triangles.clone());
        let (p, t) = eyeball(Vec3::new(0.3, 0.0, 0.0), 0.12, 0.0, 0);
        let eyes = Eyeball::of_part(&Head::new("eye", p, t), "eye", &identity_fit()).unwrap();
        (lid, eyes)
    }

    #[test]
    fn a_lid_pressed_into_the_eye_ends_just_outside_it() {
        let (lid, eyes) = lid_and_eye();
        let contact = EyelidContact::new(&lid, &eyes, 100.0).unwrap();
        let still = [RigidMotion::IDENTITY];
        assert_eq!(
            contact.measure(&lid.positions, &lid.positions, &still),
            LidsInEyes::default()
        );
        // Pressed 0.02 units (2 mm) back, the lid's middle vertex is 0.01 (1 mm) inside.
        let mut pressed: Vec<Vec3> = lid.positions.iter().map(|p| *p - Vec3::Z * 0.02).collect();
        let before = contact.measure(&lid.positions, &pressed, &still);
        assert!(
            before.vertices > 0 && (before.deepest_mm - 1.0).abs() < 0.05,
            "{before:?}"
        );
        let pushed = contact.apply(&mut pressed, &still);
        assert_eq!(pushed, before.vertices);
        assert_eq!(
            contact.measure(&lid.positions, &pressed, &still),
            LidsInEyes::default()
        );
        // Each pushed vertex sits at the surface plus the margin (0.2 mm), on its own ray.
        let centre = eyes[0].centre;
        let middle = pressed[10 * 21 + 10];
        let r = (middle - centre).length();
        assert!((r - (eyes[0].profile.radius_at(1.0) + 0.002)).abs() < 1e-5, "{r}");
        assert!((middle - centre).normalize().abs_diff_eq(Vec3::Z, 1e-3));
    }

    #[test]
    fn the_turned_cornea_is_what_the_lid_must_clear() {
        // A 1.5 cm cornea bulge: at rest it reaches 0.135 in front; the lid at 0.13 is in it
        // unless the eye looks away, and may stay as deep as it rests.
        let (lid, _) = lid_and_eye();
        let (p, t) = eyeball(Vec3::new(0.3, 0.0, 0.0), 0.12, 0.015, 0);
        let fitted = identity_fit();
        let eyes = Eyeball::of_part(&Head::new("eye", p, t), "eye", &fitted).unwrap();
        let contact = EyelidContact::new(&lid, &eyes, 100.0).unwrap();
        let still = [RigidMotion::IDENTITY];
        let mut skin = lid.positions.clone();
        assert_eq!(contact.apply(&mut skin, &still), 0, "resting depth is allowed");
        let away = [Gaze {
            yaw_rad: 0.6,
            pitch_rad: 0.0,
        }
        .motion_of(&eyes[0], &fitted.fit.pose)];
        // Looking away, the lid's middle is outside; a lid pressed in now is pushed out to
        // the sclera, not the cornea.
        let mut pressed: Vec<Vec3> = lid.positions.iter().map(|p| *p - Vec3::Z * 0.015).collect();
        let found = contact.measure(&lid.positions, &pressed, &away);
        assert!(found.vertices > 0);
        contact.apply(&mut pressed, &away);
        assert_eq!(
            contact.measure(&lid.positions, &pressed, &away),
            LidsInEyes::default()
        );
    }
}
