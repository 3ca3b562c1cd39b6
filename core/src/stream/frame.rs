//! The one in-memory frame every stream format reads into and writes from: data only
//! (what poses the mask with it is [`super::poser`]).
//!
//! A frame is a full state, not a change: whatever it does not mention is at rest. It can
//! carry parameters in three vocabularies at once (CANDIDE animation units, MPEG-4 FAP
//! counts, ARKit blendshape weights); the first two add up in
//! [`super::poser::animation_weights`], the ARKit weights (through a retarget basis) and
//! raw controls in [`super::poser::mask_offsets`].

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
/// mask in two parts: animation-unit weights ([`super::poser::animation_weights`]:
/// `animation` and `faps`) and per-vertex offsets ([`super::poser::mask_offsets`]:
/// `controls` and the `arkit` weights through an [`super::ArkitBasis`]), which
/// `FittedMask::pose_with_offsets_into` combines.
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
