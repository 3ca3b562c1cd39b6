//! Lips that close, on a head scanned with its mouth open. CANDIDE's lips meet at rest,
//! and p, b and m keep the jaw at rest while they press the lips, so on such a head they
//! would leave the scan's gap. At registration the head is closed once: the mask is laid
//! on it open as the head is (its jaw dropped until the mask's lower lip is on the
//! head's), then the jaw is raised through the default deformer just until the lips meet
//! on the midline ([`crate::fit::mouth_opening`]). The closed head, with the mask as it
//! then lies, is what is registered and animated. A head whose lips are at most
//! [`LIPS_APART_MM`] apart at rest is left as it is.

use glam::Vec3;

use super::spec::DEFAULT_ALGORITHM;
use super::{bind, AlgoSpec, Registration};
use crate::fit::{mouth_opening, FittedMask, MouthCalibration, LIPS_APART_MM};
use crate::head::Head;
use crate::mask::INNER_LIP_MID_LOWER;

/// Times the first guess of the jaw raise may grow by half before the mouth must close.
const WIDENINGS: usize = 6;
/// Halvings of the raise between open and closed: a 2^-20 share of it.
const HALVINGS: usize = 20;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MouthCalibrationError {
    #[error("the mask has no jaw_drop animation unit: a rest-open mouth cannot be closed")]
    NoJawUnit,
    #[error(
        "the lips are {open_mm:.1} mm apart at rest and raising the jaw {raised_mm:.0} mm did not close them on the midline (is the fit's mouth on the head's?)"
    )]
    DoesNotClose { open_mm: f32, raised_mm: f32 },
}

/// The head closed and the mask as it lies on the closed head, when `head`'s lips are
/// apart at rest under `fitted`; `None` for lips that meet.
pub fn close_rest_mouth(
    head: &Head,
    fitted: &FittedMask,
) -> Result<Option<(Head, FittedMask, MouthCalibration)>, MouthCalibrationError> {
    let mm_per_mask_unit = fitted.mm_per_mask_unit();
    let opening = mouth_opening(&head.positions, &head.triangles, fitted);
    let open_mm = (opening.height() * f64::from(mm_per_mask_unit)) as f32;
    if open_mm <= LIPS_APART_MM {
        return Ok(None);
    }
    let mask = &fitted.mask;
    let jaw = mask
        .animation_units
        .iter()
        .position(|u| u.key == "jaw_drop")
        .ok_or(MouthCalibrationError::NoJawUnit)?;
    let jaw_displacements = &mask.animation_units[jaw].displacements;
    // How far one unit of jaw drop lowers the mask's inner lower lip (mask units).
    let drop_per_unit = jaw_displacements
        .iter()
        .find(|(v, _)| *v as usize == INNER_LIP_MID_LOWER)
        .map_or(0.0, |(_, d)| -f64::from(d.y));
    if drop_per_unit <= 0.0 {
        return Err(MouthCalibrationError::NoJawUnit);
    }
    // The mask opened as the head is: its inner lower lip down on the head's lower lip.
    let lower_lip = f64::from(fitted.base[INNER_LIP_MID_LOWER].y);
    let dropped = ((lower_lip - opening.bottom) / drop_per_unit).max(0.0) as f32;
    let with_jaw = |weight: f32| {
        let mut fit = fitted.fit.clone();
        fit.nudges
            .extend(jaw_displacements.iter().map(|&(v, d)| (v, d * weight)));
        FittedMask::new(mask.clone(), fit)
    };
    let open = Registration::new(head.clone(), with_jaw(dropped));
    let spec: AlgoSpec = DEFAULT_ALGORITHM.parse().expect("the default spec is valid");
    let binding = bind(&open, &spec);
    let mut scratch = binding.scratch(open.mask_rest().len(), open.mask_triangles().len());
    let mut animation = vec![0.0; mask.animation_units.len()];
    let mut mask_now = vec![Vec3::ZERO; open.mask_rest().len()];
    let mut closed = head.positions.clone();
    let mut raise_jaw = |raise: f32, closed: &mut Vec<Vec3>| {
        animation[jaw] = -raise;
        open.fitted.pose_into(&animation, &mut mask_now);
        binding.deform(
            &head.positions,
            open.mask_rest(),
            &mask_now,
            open.mask_triangles(),
            &mut scratch,
            closed,
        );
        // Read under the mask as it will lie on the closed head, as the registration is.
        mouth_opening(closed, &head.triangles, &with_jaw(dropped - raise)).is_closed()
    };
    // A raise that closes the mouth, then the least one that does.
    let mut high = (opening.height() / drop_per_unit) as f32;
    let mut widenings = 0;
    while !raise_jaw(high, &mut closed) {
        widenings += 1;
        if widenings > WIDENINGS {
            return Err(MouthCalibrationError::DoesNotClose {
                open_mm,
                raised_mm: (f64::from(high) * drop_per_unit * f64::from(mm_per_mask_unit)) as f32,
            });
        }
        high *= 1.5;
    }
    let mut low = 0.0;
    for _ in 0..HALVINGS {
        let middle = (low + high) / 2.0;
        if raise_jaw(middle, &mut closed) {
            high = middle;
        } else {
            low = middle;
        }
    }
    raise_jaw(high, &mut closed);
    let calibration = MouthCalibration {
        open_mm,
        raised_mm: (f64::from(high) * drop_per_unit * f64::from(mm_per_mask_unit)) as f32,
    };
    Ok(Some((
        Head::new(&head.name, closed, head.triangles.clone()),
        with_jaw(dropped - high),
        calibration,
    )))
}
