//! `rbf` on both shipped heads: every kernel with both distances, with and without the
//! linear term. Interpolation at the anchors, affine reproduction, and the lips.
//!
//! Run with `--nocapture` to see the bind times, errors and lip leakage ratios.
//!
//! Tolerances. Deforming sums `w * delta` in f32 and `delta` itself is a difference of f32
//! positions, so rounding of about `f32::EPSILON * |position|` per control is amplified by
//! the Lebesgue constant `L = max_v sum_j |w_vj|` (1 to 1e5 here: large for wide global
//! kernels). At an anchor the row is the unit vector (L = 1): errors there stay below
//! [`ANCHOR_TOLERANCE`] of the largest displacement. Away from the anchors the affine
//! reproduction is checked to `1e-4 + L * f32::EPSILON * |position| / |displacement|`.

use crate::common::{anchor_target, deform_with, posed, register, upper_lip_vertices};

use std::sync::OnceLock;

use facewire::deform::{bind, AlgoSpec, Binding, Kernel, Metric, Registration};
use facewire::mask::LOWER_LIP;
use glam::{Mat3, Vec3};

/// Animation unit 1: AUV11 jaw drop.
const JAW_DROP: usize = 1;
/// Interpolation error at the anchors, relative to the largest control displacement.
const ANCHOR_TOLERANCE: f32 = 1e-4;
/// Lip leak bound: mean upper-lip motion over mean lower-lip control motion.
const LIP_LEAK: f32 = 0.1;

fn heads() -> [(&'static str, &'static Registration); 2] {
    static SCAN: OnceLock<Registration> = OnceLock::new();
    static MAKEHUMAN: OnceLock<Registration> = OnceLock::new();
    [
        ("scan", SCAN.get_or_init(|| register("lee_perry_smith_head"))),
        ("makehuman", MAKEHUMAN.get_or_init(|| register("makehuman_head"))),
    ]
}

const KERNELS: [(&str, f32); 5] = [
    ("gaussian", 30.0),
    ("multiquadric", 30.0),
    ("inverse_multiquadric", 30.0),
    ("thin_plate", 40.0),
    ("wendland", 40.0),
];

/// Every kernel with both distances; `poly` is "linear" or "none".
fn variants(poly: &str) -> Vec<AlgoSpec> {
    let mut specs = Vec::new();
    for (kernel, r_mm) in KERNELS {
        for distance in ["euclidean", "surface"] {
            specs.push(
                format!("rbf:kernel={kernel},distance={distance},r_mm={r_mm},poly={poly}")
                    .parse()
                    .unwrap(),
            );
        }
    }
    specs
}

/// The rest mask plus `displacement(j)` (head units) on every control.
fn displaced(reg: &Registration, displacement: impl Fn(u32) -> Vec3) -> Vec<Vec3> {
    let mut mask_now = reg.mask_rest().to_vec();
    for &j in &reg.controls {
        mask_now[j as usize] += displacement(j);
    }
    mask_now
}

/// Deterministic pseudo-random displacement in [-1, 1]^3 for control `j`.
fn jitter(j: u32) -> Vec3 {
    let mut state = u64::from(j).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03;
    let mut next = || {
        state ^= state >> 33;
        state = state.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
        state ^= state >> 33;
        (state >> 11) as f32 / (1u64 << 53) as f32 * 2.0 - 1.0
    };
    Vec3::new(next(), next(), next())
}

fn anchor_position(reg: &Registration, j: u32) -> Vec3 {
    reg.head.positions[reg.anchors.vertex[j as usize] as usize]
}

/// Largest `|deformed - rest - expected(v)|` over every head vertex.
fn worst_error(reg: &Registration, out: &[Vec3], expected: impl Fn(usize) -> Vec3) -> f32 {
    out.iter()
        .zip(&reg.head.positions)
        .enumerate()
        .map(|(v, (o, p))| (*o - *p - expected(v)).length())
        .fold(0.0, f32::max)
}

/// Largest error at the anchors, relative to the largest control displacement. Mask
/// vertices sharing an anchor are one centre that reproduces their mean displacement.
fn anchor_error(reg: &Registration, binding: &Binding, mask_now: &[Vec3]) -> f32 {
    let out = deform_with(reg, binding, mask_now);
    let delta = |j: u32| mask_now[j as usize] - reg.mask_rest()[j as usize];
    let largest = reg
        .controls
        .iter()
        .map(|&j| delta(j).length())
        .fold(0.0, f32::max);
    let mut worst = 0.0f32;
    for &j in &reg.controls {
        let anchor = reg.anchors.vertex[j as usize];
        let mean = anchor_target(reg, mask_now, anchor);
        let moved = out[anchor as usize] - reg.head.positions[anchor as usize];
        worst = worst.max((moved - mean).length());
    }
    worst / largest
}

#[test]
fn zero_displacement_moves_nothing() {
    for (name, reg) in heads() {
        for poly in ["linear", "none"] {
            for spec in variants(poly) {
                let binding = bind(reg, &spec);
                assert_eq!(binding.vertex_count(), reg.vertex_count());
                assert!(
                    binding.linear.items().iter().all(|t| t.weight.is_finite()),
                    "{name} {spec}"
                );
                let out = deform_with(reg, &binding, reg.mask_rest());
                assert_eq!(
                    out, reg.head.positions,
                    "{name} {spec}: zero displacement moved the head"
                );
                let terms = binding.linear.items().len() as f32 / reg.vertex_count() as f32;
                // Binding's time is `cargo bench --bench deform` ("bind/..."), not a test's.
                println!("{name} {spec}: {terms:.1} terms per vertex");
            }
        }
    }
}

#[test]
fn controls_are_interpolated_at_their_anchors() {
    let mut animation = vec![0.0; 65];
    animation[JAW_DROP] = 0.5;
    animation[2] = 0.6; // lip stretcher
    animation[3] = 0.4; // brow lowerer
    animation[6] = 1.0; // eyes closed: moves eyelid vertices that share an anchor
    for (name, reg) in heads() {
        let mm = reg.mm_per_unit();
        let frames = [
            ("pose", posed(reg, &animation)),
            ("jitter 3 mm", displaced(reg, |j| jitter(j) * (3.0 / mm))),
        ];
        for poly in ["linear", "none"] {
            for spec in variants(poly) {
                let binding = bind(reg, &spec);
                for (frame, mask_now) in &frames {
                    let error = anchor_error(reg, &binding, mask_now);
                    println!("{name} {spec} {frame}: anchor error {error:.2e} of the largest displacement");
                    assert!(
                        error.is_finite() && error <= ANCHOR_TOLERANCE,
                        "{name} {spec} {frame}: {error}"
                    );
                    let out = deform_with(reg, &binding, mask_now);
                    assert!(out.iter().all(|p| p.is_finite()), "{name} {spec} {frame}: NaN");
                }
            }
        }
    }
}

/// `max_v sum_j |w_vj|`: how much the binding amplifies errors in the displacements.
fn lebesgue(binding: &Binding) -> f32 {
    (0..binding.vertex_count())
        .map(|v| binding.linear.row(v).iter().map(|t| t.weight.abs()).sum::<f32>())
        .fold(0.0, f32::max)
}

/// `1e-4 + L * eps * |position| / |displacement|`, relative to `displacement`.
fn rounding_tolerance(reg: &Registration, binding: &Binding, displacement: f32) -> f32 {
    let position = reg.mask_rest().iter().map(|p| p.length()).fold(0.0, f32::max);
    1e-4 + lebesgue(binding) * f32::EPSILON * position / displacement
}

#[test]
fn the_linear_term_reproduces_translations_and_affine_motions() {
    for (name, reg) in heads() {
        let mm = reg.mm_per_unit();
        let origin = reg.head.bounds().center();
        let t = Vec3::new(2.0, -3.0, 1.5) / mm;
        // A small rotation, anisotropic scaling and shear, minus the identity.
        let linear = Mat3::from_rotation_y(0.05)
            * Mat3::from_rotation_x(-0.03)
            * Mat3::from_cols(
                Vec3::new(1.02, 0.01, 0.0),
                Vec3::new(0.0, 0.97, 0.02),
                Vec3::new(0.01, 0.0, 1.03),
            )
            - Mat3::IDENTITY;
        // Affine in the anchor positions, the centres of the interpolation (the fitted mask
        // vertices sit a little off the surface).
        let affine = |p: Vec3| linear * (p - origin) + t;
        let translated = displaced(reg, |_| t);
        let moved = displaced(reg, |j| affine(anchor_position(reg, j)));
        let largest = reg
            .head
            .positions
            .iter()
            .map(|&p| affine(p).length())
            .fold(0.0, f32::max);
        for spec in variants("linear") {
            let binding = bind(reg, &spec);
            let error = worst_error(reg, &deform_with(reg, &binding, &translated), |_| t) / t.length();
            let affine_error = worst_error(reg, &deform_with(reg, &binding, &moved), |v| {
                affine(reg.head.positions[v])
            }) / largest;
            let (translation_bound, affine_bound) = (
                rounding_tolerance(reg, &binding, t.length()),
                rounding_tolerance(reg, &binding, largest),
            );
            println!(
                "{name} {spec}: L = {:.0}, translation error {error:.1e} (bound {translation_bound:.1e}), \
                 affine error {affine_error:.1e} (bound {affine_bound:.1e})",
                lebesgue(&binding)
            );
            assert!(
                error <= translation_bound,
                "{name} {spec}: translation error {error}"
            );
            assert!(
                affine_error <= affine_bound,
                "{name} {spec}: affine error {affine_error}"
            );
        }
    }
}

/// For a jaw drop of 0.5: (mean upper-lip vertex motion, largest upper-lip vertex motion),
/// both over the mean motion of the lower-lip controls.
fn lip_leak(reg: &Registration, spec: &AlgoSpec) -> (f32, f32) {
    let mut animation = vec![0.0; 65];
    animation[JAW_DROP] = 0.5;
    let mask_now = posed(reg, &animation);
    let out = deform_with(reg, &bind(reg, spec), &mask_now);
    let lower = LOWER_LIP
        .iter()
        .map(|&j| mask_now[j].distance(reg.mask_rest()[j]))
        .sum::<f32>()
        / LOWER_LIP.len() as f32;
    let upper = upper_lip_vertices(reg);
    let motion: Vec<f32> = upper
        .iter()
        .map(|&v| out[v].distance(reg.head.positions[v]))
        .collect();
    let mean = motion.iter().sum::<f32>() / motion.len() as f32;
    (mean / lower, motion.iter().copied().fold(0.0, f32::max) / lower)
}

#[test]
fn lips_stay_apart_with_surface_distances_and_leak_with_euclidean() {
    for (name, reg) in heads() {
        assert!(upper_lip_vertices(reg).len() > 50, "{name}");
        for spec in variants("linear").into_iter().chain(variants("none")) {
            let AlgoSpec::Rbf(params) = spec else {
                unreachable!("variants are rbf")
            };
            let (leak, worst) = lip_leak(reg, &spec);
            println!("{name} {spec}: upper lip moves {leak:.3} of the lower lip (worst vertex {worst:.2})");
            assert!(leak.is_finite());
            match params.metric {
                // The upper lip is 0.1-1.5 mm from the lower lip in space: every kernel leaks.
                Metric::Euclidean => {
                    assert!(leak > LIP_LEAK, "{name} {spec}: Euclidean did not leak ({leak})")
                }
                // Geodesic Phi is indefinite; only the compact kernel is reliably local (the
                // global kernels ring, see the module docs), so only it is held to the bound.
                Metric::Surface if params.kernel == Kernel::Wendland => {
                    assert!(
                        leak < LIP_LEAK,
                        "{name} {spec}: upper lip moved {leak} of the lower lip"
                    )
                }
                Metric::Surface => {}
            }
        }
        let (surface, _) = lip_leak(reg, &"rbf".parse().unwrap());
        let (euclidean, _) = lip_leak(reg, &"rbf:distance=euclidean".parse().unwrap());
        println!("{name}: default rbf, leak with surface distances {surface:.3}, Euclidean {euclidean:.3}");
        assert!(surface < LIP_LEAK, "{name}: surface leak {surface}");
        assert!(
            euclidean > LIP_LEAK,
            "{name}: Euclidean no longer leaks ({euclidean}); update the docs"
        );
    }
}
