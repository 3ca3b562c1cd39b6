//! The fields both viewer frame layouts carry with the same bytes: lip roughness, rigid
//! motions, lip folds and heat values, each written and read (with its checks) once.

use super::{FrameHeader, LipFolds, LipRoughness, RigidMotion};
use crate::{DecodeError, Reader, Writer};

/// How far from 1 a rotation quaternion's length may be (f32 rounding is 1e-7).
const UNIT_QUATERNION_TOLERANCE: f32 = 1e-4;

/// seq (u64), producer_time_s (f64), server_receive_us (u64), server_send_us (u64).
pub(super) fn write_timing(out: &mut Vec<u8>, header: &FrameHeader) {
    out.put_u64(header.seq);
    out.put_f64(header.producer_time_s);
    out.put_u64(header.server_receive_us);
    out.put_u64(header.server_send_us);
}

pub(super) fn read_timing(r: &mut Reader<'_>) -> Result<FrameHeader, DecodeError> {
    Ok(FrameHeader {
        seq: r.u64("seq")?,
        producer_time_s: r.f64("producer_time_s")?,
        server_receive_us: r.u64("server_receive_us")?,
        server_send_us: r.u64("server_send_us")?,
    })
}

/// min, max, mean (3 x f32), n (u8), n x f32.
pub(super) fn write_lip(out: &mut Vec<u8>, lip: &LipRoughness) {
    out.put_f32s(&[lip.min, lip.max, lip.mean]);
    let count = lip.per_vertex.len().min(255);
    out.put_u8(count as u8);
    out.put_f32s(&lip.per_vertex[..count]);
}

pub(super) fn read_lip(r: &mut Reader<'_>) -> Result<LipRoughness, DecodeError> {
    let (min, max, mean) = (r.f32("lip min")?, r.f32("lip max")?, r.f32("lip mean")?);
    let count = r.u8("lip_count")?;
    let per_vertex = (0..count)
        .map(|_| r.f32("lip roughness"))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(LipRoughness {
        min,
        max,
        mean,
        per_vertex,
    })
}

/// Rotation x, y, z, w, then translation x, y, z (7 x f32).
pub(super) fn write_motion(out: &mut Vec<u8>, motion: &RigidMotion) {
    out.put_f32s(&motion.rotation);
    out.put_f32s(&motion.translation);
}

/// A rigid motion: finite numbers, a unit rotation quaternion.
pub(super) fn read_motion(r: &mut Reader<'_>, field: &'static str) -> Result<RigidMotion, DecodeError> {
    let at = r.position();
    let mut values = [0.0f32; 7];
    for x in &mut values {
        *x = r.f32(field)?;
    }
    let invalid = |problem: String| DecodeError::Invalid { field, at, problem };
    if values.iter().any(|x| !x.is_finite()) {
        return Err(invalid(format!("not finite: {values:?}")));
    }
    let rotation = [values[0], values[1], values[2], values[3]];
    let length = rotation.iter().map(|x| x * x).sum::<f32>().sqrt();
    if (length - 1.0).abs() > UNIT_QUATERNION_TOLERANCE {
        return Err(invalid(format!("rotation quaternion of length {length}, not 1")));
    }
    Ok(RigidMotion {
        rotation,
        translation: [values[4], values[5], values[6]],
    })
}

/// turned_over_60 (u16), turned_over_90 (u16), max_dihedral_increase_deg (f32).
pub(super) fn write_folds(out: &mut Vec<u8>, folds: &LipFolds) {
    out.put_u16(folds.turned_over_60);
    out.put_u16(folds.turned_over_90);
    out.put_f32(folds.max_dihedral_increase_deg);
}

/// Lip folds, refusing a largest increase that is not finite or is negative.
pub(super) fn read_folds(r: &mut Reader<'_>) -> Result<LipFolds, DecodeError> {
    let turned_over_60 = r.u16("lip folds")?;
    let turned_over_90 = r.u16("lip folds")?;
    let at = r.position();
    let max_dihedral_increase_deg = r.f32("lip folds")?;
    if !(max_dihedral_increase_deg.is_finite() && max_dihedral_increase_deg >= 0.0) {
        return Err(DecodeError::Invalid {
            field: "lip folds",
            at,
            problem: format!("largest dihedral increase {max_dihedral_increase_deg}"),
        });
    }
    Ok(LipFolds {
        turned_over_60,
        turned_over_90,
        max_dihedral_increase_deg,
    })
}

/// Heat values travel as their largest finite value and one byte per value, value / max
/// x 255 rounded: appends the max (f32), then, after whatever `between` writes, the bytes.
pub(super) fn write_heat(out: &mut Vec<u8>, values: &[f32], between: impl FnOnce(&mut Vec<u8>)) {
    let max = values
        .iter()
        .copied()
        .filter(|x| x.is_finite())
        .fold(0.0f32, f32::max);
    out.put_f32(max);
    between(out);
    out.extend(values.iter().map(|&x| {
        if max > 0.0 && x.is_finite() {
            (x / max * 255.0).round().clamp(0.0, 255.0) as u8
        } else {
            0
        }
    }));
}

/// `count` heat bytes after `max`: value = byte / 255 x max.
pub(super) fn read_heat(r: &mut Reader<'_>, max: f32, count: usize) -> Result<Vec<f32>, DecodeError> {
    let bytes = r.take(count, "heat")?;
    Ok(bytes.iter().map(|&b| f32::from(b) / 255.0 * max).collect())
}
