//! The one in-memory frame every stream format reads into and writes from, and its
//! conversion to the 65 CANDIDE-3 animation-unit weights that pose the mask.
//!
//! A frame is a full state, not a change: whatever it does not mention is at rest. It can
//! carry parameters in three vocabularies at once (CANDIDE animation units, MPEG-4 FAP
//! counts, ARKit blendshape weights); the first two add up in [`Frame::animation_weights`],
//! the ARKit weights (through a retarget basis) and raw controls in [`Frame::mask_offsets`].

use glam::Vec3;

use super::arkit::ArkitBasis;
use crate::mask::{FapuValues, Mask, UnitKind};

/// Radians per FAP count of an angle FAP (the MPEG-4 unit AU).
pub const RADIANS_PER_ANGLE_COUNT: f32 = 1e-5;

/// FAP numbers of the head rotation: pitch (rx), yaw (ry), roll (rz). MPEG-4's positive
/// directions (pitch down, yaw to the face's left, roll to the face's right) are those of
/// [`crate::mask::MaskPose`]'s rx, ry and rz, so the counts map with no sign change.
pub const HEAD_ROTATION_FAPS: [u8; 3] = [48, 49, 50];

/// MPEG-4 FAP 1, the high-level viseme: a blend of two of the standard's 14 visemes, kept
/// as read (integers as in a `.fap` file). It moves the mask through the mouth shapes of
/// [`super::visemes::VISEMES`] (text-to-speech viseme IDs arrive as one of these).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct VisemeFap {
    /// `viseme_select1`: first viseme, 0..=14.
    pub select1: i32,
    /// `viseme_select2`: second viseme, 0..=14.
    pub select2: i32,
    /// `viseme_blend`: 0..=63, weight of the first viseme in 63ths.
    pub blend: i32,
    /// `viseme_def`: 1 when the frame (re)defines the viseme rather than using it.
    pub definition: i32,
}

impl VisemeFap {
    /// The viseme a viewer frame names (`FWF2`'s `viseme` section): the shape used, not
    /// one being defined, with its selects and blend in MPEG-4's ranges; `None` otherwise.
    pub fn to_wire(self) -> Option<facewire_proto::viewer_frame::FrameViseme> {
        let byte = |x: i32, max: i32| u8::try_from(x).ok().filter(|_| (0..=max).contains(&x));
        if self.definition != 0 {
            return None;
        }
        Some(facewire_proto::viewer_frame::FrameViseme {
            select1: byte(self.select1, 14)?,
            select2: byte(self.select2, 14)?,
            blend: byte(self.blend, 63)?,
        })
    }
}

/// MPEG-4 FAP 2, the high-level expression: two of the six standard expressions with
/// intensities, kept as read. It moves the mask through the shapes of
/// [`super::expressions::EXPRESSIONS`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct ExpressionFap {
    /// `expression_select1`: 0..=6 (neutral, joy, sadness, anger, fear, disgust, surprise).
    pub select1: i32,
    /// `expression_intensity1`: 0..=63.
    pub intensity1: i32,
    /// `expression_select2`.
    pub select2: i32,
    /// `expression_intensity2`.
    pub intensity2: i32,
    /// `init_face`: 1 when the expression also sets the neutral face.
    pub init_face: i32,
    /// `expression_def`: 1 when the frame (re)defines the expression.
    pub definition: i32,
}

/// One frame of facial-animation parameters, whatever format it came from.
///
/// Readers return the sparse lists sorted by index with no index twice. A frame moves the
/// mask in two parts: animation-unit weights ([`Frame::animation_weights`]: `animation`
/// and `faps`) and per-vertex offsets ([`Frame::mask_offsets`]: `controls` and the `arkit`
/// weights through an [`ArkitBasis`]), which `FittedMask::pose_with_offsets_into` combines.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Frame {
    /// Producer sequence number; strictly increasing along a stream.
    pub seq: u64,
    /// Producer timestamp, seconds; never decreasing along a stream.
    pub time_s: f64,
    /// What is being said (a syllable), if known.
    pub label: Option<String>,
    /// CANDIDE-3 animation unit index -> weight, in mask units along the unit's stored
    /// direction (for a FAP unit, whose direction has length 1, that is a distance).
    pub animation: Vec<(u16, f32)>,
    /// MPEG-4 FAP number (3..=68) -> value in FAP counts: 1024ths of the FAP's FAPU0, or
    /// 1e-5 rad for angle FAPs. FAPs 1 and 2 live in `viseme` and `expression`.
    pub faps: Vec<(u8, f32)>,
    /// Index into [`ARKIT_BLENDSHAPES`] -> weight in 0..=1.
    pub arkit: Vec<(u8, f32)>,
    /// Head rotation (rx, ry, rz), radians, in [`crate::mask::MaskPose`]'s convention.
    pub head_rotation_rad: Option<[f32; 3]>,
    /// Head translation, mask units.
    pub head_translation: Option<[f32; 3]>,
    /// Raw control displacement of every mask vertex, mask units (tests and tools that
    /// bypass the parameters).
    pub controls: Option<Vec<[f32; 3]>>,
    /// FAP 1 (high-level viseme), when the source had it.
    pub viseme: Option<VisemeFap>,
    /// FAP 2 (high-level expression), when the source had it.
    pub expression: Option<ExpressionFap>,
}

impl Frame {
    /// The kinds of content this frame carries, named by the JSONL field that holds them:
    /// `au`, `fap` (FAPs 1 and 2 included), `arkit`, `head_rotation_rad`,
    /// `head_translation`, `controls`. A writer refuses the kinds its format cannot hold
    /// rather than dropping them.
    pub fn content(&self) -> impl Iterator<Item = &'static str> {
        [
            ("au", !self.animation.is_empty()),
            (
                "fap",
                !self.faps.is_empty() || self.viseme.is_some() || self.expression.is_some(),
            ),
            ("arkit", !self.arkit.is_empty()),
            ("head_rotation_rad", self.head_rotation_rad.is_some()),
            ("head_translation", self.head_translation.is_some()),
            ("controls", self.controls.is_some()),
        ]
        .into_iter()
        .filter_map(|(field, present)| present.then_some(field))
    }

    /// An empty frame (the mask at rest) with a sequence number and a time.
    pub fn at(seq: u64, time_s: f64) -> Frame {
        Frame {
            seq,
            time_s,
            ..Frame::default()
        }
    }

    /// Fills `out` with the animation-unit weights of this frame (`out` is zeroed first;
    /// pass one slot per animation unit of `mask`, 65 for CANDIDE-3). The weights are the
    /// sum of the `animation` entries and of the FAPs CANDIDE implements, each FAP count
    /// converted with `fapu` (`FapuValues::weight`), FAP 1's viseme as its mouth shape
    /// ([`super::visemes::add_viseme`]) and FAP 2's expressions as theirs
    /// ([`super::expressions::add_expression`]). FAPs the mask has no unit for (the head
    /// rotation 48-50, which [`Frame::head_rotation`] returns, the tongue 43-47,
    /// which shape a head's tongue part in `crate::animate::TongueShaper`, and the ears
    /// 65-68), ARKit weights ([`Frame::mask_offsets`] has them) and indices
    /// beyond `out` are left out.
    /// Allocates nothing.
    pub fn animation_weights(&self, mask: &Mask, fapu: &FapuValues, out: &mut [f32]) {
        out.fill(0.0);
        for &(unit, weight) in &self.animation {
            if let Some(slot) = out.get_mut(usize::from(unit)) {
                *slot += weight;
            }
        }
        for &(fap, count) in &self.faps {
            let Some(unit) = mask.fap_unit(fap) else {
                continue;
            };
            if let (UnitKind::Fap { fapu: kind, .. }, Some(slot)) =
                (&mask.animation_units[unit].kind, out.get_mut(unit))
            {
                *slot += fapu.weight(*kind, count);
            }
        }
        if let Some(viseme) = &self.viseme {
            super::visemes::add_viseme(viseme, out);
        }
        if let Some(expression) = &self.expression {
            super::expressions::add_expression(expression, out);
        }
    }

    /// Fills `out` with this frame's per-vertex offsets of the mask, mask units (`out` is
    /// zeroed first; pass one slot per mask vertex, 113 for CANDIDE-3): the raw `controls`
    /// plus the `arkit` weights retargeted through `basis` (`sum_k w_k B_k`). Entries
    /// beyond `out` are left out. Allocates nothing.
    ///
    /// With [`Frame::animation_weights`] this is the whole per-frame path:
    /// `fitted.pose_with_offsets_into(&weights, &offsets, &mut posed)`.
    pub fn mask_offsets(&self, basis: &ArkitBasis, out: &mut [Vec3]) {
        out.fill(Vec3::ZERO);
        for (slot, control) in out.iter_mut().zip(self.controls.iter().flatten()) {
            *slot += Vec3::from_array(*control);
        }
        basis.apply(&self.arkit, out);
    }

    /// Head rotation (rx, ry, rz) in radians: `head_rotation_rad` plus FAPs 48 (pitch,
    /// rx), 49 (yaw, ry) and 50 (roll, rz) at 1e-5 rad per count. Zero when the frame has
    /// neither.
    pub fn head_rotation(&self) -> [f32; 3] {
        let mut rotation = self.head_rotation_rad.unwrap_or([0.0; 3]);
        for &(fap, count) in &self.faps {
            if let Some(axis) = HEAD_ROTATION_FAPS.iter().position(|&f| f == fap) {
                rotation[axis] += count * RADIANS_PER_ANGLE_COUNT;
            }
        }
        rotation
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_add_animation_units_and_converted_faps() {
        let mask = Mask::candide3();
        let fapu = FapuValues::measure(&mask.vertices);
        let frame = Frame {
            animation: vec![(1, 0.25), (11, 0.01)],
            // open_jaw 512 counts = half an MNS; head pitch is not a unit; tongue neither.
            faps: vec![(3, 512.0), (44, 100.0), (48, 1000.0)],
            arkit: vec![(17, 1.0)],
            ..Frame::default()
        };
        let mut out = [7.0; 65];
        frame.animation_weights(&mask, &fapu, &mut out);
        assert_eq!(out[1], 0.25);
        assert!((out[11] - (0.01 + 0.5 * 0.196)).abs() < 1e-6, "{}", out[11]);
        let moved: Vec<usize> = (0..65).filter(|&i| out[i] != 0.0).collect();
        assert_eq!(moved, [1, 11]);
    }

    #[test]
    fn angle_faps_use_the_eyeball_radius() {
        let mask = Mask::candide3();
        let fapu = FapuValues::measure(&mask.vertices);
        let frame = Frame {
            faps: vec![(23, 100_000.0)], // yaw_l_eyeball, 1 rad
            ..Frame::default()
        };
        let mut out = [0.0; 65];
        frame.animation_weights(&mask, &fapu, &mut out);
        assert!((out[31] - 0.085).abs() < 1e-6, "{}", out[31]);
    }

    #[test]
    fn offsets_add_controls_and_retargeted_arkit_weights() {
        let basis = ArkitBasis::parse("b", "jawOpen 1 0 -0.5 0\nmouthClose 2 0 0.25 0\n").unwrap();
        let mut controls = vec![[0.0; 3]; 3];
        controls[1] = [0.1, 0.0, 0.0];
        let frame = Frame {
            controls: Some(controls),
            arkit: vec![(17, 0.5), (18, 1.0)],
            ..Frame::default()
        };
        let mut out = [Vec3::ONE; 3];
        frame.mask_offsets(&basis, &mut out);
        assert_eq!(
            out,
            [Vec3::ZERO, Vec3::new(0.1, -0.25, 0.0), Vec3::new(0.0, 0.25, 0.0)]
        );
        Frame::default().mask_offsets(&basis, &mut out);
        assert_eq!(out, [Vec3::ZERO; 3]);
    }

    #[test]
    fn head_rotation_combines_radians_and_faps() {
        let frame = Frame {
            head_rotation_rad: Some([0.1, 0.0, -0.2]),
            faps: vec![(48, 1000.0), (49, -2000.0), (50, 500.0), (3, 9.0)],
            ..Frame::default()
        };
        let [rx, ry, rz] = frame.head_rotation();
        assert!((rx - 0.11).abs() < 1e-7);
        assert!((ry + 0.02).abs() < 1e-7);
        assert!((rz + 0.195).abs() < 1e-7);
        assert_eq!(Frame::default().head_rotation(), [0.0; 3]);
    }
}
