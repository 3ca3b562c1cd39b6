//! `facewire syllables` and `facewire inspect` on stream files.

use std::path::Path;

use super::xface_joy;
use crate::common::repo_path;

fn facewire(args: &[&std::ffi::OsStr]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_facewire"))
        .args(args)
        .output()
        .expect("facewire runs")
}

fn inspect_json(path: &Path) -> serde_json::Value {
    let out = facewire(&["inspect".as_ref(), path.as_os_str(), "--json".as_ref()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("valid JSON")
}

#[test]
fn the_syllables_command_writes_the_shipped_stream() {
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("syllables.jsonl");
    std::fs::write(&out_path, "an older file\n").unwrap();
    let out = facewire(&["syllables".as_ref(), "--out".as_ref(), out_path.as_os_str()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("wrote 487 frames"));
    let shipped = std::fs::read(repo_path("data/streams/syllables.jsonl")).unwrap();
    assert!(
        std::fs::read(&out_path).unwrap() == shipped,
        "differs from data/streams/syllables.jsonl"
    );
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "no temporary file left"
    );

    let summary = inspect_json(&out_path);
    assert_eq!(summary["frames"], 487);
    assert_eq!(summary["labels"].as_array().unwrap().len(), 27);
    assert_eq!(summary["labels"][0]["label"], "pa");
    let jaw = summary["channels"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["name"] == "jaw_drop")
        .expect("a jaw_drop channel");
    assert_eq!(jaw["kind"], "animation");

    let out = facewire(&[
        "syllables".as_ref(),
        "--out".as_ref(),
        out_path.as_os_str(),
        "--fps".as_ref(),
        "0".as_ref(),
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("fps"));
}

#[test]
fn inspect_summarizes_the_xface_fap_file() {
    let summary = inspect_json(&xface_joy());
    assert_eq!(summary["frames"], 108);
    assert!((summary["fps_estimate"].as_f64().unwrap() - 25.0).abs() < 1e-9);
    assert!((summary["duration_s"].as_f64().unwrap() - 4.28).abs() < 1e-9);

    let out = facewire(&["inspect".as_ref(), xface_joy().as_os_str()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("108 frames at 25 fps, 4.28 s"), "{text}");
    assert!(text.contains("open_jaw"), "{text}");
}

#[test]
fn inspect_names_the_line_of_a_broken_stream() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.jsonl");
    std::fs::write(
        &bad,
        "{\"seq\":0,\"t\":0}\n{\"seq\":1,\"t\":0.1,\"au\":{\"jaw_drop\":\"wide\"}}\n",
    )
    .unwrap();
    let out = facewire(&["inspect".as_ref(), bad.as_os_str()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.jsonl: line 2: au.jaw_drop: \"wide\" is not a number"),
        "{err}"
    );
}
