//! Bind and deform of every preset (V is the default, `biharmonic`) and of `biharmonic`
//! held at 40 mm everywhere on the two shipped heads and on the scan subdivided twice (141k
//! vertices), beside a plain sparse gather over the same rows (the memory roofline a
//! linear deform can hope for). Run: `cargo bench --bench deform` (`-- "/(U|V)$"` for two
//! variants).

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use facewire::deform::{bind, AlgoSpec, Binding, Registration};
use facewire::fit::{FitFile, FittedMask};
use facewire::head::{subdivide, Head};
use facewire::mask::Mask;
use glam::{Vec3, Vec3A};

fn register(name: &str, subdivisions: usize) -> Registration {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/heads");
    let mut head = Head::load(&root.join(format!("{name}.obj"))).expect("shipped head");
    for _ in 0..subdivisions {
        let (p, t) = subdivide::midpoint(&head.positions, &head.triangles);
        head = Head::new(&head.name, p, t);
    }
    let mask = Mask::candide3();
    let fit = FitFile::load(&root.join(format!("{name}.fit.toml")))
        .expect("shipped fit")
        .resolve(name, &mask)
        .expect("valid fit");
    Registration::new(head, FittedMask::new(mask, fit))
}

/// Every preset by its letter, and the variants that are not presets by name.
fn variants() -> Vec<(String, AlgoSpec)> {
    let mut variants: Vec<(String, AlgoSpec)> = AlgoSpec::presets()
        .into_iter()
        .map(|(letter, spec, _)| (letter.to_string(), spec))
        .collect();
    let held_at_40 = "biharmonic:hold_mm=40,eyes_hold_mm=40,k=16";
    variants.push(("biharmonic_40".into(), held_at_40.parse().expect("a valid spec")));
    // V's field as it is bound without the lip smoothing and the needles: what they cost.
    let exact = "biharmonic:smooth_lips=0";
    variants.push(("biharmonic_exact".into(), exact.parse().expect("a valid spec")));
    variants
}

fn heads() -> Vec<(String, Registration)> {
    vec![
        ("makehuman_4k".into(), register("makehuman_head", 0)),
        ("scan_9k".into(), register("lee_perry_smith_head", 0)),
        ("scan_141k".into(), register("lee_perry_smith_head", 2)),
    ]
}

/// The mask with the jaw half dropped and the lips stretched.
fn frame(reg: &Registration) -> Vec<Vec3> {
    let mut animation = vec![0.0; 65];
    animation[1] = 0.5;
    animation[2] = 0.3;
    let mut mask_now = vec![Vec3::ZERO; reg.mask_rest().len()];
    reg.fitted.pose_into(&animation, &mut mask_now);
    mask_now
}

/// The roofline: `out[v] = rest[v] + sum w * delta[idx]` over plain arrays.
struct Gather {
    offsets: Vec<u32>,
    index: Vec<u16>,
    weight: Vec<f32>,
}

impl Gather {
    fn of(binding: &Binding) -> Gather {
        let mut offsets = vec![0u32];
        let (mut index, mut weight) = (Vec::new(), Vec::new());
        for v in 0..binding.vertex_count() {
            for t in binding.linear.row(v) {
                index.push(t.control);
                weight.push(t.weight);
            }
            offsets.push(index.len() as u32);
        }
        Gather {
            offsets,
            index,
            weight,
        }
    }

    fn run(&self, rest: &[Vec3], delta: &[Vec3A], out: &mut [Vec3]) {
        for (v, (o, p)) in out.iter_mut().zip(rest).enumerate() {
            let mut sum = Vec3A::from(*p);
            for k in self.offsets[v] as usize..self.offsets[v + 1] as usize {
                sum += self.weight[k] * delta[self.index[k] as usize];
            }
            *o = Vec3::from(sum);
        }
    }
}

fn benches(c: &mut Criterion) {
    for (name, reg) in heads() {
        let mask_now = frame(&reg);
        let delta: Vec<Vec3A> = mask_now
            .iter()
            .zip(reg.mask_rest())
            .map(|(a, b)| Vec3A::from(*a - *b))
            .collect();
        let mut out = vec![Vec3::ZERO; reg.vertex_count()];

        let mut group = c.benchmark_group(format!("deform/{name}"));
        group
            .warm_up_time(Duration::from_millis(300))
            .measurement_time(Duration::from_secs(1))
            .sample_size(20);
        for (label, spec) in variants() {
            let binding = bind(&reg, &spec);
            let mut scratch = binding.scratch(mask_now.len(), reg.mask_triangles().len());
            group.bench_function(BenchmarkId::new("algo", &label), |b| {
                b.iter(|| {
                    binding.deform(
                        &reg.head.positions,
                        reg.mask_rest(),
                        black_box(&mask_now),
                        reg.mask_triangles(),
                        &mut scratch,
                        &mut out,
                    )
                })
            });
            if spec.is_linear() {
                let gather = Gather::of(&binding);
                group.bench_function(BenchmarkId::new("gather", &label), |b| {
                    b.iter(|| gather.run(&reg.head.positions, black_box(&delta), &mut out))
                });
            }
        }
        group.finish();

        let mut group = c.benchmark_group(format!("bind/{name}"));
        group
            .warm_up_time(Duration::from_millis(100))
            .measurement_time(Duration::from_secs(2))
            .sample_size(10);
        for (label, spec) in variants() {
            group.bench_function(BenchmarkId::new("algo", &label), |b| {
                b.iter(|| bind(&reg, black_box(&spec)))
            });
        }
        group.finish();
    }
}

criterion_group!(deform, benches);
criterion_main!(deform);
