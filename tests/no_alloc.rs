//! Per-frame code allocates nothing: a counting global allocator watches one thread while
//! it turns a stream frame into mask weights, poses the mask and deforms the head with
//! every preset.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::Path;

use facewire::deform::{bind, AlgoSpec, Registration};
use facewire::fit::{FitFile, FittedMask};
use facewire::head::Head;
use facewire::mask::Mask;
use facewire::stream::open_stream;
use glam::Vec3;

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|n| n.set(n.get() + 1));
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations_during(f: impl FnOnce()) -> usize {
    let before = ALLOCATIONS.with(Cell::get);
    f();
    ALLOCATIONS.with(Cell::get) - before
}

#[test]
fn a_frame_allocates_nothing() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
    let head = Head::load(&root.join("heads/makehuman_head.obj")).unwrap();
    let mask = Mask::candide3();
    let fit = FitFile::load(&root.join("heads/makehuman_head.fit.toml"))
        .unwrap()
        .resolve("fit", &mask)
        .unwrap();
    let reg = Registration::new(head, FittedMask::new(mask.clone(), fit));
    let frames: Vec<_> = open_stream(&root.join("streams/syllables.jsonl"), &mask)
        .unwrap()
        .take(40)
        .map(Result::unwrap)
        .collect();
    let mut weights = vec![0.0f32; 65];
    let mut mask_now = vec![Vec3::ZERO; 113];
    let mut out = vec![Vec3::ZERO; reg.vertex_count()];
    for (_, spec, _) in AlgoSpec::presets() {
        let binding = bind(&reg, &spec);
        let mut scratch = binding.scratch(113, reg.mask_triangles().len());
        let count = allocations_during(|| {
            for frame in &frames {
                frame.animation_weights(&reg.fitted.mask, &reg.fitted.fapu, &mut weights);
                reg.fitted.pose_into(&weights, &mut mask_now);
                binding.deform(
                    &reg.head.positions,
                    reg.mask_rest(),
                    &mask_now,
                    reg.mask_triangles(),
                    &mut scratch,
                    &mut out,
                );
            }
        });
        assert_eq!(
            count,
            0,
            "{spec} allocated {count} times over {} frames",
            frames.len()
        );
        // the counter does see allocations
        assert_eq!(allocations_during(|| drop(vec![1u8; 10])), 1);
    }
}
