//! The one validation every frame passes, whatever brought it: a JSONL line or WebSocket
//! text message, a `.fap` or AU text file, or a binary `FWP1` message. Each format's reader
//! checks its own syntax; this module checks what the values mean (indices that exist, each
//! at most once, sorted) and keeps every number inside documented bounds, so that the same
//! frame content is refused the same way in every format and no finite but absurd value
//! (an AU weight of 3.4e38) can make the posed mask or the deformed head non-finite.
//!
//! The bounds are far beyond any real stream (docs/STREAMS.md section 1 says where each
//! comes from) and keep all per-frame arithmetic in `f32` many orders of magnitude from
//! overflow. A value outside them is refused, never clamped.

use std::f32::consts::TAU;

use facewire_proto::param_frame::{ParamFrame, ParamViseme};

use super::blendshapes::ARKIT_BLENDSHAPES;
use super::error::{Location, StreamError};
use super::frame::{Frame, VisemeFap, RADIANS_PER_ANGLE_COUNT};
use super::visemes::VisemeScheme;
use crate::mask::fap::{fap_info, Fapu};
use crate::mask::{Mask, UnknownUnit};

/// Largest sequence number: 2^53 - 1, the largest integer a JSON client reading numbers
/// as doubles (JavaScript) gets exactly, in acks and in viewer frames.
pub const MAX_SEQ: u64 = (1 << 53) - 1;
/// Largest timestamp, seconds: room for clocks counted from the stream's start and for
/// Unix-epoch seconds (1.7e9 in 2025) until the year 2286.
pub const MAX_TIME_S: f64 = 1e10;
/// Longest label, UTF-8 bytes: what the binary formats (FWP2, FWF2 and the frozen FWP1,
/// FWF1) can carry.
pub const MAX_LABEL_BYTES: usize = 255;
/// Largest |weight| of an animation unit (mask units along its direction) or an ARKit
/// blendshape: ten times a full expression. CANDIDE-3 units move a vertex at most 1.42
/// mask units per unit weight; real streams stay within -1..=1 (the syllable stream
/// within 0.7, ARKit trackers within 0..=1).
pub const MAX_WEIGHT: f32 = 10.0;
/// Largest |value| of a linear FAP, counts (1024ths of its FAPU): about 100 FAPU, over 50
/// times the widest range in Greta's FAP editor (1860) and the 3622 of the Xface file.
pub const MAX_FAP_COUNT: f32 = 100_000.0;
/// Largest |value| of an angle FAP, counts of 1e-5 rad: one full turn.
pub const MAX_FAP_ANGLE_COUNT: f32 = TAU / RADIANS_PER_ANGLE_COUNT;
/// Largest |head rotation| about each axis, radians: one full turn.
pub const MAX_ROTATION_RAD: f32 = TAU;
/// Largest |head translation| along each axis, mask units (about 10 m on an adult head).
pub const MAX_TRANSLATION: f32 = 100.0;
/// Largest |control displacement| along each axis, mask units (about 1 m; the mask is
/// about 2 units tall).
pub const MAX_CONTROL: f32 = 10.0;
/// Lowest frame rate of a `.fap` header or an AU text reader, frames per second: a frame
/// every 100 s (`1e-300` would put frame 1 past any time).
pub const MIN_FPS: f64 = 0.01;
/// Highest frame rate of a `.fap` header or an AU text reader, frames per second.
pub const MAX_FPS: f64 = 1000.0;
/// What a frame rate must be, as error messages say it.
pub(crate) const FPS_EXPECTED: &str = "a frame rate from 0.01 to 1000 frames per second";

/// Whether `fps` is within [`MIN_FPS`]..=[`MAX_FPS`] (NaN is not).
pub(crate) fn fps_in_range(fps: f64) -> bool {
    (MIN_FPS..=MAX_FPS).contains(&fps)
}

/// What a list entry's value must be within, for the error message.
struct Bound {
    limit: f32,
    unit: &'static str,
}

impl Frame {
    /// Checks everything a frame's values must satisfy, whichever format it came from:
    ///
    /// - `seq` <= [`MAX_SEQ`]; `t` finite, 0 <= `t` <= [`MAX_TIME_S`];
    /// - the label at most [`MAX_LABEL_BYTES`] bytes;
    /// - `animation` units that `mask` has, `faps` 3..=68 (FAPs 1 and 2 are `viseme` and
    ///   `expression`), `arkit` indices 0..52; each list sorted by index, no index twice;
    /// - every number finite and within its bound: weights [`MAX_WEIGHT`], FAP counts
    ///   [`MAX_FAP_COUNT`] (angle FAPs [`MAX_FAP_ANGLE_COUNT`]), [`MAX_ROTATION_RAD`],
    ///   [`MAX_TRANSLATION`], [`MAX_CONTROL`]; `controls` one per mask vertex;
    /// - `viseme` and `expression` fields in MPEG-4's ranges.
    ///
    /// Errors are located at the frame (`frame 12: au.jaw_drop: ...`) and name the field
    /// as JSONL does; [`StreamError::field`] gives the top-level name (`au`). The readers
    /// run the same check and locate its errors at their line.
    pub fn check(&self, mask: &Mask) -> Result<(), StreamError> {
        self.check_at(&Location::Frame { seq: self.seq }, Some(mask))
    }

    /// A binary `FWP1` frame as a [`Frame`], after [`Frame::check`]: FWP1 and JSONL
    /// refuse the same content with the same error and field. The lists may come in any
    /// order (they are sorted by index); an index given twice is refused.
    pub fn from_param_frame(p: ParamFrame, mask: &Mask) -> Result<Frame, StreamError> {
        let at = Location::Frame { seq: p.seq };
        let tts = |scheme: VisemeScheme, id: u8| {
            scheme
                .fap1(i64::from(id), &id.to_string())
                .map_err(|message| StreamError::syntax(&at, &format!("viseme.{}", scheme.key()), message))
        };
        let viseme = match p.viseme {
            None => None,
            Some(ParamViseme::Fap1 {
                select1,
                select2,
                blend,
                definition,
            }) => Some(VisemeFap {
                select1: select1.into(),
                select2: select2.into(),
                blend: blend.into(),
                definition: definition.into(),
            }),
            Some(ParamViseme::Oculus(id)) => Some(tts(VisemeScheme::Oculus, id)?),
            Some(ParamViseme::Microsoft(id)) => Some(tts(VisemeScheme::Microsoft, id)?),
        };
        let mut frame = Frame {
            label: p.label,
            animation: p.animation,
            faps: p.faps,
            arkit: p.arkit,
            head_rotation_rad: p.head_rotation_rad,
            head_translation: p.head_translation,
            viseme,
            ..Frame::at(p.seq, p.time_s)
        };
        frame.animation.sort_unstable_by_key(|&(unit, _)| unit);
        frame.faps.sort_unstable_by_key(|&(fap, _)| fap);
        frame.arkit.sort_unstable_by_key(|&(index, _)| index);
        frame.check(mask)?;
        Ok(frame)
    }

    /// [`Frame::check`] with errors located at `at`. Without a mask (the `.fap` reader,
    /// whose frames have no animation units or controls, and the `.fap` and AU text
    /// writers, which check units their own way), animation units are named by index and
    /// not looked up, and the length of `controls` is not checked.
    pub(crate) fn check_at(&self, at: &Location, mask: Option<&Mask>) -> Result<(), StreamError> {
        let out_of_range = |field: String, found: String, expected: String| StreamError::OutOfRange {
            at: at.clone(),
            field,
            found,
            expected,
        };
        if self.seq > MAX_SEQ {
            return Err(out_of_range(
                "seq".into(),
                self.seq.to_string(),
                format!("at most {MAX_SEQ} (2^53 - 1)"),
            ));
        }
        if !self.time_s.is_finite() {
            return Err(not_finite(at, "t".into(), format!("{:?}", self.time_s)));
        }
        if !(0.0..=MAX_TIME_S).contains(&self.time_s) {
            return Err(out_of_range(
                "t".into(),
                format!("{:?}", self.time_s),
                format!("0 to {MAX_TIME_S:e} s"),
            ));
        }
        if let Some(label) = self.label.as_deref().filter(|l| l.len() > MAX_LABEL_BYTES) {
            return Err(out_of_range(
                "label".into(),
                format!("{} bytes", label.len()),
                format!("at most {MAX_LABEL_BYTES} bytes of UTF-8"),
            ));
        }

        let weight = Bound {
            limit: MAX_WEIGHT,
            unit: "",
        };
        check_list(at, "au", "animation unit", &self.animation, |unit| {
            let Some(mask) = mask else {
                return Ok((unit.to_string(), &weight));
            };
            match mask.animation_units.get(usize::from(unit)) {
                Some(u) => Ok((u.key.clone(), &weight)),
                None => Err(StreamError::UnknownUnit {
                    at: at.clone(),
                    field: format!("au.{unit}"),
                    source: Box::new(UnknownUnit {
                        what: "animation unit",
                        name: crate::quote::quote(&unit.to_string()),
                        count: mask.animation_units.len(),
                        valid: mask
                            .animation_units
                            .iter()
                            .map(|u| u.key.as_str())
                            .collect::<Vec<_>>()
                            .join(", "),
                    }),
                }),
            }
        })?;

        let linear = Bound {
            limit: MAX_FAP_COUNT,
            unit: " counts",
        };
        let angle = Bound {
            limit: MAX_FAP_ANGLE_COUNT,
            unit: " counts of 1e-5 rad",
        };
        check_list(at, "fap", "FAP", &self.faps, |fap| match fap_info(fap) {
            Some(info) if info.number <= 2 => Err(out_of_range(
                format!("fap.{}", info.name),
                format!("FAP {fap}"),
                "a FAP 3..=68: FAPs 1 and 2 are the top-level \"viseme\" and \"expression\"".into(),
            )),
            Some(info) => Ok((
                info.name.to_string(),
                if info.fapu == Some(Fapu::Au) {
                    &angle
                } else {
                    &linear
                },
            )),
            None => Err(StreamError::UnknownName {
                at: at.clone(),
                field: format!("fap.{fap}"),
                what: "FAP",
                name: fap.to_string(),
                valid: "a FAP number 3..=68".into(),
            }),
        })?;

        check_list(
            at,
            "arkit",
            "ARKit blendshape",
            &self.arkit,
            |index| match ARKIT_BLENDSHAPES.get(usize::from(index)) {
                Some(name) => Ok((name.to_string(), &weight)),
                None => Err(StreamError::UnknownName {
                    at: at.clone(),
                    field: format!("arkit.{index}"),
                    what: "ARKit blendshape",
                    name: index.to_string(),
                    valid: "an index 0..52".into(),
                }),
            },
        )?;

        let vectors = [
            (
                "head_rotation_rad",
                self.head_rotation_rad,
                MAX_ROTATION_RAD,
                " rad",
            ),
            (
                "head_translation",
                self.head_translation,
                MAX_TRANSLATION,
                " mask units",
            ),
        ];
        for (field, vector, limit, unit) in vectors {
            if let Some(vector) = vector {
                check_vec3(at, field, &vector, limit, unit)?;
            }
        }
        if let Some(controls) = &self.controls {
            if let Some(mask) = mask.filter(|m| m.vertices.len() != controls.len()) {
                return Err(StreamError::WrongLength {
                    at: at.clone(),
                    field: "controls".into(),
                    found: controls.len(),
                    expected: format!("one per mask vertex ({})", mask.vertices.len()),
                });
            }
            for (i, control) in controls.iter().enumerate() {
                check_vec3(at, &format!("controls[{i}]"), control, MAX_CONTROL, " mask units")?;
            }
        }

        if let Some(v) = &self.viseme {
            check_ints(
                at,
                "viseme",
                &[
                    ("select1", v.select1, 14),
                    ("select2", v.select2, 14),
                    ("blend", v.blend, 63),
                    ("definition", v.definition, 1),
                ],
            )?;
        }
        if let Some(e) = &self.expression {
            check_ints(
                at,
                "expression",
                &[
                    ("select1", e.select1, 6),
                    ("intensity1", e.intensity1, 63),
                    ("select2", e.select2, 6),
                    ("intensity2", e.intensity2, 63),
                    ("init_face", e.init_face, 1),
                    ("definition", e.definition, 1),
                ],
            )?;
        }
        Ok(())
    }
}

fn not_finite(at: &Location, field: String, found: String) -> StreamError {
    StreamError::NotFinite {
        at: at.clone(),
        field,
        found,
    }
}

/// Checks a sparse list: `resolve` names each index (or refuses it) and gives its bound;
/// indices must increase strictly; values must be finite and within the bound.
fn check_list<'b, I: Copy + Ord + std::fmt::Display>(
    at: &Location,
    list: &str,
    what: &'static str,
    entries: &[(I, f32)],
    mut resolve: impl FnMut(I) -> Result<(String, &'b Bound), StreamError>,
) -> Result<(), StreamError> {
    let mut previous: Option<I> = None;
    for &(index, value) in entries {
        let (name, bound) = resolve(index)?;
        let field = format!("{list}.{name}");
        match previous {
            Some(p) if p == index => {
                return Err(StreamError::Duplicate {
                    at: at.clone(),
                    field,
                    what,
                    other: "an earlier entry".into(),
                })
            }
            Some(p) if p > index => {
                return Err(StreamError::Syntax {
                    at: at.clone(),
                    field,
                    message: format!("index {index} comes after {p}: entries must be sorted by index"),
                })
            }
            _ => previous = Some(index),
        }
        if !value.is_finite() {
            return Err(not_finite(at, field, format!("{value:?}")));
        }
        if value.abs() > bound.limit {
            return Err(StreamError::OutOfRange {
                at: at.clone(),
                field,
                found: format!("{value:?}"),
                expected: format!(
                    "-{limit} to {limit}{unit}",
                    limit = bound.limit,
                    unit = bound.unit
                ),
            });
        }
    }
    Ok(())
}

fn check_vec3(
    at: &Location,
    field: &str,
    vector: &[f32; 3],
    limit: f32,
    unit: &str,
) -> Result<(), StreamError> {
    for (k, &value) in vector.iter().enumerate() {
        if !value.is_finite() {
            return Err(not_finite(at, format!("{field}[{k}]"), format!("{value:?}")));
        }
        if value.abs() > limit {
            return Err(StreamError::OutOfRange {
                at: at.clone(),
                field: format!("{field}[{k}]"),
                found: format!("{value:?}"),
                expected: format!("-{limit} to {limit}{unit}"),
            });
        }
    }
    Ok(())
}

/// Checks the integer fields of FAP 1 or 2 against `0..=max`.
fn check_ints(at: &Location, object: &str, fields: &[(&str, i32, i32)]) -> Result<(), StreamError> {
    for &(name, value, max) in fields {
        if !(0..=max).contains(&value) {
            return Err(StreamError::OutOfRange {
                at: at.clone(),
                field: format!("{object}.{name}"),
                found: value.to_string(),
                expected: format!("0..={max}"),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stream::{ExpressionFap, VisemeFap};

    #[test]
    fn bounds_are_what_the_docs_say() {
        assert_eq!(MAX_SEQ, 9_007_199_254_740_991);
        assert!((MAX_FAP_ANGLE_COUNT - 628_318.5).abs() < 0.1);
        assert_eq!(
            FPS_EXPECTED,
            format!("a frame rate from {MIN_FPS} to {MAX_FPS} frames per second")
        );
        assert!(fps_in_range(25.0) && fps_in_range(MIN_FPS) && fps_in_range(MAX_FPS));
        assert!(!fps_in_range(1e-300) && !fps_in_range(f64::NAN) && !fps_in_range(1e4));
    }

    #[test]
    fn a_frame_at_every_bound_passes_and_one_step_beyond_fails() {
        let mask = Mask::candide3();
        let edge = Frame {
            label: Some("x".repeat(MAX_LABEL_BYTES)),
            animation: vec![(0, -MAX_WEIGHT), (64, MAX_WEIGHT)],
            faps: vec![(3, MAX_FAP_COUNT), (48, -MAX_FAP_ANGLE_COUNT), (68, 0.0)],
            arkit: vec![(0, MAX_WEIGHT), (51, -MAX_WEIGHT)],
            head_rotation_rad: Some([MAX_ROTATION_RAD, -MAX_ROTATION_RAD, 0.0]),
            head_translation: Some([MAX_TRANSLATION, 0.0, -MAX_TRANSLATION]),
            controls: Some(vec![[MAX_CONTROL, -MAX_CONTROL, 0.0]; mask.vertices.len()]),
            viseme: Some(VisemeFap {
                select1: 14,
                select2: 0,
                blend: 63,
                definition: 1,
            }),
            expression: Some(ExpressionFap {
                select1: 6,
                intensity1: 63,
                select2: 0,
                intensity2: 0,
                init_face: 1,
                definition: 1,
            }),
            ..Frame::at(MAX_SEQ, MAX_TIME_S)
        };
        edge.check(&mask).unwrap();

        let beyond = |change: fn(&mut Frame)| {
            let mut frame = edge.clone();
            change(&mut frame);
            frame.check(&mask).unwrap_err()
        };
        let err = beyond(|f| f.animation[1].1 = 10.001);
        assert_eq!(
            err.to_string(),
            format!("frame {MAX_SEQ}: au.fap64_bend_nose: 10.001 is out of range (expected -10 to 10)")
        );
        assert_eq!(err.field(), Some("au"));
        assert_eq!(beyond(|f| f.seq += 1).field(), Some("seq"));
        assert_eq!(beyond(|f| f.time_s = -1e-9).field(), Some("t"));
        assert_eq!(beyond(|f| f.label = Some("é".repeat(128))).field(), Some("label"));
        assert_eq!(beyond(|f| f.faps[0].1 = 100_001.0).field(), Some("fap"));
        assert_eq!(beyond(|f| f.faps[1].1 = -628_320.0).field(), Some("fap"));
        assert_eq!(beyond(|f| f.arkit[0].1 = f32::NAN).field(), Some("arkit"));
        assert_eq!(
            beyond(|f| f.head_rotation_rad = Some([0.0, 6.3, 0.0])).to_string(),
            format!("frame {MAX_SEQ}: head_rotation_rad[1]: 6.3 is out of range (expected -6.2831855 to 6.2831855 rad)")
        );
        assert_eq!(
            beyond(|f| f.head_translation = Some([0.0, 0.0, f32::INFINITY])).field(),
            Some("head_translation")
        );
        assert_eq!(
            beyond(|f| f.controls.as_mut().unwrap()[7][2] = -3.4e38).to_string(),
            format!(
                "frame {MAX_SEQ}: controls[7][2]: -3.4e38 is out of range (expected -10 to 10 mask units)"
            )
        );
        assert_eq!(
            beyond(|f| f.controls.as_mut().unwrap().pop().map(drop).unwrap()).field(),
            Some("controls")
        );
        assert_eq!(
            beyond(|f| f.viseme.as_mut().unwrap().select1 = 15).field(),
            Some("viseme")
        );
        assert_eq!(
            beyond(|f| f.expression.as_mut().unwrap().init_face = -1).field(),
            Some("expression")
        );
    }

    #[test]
    fn lists_must_be_sorted_with_every_index_once() {
        let mask = Mask::candide3();
        let frame = |animation: Vec<(u16, f32)>| Frame {
            animation,
            ..Frame::at(3, 0.0)
        };
        assert_eq!(
            frame(vec![(1, 0.1), (1, 0.2)])
                .check(&mask)
                .unwrap_err()
                .to_string(),
            "frame 3: au.jaw_drop: names the same animation unit as an earlier entry"
        );
        assert_eq!(
            frame(vec![(2, 0.1), (1, 0.2)])
                .check(&mask)
                .unwrap_err()
                .to_string(),
            "frame 3: au.jaw_drop: index 1 comes after 2: entries must be sorted by index"
        );
        let err = frame(vec![(65, 0.1)]).check(&mask).unwrap_err();
        assert!(matches!(err, StreamError::UnknownUnit { .. }), "{err}");
        assert_eq!(err.field(), Some("au"));
    }

    #[test]
    fn param_frames_are_sorted_then_checked() {
        let mask = Mask::candide3();
        let p = ParamFrame {
            seq: 4,
            time_s: 0.5,
            animation: vec![(11, 0.01), (1, 0.3)],
            faps: vec![(48, 10.0), (3, 120.0)],
            arkit: vec![(24, 1.0), (17, 0.5)],
            head_rotation_rad: Some([0.1, 0.0, 0.0]),
            head_translation: Some([0.0, 0.01, 0.0]),
            label: Some("pa".into()),
            viseme: Some(ParamViseme::Microsoft(18)),
            ignored: Vec::new(),
        };
        let frame = Frame::from_param_frame(p.clone(), &mask).unwrap();
        assert_eq!(frame.head_translation, Some([0.0, 0.01, 0.0]));
        assert_eq!(frame.viseme, Some(crate::stream::visemes::single(2)));
        let unknown = ParamFrame {
            viseme: Some(ParamViseme::Oculus(15)),
            ..p.clone()
        };
        let err = Frame::from_param_frame(unknown, &mask).unwrap_err();
        assert_eq!(err.field(), Some("viseme"));
        assert!(
            err.to_string()
                .contains("viseme.oculus: 15 is not a viseme: expected 0..=14"),
            "{err}"
        );
        assert_eq!(frame.animation, [(1, 0.3), (11, 0.01)]);
        assert_eq!(frame.faps, [(3, 120.0), (48, 10.0)]);
        assert_eq!(frame.arkit, [(17, 0.5), (24, 1.0)]);
        assert_eq!(frame.label.as_deref(), Some("pa"));
        let twice = ParamFrame {
            animation: vec![(1, 0.3), (11, 0.0), (1, 0.2)],
            ..p
        };
        let err = Frame::from_param_frame(twice, &mask).unwrap_err();
        assert!(matches!(err, StreamError::Duplicate { .. }), "{err}");
    }
}
