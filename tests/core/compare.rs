//! `facewire compare` and `facewire deform`'s metrics table as a user runs them: the real
//! binary on the MakeHuman head, a few algorithms and a short stream, checking every file it
//! writes (headers, row counts, finite numbers, the ground-truth reference, the report's
//! links) and the errors it gives for bad input.

use crate::common::data;

use std::collections::BTreeSet;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use facewire::mask::Mask;
use facewire::metrics::{FOLDS_TSV_HEADER, LIP_ROWS, TSV_HEADER};
use facewire::report::{
    algorithms_header, CONTACT_HEADER, FACE_HEADER, GROUND_TRUTH_HEADER, REST_LETTER, REST_SPEC,
    SYLLABLES_HEADER,
};
use facewire::stream::{open_stream, Frame, JsonlWriter};

/// Frames of the shipped syllable stream the tests replay.
const FRAMES: usize = 40;

fn facewire(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_facewire"))
        .args(args)
        .output()
        .expect("facewire runs")
}

fn succeeds(args: &[&str]) -> Output {
    let out = facewire(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn fails(args: &[&str]) -> String {
    let out = facewire(args);
    assert!(!out.status.success(), "{args:?} should fail");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The first `FRAMES` frames of the shipped stream, written with the stream writer.
fn short_stream(dir: &Path) -> (PathBuf, Vec<Frame>) {
    let mask = Mask::candide3();
    let frames: Vec<Frame> = open_stream(&data("streams/syllables.jsonl"), &mask)
        .unwrap()
        .take(FRAMES)
        .collect::<Result<_, _>>()
        .unwrap();
    let path = dir.join("short.jsonl");
    let mut writer = JsonlWriter::new(BufWriter::new(File::create(&path).unwrap()), &mask);
    for frame in &frames {
        writer.write_frame(frame).unwrap();
    }
    writer.into_inner().unwrap();
    (path, frames)
}

/// A TSV file's header and rows, split on tabs.
fn read_tsv(path: &Path) -> (String, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header = lines.next().expect("a header line").to_string();
    let rows = lines
        .map(|l| l.split('\t').map(str::to_string).collect())
        .collect();
    (header, rows)
}

fn number(field: &str) -> f64 {
    field
        .parse()
        .unwrap_or_else(|_| panic!("{field:?} is not a number"))
}

fn s(path: &Path) -> &str {
    path.to_str().unwrap()
}

#[test]
fn compare_writes_tables_charts_and_report() {
    let dir = tempfile::tempdir().unwrap();
    let (stream, frames) = short_stream(dir.path());
    let out = dir.path().join("report");
    let head = data("heads/makehuman_head.obj");
    let fit = data("heads/makehuman_head.fit.toml");
    let run = succeeds(&[
        "compare",
        "--head",
        s(&head),
        "--fit",
        s(&fit),
        "--stream",
        s(&stream),
        "--out",
        s(&out),
        "--algos",
        "G,kshirsagar,rbf",
        "--json",
    ]);

    // --json: the algorithms table on stdout
    let summary: serde_json::Value = serde_json::from_slice(&run.stdout).expect("JSON on stdout");
    let rows = summary.as_array().unwrap();
    assert_eq!(rows.len(), 3);
    let letters: Vec<&str> = rows.iter().map(|r| r["letter"].as_str().unwrap()).collect();
    assert_eq!(letters, ["G", "S", "T"]);
    assert_eq!(
        rows[2]["spec"],
        "rbf:kernel=wendland,distance=surface,r_mm=30,poly=linear"
    );
    for row in rows {
        for key in [
            "roughness_mean",
            "control_err_mm",
            "mouth_opening_ratio",
            "ground_truth_rms_mm",
            "crease",
            "lip_folds",
            "fold_deg",
        ] {
            assert!(row[key].as_f64().is_some_and(f64::is_finite), "{key}: {row}");
        }
    }
    // S and T interpolate the controls: no control error
    assert!(rows[1]["control_err_mm"].as_f64().unwrap() < 1e-3);
    assert!(rows[2]["control_err_mm"].as_f64().unwrap() < 1e-3);

    let (header, algorithms) = read_tsv(&out.join("algorithms.tsv"));
    assert_eq!(
        header,
        "letter\tspec\troughness_mean\troughness_var\tcontrol_err_mm\tmouth_opening_ratio\t\
         ground_truth_rms_mm\tcrease\tlip_folds\tfold_deg\tlips_in_teeth\tfv_gap_mm\tdeform_us"
    );
    assert_eq!(header, algorithms_header());
    assert_eq!(algorithms.len(), 3);
    for row in &algorithms {
        assert_eq!(row.len(), 13);
        assert!(
            row[2..10].iter().map(|f| number(f)).all(f64::is_finite),
            "{row:?}"
        );
        // A head without teeth has no contact measures.
        assert!(number(&row[10]).is_nan() && number(&row[11]).is_nan(), "{row:?}");
    }
    assert!(number(&algorithms[0][12]) > 0.0, "deform_us is measured");
    // Folds are counts and angles: whole triangle-frames, degrees from 0 to 180.
    for row in &algorithms {
        assert_eq!(number(&row[8]).fract(), 0.0, "{row:?}");
        assert!((0.0..=180.0).contains(&number(&row[9])), "{row:?}");
    }

    let labels: BTreeSet<&str> = frames.iter().map(|f| f.label.as_deref().unwrap()).collect();
    let (header, syllables) = read_tsv(&out.join("syllables.tsv"));
    assert_eq!(header, SYLLABLES_HEADER);
    assert_eq!(syllables.len(), 3 * labels.len());
    let counted: f64 = syllables
        .iter()
        .filter(|r| r[0] == "G")
        .map(|r| number(&r[3]))
        .sum();
    assert_eq!(
        counted as usize, FRAMES,
        "every frame counts towards one syllable"
    );
    assert!(syllables
        .iter()
        .all(|r| number(&r[4]).is_finite() && labels.contains(r[2].as_str())));

    let (header, face) = read_tsv(&out.join("face.tsv"));
    assert_eq!(header, FACE_HEADER);
    assert_eq!(face.len(), 4);
    assert_eq!(
        (face[3][0].as_str(), face[3][1].as_str()),
        (REST_LETTER, REST_SPEC)
    );
    assert!(face
        .iter()
        .all(|r| number(&r[2]).is_finite() && number(&r[3]).is_finite()));

    // ground truth: every algorithm and the head at rest against the 51 targets
    let (header, truth) = read_tsv(&out.join("ground_truth.tsv"));
    assert_eq!(header, GROUND_TRUTH_HEADER);
    assert_eq!(truth.len(), 4 * 51);
    assert!(truth
        .iter()
        .all(|r| number(&r[3]).is_finite() && number(&r[4]).is_finite()));
    let jaw = |letter: &str| {
        let row = truth
            .iter()
            .find(|r| r[0] == letter && r[2] == "jawOpen")
            .unwrap_or_else(|| panic!("a jawOpen row for {letter}"));
        (number(&row[3]), number(&row[4]))
    };
    // a head that does not move is as far from the target as the target's own motion
    let (rest_rms, rest_max) = jaw(REST_LETTER);
    assert!((rest_rms - 10.81).abs() < 0.005, "{rest_rms}");
    assert!((rest_max - 38.7).abs() < 0.05, "{rest_max}");
    for letter in ["G", "S", "T"] {
        assert!(
            jaw(letter).0 < rest_rms / 2.0,
            "{letter} reproduces jawOpen: {:?}",
            jaw(letter)
        );
    }

    // the report links every chart, and every chart is an SVG file
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    for chart in [
        "roughness_mean.svg",
        "roughness_variance.svg",
        "crease.svg",
        "roughness_vs_control_error.svg",
        "roughness_vs_ground_truth.svg",
    ] {
        assert!(report.contains(&format!("]({chart})")), "report.md links {chart}");
        let svg = std::fs::read_to_string(out.join(chart)).unwrap();
        assert!(svg.starts_with("<svg"), "{chart}");
    }
    for table in ["algorithms.tsv", "syllables.tsv", "face.tsv", "ground_truth.tsv"] {
        assert!(report.contains(&format!("]({table})")), "report.md links {table}");
    }
    assert!(
        report.contains("facewire compare --head"),
        "the command that made it"
    );
    assert!(report.contains("| **S** | `kshirsagar` |"));
    assert!(!out.join("contact.tsv").exists());
    assert!(!report.contains("lip vertices in teeth"));
}

#[test]
fn compare_with_parts_measures_contact_inside_the_mouth() {
    let dir = tempfile::tempdir().unwrap();
    let stream = dir.path().join("f.jsonl");
    std::fs::write(
        &stream,
        "{\"seq\":0,\"t\":0,\"label\":\"fa\"}\n\
         {\"seq\":1,\"t\":0.1,\"label\":\"fa\",\"viseme\":{\"oculus\":\"FF\"}}\n\
         {\"seq\":2,\"t\":0.2,\"label\":\"ta\",\"viseme\":{\"oculus\":\"DD\"}}\n",
    )
    .unwrap();
    let out = dir.path().join("report");
    let part = |file: &str| data(&format!("heads/{file}")).display().to_string();
    let (upper, lower, gums) = (
        part("ict_head_teeth_upper.obj"),
        part("ict_head_teeth_lower.obj"),
        part("ict_head_gums_upper.obj"),
    );
    let tongue = format!("tongue:{}", part("ict_head_gums_lower_tongue.obj"));
    let run = succeeds(&[
        "compare",
        "--head",
        s(&data("heads/ict_head.obj")),
        "--fit",
        s(&data("heads/ict_head.fit.toml")),
        "--stream",
        s(&stream),
        "--out",
        s(&out),
        "--algos",
        "U",
        "--part",
        &upper,
        "--part",
        &lower,
        "--part",
        &gums,
        "--part",
        &tongue,
        "--json",
    ]);
    let summary: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    assert_eq!(summary[0]["lips_in_teeth"], 0, "{summary}");
    let gap = summary[0]["fv_gap_mm"].as_f64().unwrap();
    assert!(gap <= 0.201, "the lower lip at the upper teeth on f: {gap} mm");

    let (header, rows) = read_tsv(&out.join("contact.tsv"));
    assert_eq!(header, CONTACT_HEADER);
    assert_eq!(rows.len(), 3);
    assert_eq!((rows[1][3].as_str(), rows[2][3].as_str()), ("fa", "ta"));
    let column = |name: &str| header.split('\t').position(|c| c == name).unwrap();
    // The f viseme brings the lower lip to the upper teeth; DD the tongue tip to the ridge.
    let (lip, tip) = (
        column("lower_lip_to_upper_teeth_mm"),
        column("tongue_tip_to_gums_mm"),
    );
    assert!(number(&rows[1][lip]) < number(&rows[0][lip]), "{rows:?}");
    assert!(number(&rows[2][tip]) < 1.5, "{rows:?}");
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        report.contains("](contact.tsv)") && report.contains("**the tongue**"),
        "{report}"
    );
    assert!(report.contains("--part tongue:"), "the command that made it");
}

#[test]
fn deform_writes_the_lip_roughness_table() {
    let dir = tempfile::tempdir().unwrap();
    let (stream, _) = short_stream(dir.path());
    let out = dir.path().join("frames");
    succeeds(&[
        "deform",
        "--head",
        s(&data("heads/makehuman_head.obj")),
        "--fit",
        s(&data("heads/makehuman_head.fit.toml")),
        "--algo",
        "G",
        "--stream",
        s(&stream),
        "--frames",
        "8..11",
        "--out",
        s(&out),
    ]);
    let (header, rows) = read_tsv(&out.join("metrics.tsv"));
    assert_eq!(header, TSV_HEADER);
    assert_eq!(rows.len(), 3 * LIP_ROWS);
    for (k, row) in rows.iter().enumerate() {
        assert_eq!(
            number(&row[0]) as usize,
            8 + k / LIP_ROWS,
            "frame numbers follow the OBJ files"
        );
        assert!(row[3..].iter().map(|f| number(f)).all(f64::is_finite));
    }
    assert!(
        rows.iter().filter(|r| r[2] == "-1").count() == 3,
        "one summary row per frame"
    );
    assert!(out.join("frame_00010.obj").is_file());

    // folds.tsv: one row per frame; the face's triangles include the lips', so it turns at
    // least as many and bends at least as sharply.
    let (header, folds) = read_tsv(&out.join("folds.tsv"));
    assert_eq!(header, FOLDS_TSV_HEADER);
    assert_eq!(folds.len(), 3);
    for (k, row) in folds.iter().enumerate() {
        assert_eq!(number(&row[0]) as usize, 8 + k);
        let v: Vec<f64> = row[2..].iter().map(|f| number(f)).collect();
        assert!(v.iter().all(|x| x.is_finite() && *x >= 0.0), "{row:?}");
        assert!(v[0].fract() == 0.0 && v[1] <= v[0], "{row:?}");
        assert!(v[3] >= v[0] && v[4] >= v[1] && v[5] >= v[2], "{row:?}");
    }
}

#[test]
fn compare_errors_name_what_is_wrong() {
    let head = data("heads/makehuman_head.obj");
    let fit = data("heads/makehuman_head.fit.toml");
    let stream = data("streams/syllables.jsonl");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("never");
    let base = |head: &str, stream: &str, algos: &str| {
        vec![
            "compare".to_string(),
            "--head".into(),
            head.into(),
            "--fit".into(),
            s(&fit).into(),
            "--stream".into(),
            stream.into(),
            "--out".into(),
            s(&out).into(),
            "--algos".into(),
            algos.into(),
        ]
    };
    let run = |args: Vec<String>| fails(&args.iter().map(String::as_str).collect::<Vec<_>>());

    let err = run(base(s(&head), s(&stream), "G,warp"));
    assert!(
        err.contains("\"warp\"") && err.contains("valid: bary1, bary2"),
        "{err}"
    );
    let err = run(base(s(&head), s(&stream), "rbf,r_mm=30"));
    assert!(err.contains("write rbf:r_mm=30"), "{err}");
    let err = run(base("/nonexistent/head.obj", s(&stream), "G"));
    assert!(err.contains("/nonexistent/head.obj"), "{err}");
    let err = run(base(s(&head), "/nonexistent/stream.jsonl", "G"));
    assert!(err.contains("/nonexistent/stream.jsonl"), "{err}");

    // an explicit targets folder must load
    let mut args = base(s(&data("heads/lee_perry_smith_head.obj")), s(&stream), "G");
    args[4] = s(&data("heads/lee_perry_smith_head.fit.toml")).into();
    args.extend(["--targets".into(), "/nonexistent/targets".into()]);
    let err = run(args);
    assert!(err.contains("/nonexistent/targets"), "{err}");
    assert!(!out.exists(), "nothing is written on bad input");
}

/// What `facewire compare` reports of the lips is what a viewer is sent, frame for frame:
/// the ICT head with its teeth, tongue and eyes (so the contact and eyelid constraints run)
/// through the service's per-frame job, each frame encoded as FWF2 and decoded, against
/// `report::compare` over the same frames. One code path makes both; this holds it.
#[test]
fn compare_reports_the_lips_a_viewer_is_sent() {
    use facewire::animate::{FrameJob, FrameTimes, Heat};
    use facewire::deform::bind;
    use facewire::report::{compare, parse_algorithms, CompareInput};
    use facewire::stream::ArkitBasis;
    use facewire_proto::viewer_frame::{decode, FrameLayout};
    use std::sync::Arc;

    let dir = tempfile::tempdir().unwrap();
    let (stream, frames) = short_stream(dir.path());
    let head = Arc::new(crate::common::ict_head());
    let algorithms = parse_algorithms("V").unwrap();
    let basis = ArkitBasis::shipped();
    let comparison = compare(
        &CompareInput {
            head: &head,
            stream: &stream,
            basis: &basis,
            algorithms: &algorithms,
            targets: &[],
        },
        &mut |_| {},
    )
    .unwrap();
    let reported = &comparison.algorithms[0];

    let binding = Arc::new(bind(&head.registration, &algorithms[0].spec));
    let mut job = FrameJob::new(head.clone(), binding, Arc::new(basis), Heat::None).unwrap();
    let (mut folds, mut by_label) = (0u64, Vec::<(String, usize, f64)>::new());
    for frame in &frames {
        job.deform(frame);
        job.measure(frame).unwrap();
        let sent = decode(
            job.encode(frame, FrameTimes::default(), FrameLayout::Fwf2)
                .unwrap(),
        )
        .unwrap();
        folds += u64::from(sent.folds.expect("FWF2 carries folds").turned_over_60);
        let label = frame.label.clone().unwrap_or_else(|| "-".into());
        match by_label.iter_mut().find(|(l, _, _)| *l == label) {
            Some((_, n, sum)) => {
                *n += 1;
                *sum += f64::from(sent.lip.mean);
            }
            None => by_label.push((label, 1, f64::from(sent.lip.mean))),
        }
    }
    assert_eq!(
        reported.summary.lip_folds, folds,
        "lip triangle-frames turned past 60 degrees"
    );
    assert_eq!(reported.syllables.len(), by_label.len());
    for (row, (label, n, sum)) in reported.syllables.iter().zip(&by_label) {
        assert_eq!((&row.syllable, row.frames), (label, *n as u64));
        // The wire carries the mean as f32.
        let sent = sum / *n as f64;
        assert!(
            (row.roughness_mean - sent).abs() <= 1e-6 * sent.abs().max(1e-9),
            "{label}: reported {} against {sent} sent",
            row.roughness_mean
        );
    }
}

/// Each expression target's lip folds are counted three ways: the algorithm's when asked
/// for the target, the target's own (what the face itself does; the same in the rest row),
/// and the algorithm's that the target does not make. On the ICT head the light-stage
/// jawOpen turns lip triangles past 60 degrees itself (the crease of each mouth corner
/// opening).
#[test]
fn compare_counts_the_lip_folds_of_the_targets_themselves() {
    use facewire::report::{compare, parse_algorithms, CompareInput};
    use facewire::stream::ArkitBasis;
    use facewire::targets::ExpressionTarget;
    use std::sync::Arc;

    let dir = tempfile::tempdir().unwrap();
    let (stream, _) = short_stream(dir.path());
    let head = Arc::new(crate::common::ict_head());
    let targets = ExpressionTarget::load_dir(
        &data("heads/ict_targets/skin"),
        head.registration.head.positions.len(),
    )
    .unwrap();
    let algorithms = parse_algorithms("V").unwrap();
    let comparison = compare(
        &CompareInput {
            head: &head,
            stream: &stream,
            basis: &ArkitBasis::shipped(),
            algorithms: &algorithms,
            targets: &targets,
        },
        &mut |_| {},
    )
    .unwrap();
    let rows = &comparison.algorithms[0].ground_truth;
    assert_eq!(rows.len(), targets.len());
    for (row, rest) in rows.iter().zip(&comparison.rest_ground_truth) {
        assert_eq!(row.target, rest.target);
        assert_eq!(
            (rest.lip_folds, rest.lip_folds_not_in_target),
            (0, 0),
            "{}",
            rest.target
        );
        assert_eq!(row.target_lip_folds, rest.target_lip_folds, "{}", row.target);
        assert!(row.lip_folds_not_in_target <= row.lip_folds, "{row:?}");
    }
    let jaw_open = rows.iter().find(|r| r.target == "jawOpen").unwrap();
    eprintln!("{jaw_open:?}");
    assert!(jaw_open.target_lip_folds > 0, "{jaw_open:?}");
}

/// A glTF avatar's morph targets are its ground truth: MakeHuman's head written as a
/// `.glb` carrying its 51 ARKit targets as morph targets, fitted from the same landmarks,
/// is compared exactly as the OBJ with its `.target` files is.
#[test]
fn compare_reads_a_gltf_avatars_morph_targets_as_its_ground_truth() {
    use crate::common::glb::{write_glb, GlbMeshSpec, GlbPrimitive};
    use facewire::head::Head;
    use facewire::targets::ExpressionTarget;

    let dir = tempfile::tempdir().unwrap();
    let (stream, _) = short_stream(dir.path());
    let obj = data("heads/makehuman_head.obj");
    let head = Head::load(&obj).unwrap();
    let targets = ExpressionTarget::load_dir(&data("heads/makehuman_arkit"), head.positions.len()).unwrap();
    let spec = GlbMeshSpec {
        name: "Head".into(),
        matrix: None,
        primitives: vec![GlbPrimitive {
            material: "Skin".into(),
            positions: head.positions.iter().map(|p| p.to_array()).collect(),
            indices: head.triangles.iter().flatten().copied().collect(),
            targets: targets
                .iter()
                .map(|t| t.displacements.iter().map(|d| d.to_array()).collect())
                .collect(),
            joints: None,
            texcoords: None,
            base_colour: None,
        }],
        target_names: targets.iter().map(|t| t.name.clone()).collect(),
    };
    let glb = dir.path().join("makehuman.glb");
    std::fs::write(
        &glb,
        write_glb(&[spec], glam::Mat4::IDENTITY.to_cols_array(), None),
    )
    .unwrap();
    let landmarks = data("heads/makehuman_head.landmarks.toml");
    let summary = |head: &Path, targets: Option<&Path>, name: &str| {
        let fit = dir.path().join(format!("{name}.fit.toml"));
        succeeds(&[
            "fit",
            "--head",
            s(head),
            "--landmarks",
            s(&landmarks),
            "--out",
            s(&fit),
        ]);
        let out = dir.path().join(name);
        let mut args = vec![
            "compare",
            "--head",
            s(head),
            "--fit",
            s(&fit),
            "--stream",
            s(&stream),
        ];
        args.extend(["--algos", "V", "--out", s(&out), "--json"]);
        if let Some(targets) = targets {
            args.extend(["--targets", s(targets)]);
        }
        let printed: serde_json::Value = serde_json::from_slice(&succeeds(&args).stdout).unwrap();
        let (_, rows) = read_tsv(&out.join("ground_truth.tsv"));
        (printed[0]["ground_truth_rms_mm"].as_f64(), rows)
    };
    let from_glb = summary(&glb, None, "glb");
    let from_obj = summary(&obj, Some(&data("heads/makehuman_arkit")), "obj");
    assert!(from_glb.0.is_some_and(|rms| rms > 0.0), "{from_glb:?}");
    assert_eq!(from_glb.1.len(), from_obj.1.len());
    assert_eq!(from_glb, from_obj);
}
