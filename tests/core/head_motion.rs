//! The head's own motion (head rotation and translation from every input format): a rigid
//! transform about the documented neck pivot, kept out of the deformation and the deltas,
//! applied by `facewire deform` and carried in viewer frames.

use crate::common::{data, facewire_deform, obj_positions, register};

use std::sync::Arc;

use facewire::animate::{head_motion, AnimatedHead, FrameJob, FrameTimes, Heat, NECK_PIVOT_MASK};
use facewire::deform::{bind, AlgoSpec, Registration};
use facewire::mask::MaskPose;
use facewire::stream::{open_stream, ArkitBasis, Frame};
use facewire_proto::viewer_frame::{decode, FrameLayout};
use glam::Vec3;

const ROTATION_RAD: [f32; 3] = [0.12, -0.35, 0.08];
const TRANSLATION_MASK: [f32; 3] = [0.02, -0.05, 0.1];

/// Where a rest vertex `x` (head units) goes, computed in the mask's frame: back through
/// the fit's pose, turned about the neck pivot and shifted there, forward again.
fn expected_place(reg: &Registration, x: Vec3) -> Vec3 {
    let pose = reg.fitted.fit.pose;
    let in_mask = pose.affine().inverse().transform_point3(x);
    let turn = MaskPose::similarity(Vec3::from_array(ROTATION_RAD), 1.0, Vec3::ZERO).rotation();
    let moved = turn * (in_mask - NECK_PIVOT_MASK) + NECK_PIVOT_MASK + Vec3::from_array(TRANSLATION_MASK);
    pose.affine().transform_point3(moved)
}

fn motion_only() -> Frame {
    Frame {
        head_rotation_rad: Some(ROTATION_RAD),
        head_translation: Some(TRANSLATION_MASK),
        ..Frame::at(0, 0.0)
    }
}

#[test]
fn a_frame_with_only_head_motion_moves_every_vertex_rigidly_about_the_neck_pivot() {
    for name in ["lee_perry_smith_head", "makehuman_head"] {
        let head = Arc::new(AnimatedHead::new(register(name)).unwrap());
        let reg = &head.registration;
        let mm = reg.mm_per_unit();
        let rest: Vec<f32> = reg.head.positions.iter().flat_map(|p| p.to_array()).collect();
        for spec in ["U", "biharmonic", "A", "O"] {
            let spec: AlgoSpec = spec.parse().unwrap();
            let binding = Arc::new(bind(reg, &spec));
            let mut job =
                FrameJob::new(head.clone(), binding, Arc::new(ArkitBasis::shipped()), Heat::None).unwrap();
            let frame = motion_only();
            let local_worst = job
                .deform(&frame)
                .iter()
                .zip(&reg.head.positions)
                .map(|(a, b)| a.distance(*b) * mm)
                .fold(0.0f32, f32::max);
            assert!(
                local_worst < 1e-3,
                "{name} {spec}: the deformation moved {local_worst} mm"
            );
            let motion = job.head_motion();
            let worst = reg
                .head
                .positions
                .iter()
                .map(|&x| motion.apply(x).distance(expected_place(reg, x)) * mm)
                .fold(0.0f32, f32::max);
            assert!(worst < 0.01, "{name} {spec}: {worst} mm from the rigid motion");

            // On the wire: no deltas, the motion beside them, the same placed head.
            job.measure(&frame).unwrap();
            let decoded = decode(
                job.encode(&frame, FrameTimes::default(), FrameLayout::Fwf2)
                    .unwrap(),
            )
            .unwrap();
            assert_eq!(decoded.moved.len(), 0, "{name} {spec}");
            let mut placed = Vec::new();
            decoded.place(&rest, &mut placed);
            let worst = reg
                .head
                .positions
                .iter()
                .enumerate()
                .map(|(v, &x)| {
                    Vec3::from_slice(&placed[v * 3..v * 3 + 3]).distance(expected_place(reg, x)) * mm
                })
                .fold(0.0f32, f32::max);
            assert!(
                worst < 0.01,
                "{name} {spec}: decoded {worst} mm from the rigid motion"
            );
        }
    }
}

#[test]
fn the_xface_stream_turns_the_head() {
    let reg = register("makehuman_head");
    let frames: Vec<Frame> = open_stream(&data("candide3/xface_joy.fap"), &reg.fitted.mask)
        .unwrap()
        .map(Result::unwrap)
        .collect();
    let angles: Vec<f32> = frames
        .iter()
        .map(|f| {
            head_motion(f, &reg.fitted.fit.pose)
                .rotation
                .angle_between(glam::Quat::IDENTITY)
        })
        .collect();
    let turning = angles.iter().filter(|&&a| a > 0.0).count();
    let largest = angles.iter().copied().fold(0.0f32, f32::max);
    eprintln!(
        "xface_joy.fap: {turning} of {} frames turn the head, up to {largest} rad",
        frames.len()
    );
    assert!(turning * 2 > frames.len(), "{turning} of {} frames", frames.len());
    assert!(largest > 0.01, "{largest} rad");
}

#[test]
fn facewire_deform_writes_the_head_where_its_motion_puts_it() {
    let reg = register("makehuman_head");
    let scratch = tempfile::tempdir().unwrap();
    let stream = scratch.path().join("turn.jsonl");
    std::fs::write(
        &stream,
        format!(
            "{{\"seq\":0,\"t\":0,\"head_rotation_rad\":{ROTATION_RAD:?},\"head_translation\":{TRANSLATION_MASK:?}}}\n"
        ),
    )
    .unwrap();
    let out = scratch.path().join("out");
    let run = facewire_deform("makehuman_head", &stream, &out, &[]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let written: Vec<Vec3> = obj_positions(&out.join("frame_00000.obj"))
        .into_iter()
        .map(Vec3::from_array)
        .collect();
    assert_eq!(written.len(), reg.vertex_count());
    let mm = reg.mm_per_unit();
    let (mut worst, mut largest_move) = (0.0f32, 0.0f32);
    for (got, &x) in written.iter().zip(&reg.head.positions) {
        worst = worst.max(got.distance(expected_place(&reg, x)) * mm);
        largest_move = largest_move.max(got.distance(x) * mm);
    }
    assert!(largest_move > 20.0, "the head hardly moved: {largest_move} mm");
    assert!(worst < 0.01, "{worst} mm from the rigid motion");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_xface_file_posted_as_a_batch_turns_the_head_on_the_wire() {
    use crate::common::service::{connect, memory_config, next_frame, next_json, Server};
    let server = Server::start(memory_config()).await;
    server.register("mh", "makehuman_head", "").await;
    let mut viewer = connect(&server.ws("/v1/heads/mh/streams/joy/view")).await;
    assert!(matches!(
        next_json(&mut viewer).await,
        facewire_proto::messages::ServerMessage::Snapshot(_)
    ));
    let response = reqwest::Client::new()
        .post(server.http("/v1/heads/mh/streams/joy/batch"))
        .header("content-type", "application/x-fap")
        .body(std::fs::read(data("candide3/xface_joy.fap")).unwrap())
        .send()
        .await
        .unwrap();
    assert_eq!(response.status(), 202, "{}", response.text().await.unwrap());
    let reg = register("makehuman_head");
    let frames: Vec<Frame> = open_stream(&data("candide3/xface_joy.fap"), &reg.fitted.mask)
        .unwrap()
        .map(Result::unwrap)
        .collect();
    let mut turned = 0;
    for _ in 0..10 {
        let frame = next_frame(&mut viewer).await;
        let sent = frames.iter().find(|f| f.seq == frame.header.seq).unwrap();
        let expected = head_motion(sent, &reg.fitted.fit.pose);
        let rotation = glam::Quat::from_array(frame.head.rotation);
        assert!(
            rotation.abs_diff_eq(expected.rotation, 1e-6),
            "seq {}",
            frame.header.seq
        );
        turned += usize::from(rotation != glam::Quat::IDENTITY);
    }
    assert!(turned >= 5, "{turned} of 10 frames turned the head");
    server.stop().await;
}
