//! The contact constraint on the ICT head (13,294 vertices, its teeth, gums and tongue)
//! with the default algorithm, over the frames of the shipped syllable stream: the job's
//! deform with the constraint against the same deform without it; and on the frames of
//! the f syllables, the deform with the labiodental contact (the lower lip brought to the
//! upper teeth) against the same deform without it.
//!
//! `cargo bench --bench teeth_contact`; numbers in docs/PERFORMANCE.md ("Contact").

use std::hint::black_box;
use std::path::Path;
use std::sync::Arc;

use criterion::{criterion_group, criterion_main, Criterion};
use facewire::animate::{AnimatedHead, FrameJob, Heat, PartInput};
use facewire::deform::{bind, AlgoSpec, Registration};
use facewire::fit::{FitFile, FittedMask};
use facewire::head::Head;
use facewire::mask::Mask;
use facewire::stream::{open_stream, ArkitBasis, Frame};

fn data(path: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(path)
}

fn ict() -> AnimatedHead {
    let head = Head::load(&data("heads/ict_head.obj")).expect("shipped head");
    let mask = Mask::candide3();
    let fit = FitFile::load(&data("heads/ict_head.fit.toml"))
        .expect("shipped fit")
        .resolve("ict_head", &mask)
        .expect("valid fit");
    let part = |name: &str, role: Option<&str>| PartInput {
        name: name.into(),
        role: role.map(|r| r.parse().expect("a role")),
        mesh: Head::load(&data(&format!("heads/ict_head_{name}.obj"))).expect("shipped part"),
    };
    let parts = vec![
        part("teeth_upper", None),
        part("teeth_lower", None),
        part("gums_upper", None),
        part("gums_lower_tongue", Some("tongue")),
    ];
    AnimatedHead::with_parts(Registration::new(head, FittedMask::new(mask, fit)), parts).expect("parts")
}

fn syllables(mask: &Mask) -> Vec<Frame> {
    open_stream(&data("streams/syllables.jsonl"), mask)
        .expect("shipped stream")
        .map(|f| f.expect("valid frame"))
        .collect()
}

fn teeth_contact(c: &mut Criterion) {
    let with = ict();
    let frames = syllables(&with.registration.fitted.mask);
    let spec: AlgoSpec = facewire::deform::spec::DEFAULT_ALGORITHM
        .parse()
        .expect("default spec");
    let binding = Arc::new(bind(&with.registration, &spec));
    let mut without = ict();
    without.contact = None;
    let basis = Arc::new(ArkitBasis::shipped());
    let mut group = c.benchmark_group("teeth_contact/ict_13k");
    for (name, head) in [("deform with contact", with), ("deform without contact", without)] {
        let mut job =
            FrameJob::new(Arc::new(head), binding.clone(), basis.clone(), Heat::None).expect("job builds");
        let mut next = frames.iter().cycle();
        group.bench_function(name, |b| {
            b.iter(|| black_box(job.deform(next.next().expect("cycled")).len()))
        });
    }
    group.finish();

    // The frames that ask for the labiodental shape: the f syllables' (the contact does
    // nothing on the others).
    let f_frames: Vec<Frame> = frames
        .iter()
        .filter(|f| f.label.as_deref().is_some_and(|l| l.starts_with('f')))
        .cloned()
        .collect();
    let with = ict();
    let mut without = ict();
    without.labiodental = None;
    let mut group = c.benchmark_group("labiodental/ict_13k");
    for (name, head) in [
        ("deform of f frames with labiodental contact", with),
        ("deform of f frames without it", without),
    ] {
        let mut job =
            FrameJob::new(Arc::new(head), binding.clone(), basis.clone(), Heat::None).expect("job builds");
        let mut next = f_frames.iter().cycle();
        group.bench_function(name, |b| {
            b.iter(|| black_box(job.deform(next.next().expect("cycled")).len()))
        });
    }
    group.finish();
}

criterion_group!(benches, teeth_contact);
criterion_main!(benches);
