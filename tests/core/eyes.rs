//! The ICT head's eyeballs: split one a side, each turned about its own centre by the
//! frame's gaze (FAPs 23-26, ARKit `eyeLook*`), and the lids closed over them on a blink
//! without passing through them, for every algorithm below; measured against the same
//! skin deformed without the constraint.

use std::sync::Arc;

use crate::common::{data, ict_head, register, ICT_PARTS};

use facewire::animate::{AnimatedHead, FrameJob, Heat, PartInput, RigidMotion, Side};
use facewire::deform::bind;
use facewire::head::Head;
use facewire::metrics::FoldMeter;
use facewire::stream::{arkit_index, ArkitBasis, Frame};
use glam::Vec3;

fn job(head: &Arc<AnimatedHead>, spec: &str) -> FrameJob {
    let binding = Arc::new(bind(&head.registration, &spec.parse().unwrap()));
    FrameJob::new(head.clone(), binding, Arc::new(ArkitBasis::shipped()), Heat::None).unwrap()
}

/// The ICT head with its parts but no eyes: the same skin and binding, no lid constraint.
fn ict_head_without_eyes() -> AnimatedHead {
    let parts = ICT_PARTS
        .iter()
        .filter(|(_, _, role)| *role != Some("eyes"))
        .map(|&(name, file, role)| PartInput {
            name: name.into(),
            role: role.map(|r| r.parse().unwrap()),
            mesh: Head::load(&data(&format!("heads/{file}"))).unwrap(),
        })
        .collect();
    AnimatedHead::with_parts(register("ict_head"), parts).unwrap()
}

fn arkit(weights: &[(&str, f32)]) -> Vec<(u8, f32)> {
    weights
        .iter()
        .map(|&(name, w)| (arkit_index(name).unwrap(), w))
        .collect()
}

#[test]
fn the_ict_eyes_split_one_a_side_and_turn_about_their_centres() {
    let head = Arc::new(ict_head());
    let mm = head.registration.mm_per_unit();
    let names: Vec<(&str, Side)> = head.eyes.iter().map(|e| (e.name.as_str(), e.side)).collect();
    assert_eq!(names, [("eyes_left", Side::Left), ("eyes_right", Side::Right)]);
    for eye in &head.eyes {
        assert_eq!(eye.mesh.positions.len(), 1570, "{}", eye.name);
        // The face's left is +x on this head; the eyeballs' spheres are 14-16 mm in radius.
        assert_eq!(eye.centre.x > 0.0, eye.side == Side::Left);
        assert!(
            (14.0..16.5).contains(&(eye.radius * mm)),
            "{} {}",
            eye.name,
            eye.radius * mm
        );
        assert!(eye.forward.z > 0.99, "{}", eye.forward);
    }
    // The two are mirror images: centres 62-64 mm apart, level.
    let (l, r) = (head.eyes[0].centre, head.eyes[1].centre);
    assert!((l.x + r.x).abs() * mm < 0.01 && (l.y - r.y).abs() * mm < 0.01);
    assert!(
        (55.0..70.0).contains(&(l.distance(r) * mm)),
        "{}",
        l.distance(r) * mm
    );

    let mut job = job(&head, "V");
    job.deform(&Frame::at(0, 0.0));
    assert!(job.eye_motions().iter().all(RigidMotion::is_identity));

    // FAP 23 of 17,453 counts: the left eye 10 degrees to the face's left; eyeLookDownRight
    // 0.5: the right eye 15 degrees down (ARKIT_LOOK_RAD is 30 degrees).
    let frame = Frame {
        faps: vec![(23, 17_453.3)],
        arkit: arkit(&[("eyeLookDownRight", 0.5)]),
        ..Frame::at(1, 0.04)
    };
    job.deform(&frame);
    for (eye, motion) in head.eyes.iter().zip(job.eye_motions()) {
        assert!(
            motion.apply(eye.centre).distance(eye.centre) * mm < 1e-3,
            "{}",
            eye.name
        );
        let gaze = motion.rotation * eye.forward;
        let turned = gaze.angle_between(eye.forward).to_degrees();
        match eye.side {
            // Towards the face's left (+x) on the level...
            Side::Left => {
                assert!((turned - 10.0).abs() < 0.01 && gaze.x > eye.forward.x, "{turned}");
                assert!((gaze.y - eye.forward.y).abs() < 0.01, "{gaze}");
            }
            // ... and straight down.
            Side::Right => {
                assert!((turned - 15.0).abs() < 0.01 && gaze.y < eye.forward.y, "{turned}");
                assert!((gaze.x - eye.forward.x).abs() < 1e-3, "{gaze}");
            }
        }
    }
}

/// Ten blinks of both eyes at 25 fps, each drawing the lids closed and open again over 12
/// frames, the eyes looking about between and during them (down, left, up and right).
fn blinks() -> Vec<Frame> {
    let looks = [
        ("eyeLookDownLeft", "eyeLookDownRight"),
        ("eyeLookOutLeft", "eyeLookInRight"),
        ("eyeLookUpLeft", "eyeLookUpRight"),
        ("eyeLookInLeft", "eyeLookOutRight"),
    ];
    let mut frames = Vec::new();
    for blink in 0..10 {
        for k in 0..12 {
            let closed = 1.0 - ((k as f32 - 6.0) / 6.0).abs();
            let (left, right) = looks[blink % looks.len()];
            let look = 0.3 + 0.07 * blink as f32;
            let seq = frames.len() as u64;
            frames.push(Frame {
                arkit: arkit(&[
                    ("eyeBlinkLeft", closed),
                    ("eyeBlinkRight", closed),
                    (left, look),
                    (right, look),
                ]),
                ..Frame::at(seq, seq as f64 * 0.04)
            });
        }
    }
    frames
}

#[test]
fn the_lids_close_over_the_eyes_without_passing_through_them() {
    let head = Arc::new(ict_head());
    let bare = Arc::new(ict_head_without_eyes());
    let lids = head.eyelids.as_ref().expect("the ICT head has eyes");
    let watched: Vec<usize> = lids.watched().collect();
    assert!(watched.iter().all(|&n| n > 100), "{watched:?}");
    let rest = &head.registration.head.positions;
    let frames = blinks();
    // The skin about the eyes: triangles within 12 mm of an eyeball's sphere.
    let mm = head.registration.mm_per_unit();
    let near_eye = |p: Vec3| {
        head.eyes
            .iter()
            .any(|e| p.distance(e.centre) < e.radius + 12.0 / mm)
    };
    let around_eyes: Vec<u32> = (0..head.registration.head.triangles.len() as u32)
        .filter(|&t| {
            head.registration.head.triangles[t as usize]
                .iter()
                .all(|&v| near_eye(rest[v as usize]))
        })
        .collect();
    assert!(around_eyes.len() > 500, "{}", around_eyes.len());
    for spec in ["V", "U", "A", "O"] {
        let (mut with, mut without) = (job(&head, spec), job(&bare, spec));
        let mut meters = [(); 2].map(|_| FoldMeter::new(&head.registration.head, &around_eyes).unwrap());
        let mut folds = [0u32; 2];
        let mut over_90 = [0u32; 2];
        let mut sharpest = [0.0f64; 2];
        let (mut left_in, mut left_deepest, mut before_in, mut before_deepest) = (0, 0.0f32, 0, 0.0f32);
        let mut farthest_mm = 0.0f32;
        for frame in &frames {
            let skin = with.deform(frame).to_vec();
            let motions = with.eye_motions().to_vec();
            let after = lids.measure(rest, &skin, &motions);
            left_in += after.vertices;
            left_deepest = left_deepest.max(after.deepest_mm);
            let bare_skin = without.deform(frame);
            let before = lids.measure(rest, bare_skin, &motions);
            for (k, positions) in [bare_skin, skin.as_slice()].into_iter().enumerate() {
                let f = meters[k].measure(positions).unwrap();
                folds[k] += f.turned_over_60;
                over_90[k] += f.turned_over_90;
                sharpest[k] = sharpest[k].max(f.max_dihedral_increase_deg);
            }
            before_in += before.vertices;
            before_deepest = before_deepest.max(before.deepest_mm);
            let moved = skin
                .iter()
                .zip(rest)
                .map(|(a, b)| a.distance(*b))
                .fold(0.0f32, f32::max);
            farthest_mm = farthest_mm.max(moved * head.registration.mm_per_unit());
        }
        eprintln!(
            "{spec}: {} blink frames; lid vertex-frames in the eyes {before_in} (deepest \
             {before_deepest:.2} mm) without the constraint, {left_in} with it; triangle-frames \
             about the eyes turned past 60 degrees {} without, {} with; the skin moved up to \
             {:.1} mm",
            frames.len(),
            folds[0],
            folds[1],
            farthest_mm
        );
        eprintln!("  facing away (over 90): {over_90:?}, sharpest dihedral increase {sharpest:?}");
        // The blink itself turns the lids' skin over on this head (issue: folds about the
        // eyes); laying the lids on the eyeball adds some (V: 7,077 -> 9,600 past 60 degrees,
        // 2,456 -> 3,065 past 90, the sharpest crease unchanged). Held here so it grows no
        // further.
        assert!(folds[1] as f32 <= 1.5 * folds[0] as f32, "{spec}: {folds:?}");
        assert!(
            over_90[1] as f32 <= 1.5 * over_90[0] as f32,
            "{spec}: {over_90:?}"
        );
        // The constraint makes no crease sharper, unless the blink alone already turns the
        // skin over (past 175 degrees: U, A and O), where the sharpest angle only wobbles
        // towards 180 (O: 178.5 -> 179.7) and the counts above hold it.
        assert!(
            sharpest[1] <= sharpest[0] + 1.0 || sharpest[0] > TURNED_OVER_DEG,
            "{spec}: {sharpest:?}"
        );
        assert_eq!(left_in, 0, "{spec}: deepest {left_deepest} mm");
        // The blink moves the lids by millimetres: the frames exercise them.
        assert!(farthest_mm > 3.0, "{spec}: {farthest_mm}");
    }
}

/// A crease this sharp is skin facing away from where it faced (degrees).
const TURNED_OVER_DEG: f64 = 175.0;
