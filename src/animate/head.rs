//! What the per-frame job needs of a head besides its binding: the registration, the lip
//! region the roughness is measured on, and the quantization step of viewer frames.

use crate::deform::Registration;
use crate::metrics::{LipRegion, RegionError};

/// Largest quantization error of viewer frames is half of this, in mm.
pub const STEP_MM: f32 = 0.08;

/// A head ready to animate: shared by every job on it.
pub struct AnimatedHead {
    pub registration: Registration,
    pub lip_region: LipRegion,
    /// Quantization step of viewer frames, head units per count ([`STEP_MM`] in mm).
    pub step: f32,
}

#[derive(Debug, thiserror::Error)]
pub enum AnimatedHeadError {
    #[error("lip region: {0}")]
    LipRegion(#[from] RegionError),
}

impl AnimatedHead {
    /// Finds the lip region of `registration` (blocking; milliseconds).
    pub fn new(registration: Registration) -> Result<AnimatedHead, AnimatedHeadError> {
        let lip_region = LipRegion::new(
            &registration.head,
            &registration.anchors,
            registration.mm_per_unit(),
        )?;
        let step = STEP_MM / registration.mm_per_unit();
        Ok(AnimatedHead {
            registration,
            lip_region,
            step,
        })
    }
}
