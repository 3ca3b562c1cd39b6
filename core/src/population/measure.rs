//! One member through the automatic fit, against its reference: refused or not (with the
//! reason), the landmark mask vertices' distance from the reference's (mm), the guessed
//! scale against the true one, the mask's distance to the surface, and the time taken.

use std::time::Instant;

use super::Member;
use crate::fit::{fit_automatically, mouth_opening, FaceLengths, FittedMask};
use crate::mask::Mask;

/// What the automatic fit made of a member.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Outcome {
    pub member: String,
    /// `ict`, `makehuman` or `scan`.
    pub family: &'static str,
    pub held_out: bool,
    pub vertices: usize,
    /// Wall time of the fit, s.
    pub seconds: f64,
    /// The measures, or the reason it was refused.
    pub result: Result<Measures, String>,
}

#[derive(Debug, Clone, serde::Serialize)]
pub struct Measures {
    /// The reference's landmark mask vertices against the fit's (mm, the true scale).
    pub landmark_mean_mm: f32,
    pub landmark_max_mm: f32,
    /// The landmark mask vertex furthest from the reference's.
    pub worst_vertex: u32,
    /// Guessed over true mm per unit, minus one (the standard unit the pupils' guess was
    /// taken as, when it was).
    pub scale_error: f32,
    /// What 63 mm pupils alone gave, over the true mm per unit, minus one.
    pub pupils_scale_error: f32,
    /// How far apart the fit reads the lips at rest (mm, true scale; the fit report's
    /// `inner_lip_gap_mm`). The members' own lips stand at most a few millimetres apart
    /// (2.74 mm on the population); tens of millimetres is a misreading that registration
    /// would "close" by raising the jaw into lips that meet.
    pub lips_apart_mm: f32,
    /// The fit's own score: the mask's mean capped distance to the surface, mm (true scale).
    pub surface_mm: f32,
    /// How sure the learned model was that it saw a face, and how far the fit's marked
    /// vertices lie from its marks on average (mm, true scale); not a confidence: neither ranks
    /// the fits by their error (docs/FITTING.md, "On a population").
    pub face_probability: f32,
    pub marks_mean_mm: f32,
    /// Each mark's offset from its mask vertex (mask axes, mm, true scale).
    pub mark_offsets_mm: Vec<(u32, [f32; 3])>,
    /// What the fit asks a person to check ([`crate::fit::AutomaticFitWarning`]).
    pub warnings: Vec<crate::fit::AutomaticFitWarning>,
    /// The learned reading's face-mesh points (`None`: not seen on the surface) and the
    /// reference's marked vertices, in the fitted mask's frame (mask units, mask axes):
    /// what `tools/face_marks/train.py` learns the marks from.
    pub face_points_mask_units: Vec<Option<[f32; 3]>>,
    pub reference_mask_units: Vec<(u32, [f32; 3])>,
    /// Millimetres per mask unit at the true scale.
    pub mm_per_mask_unit: f32,
    /// Lengths across the fitted face (mm, true scale): what `tools/unit_guess/train.py`
    /// learns the unit guess from.
    pub face_lengths_mm: FaceLengths,
}

/// Fits `member` automatically (scale guessed) and compares it with its reference.
pub fn measure(member: &Member, mask: &Mask) -> Outcome {
    let started = Instant::now();
    let fitted = fit_automatically(&member.head, mask, None);
    let seconds = started.elapsed().as_secs_f64();
    let result = fitted.map_err(|e| e.to_string()).map(|automatic| {
        let scale = automatic.fit.pose.scale.x;
        let to_mask_axes = automatic.fit.pose.rotation().transpose();
        let pose = automatic.fit.pose;
        let score = automatic.score;
        let guessed_mm = automatic.fit.mm_per_unit;
        let pupils_mm = automatic.pupils_mm_per_unit.unwrap_or(guessed_mm);
        let reading = automatic.reading;
        let warnings = automatic.warnings;
        let fitted = FittedMask::new(mask.clone(), automatic.fit);
        let lips_apart_mm = mouth_opening(&member.head.positions, &member.head.triangles, &fitted).height()
            as f32
            * scale
            * member.mm_per_unit;
        let face_lengths_mm = FaceLengths::measure(&fitted.base).scaled(scale * member.mm_per_unit);
        let neutral = fitted.neutral;
        // Each reference vertex with the fitted vertex it is compared with: a mirrored
        // head's left is the mask's right.
        let references: Vec<(u32, glam::Vec3)> = member
            .reference
            .iter()
            .map(|&(vertex, reference)| match member.mirrored {
                true => (mask.mirror_partner(vertex), reference),
                false => (vertex, reference),
            })
            .collect();
        let distances: Vec<f32> = references
            .iter()
            .map(|&(vertex, reference)| neutral[vertex as usize].distance(reference) * member.mm_per_unit)
            .collect();
        let worst = (0..distances.len())
            .max_by(|&a, &b| distances[a].total_cmp(&distances[b]))
            .unwrap_or(0);
        let into_mask = |p: glam::Vec3| (to_mask_axes * (p - pose.translation) / scale).to_array();
        let face_points_mask_units = reading.points.iter().map(|p| p.map(into_mask)).collect();
        let reference_mask_units = references
            .iter()
            .map(|&(vertex, reference)| (vertex, into_mask(reference)))
            .collect();
        Measures {
            warnings,
            face_points_mask_units,
            reference_mask_units,
            mm_per_mask_unit: scale * member.mm_per_unit,
            face_lengths_mm,
            landmark_mean_mm: distances.iter().sum::<f32>() / distances.len() as f32,
            landmark_max_mm: distances.iter().copied().fold(0.0, f32::max),
            worst_vertex: member.reference.get(worst).map_or(0, |&(vertex, _)| vertex),
            scale_error: guessed_mm / member.mm_per_unit - 1.0,
            pupils_scale_error: pupils_mm / member.mm_per_unit - 1.0,
            lips_apart_mm,
            surface_mm: score as f32 * scale * member.mm_per_unit,
            face_probability: reading.face_probability,
            marks_mean_mm: reading.marks_mean_mm / guessed_mm * member.mm_per_unit,
            mark_offsets_mm: reading
                .mark_offsets_mm
                .iter()
                .map(|&(vertex, offset)| (vertex, offset.map(|c| c / guessed_mm * member.mm_per_unit)))
                .collect(),
        }
    });
    Outcome {
        member: member.spec.name(),
        family: member.spec.source.family(),
        held_out: member.spec.held_out,
        vertices: member.head.positions.len(),
        seconds,
        result,
    }
}
