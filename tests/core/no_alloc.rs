//! Per-frame code allocates nothing: a counting global allocator watches one thread while
//! the per-frame job (`animate::FrameJob`) turns stream frames into deformed heads and
//! encoded viewer frames, with every preset and `biharmonic`, with no per-vertex values,
//! with face roughness and with folds.

use std::sync::Arc;

use crate::allocations_during;
use crate::common::data;
use facewire::animate::{AnimatedHead, FrameJob, FrameTimes, Heat};
use facewire::deform::{bind, AlgoSpec};
use facewire::mask::Mask;
use facewire::stream::{open_stream, ArkitBasis};
use facewire_proto::viewer_frame::FrameLayout;

/// Allocations while `job` deforms, measures and encodes every frame in both layouts, after a first
/// frame has sized the encoder's buffers.
fn allocations_over(job: &mut FrameJob, frames: &[facewire::stream::Frame]) -> u64 {
    job.deform(&frames[0]);
    job.measure(&frames[0]).unwrap();
    job.encode(&frames[0], FrameTimes::default(), FrameLayout::Fwf2)
        .unwrap();
    allocations_during(|| {
        for frame in frames {
            job.deform(frame);
            job.measure(frame).unwrap();
            for layout in [FrameLayout::Fwf2, FrameLayout::Fwf1] {
                job.encode(frame, FrameTimes::default(), layout).unwrap();
            }
        }
    })
}

#[test]
fn the_per_frame_job_allocates_nothing() {
    let mask = Mask::candide3();
    let head = Arc::new(AnimatedHead::new(crate::common::register("makehuman_head")).unwrap());
    let frames: Vec<_> = open_stream(&data("streams/syllables.jsonl"), &mask)
        .unwrap()
        .take(40)
        .map(Result::unwrap)
        .collect();
    let basis = Arc::new(ArkitBasis::shipped());
    let biharmonic: AlgoSpec = "biharmonic".parse().unwrap();
    let specs = AlgoSpec::presets().into_iter().map(|(_, spec, _)| spec);
    for spec in specs.chain([biharmonic]) {
        for heat in [Heat::None, Heat::Roughness, Heat::Folds] {
            let binding = Arc::new(bind(&head.registration, &spec));
            let mut job = FrameJob::new(head.clone(), binding, basis.clone(), heat).unwrap();
            let count = allocations_over(&mut job, &frames);
            assert_eq!(
                count,
                0,
                "{spec} (heat {heat:?}) allocated {count} times over {} frames",
                frames.len()
            );
        }
        // the counter does see allocations
        assert_eq!(allocations_during(|| drop(vec![1u8; 10])), 1);
    }
}

#[test]
fn the_contact_constraint_allocates_nothing() {
    let head = Arc::new(crate::common::ict_head());
    assert!(head.contact.is_some(), "the ICT head's teeth are closed pieces");
    let mask = Mask::candide3();
    let frames: Vec<_> = open_stream(&data("streams/syllables.jsonl"), &mask)
        .unwrap()
        .map(Result::unwrap)
        .collect();
    let spec: AlgoSpec = "biharmonic".parse().unwrap();
    let binding = Arc::new(bind(&head.registration, &spec));
    let mut job = FrameJob::new(head.clone(), binding, Arc::new(ArkitBasis::shipped()), Heat::None).unwrap();
    let count = allocations_over(&mut job, &frames);
    assert_eq!(count, 0, "allocated {count} times over {} frames", frames.len());
}
