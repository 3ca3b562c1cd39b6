//! The ranges a fit's numbers must lie in (docs/FITTING.md, "What a fit may hold").
//!
//! Finite is not enough: `scale = 1e30` or `mm_per_unit = 1e-30` parse, and then every
//! radius in millimetres turns into zero or infinity head units downstream. The ranges are
//! twelve orders of magnitude wide, far beyond any head in any unit, and narrow enough
//! that products of them stay finite in f32. Whether the mask lands on the head is checked
//! where both are known ([`crate::deform::Registration::try_new`]).

use glam::Vec3;

use super::Fit;

/// Head units per mask unit. The shipped fits use 0.90 (decimetres) and 1.80 (about 5 cm);
/// a head in metres or micrometres still lies far inside.
pub const SCALE_RANGE: [f32; 2] = [1e-6, 1e6];

/// Millimetres per head unit: 100 for decimetres, 1 for millimetres, 1e6 for kilometres.
pub const MM_PER_UNIT_RANGE: [f32; 2] = [1e-6, 1e6];

/// The longest side of a head's bounding box, head units: the mask is a few mask units
/// across, so a head outside this has no fit within [`SCALE_RANGE`].
pub const HEAD_EXTENT_RANGE: [f32; 2] = [1e-6, 1e7];

/// A value outside its range, naming the field.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {reason}")]
pub struct RangeError {
    pub field: String,
    pub reason: String,
}

/// `value` if it is finite and within `[min, max]`.
pub fn in_range(field: &str, value: f32, [min, max]: [f32; 2]) -> Result<f32, RangeError> {
    if value.is_finite() && (min..=max).contains(&value) {
        Ok(value)
    } else {
        Err(RangeError {
            field: field.to_string(),
            reason: format!("{value} is not a number in [{min:e}, {max:e}]"),
        })
    }
}

/// `value` if every component is finite.
pub fn finite3(field: &str, value: [f32; 3]) -> Result<Vec3, RangeError> {
    if value.iter().all(|x| x.is_finite()) {
        Ok(Vec3::from_array(value))
    } else {
        Err(RangeError {
            field: field.to_string(),
            reason: format!("{value:?} is not finite"),
        })
    }
}

/// A head a fit can be found for: its longest side within [`HEAD_EXTENT_RANGE`] and no
/// coordinate past [`crate::head::obj::MAX_COORDINATE`] (where nearest-point queries stop
/// being finite).
pub fn check_head_extent(positions: &[Vec3]) -> Result<(), RangeError> {
    let farthest = positions
        .iter()
        .map(|p| p.abs().max_element())
        .fold(0.0_f32, f32::max);
    let limit = crate::head::obj::MAX_COORDINATE;
    if farthest.is_nan() || farthest > limit {
        return Err(RangeError {
            field: "head coordinates".into(),
            reason: format!("a vertex lies {farthest:e} head units out; at most {limit:e}"),
        });
    }
    let size = crate::head::Bounds::of(positions).size().max_element();
    in_range("head size (longest side, head units)", size, HEAD_EXTENT_RANGE)?;
    Ok(())
}

impl Fit {
    /// Checks every number of the fit: scale and `mm_per_unit` within their ranges, the
    /// rest finite.
    pub fn check_ranges(&self) -> Result<(), RangeError> {
        let pose = &self.pose;
        for s in pose.scale.to_array() {
            in_range("scale", s, SCALE_RANGE)?;
        }
        finite3("rotation", pose.rotation_rad.to_array())?;
        finite3("translation", pose.translation.to_array())?;
        for (i, &w) in self.shape.iter().enumerate() {
            if !w.is_finite() {
                return Err(RangeError {
                    field: format!("shape[{i}]"),
                    reason: format!("{w} is not finite"),
                });
            }
        }
        for (i, &(_, offset)) in self.nudges.iter().enumerate() {
            finite3(&format!("nudge[{i}].offset"), offset.to_array())?;
        }
        in_range("mm_per_unit", self.mm_per_unit, MM_PER_UNIT_RANGE)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mask::MaskPose;

    #[test]
    fn ranges_refuse_extremes_and_name_the_field() {
        assert_eq!(in_range("scale", 0.55, SCALE_RANGE), Ok(0.55));
        for bad in [0.0, -5.0, 1e30, 1e-30, f32::NAN, f32::INFINITY] {
            let err = in_range("mm_per_unit", bad, MM_PER_UNIT_RANGE).unwrap_err();
            assert_eq!(err.field, "mm_per_unit");
            assert!(
                err.to_string().ends_with("is not a number in [1e-6, 1e6]"),
                "{err}"
            );
        }
        let fit = Fit {
            pose: MaskPose::similarity(Vec3::ZERO, 1e30, Vec3::ZERO),
            shape: vec![0.0; 14],
            nudges: Vec::new(),
            mm_per_unit: 1.0,
        };
        assert_eq!(fit.check_ranges().unwrap_err().field, "scale");
        let fit = Fit {
            pose: MaskPose::similarity(Vec3::ZERO, 1.0, Vec3::ZERO),
            mm_per_unit: 1e-30,
            ..fit
        };
        assert_eq!(fit.check_ranges().unwrap_err().field, "mm_per_unit");
    }
}
