//! Shared by the integration tests that deform the shipped heads: data paths, registering
//! a shipped head with its fit, posing the mask, deforming with a binding, and the error
//! against a head's own expression targets.
#![allow(dead_code)] // each test file uses its own subset

pub mod glb;
pub mod nats;
pub mod nats_jwt;
pub mod service;
pub mod streams;
pub mod texture;

use std::path::{Path, PathBuf};

use facewire::deform::{bind, Binding, Registration};
use facewire::fit::{FitFile, FittedMask};
use facewire::head::Head;
use facewire::mask::Mask;
use facewire::metrics::{ground_truth_error, FaceVertices};
use facewire::targets::ExpressionTarget;
use glam::Vec3;

/// The ICT head's shipped parts: (name, file under data/heads/, role to give or `None`
/// to let it be inferred).
pub const ICT_PARTS: [(&str, &str, Option<&str>); 5] = [
    ("teeth_upper", "ict_head_teeth_upper.obj", None),
    ("teeth_lower", "ict_head_teeth_lower.obj", None),
    ("gums_upper", "ict_head_gums_upper.obj", None),
    (
        "gums_lower_tongue",
        "ict_head_gums_lower_tongue.obj",
        Some("tongue"),
    ),
    ("eyes", "ict_head_eyes.obj", Some("eyes")),
];

/// The ICT head with its shipped parts, as the library animates it.
pub fn ict_head() -> facewire::animate::AnimatedHead {
    let parts = ICT_PARTS
        .iter()
        .map(|&(name, file, role)| facewire::animate::PartInput {
            name: name.into(),
            role: role.map(|r| r.parse().unwrap()),
            mesh: Head::load(&data(&format!("heads/{file}"))).unwrap(),
        })
        .collect();
    facewire::animate::AnimatedHead::with_parts(register("ict_head"), parts).unwrap()
}

/// A path relative to the repository root.
pub fn repo_path(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(relative)
}

/// A path under `data/`.
pub fn data(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(path)
}

/// The `v x y z` lines of an OBJ file, in order.
pub fn obj_positions(path: &Path) -> Vec<[f32; 3]> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let v: Vec<f32> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            [v[0], v[1], v[2]]
        })
        .collect()
}

/// `facewire deform` on shipped head `name` with its fit, over `stream`, into `out`,
/// with `extra` arguments (`--algo`, `--frames`, `--part`).
pub fn facewire_deform(
    name: &str,
    stream: &Path,
    out: &Path,
    extra: &[&std::ffi::OsStr],
) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_facewire"))
        .arg("deform")
        .arg("--head")
        .arg(data(&format!("heads/{name}.obj")))
        .arg("--fit")
        .arg(data(&format!("heads/{name}.fit.toml")))
        .arg("--stream")
        .arg(stream)
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .expect("facewire runs")
}

/// A shipped head (`lee_perry_smith_head`, `makehuman_head`) registered with its fit.
pub fn register(name: &str) -> Registration {
    let head = Head::load(&data(&format!("heads/{name}.obj"))).unwrap();
    let mask = Mask::candide3();
    let fit = FitFile::load(&data(&format!("heads/{name}.fit.toml")))
        .unwrap()
        .resolve(name, &mask)
        .unwrap();
    Registration::new(head, FittedMask::new(mask, fit))
}

/// What an interpolating algorithm must move head vertex `anchor` by: the mean
/// displacement of the controls it anchors (controls sharing an anchor are one constraint).
pub fn anchor_target(reg: &Registration, mask_now: &[Vec3], anchor: u32) -> Vec3 {
    let sharing: Vec<u32> = reg
        .controls
        .iter()
        .copied()
        .filter(|&k| reg.anchors.vertex[k as usize] == anchor)
        .collect();
    sharing
        .iter()
        .map(|&k| mask_now[k as usize] - reg.mask_rest()[k as usize])
        .sum::<Vec3>()
        / sharing.len() as f32
}

/// The head deformed by `binding` for the moved mask `mask_now` (head units).
pub fn deform_with(reg: &Registration, binding: &Binding, mask_now: &[Vec3]) -> Vec<Vec3> {
    let mut scratch = binding.scratch(mask_now.len(), reg.mask_triangles().len());
    let mut out = vec![Vec3::ZERO; reg.vertex_count()];
    binding.deform(
        &reg.head.positions,
        reg.mask_rest(),
        mask_now,
        reg.mask_triangles(),
        &mut scratch,
        &mut out,
    );
    out
}

/// The fitted mask moved by animation weights, head units.
pub fn posed(reg: &Registration, animation: &[f32]) -> Vec<Vec3> {
    let mut mask_now = vec![Vec3::ZERO; reg.mask_rest().len()];
    reg.fitted.pose_into(animation, &mut mask_now);
    mask_now
}

/// Upper-lip head vertices: those whose projection triangle has only upper-lip corners and
/// lies within 10 mm of them along the surface (far vertices, such as the back of the
/// head, can project into a lip triangle too).
pub fn upper_lip_vertices(reg: &Registration) -> Vec<usize> {
    let upper = [7u32, 33, 66, 79, 80, 81, 82, 87, 31, 64, 88, 89];
    let upper_triangles: Vec<bool> = reg
        .mask_triangles()
        .iter()
        .map(|t| t.iter().all(|j| upper.contains(j)))
        .collect();
    (0..reg.vertex_count())
        .filter(|&v| {
            let p = reg.projections[v];
            upper_triangles[p.triangle as usize] && p.distance_mm < 10.0
        })
        .collect()
}

/// A ball as OBJ text (20 x 20 vertices, unit radius): a closed surface with no face on it.
pub fn ball_obj() -> String {
    let mut text = String::new();
    for r in 0..20 {
        for c in 0..20 {
            let theta = std::f32::consts::PI * r as f32 / 19.0;
            let phi = std::f32::consts::TAU * c as f32 / 20.0;
            text.push_str(&format!(
                "v {} {} {}\n",
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin()
            ));
        }
    }
    for r in 0..19 {
        for c in 0..20 {
            let (a, b) = (r * 20 + c + 1, r * 20 + (c + 1) % 20 + 1);
            text.push_str(&format!("f {a} {} {b}\nf {b} {} {}\n", a + 20, a + 20, b + 20));
        }
    }
    text
}

/// The part of `head` within `radius_mm` of `centre` and in front of the plane `depth_mm`
/// behind it (+z forward), renumbered.
pub fn cut_face(
    head: &facewire::head::Head,
    centre: glam::Vec3,
    radius_mm: f32,
    depth_mm: f32,
    mm_per_unit: f32,
) -> facewire::head::Head {
    let keep: Vec<bool> = head
        .positions
        .iter()
        .map(|p| p.distance(centre) * mm_per_unit < radius_mm && (centre.z - p.z) * mm_per_unit < depth_mm)
        .collect();
    let mut renumber = vec![u32::MAX; head.positions.len()];
    let mut positions = Vec::new();
    for (v, p) in head.positions.iter().enumerate() {
        if keep[v] {
            renumber[v] = positions.len() as u32;
            positions.push(*p);
        }
    }
    let triangles = head
        .triangles
        .iter()
        .filter(|t| t.iter().all(|&v| keep[v as usize]))
        .map(|t| t.map(|v| renumber[v as usize]))
        .collect();
    facewire::head::Head::new("face.obj", positions, triangles)
}

/// Shipped head `name` with `share` of its jawOpen target (`target`, under data/heads).
pub fn part_open_head(name: &str, target: &str, share: f32) -> Head {
    let neutral = Head::load(&data(&format!("heads/{name}.obj"))).unwrap();
    let open =
        facewire::targets::ExpressionTarget::load(&data(&format!("heads/{target}")), neutral.positions.len())
            .unwrap();
    let positions = neutral
        .positions
        .iter()
        .zip(&open.displacements)
        .map(|(n, d)| *n + *d * share)
        .collect();
    Head::new(&format!("{name}_part_open"), positions, neutral.triangles.clone())
}

/// Mean over a head's expression targets of the RMS error (mm) over the face when the
/// target, sampled at the anchors, drives `spec`: what `facewire compare` reports as
/// `ground_truth_rms_mm`.
pub fn ground_truth_mm(reg: &Registration, targets: &[ExpressionTarget], spec: &str) -> f64 {
    let mm = reg.mm_per_unit();
    let face = FaceVertices::new(&reg.head, &reg.fitted.mask, &reg.anchors, mm).unwrap();
    let binding = bind(reg, &spec.parse().unwrap());
    let rest = &reg.head.positions;
    let mut controls = vec![Vec3::ZERO; reg.mask_rest().len()];
    let mut target_positions = vec![Vec3::ZERO; rest.len()];
    let mut sum = 0.0;
    for target in targets {
        target.controls_into(&reg.anchors, 1.0, &mut controls).unwrap();
        let mask_now: Vec<Vec3> = reg
            .mask_rest()
            .iter()
            .zip(&controls)
            .map(|(r, c)| *r + *c)
            .collect();
        let deformed = deform_with(reg, &binding, &mask_now);
        target.apply_into(rest, 1.0, &mut target_positions).unwrap();
        sum += ground_truth_error(&deformed, &target_positions, &face, mm)
            .unwrap()
            .rms_mm;
    }
    sum / targets.len() as f64
}
