//! The tongue's own shape: the jaw carries the tongue like the lower teeth, and on top of
//! that MPEG-4's tongue FAPs (and ARKit's `tongueOut`) bend it. The result is a delta per
//! tongue vertex in the head's frame before the jaw's and the head's motions, the one part
//! whose vertices travel as deltas (the teeth and gums are rigid).
//!
//! The model, in mask units and the mask's axes (+x the face's left, +y up, +z out of the
//! face), set up once from the tongue mesh at rest:
//! - a vertex's **mobility** is `smoothstep((d - `[`HELD_MM`]`) / `[`FREE_MM`]`)`, `d` its
//!   distance to the nearest vertex of the parts that move with the jaw (the lower
//!   teeth): a tongue mesh that also holds the lower gums and the floor of the mouth
//!   (the ICT model's does) keeps them on the jaw, and the floor stretches as the tongue
//!   moves. With no such parts every vertex is mobile;
//! - the **tip** (feature point 6.1) is the vertex of mobility at least 1/2 with the
//!   largest `z - |x|` (the most forward, and of a front row the one on the mid-line
//!   `x = 0`), the **back** the rearmost vertex; the length `L` is the distance between
//!   them along z;
//! - the **body** (6.2) is the highest vertex within `0.05 L` of the mid-line plane
//!   through the tip, [`BODY_BEHIND_TIP`]` L` behind the tip;
//! - a vertex's tip weight is `f(|p - tip| / (`[`TIP_REACH`]` L))`, its body weight
//!   `f(|p - body| / (`[`BODY_REACH`]` L))`, with `f(r) = (1 - r²)²` for `r < 1` and 0
//!   beyond (smooth, 1 at the feature point);
//! - both are scaled by the vertex's mobility.
//!
//! Per frame (counts as in [`crate::stream::Frame::faps`], plus FAP 1's viseme's tongue,
//! [`crate::stream::visemes::viseme_tongue`]; MW and MNS of the fitted mask):
//! FAP 43 moves the tip weight towards the face's right (−x) by `count · MW / 1024`, 44 up
//! by `count · MNS / 1024`, 45 forward by `count · MW / 1024` (`tongueOut` adds
//! [`TONGUE_OUT_COUNTS`] to it); 46 moves the body weight up by `count · MNS / 1024`; 47
//! rolls the sides up, concave upward, by `|x| · tan(count · 1e-5 rad)` (x from the
//! mid-line) times the body weight.

use glam::Vec3;

use crate::fit::FittedMask;
use crate::head::{Head, Part, PartRole};
use crate::mask::{FapuValues, MaskPose};
use crate::stream::{arkit_index, visemes::viseme_tongue, Frame, RADIANS_PER_ANGLE_COUNT};

/// Reach of the tip's FAPs (43-45): this share of the tongue's length.
pub const TIP_REACH: f32 = 0.25;
/// Reach of the body's raise (46) and the roll (47): this share of the tongue's length.
pub const BODY_REACH: f32 = 0.5;
/// The body point lies this share of the tongue's length behind the tip.
pub const BODY_BEHIND_TIP: f32 = 0.45;
/// Tongue vertices this close to the jaw's teeth (mm) stay on the jaw (gums).
pub const HELD_MM: f32 = 2.0;
/// Beyond [`HELD_MM`], mobility rises from 0 to 1 over this many millimetres.
pub const FREE_MM: f32 = 4.0;
/// ARKit `tongueOut` at 1 thrusts the tip as FAP 45 at this many counts (about 0.34 of
/// the mouth's width: some 17 mm on an adult, past the lips).
pub const TONGUE_OUT_COUNTS: f32 = 350.0;

/// Where the tongue's feature points are at rest (head units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TongueLandmarks {
    /// Feature point 6.1.
    pub tip: Vec3,
    /// Feature point 6.2.
    pub body: Vec3,
    /// The tongue vertex at the tip.
    pub tip_vertex: usize,
}

/// The tongue's FAP values of one frame, counts.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct TongueCounts {
    shift_tip: f32,
    raise_tip: f32,
    thrust_tip: f32,
    raise_body: f32,
    roll: f32,
}

impl TongueCounts {
    fn of(frame: &Frame, tongue_out: Option<u8>) -> TongueCounts {
        let mut counts = TongueCounts::default();
        let from_viseme = frame.viseme.iter().flat_map(viseme_tongue);
        for (fap, count) in frame.faps.iter().copied().chain(from_viseme) {
            match fap {
                43 => counts.shift_tip += count,
                44 => counts.raise_tip += count,
                45 => counts.thrust_tip += count,
                46 => counts.raise_body += count,
                47 => counts.roll += count,
                _ => {}
            }
        }
        if let Some(index) = tongue_out {
            for &(blendshape, weight) in &frame.arkit {
                if blendshape == index {
                    counts.thrust_tip += weight * TONGUE_OUT_COUNTS;
                }
            }
        }
        counts
    }

    fn is_rest(&self) -> bool {
        *self == TongueCounts::default()
    }
}

/// A tongue mesh ready to be shaped frame after frame (no allocation per frame).
#[derive(Debug, Clone)]
pub struct TongueShaper {
    /// Tip weight, body weight, roll lever (|x| in mask units) per vertex.
    weights: Vec<[f32; 3]>,
    /// Whether each vertex is the tongue proper (mobility at least 1/2), not the gums or
    /// the floor of the mouth held by the jaw.
    free: Vec<bool>,
    landmarks: TongueLandmarks,
    /// Head-unit displacement of one count of FAPs 43, 44, 45 and 46.
    per_count: [Vec3; 4],
    /// Head-unit displacement of one mask unit up (the roll's direction).
    up: Vec3,
    tongue_out: Option<u8>,
}

fn falloff(r: f32) -> f32 {
    if r < 1.0 {
        let s = 1.0 - r * r;
        s * s
    } else {
        0.0
    }
}

fn smoothstep(x: f32) -> f32 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

impl TongueShaper {
    /// Sets the model up for `tongue` (head units), in the frame of a mask fitted with
    /// `pose` whose FAP units (mask units) are `fapu`, held still near `jaw_points` (the
    /// vertices of the parts that move with the jaw, head units; `mm_per_unit` mm per head
    /// unit). Registration time: milliseconds.
    pub fn new(
        tongue: &Head,
        pose: &MaskPose,
        fapu: &FapuValues,
        jaw_points: &[Vec3],
        mm_per_unit: f32,
    ) -> TongueShaper {
        let to_head = pose.affine();
        let to_mask = to_head.inverse();
        let held = (!jaw_points.is_empty()).then(|| crate::head::VertexIndex::new(jaw_points));
        let mobility: Vec<f32> = tongue
            .positions
            .iter()
            .map(|&p| match &held {
                Some(index) => index
                    .nearest(p)
                    .map_or(1.0, |(_, d)| smoothstep((d * mm_per_unit - HELD_MM) / FREE_MM)),
                None => 1.0,
            })
            .collect();
        let rest: Vec<Vec3> = tongue
            .positions
            .iter()
            .map(|&p| to_mask.transform_point3(p))
            .collect();
        // Forward most, and of a front row the one nearest the mid-line.
        let reach = |v: usize| rest[v].z - rest[v].x.abs();
        let tip_vertex = (0..rest.len())
            .filter(|&v| mobility[v] >= 0.5)
            .max_by(|&a, &b| reach(a).total_cmp(&reach(b)))
            .unwrap_or(0);
        let tip = rest.get(tip_vertex).copied().unwrap_or(Vec3::ZERO);
        let back = rest
            .iter()
            .min_by(|a, b| a.z.total_cmp(&b.z))
            .copied()
            .unwrap_or(Vec3::ZERO);
        let length = (tip.z - back.z).max(f32::EPSILON);
        let body_z = tip.z - BODY_BEHIND_TIP * length;
        let near_body =
            |p: &&Vec3| (p.x - tip.x).abs() < 0.05 * length && (p.z - body_z).abs() < 0.05 * length;
        let body = rest
            .iter()
            .filter(near_body)
            .max_by(|a, b| a.y.total_cmp(&b.y))
            .copied()
            .unwrap_or(Vec3::new(0.0, tip.y, body_z));

        let weights = rest
            .iter()
            .zip(&mobility)
            .map(|(&p, &mobility)| {
                [
                    mobility * falloff(p.distance(tip) / (TIP_REACH * length)),
                    mobility * falloff(p.distance(body) / (BODY_REACH * length)),
                    p.x.abs(),
                ]
            })
            .collect();
        let along = |direction: Vec3, unit: f32| to_head.transform_vector3(direction * unit / 1024.0);
        TongueShaper {
            weights,
            free: mobility.iter().map(|&m| m >= 0.5).collect(),
            landmarks: TongueLandmarks {
                tip: to_head.transform_point3(tip),
                body: to_head.transform_point3(body),
                tip_vertex,
            },
            per_count: [
                along(Vec3::NEG_X, fapu.mw),
                along(Vec3::Y, fapu.mns),
                along(Vec3::Z, fapu.mw),
                along(Vec3::Y, fapu.mns),
            ],
            up: to_head.transform_vector3(Vec3::Y),
            tongue_out: arkit_index("tongueOut"),
        }
    }

    /// The shaper of the first part of `parts` with role tongue (its index and shaper),
    /// held by the parts with role jaw, for a head whose mask is `fitted` (`mm_per_unit`
    /// mm per head unit); `None` without a tongue.
    pub fn for_parts(parts: &[Part], fitted: &FittedMask, mm_per_unit: f32) -> Option<(usize, TongueShaper)> {
        let index = parts.iter().position(|p| p.role == PartRole::Tongue)?;
        let jaw_points: Vec<Vec3> = parts
            .iter()
            .filter(|p| p.role == PartRole::Jaw)
            .flat_map(|p| p.mesh.positions.iter().copied())
            .collect();
        let shaper = TongueShaper::new(
            &parts[index].mesh,
            &fitted.fit.pose,
            &fitted.fapu,
            &jaw_points,
            mm_per_unit,
        );
        Some((index, shaper))
    }

    /// The tip and body at rest (head units).
    pub fn landmarks(&self) -> TongueLandmarks {
        self.landmarks
    }

    /// Whether each vertex is the tongue proper (mobility at least 1/2) rather than gums or
    /// floor held by the jaw.
    pub fn free_vertices(&self) -> &[bool] {
        &self.free
    }

    /// Vertices of the tongue this shaper was made for.
    pub fn vertex_count(&self) -> usize {
        self.weights.len()
    }

    /// Writes each tongue vertex's delta for `frame` into `out` (head units, before the
    /// jaw's and the head's motions; one slot per tongue vertex). Returns whether any FAP
    /// of the tongue is set: when none is, `out` is all zeros. Allocates nothing.
    pub fn shape(&self, frame: &Frame, out: &mut [Vec3]) -> bool {
        let counts = TongueCounts::of(frame, self.tongue_out);
        if counts.is_rest() {
            out.fill(Vec3::ZERO);
            return false;
        }
        let tip = self.per_count[0] * counts.shift_tip
            + self.per_count[1] * counts.raise_tip
            + self.per_count[2] * counts.thrust_tip;
        let body = self.per_count[3] * counts.raise_body;
        let roll = self.up * (counts.roll * RADIANS_PER_ANGLE_COUNT).tan();
        for (slot, &[tip_weight, body_weight, lever]) in out.iter_mut().zip(&self.weights) {
            *slot = tip * tip_weight + (body + roll * lever) * body_weight;
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat tongue of 11 x 5 vertices in mask units = head units, 1 unit long (z from
    /// -1 to 0), x from -0.2 to 0.2.
    fn strip() -> Head {
        let mut obj = String::new();
        for i in 0..11 {
            for j in 0..5 {
                let (x, z) = (-0.2 + 0.1 * j as f32, -1.0 + 0.1 * i as f32);
                obj += &format!("v {x} 0 {z}\n");
            }
        }
        for i in 0..10 {
            for j in 0..4 {
                let v = |a: usize, b: usize| (a * 5 + b + 1).to_string();
                obj += &format!(
                    "f {} {} {} {}\n",
                    v(i, j),
                    v(i, j + 1),
                    v(i + 1, j + 1),
                    v(i + 1, j)
                );
            }
        }
        Head::from_obj_bytes("strip", obj.as_bytes()).unwrap()
    }

    fn fapu() -> FapuValues {
        FapuValues {
            mns: 1024.0,
            mw: 2048.0,
            ens: 1.0,
            es: 1.0,
            irisd: 1.0,
        }
    }

    fn frame(faps: &[(u8, f32)]) -> Frame {
        Frame {
            faps: faps.to_vec(),
            ..Frame::default()
        }
    }

    #[test]
    fn no_tongue_parameters_move_nothing() {
        let shaper = TongueShaper::new(&strip(), &MaskPose::IDENTITY, &fapu(), &[], 1.0);
        let mut out = vec![Vec3::ONE; shaper.vertex_count()];
        let moved = shaper.shape(&frame(&[(3, 500.0), (48, 1000.0)]), &mut out);
        assert!(!moved);
        assert!(out.iter().all(|d| *d == Vec3::ZERO));
    }

    #[test]
    fn landmarks_are_the_front_and_the_mid_line_behind_it() {
        let shaper = TongueShaper::new(&strip(), &MaskPose::IDENTITY, &fapu(), &[], 1.0);
        let landmarks = shaper.landmarks();
        assert_eq!(landmarks.tip.z, 0.0);
        assert!(
            (landmarks.body.z + BODY_BEHIND_TIP).abs() < 0.051,
            "{landmarks:?}"
        );
    }

    #[test]
    fn what_lies_near_the_jaw_stays_and_the_tip_weight_falls_off() {
        let head = strip();
        // A lower tooth 1 head unit (10 mm) below the strip's back row: further than
        // HELD_MM + FREE_MM = 6 mm from every vertex, so the whole strip is mobile.
        let jaw = [Vec3::new(0.0, -1.0, -1.0)];
        let shaper = TongueShaper::new(&head, &MaskPose::IDENTITY, &fapu(), &jaw, 10.0);
        let mut out = vec![Vec3::ZERO; shaper.vertex_count()];
        // 44 raise_tongue_tip, 1 count = MNS / 1024 = 1 head unit here.
        assert!(shaper.shape(&frame(&[(44, 0.01)]), &mut out));
        let at = |x: f32, z: f32| {
            head.positions
                .iter()
                .position(|p| (p.x - x).abs() < 1e-4 && (p.z - z).abs() < 1e-4)
                .unwrap()
        };
        let moved_at = |out: &[Vec3], x: f32, z: f32| out[at(x, z)];
        for (p, d) in head.positions.iter().zip(&out) {
            assert_eq!((d.x, d.z), (0.0, 0.0), "{p}");
            assert!(d.y >= 0.0 && d.y <= 0.01, "{p} {d}");
        }
        // The tip takes the whole raise; it falls off behind and is gone beyond the
        // tip's reach.
        assert_eq!(moved_at(&out, 0.0, 0.0).y, 0.01);
        assert!(
            moved_at(&out, 0.0, -0.1).y < 0.01 && moved_at(&out, 0.0, -0.1).y > moved_at(&out, 0.0, -0.3).y
        );
        assert_eq!(moved_at(&out, 0.0, -0.5).y, 0.0);
        // A tooth 1 mm under the front row holds it (within HELD_MM), and the tip moves
        // back to the first row free enough to be one.
        let near = [Vec3::new(0.0, -0.1, 0.0)];
        let held = TongueShaper::new(&head, &MaskPose::IDENTITY, &fapu(), &near, 10.0);
        held.shape(&frame(&[(44, 0.01)]), &mut out);
        assert_eq!(
            moved_at(&out, 0.0, 0.0).y,
            0.0,
            "the front row beside a tooth is held"
        );
        let tip = head.positions[held.landmarks().tip_vertex];
        assert!(tip.z < 0.0, "{tip}");
    }

    #[test]
    fn directions_follow_the_standard_and_the_fitted_pose() {
        // A closed mesh (a tetrahedron) is mobile everywhere; the tip (its front vertex)
        // takes each FAP whole.
        let tetra = Head::from_obj_bytes(
            "tetra",
            b"v 0 0 1\nv 0.5 0 0\nv -0.5 0 0\nv 0 0.5 0.2\nf 1 2 3\nf 1 4 2\nf 2 4 3\nf 3 4 1\n",
        )
        .unwrap();
        // The head is the mask turned a quarter turn about y and scaled 10 times.
        let pose = MaskPose::similarity(Vec3::new(0.0, std::f32::consts::FRAC_PI_2, 0.0), 10.0, Vec3::ZERO);
        let mut head = tetra.clone();
        for p in &mut head.positions {
            *p = pose.affine().transform_point3(*p);
        }
        let shaper = TongueShaper::new(&head, &pose, &fapu(), &[], 1.0);
        let mut out = vec![Vec3::ZERO; 4];
        let tip_moves = |faps: &[(u8, f32)], out: &mut Vec<Vec3>| {
            shaper.shape(&frame(faps), out);
            pose.affine().inverse().transform_vector3(out[0])
        };
        // 45 thrust: MW / 1024 = 2 mask units per count, forward (+z in the mask).
        assert!(tip_moves(&[(45, 0.5)], &mut out).abs_diff_eq(Vec3::Z, 1e-5));
        // 43 shift: towards the face's right, -x.
        assert!(tip_moves(&[(43, 0.5)], &mut out).abs_diff_eq(Vec3::NEG_X, 1e-5));
        // tongueOut 1 is TONGUE_OUT_COUNTS of 45.
        let tongue_out = Frame {
            arkit: vec![(arkit_index("tongueOut").unwrap(), 1.0)],
            ..Frame::default()
        };
        shaper.shape(&tongue_out, &mut out);
        let moved = pose.affine().inverse().transform_vector3(out[0]);
        assert!(
            moved.abs_diff_eq(Vec3::Z * 2.0 * TONGUE_OUT_COUNTS, 1e-2),
            "{moved}"
        );
        // In head units the mask's forward is the head's +x after the quarter turn.
        assert!(out[0].x > 0.0 && out[0].z.abs() < 1e-2, "{}", out[0]);
    }

    #[test]
    fn the_roll_lifts_the_sides() {
        let head = strip();
        let shaper = TongueShaper::new(&head, &MaskPose::IDENTITY, &fapu(), &[], 1.0);
        let mut out = vec![Vec3::ZERO; shaper.vertex_count()];
        shaper.shape(&frame(&[(47, 10_000.0)]), &mut out); // 0.1 rad
        let body = shaper.landmarks().body;
        for (p, d) in head.positions.iter().zip(&out) {
            assert_eq!((d.x, d.z), (0.0, 0.0));
            if p.x == 0.0 {
                assert_eq!(d.y, 0.0, "the mid-line does not roll: {p}");
            }
            if p.distance(body) < 0.1 && p.x.abs() > 0.1 {
                assert!(d.y > 0.0, "{p} {d}");
            }
        }
        // Symmetric: both sides rise alike.
        let side = |x: f32| {
            let i = head
                .positions
                .iter()
                .position(|p| (p.x - x).abs() < 1e-4 && (p.z + 0.5).abs() < 1e-4);
            out[i.unwrap()].y
        };
        assert!(side(0.2) > side(0.1) && (side(0.2) - side(-0.2)).abs() < 1e-7);
    }
}
