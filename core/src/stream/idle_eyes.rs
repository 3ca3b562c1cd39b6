//! Eyes that live while a face speaks: blinks and small glances, as ARKit `eyeBlink*` and
//! `eyeLook*` weights to add to a stream that has none (the demo's syllables). A face that
//! never blinks and stares reads as a mask; people watching a talking head for its lips
//! still look at the eyes.
//!
//! The schedule is a pure function of the time and a seed (any replay or seek gives the
//! same eyes): time is cut into [`BLINK_SLOT_S`] slots with one blink each, at a
//! pseudo-random offset, closing over [`CLOSING_S`] and opening over [`OPENING_S`] (people
//! in conversation blink 15-25 times a minute, each blink a few tenths of a second); and
//! into [`GLANCE_SLOT_S`] slots, each holding the gaze on the listener or, one slot in
//! [`GLANCE_SHARE`]'s inverse, a glance within [`GLANCE_YAW_RAD`] sideways and
//! [`GLANCE_PITCH_RAD`] up or down, reached by a saccade of [`SACCADE_S`].

use super::ARKIT_LOOK_RAD;

/// One blink in each slot this long, seconds (about 17 a minute).
pub const BLINK_SLOT_S: f64 = 3.5;
/// The lids close over this long, seconds...
pub const CLOSING_S: f64 = 0.1;
/// ... and open again over this long.
pub const OPENING_S: f64 = 0.2;
/// The gaze holds for a slot this long, seconds.
pub const GLANCE_SLOT_S: f64 = 1.2;
/// The share of slots that glance away from the listener.
pub const GLANCE_SHARE: f64 = 0.4;
/// A glance turns the eyes at most this far sideways (radians, 12 degrees) ...
pub const GLANCE_YAW_RAD: f32 = 0.21;
/// ... and up or down (6 degrees).
pub const GLANCE_PITCH_RAD: f32 = 0.105;
/// A saccade to the next gaze takes this long, seconds.
pub const SACCADE_S: f64 = 0.04;

/// ARKit blendshape indices (`ARKIT_BLENDSHAPES`) the schedule writes.
const BLINK: [u8; 2] = [0, 7];
const LOOK_DOWN: [u8; 2] = [1, 8];
const LOOK_UP: [u8; 2] = [4, 11];
/// Towards the face's left: the left eye looks out, the right one in.
const LOOK_LEFTWARDS: [u8; 2] = [3, 9];
const LOOK_RIGHTWARDS: [u8; 2] = [2, 10];

/// A blink and glance schedule.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IdleEyes {
    pub seed: u64,
}

/// A number in 0..1 from a slot and a stream of the seed (SplitMix64's finalizer).
fn unit(seed: u64, slot: i64, stream: u64) -> f64 {
    let mut z =
        seed ^ (slot as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ stream.wrapping_mul(0xD1B5_4A32_D192_ED03);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    (z ^ (z >> 31)) as f64 / u64::MAX as f64
}

impl IdleEyes {
    /// How closed the lids are at `t_s`, 0 (open) to 1.
    pub fn blink(&self, t_s: f64) -> f32 {
        let slot = (t_s / BLINK_SLOT_S).floor();
        let room = BLINK_SLOT_S - CLOSING_S - OPENING_S;
        let start = slot * BLINK_SLOT_S + unit(self.seed, slot as i64, 1) * room;
        let since = t_s - start;
        let closed = if since < 0.0 {
            0.0
        } else if since < CLOSING_S {
            since / CLOSING_S
        } else {
            1.0 - (since - CLOSING_S) / OPENING_S
        };
        closed.clamp(0.0, 1.0) as f32
    }

    /// The gaze held in glance slot `slot`: (yaw towards the face's left, pitch down), rad.
    fn gaze_of_slot(&self, slot: i64) -> (f32, f32) {
        if unit(self.seed, slot, 2) >= GLANCE_SHARE {
            return (0.0, 0.0);
        }
        let yaw = (2.0 * unit(self.seed, slot, 3) - 1.0) as f32 * GLANCE_YAW_RAD;
        let pitch = (2.0 * unit(self.seed, slot, 4) - 1.0) as f32 * GLANCE_PITCH_RAD;
        (yaw, pitch)
    }

    /// Where both eyes look at `t_s`: (yaw towards the face's left, pitch down), radians.
    pub fn gaze(&self, t_s: f64) -> (f32, f32) {
        let slot = (t_s / GLANCE_SLOT_S).floor();
        let now = self.gaze_of_slot(slot as i64);
        let before = self.gaze_of_slot(slot as i64 - 1);
        let t = ((t_s - slot * GLANCE_SLOT_S) / SACCADE_S).clamp(0.0, 1.0) as f32;
        (
            before.0 + (now.0 - before.0) * t,
            before.1 + (now.1 - before.1) * t,
        )
    }

    /// Appends the ARKit weights of `t_s` to `arkit` (a frame's `arkit`): both blinks, and
    /// the looks that turn both eyes to [`IdleEyes::gaze`]. Weights left at 0 are left out.
    pub fn add_to(&self, t_s: f64, arkit: &mut Vec<(u8, f32)>) {
        let blink = self.blink(t_s);
        let (yaw, pitch) = self.gaze(t_s);
        let (sideways, vertical) = (yaw / ARKIT_LOOK_RAD, pitch / ARKIT_LOOK_RAD);
        let looks = [
            (BLINK, blink),
            (LOOK_LEFTWARDS, sideways.max(0.0)),
            (LOOK_RIGHTWARDS, (-sideways).max(0.0)),
            (LOOK_DOWN, vertical.max(0.0)),
            (LOOK_UP, (-vertical).max(0.0)),
        ];
        for (shapes, weight) in looks {
            if weight > 0.0 {
                arkit.extend(shapes.map(|shape| (shape, weight)));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stream::ARKIT_BLENDSHAPES;

    #[test]
    fn the_shapes_are_the_ones_named() {
        let names = |shapes: [u8; 2]| shapes.map(|s| ARKIT_BLENDSHAPES[usize::from(s)]);
        assert_eq!(names(BLINK), ["eyeBlinkLeft", "eyeBlinkRight"]);
        assert_eq!(names(LOOK_LEFTWARDS), ["eyeLookOutLeft", "eyeLookInRight"]);
        assert_eq!(names(LOOK_RIGHTWARDS), ["eyeLookInLeft", "eyeLookOutRight"]);
        assert_eq!(names(LOOK_DOWN), ["eyeLookDownLeft", "eyeLookDownRight"]);
        assert_eq!(names(LOOK_UP), ["eyeLookUpLeft", "eyeLookUpRight"]);
    }

    #[test]
    fn one_blink_a_slot_closing_fast_and_opening_slower() {
        let eyes = IdleEyes { seed: 7 };
        let step = 0.005;
        for slot in 0..40 {
            let times: Vec<f64> = (0..(BLINK_SLOT_S / step) as usize)
                .map(|k| slot as f64 * BLINK_SLOT_S + k as f64 * step)
                .collect();
            let closed: Vec<f32> = times.iter().map(|&t| eyes.blink(t)).collect();
            // Fully closed once, shut for no longer than a sample, open most of the slot.
            assert!(closed.iter().any(|&c| c > 0.97), "slot {slot}");
            let moving = closed.iter().filter(|&&c| c > 0.0).count() as f64 * step;
            assert!(
                (moving - (CLOSING_S + OPENING_S)).abs() < 2.0 * step,
                "slot {slot}: {moving}"
            );
        }
        // The same time, the same eyes.
        assert_eq!(eyes.blink(12.345), IdleEyes { seed: 7 }.blink(12.345));
        assert_ne!(
            (0..100).map(|k| eyes.blink(k as f64 * 0.05)).collect::<Vec<_>>(),
            (0..100)
                .map(|k| IdleEyes { seed: 8 }.blink(k as f64 * 0.05))
                .collect::<Vec<_>>()
        );
    }

    #[test]
    fn glances_stay_small_and_turn_both_eyes_alike() {
        let eyes = IdleEyes { seed: 3 };
        let (mut away, mut slots) = (0, 0);
        for k in 0..2000 {
            let t = k as f64 * 0.037;
            let (yaw, pitch) = eyes.gaze(t);
            assert!(yaw.abs() <= GLANCE_YAW_RAD && pitch.abs() <= GLANCE_PITCH_RAD);
            let mut arkit = Vec::new();
            eyes.add_to(t, &mut arkit);
            // Both eyes get the same look: sideways as out and in, up or down alike.
            let weight = |shape: u8| arkit.iter().find(|(s, _)| *s == shape).map_or(0.0, |(_, w)| *w);
            for side in 0..2 {
                let sideways = weight(LOOK_LEFTWARDS[side]) - weight(LOOK_RIGHTWARDS[side]);
                let vertical = weight(LOOK_DOWN[side]) - weight(LOOK_UP[side]);
                assert!((sideways * ARKIT_LOOK_RAD - yaw).abs() < 1e-6);
                assert!((vertical * ARKIT_LOOK_RAD - pitch).abs() < 1e-6);
            }
        }
        for slot in 0..500 {
            slots += 1;
            away += usize::from(eyes.gaze_of_slot(slot) != (0.0, 0.0));
        }
        let share = away as f64 / slots as f64;
        assert!((share - GLANCE_SHARE).abs() < 0.07, "{share}");
    }
}
