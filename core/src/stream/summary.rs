//! A one-pass summary of a stream (frame count, rate, duration, value ranges per channel,
//! labels), to check a recording before replaying it and to describe one in JSON. Memory
//! grows with the number of channels and distinct labels, never with the frame count.

use std::collections::{BTreeMap, HashMap};

use super::blendshapes::ARKIT_BLENDSHAPES;
use super::error::StreamError;
use super::frame::{Frame, HEAD_ROTATION_FAPS};
use crate::mask::fap::fap_info;
use crate::mask::Mask;

/// Which parameter a channel is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ChannelKind {
    /// A CANDIDE animation unit weight (`Frame::animation`); index = unit.
    Animation,
    /// A FAP value in counts (`Frame::faps`); index = FAP number.
    Fap,
    /// An ARKit blendshape weight; index into `ARKIT_BLENDSHAPES`.
    Arkit,
    /// `Frame::head_rotation_rad`, radians; index 0, 1, 2 = rx, ry, rz.
    HeadRotationRad,
    /// `Frame::head_translation`, mask units; index 0, 1, 2 = x, y, z.
    HeadTranslation,
}

/// The range of one channel over the frames that have it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ChannelRange {
    pub kind: ChannelKind,
    pub index: u16,
    /// FAP or ARKit name, axis for head motion; animation units are named by
    /// [`StreamSummary::name_animation_units`].
    pub name: Option<String>,
    pub min: f32,
    pub max: f32,
    /// Frames in which the channel appears.
    pub frames: u64,
}

/// A label and the number of frames that carry it.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct LabelCount {
    pub label: String,
    pub frames: u64,
}

/// What [`summarize`] found.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StreamSummary {
    pub frames: u64,
    pub first_time_s: Option<f64>,
    pub last_time_s: Option<f64>,
    /// `last_time_s - first_time_s`; 0 for fewer than two frames.
    pub duration_s: f64,
    /// `(frames - 1) / duration_s`; `None` when the duration is 0.
    pub fps_estimate: Option<f64>,
    /// Frames that carry raw control displacements.
    pub frames_with_controls: u64,
    /// Every channel seen, ordered by kind then index.
    pub channels: Vec<ChannelRange>,
    /// Labels in order of first appearance.
    pub labels: Vec<LabelCount>,
}

const AXES: [&str; 3] = ["x", "y", "z"];

fn channel_name(kind: ChannelKind, index: u16) -> Option<String> {
    match kind {
        ChannelKind::Animation => None,
        ChannelKind::Fap => u8::try_from(index)
            .ok()
            .and_then(fap_info)
            .map(|info| info.name.to_string()),
        ChannelKind::Arkit => ARKIT_BLENDSHAPES
            .get(usize::from(index))
            .map(|name| name.to_string()),
        ChannelKind::HeadRotationRad => {
            let fap = HEAD_ROTATION_FAPS.get(usize::from(index));
            let axis = AXES.get(usize::from(index));
            axis.zip(fap).map(|(axis, fap)| format!("r{axis} (FAP {fap})"))
        }
        ChannelKind::HeadTranslation => AXES.get(usize::from(index)).map(|a| a.to_string()),
    }
}

/// Reads a whole stream once and summarizes it; the first error is returned as is.
pub fn summarize<I>(frames: I) -> Result<StreamSummary, StreamError>
where
    I: IntoIterator<Item = Result<Frame, StreamError>>,
{
    let mut count = 0u64;
    let mut first_time_s = None;
    let mut last_time_s = None;
    let mut frames_with_controls = 0;
    let mut ranges: BTreeMap<(ChannelKind, u16), (f32, f32, u64)> = BTreeMap::new();
    let mut labels: Vec<LabelCount> = Vec::new();
    let mut label_slots: HashMap<String, usize> = HashMap::new();

    for frame in frames {
        let frame = frame?;
        count += 1;
        first_time_s.get_or_insert(frame.time_s);
        last_time_s = Some(frame.time_s);
        frames_with_controls += u64::from(frame.controls.is_some());
        let mut see = |kind: ChannelKind, index: u16, value: f32| {
            let range = ranges.entry((kind, index)).or_insert((value, value, 0));
            range.0 = range.0.min(value);
            range.1 = range.1.max(value);
            range.2 += 1;
        };
        for &(unit, weight) in &frame.animation {
            see(ChannelKind::Animation, unit, weight);
        }
        for &(fap, value) in &frame.faps {
            see(ChannelKind::Fap, u16::from(fap), value);
        }
        for &(index, weight) in &frame.arkit {
            see(ChannelKind::Arkit, u16::from(index), weight);
        }
        for (kind, vector) in [
            (ChannelKind::HeadRotationRad, frame.head_rotation_rad),
            (ChannelKind::HeadTranslation, frame.head_translation),
        ] {
            for (axis, value) in (0u16..).zip(vector.into_iter().flatten()) {
                see(kind, axis, value);
            }
        }
        if let Some(label) = frame.label {
            match label_slots.get(&label) {
                Some(&slot) => labels[slot].frames += 1,
                None => {
                    label_slots.insert(label.clone(), labels.len());
                    labels.push(LabelCount { label, frames: 1 });
                }
            }
        }
    }

    let duration_s = match (first_time_s, last_time_s) {
        (Some(first), Some(last)) => last - first,
        _ => 0.0,
    };
    Ok(StreamSummary {
        frames: count,
        first_time_s,
        last_time_s,
        duration_s,
        fps_estimate: (duration_s > 0.0).then(|| (count - 1) as f64 / duration_s),
        frames_with_controls,
        channels: ranges
            .into_iter()
            .map(|((kind, index), (min, max, frames))| ChannelRange {
                kind,
                index,
                name: channel_name(kind, index),
                min,
                max,
                frames,
            })
            .collect(),
        labels,
    })
}

impl StreamSummary {
    /// Names the animation-unit channels with `mask`'s unit keys (`jaw_drop`).
    pub fn name_animation_units(&mut self, mask: &Mask) {
        for channel in &mut self.channels {
            if channel.kind == ChannelKind::Animation {
                channel.name = mask
                    .animation_units
                    .get(usize::from(channel.index))
                    .map(|unit| unit.key.clone());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summarizes_ranges_rate_and_labels() {
        let frames = [
            Frame {
                label: Some("pa".into()),
                animation: vec![(1, 0.2)],
                head_rotation_rad: Some([0.1, 0.0, -0.1]),
                ..Frame::at(0, 1.0)
            },
            Frame {
                label: Some("pa".into()),
                animation: vec![(1, 0.5), (2, -0.1)],
                faps: vec![(3, 40.0)],
                ..Frame::at(1, 1.5)
            },
            Frame {
                label: Some("mi".into()),
                animation: vec![(1, 0.1)],
                ..Frame::at(2, 2.0)
            },
        ];
        let mut summary = summarize(frames.into_iter().map(Ok)).unwrap();
        summary.name_animation_units(&Mask::candide3());
        assert_eq!(summary.frames, 3);
        assert_eq!(summary.duration_s, 1.0);
        assert_eq!(summary.fps_estimate, Some(2.0));
        let jaw = &summary.channels[0];
        assert_eq!(
            (jaw.kind, jaw.index, jaw.name.as_deref()),
            (ChannelKind::Animation, 1, Some("jaw_drop"))
        );
        assert_eq!((jaw.min, jaw.max, jaw.frames), (0.1, 0.5, 3));
        let open_jaw = summary
            .channels
            .iter()
            .find(|c| c.kind == ChannelKind::Fap)
            .unwrap();
        assert_eq!(open_jaw.name.as_deref(), Some("open_jaw"));
        let roll = summary.channels.last().unwrap();
        assert_eq!(roll.name.as_deref(), Some("rz (FAP 50)"));
        assert_eq!(roll.min, -0.1);
        let labels: Vec<(&str, u64)> = summary
            .labels
            .iter()
            .map(|l| (l.label.as_str(), l.frames))
            .collect();
        assert_eq!(labels, [("pa", 2), ("mi", 1)]);
        let json = serde_json::to_value(&summary).unwrap();
        assert_eq!(json["channels"][0]["kind"], "animation");
    }

    #[test]
    fn an_empty_stream_has_no_rate() {
        let summary = summarize(std::iter::empty()).unwrap();
        assert_eq!(summary.frames, 0);
        assert_eq!(summary.fps_estimate, None);
        assert_eq!(summary.duration_s, 0.0);
    }
}
