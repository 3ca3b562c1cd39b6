//! What the per-frame job needs of a head besides its binding: the registration, the lip
//! region the roughness is measured on, the quantization step of viewer frames, the parts
//! (teeth, gums, tongue) that move with the skull or the jaw, and the eyeballs.

use glam::Vec3;

use super::part_split::split_rows;
use super::{
    infer_role, Eyeball, EyeballError, EyelidContact, LabiodentalContact, TeethContact, TongueShaper,
};
use crate::deform::Registration;
use crate::head::{check_part_names, Head, Part, PartListError, PartRole};
use crate::mask::{INNER_LIP_MID_LOWER, INNER_LIP_MID_UPPER};
use crate::metrics::{LipRegion, RegionError};

/// Largest quantization error of viewer frames is half of this, in mm.
pub const STEP_MM: f32 = 0.08;

/// A head ready to animate: shared by every job on it.
pub struct AnimatedHead {
    pub registration: Registration,
    pub lip_region: LipRegion,
    /// Quantization step of viewer frames, head units per count ([`STEP_MM`] in mm).
    pub step: f32,
    /// Teeth, gums, tongue: at most [`crate::head::MAX_PARTS`], names unique.
    pub parts: Vec<Part>,
    /// The part with role tongue (at most one), by index into `parts`, and its shaper.
    pub tongue: Option<(usize, TongueShaper)>,
    /// Parts given without a role that held both rows of teeth, and so were split in two.
    pub splits: Vec<PartSplit>,
    /// Keeps the lips and the tongue out of the teeth; `None` without closed teeth.
    pub contact: Option<TeethContact>,
    /// Brings the lower lip to the upper teeth on f and v; `None` without parts that move
    /// with the skull.
    pub labiodental: Option<LabiodentalContact>,
    /// The eyeballs (parts given the role eyes, split one a side): not in `parts`, which
    /// viewers index; at most two.
    pub eyes: Vec<Eyeball>,
    /// Keeps the lids out of the eyeballs; `None` without eyes.
    pub eyelids: Option<EyelidContact>,
}

/// A part given whole that moves as two ([`super::part_split`]): `{name}_upper` with the
/// skull and `{name}_lower` with the jaw.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct PartSplit {
    /// The part's name as given.
    pub name: String,
    pub upper: String,
    pub lower: String,
    /// Connected pieces (teeth) in each row.
    pub upper_pieces: usize,
    pub lower_pieces: usize,
}

/// A part mesh before its role is settled.
#[derive(Debug, Clone)]
pub struct PartInput {
    pub name: String,
    /// `None`: inferred ([`infer_role`]).
    pub role: Option<PartRole>,
    pub mesh: Head,
}

#[derive(Debug, thiserror::Error)]
pub enum AnimatedHeadError {
    #[error("lip region: {0}")]
    LipRegion(#[from] RegionError),
    #[error(transparent)]
    Parts(#[from] PartListError),
    #[error("part {name:?} has no vertices")]
    EmptyPart { name: String },
    #[error(
        "part {name:?} lies {outside:.3e} head units outside the head's bounds, {sizes:.2e} times \
         the head's size: a head's parts lie on it or in it (at most one head size out)"
    )]
    OutOfReach { name: String, outside: f32, sizes: f32 },
    #[error("parts {first:?} and {second:?} are both tongues; a head has at most one")]
    TwoTongues { first: String, second: String },
    #[error(transparent)]
    Eyeball(#[from] EyeballError),
    #[error("eyes {first:?} and {second:?} are both the face's {side} eye; a head has one eye a side")]
    TwoEyesOneSide {
        first: String,
        second: String,
        side: &'static str,
    },
}

/// A part's bounds may reach at most one head diagonal outside the head's: teeth, tongue
/// and eyes lie inside a head, and even a face-only cut keeps them within its own size.
fn check_reach(head: &Head, part: &PartInput) -> Result<(), AnimatedHeadError> {
    let (bounds, own) = (head.bounds(), part.mesh.bounds());
    let size = bounds.size().length();
    let outside = (own.max - bounds.max)
        .max(bounds.min - own.min)
        .max(Vec3::ZERO)
        .length();
    match outside <= size {
        true => Ok(()),
        false => Err(AnimatedHeadError::OutOfReach {
            name: part.name.clone(),
            outside,
            sizes: outside / size.max(f32::MIN_POSITIVE),
        }),
    }
}

impl AnimatedHead {
    /// Finds the lip region of `registration` (blocking; milliseconds).
    pub fn new(registration: Registration) -> Result<AnimatedHead, AnimatedHeadError> {
        AnimatedHead::with_parts(registration, Vec::new())
    }

    /// Like [`AnimatedHead::new`], with part meshes (head units); a part without a role
    /// gets the one [`infer_role`] finds.
    pub fn with_parts(
        registration: Registration,
        parts: Vec<PartInput>,
    ) -> Result<AnimatedHead, AnimatedHeadError> {
        check_part_names(parts.iter().map(|p| p.name.as_str()))?;
        let mut settled: Vec<Part> = Vec::with_capacity(parts.len());
        let mut splits = Vec::new();
        let mut eyes: Vec<Eyeball> = Vec::new();
        for part in parts {
            if part.mesh.positions.is_empty() {
                return Err(AnimatedHeadError::EmptyPart { name: part.name });
            }
            check_reach(&registration.head, &part)?;
            if part.role == Some(PartRole::Eyes) {
                for eye in Eyeball::of_part(&part.mesh, &part.name, &registration.fitted)? {
                    if let Some(other) = eyes.iter().find(|e| e.side == eye.side) {
                        return Err(AnimatedHeadError::TwoEyesOneSide {
                            first: other.name.clone(),
                            second: eye.name,
                            side: eye.side.name(),
                        });
                    }
                    eyes.push(eye);
                }
                continue;
            }
            if part.role.is_none() {
                if let Some(split) = split_rows(&part.mesh, &part.name, &registration.fitted) {
                    splits.push(PartSplit {
                        name: part.name.clone(),
                        upper: split.upper.name.clone(),
                        lower: split.lower.name.clone(),
                        upper_pieces: split.upper_pieces,
                        lower_pieces: split.lower_pieces,
                    });
                    for (mesh, role) in [(split.upper, PartRole::Skull), (split.lower, PartRole::Jaw)] {
                        settled.push(Part::new(mesh.name.clone(), role, mesh, Some(part.name.clone())));
                    }
                    continue;
                }
            }
            let role = part
                .role
                .unwrap_or_else(|| infer_role(&part.mesh, &registration.fitted));
            settled.push(Part::new(part.name, role, part.mesh, None));
        }
        check_part_names(
            settled
                .iter()
                .map(|p| p.name.as_str())
                .chain(eyes.iter().map(|e| e.name.as_str()))
                .collect::<Vec<_>>()
                .into_iter(),
        )?;
        let mut tongues = settled.iter().filter(|p| p.role == PartRole::Tongue);
        if let (Some(first), Some(second)) = (tongues.next(), tongues.next()) {
            return Err(AnimatedHeadError::TwoTongues {
                first: first.name.clone(),
                second: second.name.clone(),
            });
        }
        let tongue = TongueShaper::for_parts(&settled, &registration.fitted, registration.mm_per_unit());
        let lip_region = LipRegion::new(
            &registration.head,
            &registration.anchors,
            registration.mm_per_unit(),
        )?;
        let step = STEP_MM / registration.mm_per_unit();
        let contact = TeethContact::new(
            &registration.head,
            lip_region.union(),
            &settled,
            registration.mm_per_unit(),
        );
        let labiodental = LabiodentalContact::new(&registration, &lip_region, &settled);
        let eyelids = EyelidContact::new(&registration.head, &eyes, registration.mm_per_unit());
        Ok(AnimatedHead {
            eyes,
            eyelids,
            registration,
            lip_region,
            step,
            parts: settled,
            tongue,
            splits,
            contact,
            labiodental,
        })
    }

    /// The mouth at rest (head units): the midpoint of the inner-lip midpoint anchors.
    pub fn mouth(&self) -> Vec3 {
        let reg = &self.registration;
        let anchor = |j: usize| reg.head.positions[reg.anchors.vertex[j] as usize];
        (anchor(INNER_LIP_MID_UPPER) + anchor(INNER_LIP_MID_LOWER)) / 2.0
    }

    /// Whether any part moves with the jaw (then frames carry the jaw's motion).
    pub fn has_jaw_parts(&self) -> bool {
        self.parts.iter().any(|p| p.role.moves_with_jaw())
    }
}
