//! The geometry core against the shipped data: the CANDIDE-3 model, both real heads and
//! their fits.

use crate::common::data;

use std::path::Path;

use facewire::fit::{anchor_mask, residuals, FitFile, FittedMask, Landmarks};
use facewire::head::{Head, HeadError, ObjError, SurfaceDistance};
use facewire::input::ReadError;
use facewire::mask::{Fapu, Mask, MaskPose, WfmError, INNER_LIP_MID_LOWER, INNER_LIP_MID_UPPER};
use facewire::quote::quote;
use glam::Vec3;

fn wfm_text() -> String {
    std::fs::read(data("candide3/candide3.wfm"))
        .unwrap()
        .iter()
        .map(|&b| char::from(b))
        .collect()
}

#[test]
fn the_real_model_parses_with_every_section() {
    let mask = Mask::load(&data("candide3/candide3.wfm")).unwrap();
    assert_eq!(mask.vertices.len(), 113);
    assert_eq!(mask.triangles.len(), 184);
    assert_eq!(mask.animation_units.len(), 65);
    assert_eq!(mask.shape_units.len(), 14);
    assert!(mask.animation_params.is_empty() && mask.shape_params.is_empty() && mask.texture.is_empty());
    assert_eq!(mask.global_motion.scale, Vec3::ONE);
    let unused: Vec<usize> = mask
        .used_vertices()
        .iter()
        .enumerate()
        .filter(|(_, u)| !**u)
        .map(|(v, _)| v)
        .collect();
    assert_eq!(unused, vec![4, 35, 36, 37, 38, 39, 41, 42, 43]);
    assert_eq!(mask.vertices[31], Vec3::new(0.246, -0.461, 0.0));
    assert_eq!(mask.animation_units[1].title, "AUV11 Jaw drop (AU26/27)");
    assert_eq!(mask.shape_units[13].key, "chin_width");
    // Latin-1 header survives: the embedded copy is the same model.
    assert_eq!(Mask::candide3().vertices, mask.vertices);
}

/// Replaces the `n`-th (1-based) line of the model.
fn with_line(n: usize, replacement: &str) -> String {
    wfm_text()
        .lines()
        .enumerate()
        .map(|(i, l)| if i + 1 == n { replacement } else { l })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn malformed_models_name_the_line() {
    // The vertex list starts at line 39 (count), vertices on 40..=152; faces count on 155.
    let text = wfm_text();
    let truncated: String = text.lines().take(100).collect::<Vec<_>>().join("\n");
    assert_eq!(
        Mask::from_wfm_bytes(truncated.as_bytes()).unwrap_err(),
        WfmError::Truncated {
            line: 101,
            expected: "vertex 61".into()
        }
    );
    let err = Mask::from_wfm_bytes(with_line(40, "0.0 abc 0.0").as_bytes()).unwrap_err();
    assert_eq!(
        err,
        WfmError::NotANumber {
            line: 40,
            field: "vertex 0 y".into(),
            found: quote("abc")
        }
    );
    assert_eq!(err.to_string(), "line 40: vertex 0 y \"abc\" is not a number");
    // A 6 MB token is quoted short, with its length.
    let token = "7".repeat(3_000_000) + &"x".repeat(3_000_000);
    for line in [format!("0.0 {token} 0.0"), format!("0.0 0.0 0.0 {token}")] {
        let err = Mask::from_wfm_bytes(with_line(40, &line).as_bytes())
            .unwrap_err()
            .to_string();
        assert!(err.len() < 200, "{} bytes", err.len());
        assert!(err.contains("\"… (6000"), "{err}");
    }
    let err = Mask::from_wfm_bytes(with_line(156, "0 1 113").as_bytes()).unwrap_err();
    assert!(
        matches!(
            err,
            WfmError::OutOfRange {
                line: 156,
                value: 113,
                limit: 113,
                ..
            }
        ),
        "{err}"
    );
    // A count larger than the data: the reader runs into the next section's title.
    let err = Mask::from_wfm_bytes(with_line(155, "185").as_bytes()).unwrap_err();
    assert!(
        err.to_string()
            .starts_with("line 342: expected 3 number(s) for face 184"),
        "{err}"
    );
    let err = Mask::from_wfm_bytes(with_line(39, "99999999").as_bytes()).unwrap_err();
    assert!(matches!(err, WfmError::CountTooLarge { line: 39, .. }), "{err}");
    let err = Mask::from_wfm_bytes(with_line(40, "0.0 inf 0.0").as_bytes()).unwrap_err();
    assert!(matches!(err, WfmError::NotFinite { line: 40, .. }), "{err}");
    assert!(Mask::from_wfm_bytes(b"").is_err());
}

#[test]
fn zero_parameters_give_the_neutral_mask_exactly() {
    let mask = Mask::candide3();
    let mut out = Vec::new();
    mask.pose(&[0.0; 14], &[0.0; 65], &MaskPose::IDENTITY, &mut out);
    assert_eq!(out, mask.vertices);
}

#[test]
fn open_jaw_at_512_moves_the_jaw_half_an_mns() {
    let mask = Mask::candide3();
    let fapu = facewire::mask::FapuValues::measure(&mask.vertices);
    let unit = mask.fap_unit(3).unwrap();
    let mut animation = vec![0.0; 65];
    animation[unit] = fapu.weight(Fapu::Mns, 512.0);
    let mut out = Vec::new();
    mask.pose(&[0.0; 14], &animation, &MaskPose::IDENTITY, &mut out);
    for (v, (moved, rest)) in out.iter().zip(&mask.vertices).enumerate() {
        let expected = if [10, 32, 65].contains(&v) {
            Vec3::new(0.0, -0.5 * 0.196, 0.0)
        } else {
            Vec3::ZERO
        };
        assert!(
            (*moved - *rest).abs_diff_eq(expected, 1e-6),
            "vertex {v}: {}",
            *moved - *rest
        );
    }
}

#[test]
fn shape_and_animation_units_add_linearly() {
    let mask = Mask::candide3();
    let mut shape = vec![0.0; 14];
    shape[mask.shape_unit("mouth_width").unwrap()] = 0.7;
    let mut animation = vec![0.0; 65];
    animation[mask.animation_unit("jaw_drop").unwrap()] = 0.4;
    animation[mask.animation_unit("lip_stretcher").unwrap()] = -0.3;
    let pose = |s: &[f32], a: &[f32]| {
        let mut out = Vec::new();
        mask.pose(s, a, &MaskPose::IDENTITY, &mut out);
        out
    };
    let both = pose(&shape, &animation);
    let only_shape = pose(&shape, &[0.0; 65]);
    let only_animation = pose(&[0.0; 14], &animation);
    for v in 0..113 {
        let sum = only_shape[v] + only_animation[v] - mask.vertices[v];
        assert!(both[v].abs_diff_eq(sum, 1e-6), "vertex {v}");
    }
    // and the pose is applied after both
    let pose = MaskPose::similarity(Vec3::new(0.1, 0.2, 0.3), 2.0, Vec3::new(1.0, 2.0, 3.0));
    let mut posed = Vec::new();
    mask.pose(&shape, &animation, &pose, &mut posed);
    for v in 0..113 {
        let expected = pose.affine().transform_point3(both[v]);
        assert!(posed[v].abs_diff_eq(expected, 1e-5));
    }
}

struct Fitted {
    head: Head,
    fitted: FittedMask,
}

fn load_fitted(name: &str) -> Fitted {
    let head = Head::load(&data(&format!("heads/{name}.obj"))).unwrap();
    let mask = Mask::candide3();
    let path = data(&format!("heads/{name}.fit.toml"));
    let fit = FitFile::load(&path).unwrap().resolve("fit", &mask).unwrap();
    Fitted {
        head,
        fitted: FittedMask::new(mask, fit),
    }
}

#[test]
fn shipped_fits_lay_the_mask_within_a_few_mm_of_every_head() {
    // (head, mean mm bound, max mm bound): the figures docs/FITTING.md quotes.
    for (name, mean_bound, max_bound) in [
        ("makehuman_head", 3.5, 10.0),
        ("lee_perry_smith_head", 3.5, 20.0),
        ("ict_head", 2.0, 7.0),
    ] {
        let Fitted { head, fitted } = load_fitted(name);
        assert!(head.problems.is_empty(), "{name}: {:?}", head.problems);
        let r = residuals::measure(
            &head,
            &fitted.neutral,
            &fitted.mask.used_vertices(),
            &[],
            fitted.fit.mm_per_unit,
        );
        assert!(r.surface.mean_mm < mean_bound, "{name}: {:?}", r.surface);
        assert!(r.surface.max_mm < max_bound, "{name}: {:?}", r.surface);
    }
}

#[test]
fn inner_lip_anchors_touch_in_space_but_are_far_apart_along_the_surface() {
    for name in ["makehuman_head", "lee_perry_smith_head", "ict_head"] {
        let Fitted { head, fitted } = load_fitted(name);
        let mm = fitted.fit.mm_per_unit;
        let anchors = anchor_mask(&head, &fitted.neutral, mm);
        let (up, low) = (
            anchors.vertex[INNER_LIP_MID_UPPER],
            anchors.vertex[INNER_LIP_MID_LOWER],
        );
        let space_mm = head.positions[up as usize].distance(head.positions[low as usize]) * mm;
        let mut sd = SurfaceDistance::new(head.positions.len());
        sd.run(&head.topology, &[(up, 0.0)], f32::INFINITY);
        let surface_mm = sd.distance(low) * mm;
        assert!(space_mm < 3.0, "{name}: {space_mm} mm apart in space");
        assert!(
            surface_mm > 20.0,
            "{name}: {surface_mm} mm apart along the surface"
        );
        // every lip pair that coincides in the neutral mask gets two different anchors
        for (a, b) in [(87, 40), (81, 83), (82, 84)] {
            assert_ne!(anchors.vertex[a], anchors.vertex[b], "{name}: {a}/{b}");
        }
    }
}

#[test]
fn scan_scale_comes_from_63_mm_pupils() {
    let Fitted { fitted, .. } = load_fitted("lee_perry_smith_head");
    let pupil = |ids: [usize; 4]| ids.iter().map(|&i| fitted.neutral[i]).sum::<Vec3>() / 4.0;
    let separation_mm = pupil([67, 68, 71, 72]).distance(pupil([69, 70, 73, 74])) * fitted.fit.mm_per_unit;
    assert!((separation_mm - 63.0).abs() < 0.01, "{separation_mm}");
    let Fitted { fitted, .. } = load_fitted("makehuman_head");
    assert_eq!(fitted.fit.mm_per_unit, 100.0);
}

#[test]
fn fitted_mask_controls_are_zero_at_rest_and_follow_the_pose() {
    let Fitted { fitted, .. } = load_fitted("makehuman_head");
    let mut controls = vec![Vec3::ZERO; 113];
    fitted.controls_into(&[0.0; 65], &mut controls);
    assert!(controls.iter().all(|d| *d == Vec3::ZERO));
    let mut animation = [0.0; 65];
    animation[1] = 1.0; // jaw drop
    fitted.controls_into(&animation, &mut controls);
    // vertex 8 (lower lip) moves by the rotated, scaled AUV displacement (0, -0.26, -0.05)
    let expected = fitted.fit.pose.rotation() * (fitted.fit.pose.scale * Vec3::new(0.0, -0.26, -0.05));
    assert!(
        controls[8].abs_diff_eq(expected, 1e-5),
        "{} vs {expected}",
        controls[8]
    );
    assert_eq!(controls[5], Vec3::ZERO);
}

#[test]
fn bad_obj_input_gives_clear_errors() {
    let missing = Head::load(Path::new("/nonexistent/head.obj")).unwrap_err();
    assert!(matches!(missing, HeadError::Read(ReadError::Io { .. })));
    assert!(missing.to_string().contains("/nonexistent/head.obj"), "{missing}");
    let garbage = Head::from_obj_bytes("g.obj", &[0xff, 0x00, 0x13, 0x37]).unwrap_err();
    assert_eq!(garbage, ObjError::NoTriangles);
    let nan = Head::from_obj_bytes("n.obj", b"v 0 0 0\nv NaN 0 0\nv 0 1 0\nf 1 2 3\n").unwrap_err();
    assert_eq!(
        nan.to_string(),
        "line 2: vertex 1 has a non-finite coordinate (NaN)"
    );
    let range = Head::from_obj_bytes("r.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n").unwrap_err();
    assert_eq!(
        range.to_string(),
        "line 4: face corner 9 is out of range (the file has 3 vertices so far)"
    );
}

#[test]
fn expression_targets_index_the_head_in_file_order() {
    // Applying jawOpen.target to the neutral head gives the shipped jaw-open head exactly:
    // the OBJ reader keeps the file's vertex numbering.
    let neutral = Head::load(&data("heads/makehuman_head.obj")).unwrap();
    let open = Head::load(&data("heads/makehuman_head_jawopen.obj")).unwrap();
    let mut moved = neutral.positions.clone();
    let target = std::fs::read_to_string(data("heads/makehuman_arkit/jawOpen.target")).unwrap();
    for line in target
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
    {
        let f: Vec<f32> = line.split_whitespace().map(|x| x.parse().unwrap()).collect();
        moved[f[0] as usize] += Vec3::new(f[1], f[2], f[3]);
    }
    for (v, (a, b)) in moved.iter().zip(&open.positions).enumerate() {
        assert!(a.abs_diff_eq(*b, 2e-4), "vertex {v}: {a} vs {b}");
    }
    assert_eq!(neutral.triangles, open.triangles);
}

/// MPEG-4 feature point -> CANDIDE-3 vertex, from `data/candide3/NOTES.md` section 6.1
/// (single-vertex entries only).
fn fdp_table() -> std::collections::HashMap<String, u32> {
    let notes = std::fs::read_to_string(data("candide3/NOTES.md")).unwrap();
    let section = notes
        .split("### 6.1")
        .nth(1)
        .and_then(|rest| rest.split("###").next())
        .unwrap();
    section
        .lines()
        .filter(|l| l.starts_with("- **") && l.contains('→'))
        .flat_map(|l| l.split([':', ',']).skip(1))
        .filter_map(|pair| {
            let (point, vertex) = pair.trim().trim_start_matches("**").trim().split_once('→')?;
            Some((point.trim().to_string(), vertex.trim().parse().ok()?))
        })
        .collect()
}

#[test]
fn landmark_names_agree_with_the_fdp_table() {
    let table = fdp_table();
    assert_eq!(table["3.7"], 20, "left eye, outer corner");
    assert_eq!(table["3.12"], 53, "right eye, outer corner (x = -0.47)");
    for name in ["makehuman_head", "lee_perry_smith_head"] {
        let landmarks = Landmarks::load(&data(&format!("heads/{name}.landmarks.toml"))).unwrap();
        for l in &landmarks.landmarks {
            let label = l.name.as_deref().unwrap_or("");
            let Some(point) = label.split("(FP ").nth(1).map(|p| p.trim_end_matches(')')) else {
                continue;
            };
            assert_eq!(table.get(point), Some(&l.mask_vertex), "{name}: {label}");
        }
    }
}
