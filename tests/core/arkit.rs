//! ARKit input end to end: the shipped retarget basis is what the generator makes from the
//! MakeHuman targets, it reproduces a target at the anchors of the head it came from, and
//! it carries over to another head through that head's fit.
//!
//! `FACEWIRE_BLESS=1 cargo test --test core arkit::` rewrites `data/arkit/basis.tsv` from the
//! generator (as `facewire arkit-basis` does).

use crate::common::repo_path;

use glam::Vec3;

use facewire::fit::{anchor_mask, Anchors, FitFile, FittedMask};
use facewire::head::Head;
use facewire::mask::{Mask, LOWER_LIP, UPPER_LIP};
use facewire::stream::arkit::{OFFSET_DECIMALS, SHIPPED_BASIS_COMMAND, SHIPPED_BASIS_TSV};
use facewire::stream::{arkit_index, ArkitBasis, Frame, ARKIT_BLENDSHAPES};
use facewire::targets::ExpressionTarget;

/// The shipped file and the generator may differ by one unit of the last written digit
/// (1e-6 mask units, about 1e-4 mm on the MakeHuman head) where a platform rounds an f32
/// operation differently.
const FILE_TOLERANCE_MASK_UNITS: f32 = 1.01e-6;

/// The basis moves the MakeHuman anchors to the target within this (mm): rounding to
/// 1e-6 mask units leaves at most 0.8e-4 mm, f32 positions about 1e-4 mm more.
const ANCHOR_TOLERANCE_MM: f32 = 1e-3;

fn fitted(fit_file: &str) -> FittedMask {
    let mask = Mask::candide3();
    let fit = FitFile::load(&repo_path(fit_file))
        .unwrap()
        .resolve(fit_file, &mask)
        .unwrap();
    FittedMask::new(mask, fit)
}

struct MakeHuman {
    head: Head,
    fitted: FittedMask,
    anchors: Anchors,
}

fn makehuman() -> MakeHuman {
    let head = Head::load(&repo_path("data/heads/makehuman_head.obj")).unwrap();
    let fitted = fitted("data/heads/makehuman_head.fit.toml");
    let anchors = anchor_mask(&head, &fitted.neutral, fitted.fit.mm_per_unit);
    MakeHuman {
        head,
        fitted,
        anchors,
    }
}

/// Blendshape `shape` at weight 1, one offset per mask vertex (mask units).
fn dense(basis: &ArkitBasis, shape: u8, vertices: usize) -> Vec<Vec3> {
    let mut out = vec![Vec3::ZERO; vertices];
    basis.apply(&[(shape, 1.0)], &mut out);
    out
}

/// The mask vertices (head units) for a frame, by the per-frame path.
fn pose_frame(fitted: &FittedMask, basis: &ArkitBasis, frame: &Frame) -> Vec<Vec3> {
    let mut weights = vec![0.0; fitted.mask.animation_units.len()];
    let mut offsets = vec![Vec3::ZERO; fitted.mask.vertices.len()];
    let mut posed = offsets.clone();
    facewire::stream::animation_weights(frame, &fitted.mask, &fitted.fapu, &mut weights);
    facewire::stream::mask_offsets(frame, basis, &mut offsets);
    fitted.pose_with_offsets_into(&weights, &offsets, &mut posed);
    posed
}

fn jaw_open_frame() -> Frame {
    Frame {
        arkit: vec![(arkit_index("jawOpen").unwrap(), 1.0)],
        ..Frame::at(0, 0.0)
    }
}

#[test]
fn shipped_basis_matches_the_generator() {
    let MakeHuman {
        head,
        fitted,
        anchors,
    } = makehuman();
    let targets =
        ExpressionTarget::load_dir(&repo_path("data/heads/makehuman_arkit"), head.positions.len()).unwrap();
    assert_eq!(targets.len(), 51);
    let generated = ArkitBasis::derive(&fitted, &anchors, &targets)
        .unwrap()
        .to_tsv(SHIPPED_BASIS_COMMAND);
    let path = repo_path("data/arkit/basis.tsv");
    if std::env::var_os("FACEWIRE_BLESS").is_some_and(|v| v == "1") {
        facewire::atomic::write_atomic(&path, generated.as_bytes()).unwrap();
    }
    let shipped = std::fs::read_to_string(&path).unwrap();
    let comments = |text: &str| -> Vec<String> {
        text.lines()
            .filter(|l| l.starts_with('#'))
            .map(str::to_string)
            .collect()
    };
    assert_eq!(
        comments(&shipped),
        comments(&generated),
        "header of {}",
        path.display()
    );
    assert!(shipped.contains(&format!("offsets rounded to 1e-{OFFSET_DECIMALS}")));

    let shipped_basis = ArkitBasis::parse("shipped", &shipped).unwrap();
    let generated_basis = ArkitBasis::parse("generated", &generated).unwrap();
    let vertices = fitted.mask.vertices.len();
    for (shape, name) in (0u8..).zip(ARKIT_BLENDSHAPES) {
        let (a, b) = (
            dense(&shipped_basis, shape, vertices),
            dense(&generated_basis, shape, vertices),
        );
        for (vertex, (a, b)) in a.iter().zip(&b).enumerate() {
            assert!(
                a.abs_diff_eq(*b, FILE_TOLERANCE_MASK_UNITS),
                "{name} mask vertex {vertex}: shipped {a}, generated {b}; \
                 rerun with FACEWIRE_BLESS=1 if the change is intended"
            );
        }
    }
    // The binary embeds the file the tests see.
    assert_eq!(SHIPPED_BASIS_TSV, shipped);
}

#[test]
fn jaw_open_moves_the_makehuman_anchors_with_the_target() {
    let MakeHuman {
        head,
        fitted,
        anchors,
    } = makehuman();
    let target = ExpressionTarget::load(
        &repo_path("data/heads/makehuman_arkit/jawOpen.target"),
        head.positions.len(),
    )
    .unwrap();
    let mut truth = vec![Vec3::ZERO; anchors.vertex.len()];
    target.controls_into(&anchors, 1.0, &mut truth).unwrap();

    let posed = pose_frame(&fitted, &ArkitBasis::shipped(), &jaw_open_frame());
    let mm = fitted.fit.mm_per_unit;
    let used = fitted.mask.used_vertices();
    let mut worst_mm = 0.0f32;
    for (j, is_used) in used.iter().enumerate() {
        let moved = posed[j] - fitted.neutral[j];
        let expected = if *is_used { truth[j] } else { Vec3::ZERO };
        worst_mm = worst_mm.max((moved - expected).length() * mm);
    }
    assert!(worst_mm < ANCHOR_TOLERANCE_MM, "worst anchor error {worst_mm} mm");

    // Not trivially so: the inner lower-lip middle drops by centimetres (34.3 mm).
    let drop_mm = -(posed[40] - fitted.neutral[40]).y * mm;
    assert!(drop_mm > 20.0, "inner lower lip drops {drop_mm} mm");
}

#[test]
fn jaw_open_lowers_the_scans_lower_lip() {
    let scan = fitted("data/heads/lee_perry_smith_head.fit.toml");
    let posed = pose_frame(&scan, &ArkitBasis::shipped(), &jaw_open_frame());
    let mm = scan.fit.mm_per_unit;
    let drop_mm = |j: usize| -(posed[j] - scan.neutral[j]).y * mm;
    // Measured: lower lip 29.7 to 36.9 mm, upper lip at most 4.1 mm.
    for j in LOWER_LIP {
        assert!(
            drop_mm(j) > 20.0,
            "scan lower-lip mask vertex {j} drops {} mm",
            drop_mm(j)
        );
    }
    let lowest_lower = LOWER_LIP
        .iter()
        .map(|&j| drop_mm(j))
        .fold(f32::INFINITY, f32::min);
    for j in UPPER_LIP {
        assert!(
            drop_mm(j) < lowest_lower,
            "upper-lip mask vertex {j} drops {} mm, as much as the lower lip",
            drop_mm(j)
        );
    }
}

#[test]
fn a_jsonl_arkit_frame_poses_the_mask() {
    let mask = Mask::candide3();
    let line = "{\"seq\":0,\"t\":0,\"arkit\":{\"jawOpen\":0.5,\"mouthSmileLeft\":0.25}}\n";
    let frame = facewire::stream::JsonlReader::new(line.as_bytes(), &mask)
        .next()
        .unwrap()
        .unwrap();
    let scan = fitted("data/heads/lee_perry_smith_head.fit.toml");
    let basis = ArkitBasis::shipped();
    let posed = pose_frame(&scan, &basis, &frame);
    // Linear in the weights: half a jawOpen plus a quarter smile.
    let vertices = scan.mask.vertices.len();
    let jaw = dense(&basis, arkit_index("jawOpen").unwrap(), vertices);
    let smile = dense(&basis, arkit_index("mouthSmileLeft").unwrap(), vertices);
    let offsets: Vec<Vec3> = jaw
        .iter()
        .zip(&smile)
        .map(|(j, s)| 0.5 * *j + 0.25 * *s)
        .collect();
    let mut expected = vec![Vec3::ZERO; vertices];
    scan.pose_with_offsets_into(
        &vec![0.0; scan.mask.animation_units.len()],
        &offsets,
        &mut expected,
    );
    for (a, b) in posed.iter().zip(&expected) {
        assert!(a.abs_diff_eq(*b, 1e-6), "{a} {b}");
    }
}
