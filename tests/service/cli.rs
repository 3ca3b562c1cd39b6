//! The `facewire` binary as a user runs it: real processes, real files.

use crate::common::{data, facewire_deform, obj_positions};

use std::path::Path;
use std::process::{Command, Output};

fn facewire(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_facewire"))
        .args(args)
        .output()
        .expect("facewire runs")
}

fn json(args: &[&str]) -> serde_json::Value {
    let out = facewire(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("valid JSON")
}

#[test]
fn inspect_reports_the_model_and_the_heads() {
    let wfm = data("candide3/candide3.wfm");
    let mask = json(&["inspect", wfm.to_str().unwrap(), "--json"]);
    assert_eq!(mask["vertices"], 113);
    assert_eq!(mask["triangles"], 184);
    assert_eq!(mask["animation_units"].as_array().unwrap().len(), 65);
    assert_eq!(mask["shape_units"].as_array().unwrap().len(), 14);
    assert_eq!(mask["animation_units"][11]["key"], "fap3_open_jaw");

    let scan = data("heads/lee_perry_smith_head.obj");
    let head = json(&["inspect", scan.to_str().unwrap(), "--json"]);
    assert_eq!(head["vertices"], 8838);
    assert_eq!(head["triangles"], 17672);
    assert_eq!(head["boundary_loops"], 0);
    assert_eq!(head["problems"].as_array().unwrap().len(), 0);

    let fit = data("heads/makehuman_head.fit.toml");
    let report = json(&["inspect", fit.to_str().unwrap(), "--json"]);
    assert_eq!(report["mm_per_unit"], 100.0);
    let mean = report["residuals"]["surface"]["mean_mm"].as_f64().unwrap();
    assert!(mean > 0.5 && mean < 3.5, "{mean}");
}

#[test]
fn inspect_refuses_bad_files_with_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n").unwrap();
    let out = facewire(&["inspect", bad.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.obj: line 4: face corner 7 is out of range"),
        "{err}"
    );

    let unknown = dir.path().join("notes.md");
    std::fs::write(&unknown, "hello").unwrap();
    let out = facewire(&["inspect", unknown.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown kind of file"));
}

#[test]
fn fit_reproduces_the_shipped_fits() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["makehuman_head", "lee_perry_smith_head", "ict_head"] {
        let out_path = dir.path().join(format!("{name}.fit.toml"));
        let head = data(&format!("heads/{name}.obj"));
        let landmarks = data(&format!("heads/{name}.landmarks.toml"));
        let out = facewire(&[
            "fit",
            "--head",
            head.to_str().unwrap(),
            "--landmarks",
            landmarks.to_str().unwrap(),
            "--out",
            out_path.to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(stdout.contains("before (similarity only)") && stdout.contains("after (with shape units)"));
        let shipped = std::fs::read_to_string(data(&format!("heads/{name}.fit.toml"))).unwrap();
        assert_eq!(std::fs::read_to_string(&out_path).unwrap(), shipped, "{name}");
    }
}

#[test]
fn inspect_says_what_each_mesh_of_a_gltf_avatar_is_taken_for() {
    let dir = tempfile::tempdir().unwrap();
    let avatar = dir.path().join("avatar.glb");
    std::fs::write(&avatar, crate::common::glb::ict_avatar()).unwrap();
    let report = json(&["inspect", avatar.to_str().unwrap(), "--json"]);
    let rows: Vec<(String, String, u64)> = report["meshes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            let name = m["name"].as_str().unwrap().to_string();
            (
                name,
                m["role"].as_str().unwrap().to_string(),
                m["triangles"].as_u64().unwrap(),
            )
        })
        .collect();
    let roles: Vec<(&str, &str)> = rows.iter().map(|(n, r, _)| (n.as_str(), r.as_str())).collect();
    assert_eq!(
        roles,
        [
            ("Head", "skin"),
            ("Wolf3D_Teeth", "part"),
            ("Tongue", "tongue"),
            ("EyeLeft", "eyes"),
            ("Eyelashes", "none")
        ]
    );
    let head = facewire::head::Head::load(&data("heads/ict_head.obj")).unwrap();
    assert_eq!(rows[0].2, head.triangles.len() as u64);
    assert_eq!(report["meshes"][0]["vertices"], head.positions.len());
    assert!(report["refused"].is_null(), "{report}");
    // The text report says the same, and when a registration would refuse the file.
    let out = facewire(&["inspect", avatar.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("registers as it is"), "{text}");
    assert!(!text.contains("ARKit"), "{text}");

    // With the ICT model's 53 expressions on its skin: the 51 ARKit blendshapes they make.
    std::fs::write(&avatar, crate::common::glb::ict_avatar_with_targets()).unwrap();
    let report = json(&["inspect", avatar.to_str().unwrap(), "--json"]);
    let skin = &report["meshes"][0];
    assert_eq!(skin["morph_targets"].as_array().unwrap().len(), 54);
    assert_eq!(skin["arkit_blendshapes"].as_array().unwrap().len(), 51);
    let out = facewire(&["inspect", avatar.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("54 morph targets (51 ARKit blendshapes)"), "{text}");
}

#[test]
fn fit_reads_a_gltf_avatar_in_metres() {
    let dir = tempfile::tempdir().unwrap();
    let avatar = dir.path().join("avatar.glb");
    std::fs::write(&avatar, crate::common::glb::ict_avatar()).unwrap();
    let out_path = dir.path().join("avatar.fit.toml");
    let report = json(&[
        "fit",
        "--head",
        avatar.to_str().unwrap(),
        "--out",
        out_path.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(
        report["mm_per_unit_source"], "the file's format (glTF: metres)",
        "{report}"
    );
    assert_eq!(report["fit"]["mm_per_unit"], 1000.0, "{report}");
    // The skin read from the file is the shipped head in metres: measured 1.86 mm from
    // the surface on average (0.61 mm in its centimetres: the automatic fit still depends on
    // the head's unit, docs/FITTING.md "Units").
    let surface = report["report"]["surface"]["mean_mm"].as_f64().unwrap();
    assert!(surface < 2.0, "{report}");
}

#[test]
fn fit_without_landmarks_finds_the_face_and_guesses_the_units() {
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("ict.fit.toml");
    let head = data("heads/ict_head.obj");
    let args = [
        "fit",
        "--head",
        head.to_str().unwrap(),
        "--out",
        out_path.to_str().unwrap(),
    ];
    let out = facewire(&args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("with no landmarks"), "{stdout}");
    // The pupils' guess (9.77 mm per unit: the ICT head's pupils are 64.5 mm apart) is
    // taken as the standard unit near it.
    assert!(
        stdout.contains("+/- 6 % (1 sd), within 15 % of centimetres: taken as centimetres"),
        "{stdout}"
    );
    assert!(
        stdout.contains(
            "found: both eyes as openings, their corners pinned; mouth corners where the lips' fissure ends (its ends' mean width)"
        ),
        "{stdout}"
    );
    // The fit report: the regions' table and the mouth at rest.
    assert!(
        stdout.contains("forehead and cheeks") && stdout.contains("inner lips apart at rest"),
        "{stdout}"
    );
    // The written fit is a fit like any other: `facewire inspect` resolves it on the head.
    let inspected = json(&[
        "inspect",
        out_path.to_str().unwrap(),
        "--head",
        head.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(inspected["mm_per_unit"].as_f64(), Some(10.0), "{inspected}");

    let mut json_args = args.to_vec();
    json_args.push("--json");
    let report = json(&json_args);
    assert_eq!(report["unit_guess"], "centimetres");
    let pupils = report["pupils_mm_per_unit"].as_f64().unwrap();
    assert!((9.0..10.5).contains(&pupils), "{report}");
    // The uncertainty measured on the population (docs/FITTING.md, "Units").
    assert_eq!(report["pupils_relative_sd"].as_f64(), Some(0.061), "{report}");
    assert_eq!(
        report["found"],
        serde_json::json!({
            "eyes": ["opening", "opening"],
            "eye_corners_pinned": true,
            "outer_eye_corners_on_skin": false,
            "mouth_corners": "at_both_ends"
        })
    );
    assert_eq!(report["mm_per_unit_source"], "63 mm pupil separation");
    assert!(
        report["report"]["surface"]["mean_mm"].as_f64().unwrap() < 2.0,
        "{report}"
    );
    assert_eq!(
        report["report"]["regions"].as_array().unwrap().len(),
        6,
        "{report}"
    );
    let forward = report["forward"].as_array().unwrap();
    assert!(forward[2].as_f64().unwrap() > 0.99, "{report}");

    // A mesh with no face is refused with the reason, and nothing is written.
    let ball = dir.path().join("ball.obj");
    std::fs::write(&ball, crate::common::ball_obj()).unwrap();
    let refused = dir.path().join("ball.fit.toml");
    let out = facewire(&[
        "fit",
        "--head",
        ball.to_str().unwrap(),
        "--out",
        refused.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("ball.obj: no face found") && err.contains("Give landmarks"),
        "{err}"
    );
    assert!(!refused.exists());
}

#[test]
fn render_writes_a_png() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("mh.png");
    let head = data("heads/makehuman_head.obj");
    let fit = data("heads/makehuman_head.fit.toml");
    let out = facewire(&[
        "render",
        "--head",
        head.to_str().unwrap(),
        "--fit",
        fit.to_str().unwrap(),
        "--size",
        "64",
        "--out",
        png.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    // IHDR: width and height, big-endian, at bytes 16..24
    assert_eq!(&bytes[16..24], &[0, 0, 0, 64, 0, 0, 0, 64]);
}

#[test]
fn render_frames_the_mouth_and_leaves_the_mask_out_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    let head = data("heads/makehuman_head.obj");
    let fit = data("heads/makehuman_head.fit.toml");
    let render = |name: &str, flags: &[&str]| {
        let png = dir.path().join(name);
        let mut args = vec!["render", "--head", head.to_str().unwrap(), "--size", "96"];
        args.extend_from_slice(flags);
        args.extend_from_slice(&["--out", png.to_str().unwrap()]);
        let out = facewire(&args);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        std::fs::read(&png).unwrap()
    };
    let fit = fit.to_str().unwrap();
    let face = render("face.png", &["--fit", fit, "--face"]);
    let bare_face = render("bare_face.png", &["--fit", fit, "--face", "--no-mask"]);
    let mouth = render("mouth.png", &["--fit", fit, "--mouth", "--no-mask"]);
    assert_ne!(face, bare_face, "--no-mask drew the mask");
    assert_ne!(bare_face, mouth, "--mouth framed the face");
    let out = facewire(&[
        "render",
        "--head",
        head.to_str().unwrap(),
        "--mouth",
        "--out",
        "x.png",
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--fit"));
}

/// `facewire deform` on the MakeHuman head with algorithm G over frames `A..B` of a stream file.
fn deform(stream: &Path, frames: &str, dir: &Path) -> Output {
    let extra = ["--algo", "G", "--frames", frames].map(std::ffi::OsStr::new);
    facewire_deform("makehuman_head", stream, dir, &extra)
}

#[test]
fn every_stream_format_drives_deform() {
    let rest = obj_positions(&data("heads/makehuman_head.obj"));
    let scratch = tempfile::tempdir().unwrap();
    let arkit = scratch.path().join("arkit.jsonl");
    std::fs::write(&arkit, "{\"seq\":0,\"t\":0,\"arkit\":{\"jawOpen\":1.0}}\n").unwrap();
    let au_text = scratch.path().join("jaw.fau");
    std::fs::write(&au_text, "# columns: jaw_drop\n0.6\n").unwrap();
    for (stream, frames) in [
        (data("streams/syllables.jsonl"), "10..12"),
        (data("candide3/xface_joy.fap"), "40..41"),
        (arkit, "0..1"),
        (au_text, "0..1"),
    ] {
        let out = scratch
            .path()
            .join(format!("out-{}", stream.file_name().unwrap().to_string_lossy()));
        let run = deform(&stream, frames, &out);
        assert!(
            run.status.success(),
            "{}: {}",
            stream.display(),
            String::from_utf8_lossy(&run.stderr)
        );
        let first: usize = frames.split("..").next().unwrap().parse().unwrap();
        let moved = obj_positions(&out.join(format!("frame_{first:05}.obj")));
        assert_eq!(moved.len(), rest.len());
        let largest = moved
            .iter()
            .zip(&rest)
            .map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0f32, f32::max))
            .fold(0.0f32, f32::max);
        assert!(
            largest > 0.01,
            "{}: the head did not move ({largest})",
            stream.display()
        );
        let control = std::fs::read_to_string(out.join("control.tsv")).unwrap();
        let expected_frames = frames
            .split("..")
            .map(|x| x.parse::<usize>().unwrap())
            .collect::<Vec<_>>();
        assert_eq!(
            control.lines().count(),
            1 + 113 * (expected_frames[1] - expected_frames[0])
        );
        let metrics = std::fs::read_to_string(out.join("metrics.tsv")).unwrap();
        assert_eq!(
            metrics.lines().count(),
            1 + 19 * (expected_frames[1] - expected_frames[0])
        );
    }
}

/// The face lines of an OBJ, as written.
fn obj_faces(path: &Path) -> Vec<String> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| l.starts_with("f "))
        .map(str::to_string)
        .collect()
}

/// `--algo` reaches the deformer: `facewire algos` lists the 22 presets, and the default
/// and another preset write the same faces with different vertices. (Every preset
/// on both heads and both shipped streams is `tests/core/deform.rs`'s, in-process.)
#[test]
fn deform_takes_the_algorithm_asked_for() {
    let scratch = tempfile::tempdir().unwrap();
    let presets = json(&["algos", "--json"]);
    let letters: Vec<&str> = presets
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["letter"].as_str().unwrap())
        .collect();
    assert_eq!(letters.len(), 22);
    // The default is V (README); A is another preset.
    let (default, other) = ("V", "A");
    assert!(letters.contains(&default) && letters.contains(&other));
    let obj = data("heads/makehuman_head.obj");
    let fit = data("heads/makehuman_head.fit.toml");
    let rest = obj_positions(&obj);
    let faces = obj_faces(&obj);
    let stream = data("streams/syllables.jsonl");
    // Syllable frame 280 drops the jaw.
    let written: Vec<Vec<[f32; 3]>> = [None, Some(other)]
        .iter()
        .map(|letter| {
            let out = scratch.path().join(letter.unwrap_or("default"));
            let mut args = vec![
                "deform",
                "--head",
                obj.to_str().unwrap(),
                "--fit",
                fit.to_str().unwrap(),
                "--stream",
                stream.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
                "--frames",
                "280..281",
            ];
            if let Some(letter) = letter {
                args.extend(["--algo", letter]);
            }
            let run = facewire(&args);
            assert!(
                run.status.success(),
                "{letter:?}: {}",
                String::from_utf8_lossy(&run.stderr)
            );
            let written = out.join("frame_00280.obj");
            assert_eq!(obj_faces(&written), faces, "{letter:?}: faces changed");
            let moved = obj_positions(&written);
            assert_eq!(moved.len(), rest.len());
            assert!(
                moved.iter().flatten().all(|x| x.is_finite()),
                "{letter:?}: not finite"
            );
            assert!(moved != rest, "{letter:?}: nothing moved");
            moved
        })
        .collect();
    assert_ne!(
        written[0], written[1],
        "{default} and {other} wrote the same head"
    );
}

/// Runs `facewire inspect FILE` expecting it to fail; returns stderr.
fn inspect_error(file: &Path) -> String {
    let out = facewire(&["inspect", file.to_str().unwrap()]);
    assert!(!out.status.success(), "{} was accepted", file.display());
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn inspect_counts_32000_duplicate_faces_and_refuses_a_huge_polygon() {
    let dir = tempfile::tempdir().unwrap();
    let duplicates = dir.path().join("dup.obj");
    let text = format!("v 0 0 0\nv 1 0 0\nv 0 1 0\n{}", "f 1 2 3\n".repeat(32_000));
    std::fs::write(&duplicates, text).unwrap();
    let report = json(&["inspect", duplicates.to_str().unwrap(), "--json"]);
    let problems = report["problems"].as_array().unwrap();
    let count = |kind: &str| {
        problems
            .iter()
            .find(|p| p["kind"] == kind)
            .map(|p| p["count"].clone())
    };
    assert_eq!(count("duplicate_triangles"), Some(31_999.into()));
    assert_eq!(count("non_manifold_edges"), Some(3.into()));

    let polygon = dir.path().join("poly.obj");
    let corners: Vec<String> = (1..=80_000).map(|i| i.to_string()).collect();
    std::fs::write(
        &polygon,
        format!("{}f {}\n", "v 0 0 0\n".repeat(80_000), corners.join(" ")),
    )
    .unwrap();
    let err = inspect_error(&polygon);
    assert!(
        err.contains("poly.obj: line 80001: a face with 80000 corners; at most 64"),
        "{err}"
    );
}

#[test]
fn inspect_validates_landmarks_as_the_service_does() {
    let dir = tempfile::tempdir().unwrap();
    let shipped = std::fs::read_to_string(data("heads/makehuman_head.landmarks.toml")).unwrap();
    let bad = dir.path().join("bad.landmarks.toml");
    std::fs::write(&bad, shipped.replace("mask_vertex = 20\n", "mask_vertex = 999\n")).unwrap();
    let err = inspect_error(&bad);
    assert!(
        err.contains("bad.landmarks.toml: landmark[0].mask_vertex = 999 is out of range (must be below 113)"),
        "{err}"
    );
    // With the head at hand, head vertices are checked too.
    let far = dir.path().join("far.landmarks.toml");
    std::fs::write(
        &far,
        shipped.replace("head_vertex = 15\n", "head_vertex = 999999\n"),
    )
    .unwrap();
    let head = data("heads/makehuman_head.obj");
    let out = facewire(&["inspect", far.to_str().unwrap(), "--head", head.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("landmark[1].head_vertex = 999999 is out of range"),
        "{err}"
    );
    for bad_scale in ["nan", "0.0", "-5.0", "inf"] {
        let file = dir.path().join("scale.landmarks.toml");
        std::fs::write(
            &file,
            shipped.replace("mm_per_unit = 100.0", &format!("mm_per_unit = {bad_scale}")),
        )
        .unwrap();
        let err = inspect_error(&file);
        assert!(
            err.contains("scale.landmarks.toml: field mm_per_unit: "),
            "{bad_scale}: {err}"
        );
    }
}

#[test]
fn inspect_reads_only_regular_files() {
    let dir = tempfile::tempdir().unwrap();
    let shipped = std::fs::read_to_string(data("heads/makehuman_head.fit.toml")).unwrap();
    let fit = dir.path().join("zero.fit.toml");
    std::fs::write(
        &fit,
        shipped.replace("head = \"makehuman_head.obj\"", "head = \"/dev/zero\""),
    )
    .unwrap();
    let err = inspect_error(&fit);
    assert!(
        err.contains("cannot read /dev/zero: it is a character device, not a regular file"),
        "{err}"
    );
    let folder = dir.path().join("folder.obj");
    std::fs::create_dir(&folder).unwrap();
    assert!(inspect_error(&folder).contains("it is a directory, not a regular file"));
}

#[test]
fn errors_cut_a_six_megabyte_token() {
    let dir = tempfile::tempdir().unwrap();
    let token = "1".repeat(3_000_000) + &"e".repeat(3_000_000);
    // Stream lines stop at 1 MiB; a 600 kB token fits in one.
    let stream_token = &token[2_700_000..3_300_000];
    let files = [
        ("token.obj", format!("v 0 0 0\nv 0 {token} 0\n")),
        ("token.fit.toml", format!("{token} = 1\n")),
        (
            "token.jsonl",
            format!("{{\"seq\":0,\"t\":0,\"au\":{{\"{stream_token}\":1}}}}\n"),
        ),
        ("token.fap", format!("2.1 token {stream_token} 1\n")),
    ];
    for (name, text) in files {
        let file = dir.path().join(name);
        std::fs::write(&file, text).unwrap();
        let err = inspect_error(&file);
        assert!(err.len() < 2_000, "{name}: {} bytes on stderr", err.len());
        assert!(err.contains("… (600000"), "{name}: {err}");
    }
}

#[test]
fn bad_utf8_in_toml_names_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let landmarks = dir.path().join("l.landmarks.toml");
    std::fs::write(&landmarks, b"head = \"h.obj\"\n# na\xefve\n").unwrap();
    let err = inspect_error(&landmarks);
    assert!(
        err.contains("l.landmarks.toml: line 2, column 5: not valid UTF-8 (byte 19)"),
        "{err}"
    );
}
