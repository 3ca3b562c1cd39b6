//! JSONL: every field round-trips, names, indices and aliases, errors by line and field,
//! line limits, and file names in errors.

use super::read_all;
use crate::common::streams::jsonl_error;
use facewire::mask::Mask;
use facewire::stream::{
    open_stream, ExpressionFap, Frame, JsonlReader, JsonlWriter, StreamError, VisemeFap, MAX_LINE_BYTES,
};

fn every_field_frames(mask: &Mask) -> Vec<Frame> {
    let controls: Vec<[f32; 3]> = (0..mask.vertices.len())
        .map(|i| [i as f32 * 1e-3, -0.25, 1.0 / 3.0])
        .collect();
    vec![
        Frame {
            label: Some("pa \"quoted\" é".into()),
            animation: vec![(0, 0.1), (1, 0.3), (64, -0.0625)],
            faps: vec![(3, 120.0), (48, -2184.0), (68, 0.5)],
            arkit: vec![(0, 0.25), (17, 1.0), (51, 0.125)],
            head_rotation_rad: Some([0.01, -0.2, 0.3]),
            head_translation: Some([0.0, 0.1, -0.05]),
            controls: Some(controls),
            viseme: Some(VisemeFap {
                select1: 1,
                select2: 2,
                blend: 63,
                definition: 0,
            }),
            expression: Some(ExpressionFap {
                select1: 2,
                intensity1: 10,
                select2: 3,
                intensity2: 20,
                init_face: 1,
                definition: 0,
            }),
            ..Frame::at(0, 0.0)
        },
        Frame::at(1, 1.0 / 30.0),
        Frame {
            animation: vec![(2, 0.123_456_79)],
            ..Frame::at(5, 1.0 / 3.0)
        },
    ]
}

#[test]
fn jsonl_round_trips_every_field() {
    let mask = Mask::candide3();
    let frames = every_field_frames(&mask);
    let mut writer = JsonlWriter::new(Vec::new(), &mask);
    for frame in &frames {
        writer.write_frame(frame).unwrap();
    }
    let bytes = writer.into_inner().unwrap();
    let text = std::str::from_utf8(&bytes).unwrap();
    assert_eq!(text.lines().count(), 3);
    assert_eq!(text.lines().nth(1), Some(r#"{"seq":1,"t":0.03333333333333333}"#));
    assert!(text.starts_with(
        r#"{"seq":0,"t":0.0,"label":"pa \"quoted\" é","au":{"upper_lip_raiser":0.1,"jaw_drop":0.3,"fap64_bend_nose":-0.0625},"fap":{"open_jaw":120.0,"head_pitch":-2184.0,"pull_r_ear":0.5},"arkit":{"eyeBlinkLeft":0.25,"jawOpen":1.0,"tongueOut":0.125},"head_rotation_rad":[0.01,-0.2,0.3]"#
    ));
    assert_eq!(read_all(JsonlReader::new(&bytes[..], &mask)), frames);
}

#[test]
fn jsonl_accepts_names_indices_and_aliases() {
    let mask = Mask::candide3();
    let text = "\n{\"t\":0.5,\"seq\":9,\"au\":{\"AUV11\":0.2,\"open_jaw\":0.01,\"2\":0.1},\
                \"fap\":{\"fap17\":3,\"push_b_lip\":-2,\"52\":7},\"arkit\":{\"JAWOPEN\":0.5,\"0\":1},\
                \"label\":null,\"head_translation\":null}\n\n";
    let frames = read_all(JsonlReader::new(text.as_bytes(), &mask));
    assert_eq!(
        frames,
        [Frame {
            animation: vec![(1, 0.2), (2, 0.1), (11, 0.01)],
            faps: vec![(16, -2.0), (17, 3.0), (52, 7.0)],
            arkit: vec![(0, 1.0), (17, 0.5)],
            ..Frame::at(9, 0.5)
        }]
    );
}

#[test]
fn jsonl_errors_name_the_line_and_field() {
    let ok = r#"{"seq":0,"t":0.5}"#;
    let cases: [(String, &str); 16] = [
        (
            format!("{ok}\n{{\"seq\":1,\"t\":1,\"au\":{{\"jaw_drop\":\"wide\"}}}}"),
            "line 2: au.jaw_drop: \"wide\" is not a number",
        ),
        (
            r#"{"seq":0,"t":0,"fap":{"open_jaw":1e39}}"#.to_string(),
            "line 1: fap.open_jaw: 1e+39 is not a finite number",
        ),
        (
            r#"{"seq":0,"t":0,"fap":{"open_jaw":NaN}}"#.to_string(),
            "line 1: json: invalid JSON: expected value",
        ),
        (
            r#"{"seq":0,"t":0,"au":{"smile":0.5}}"#.to_string(),
            "line 1: au.smile: unknown animation unit \"smile\"; valid: an index 0..65 or one of \
             upper_lip_raiser, jaw_drop,",
        ),
        (
            r#"{"seq":0,"t":0,"fap":{"smile":5}}"#.to_string(),
            "line 1: fap.smile: unknown FAP \"smile\"; valid: a FAP number 3..=68 or a name: \
             open_jaw,",
        ),
        (
            r#"{"seq":0,"t":0,"fap":{"viseme":5}}"#.to_string(),
            "line 1: fap.viseme: FAP 1 is out of range (expected a FAP 3..=68: FAPs 1 and 2 are \
             the top-level \"viseme\" and \"expression\")",
        ),
        (
            r#"{"seq":0,"t":0,"arkit":{"smile":1}}"#.to_string(),
            "line 1: arkit.smile: unknown ARKit blendshape \"smile\"; valid: an index 0..52 or \
             one of eyeBlinkLeft,",
        ),
        (
            format!("{ok}\n{{\"seq\":1,\"t\":0.25}}"),
            "line 2: t: time 0.25 s is before the previous frame's 0.5 s",
        ),
        (
            format!("{ok}\n\n{{\"seq\":0,\"t\":0.75}}"),
            "line 3: seq: 0 does not increase on the previous frame's 0",
        ),
        (
            r#"{"seq":-1,"t":0}"#.to_string(),
            "line 1: seq: -1 is not a non-negative integer",
        ),
        (
            r#"{"t":0}"#.to_string(),
            "line 1: seq: missing (every frame needs one)",
        ),
        (
            r#"{"seq":0,"t":0,"jaw":1}"#.to_string(),
            "line 1: jaw: unknown field \"jaw\"; valid: seq, t, label, au, fap, arkit,",
        ),
        (
            r#"{"seq":0,"t":0,"head_rotation_rad":[0,1]}"#.to_string(),
            "line 1: head_rotation_rad: has 2 entries, expected 3 (x, y, z)",
        ),
        (
            r#"{"seq":0,"t":0,"controls":[[0,0,0]]}"#.to_string(),
            "line 1: controls: has 1 entries, expected one per mask vertex (113)",
        ),
        (
            r#"{"seq":0,"t":0,"viseme":{"select1":1,"select2":2,"blend":0.5,"definition":0}}"#.to_string(),
            "line 1: viseme.blend: 0.5 is not a 32-bit integer",
        ),
        ("[1,2]".to_string(), "line 1: frame: expected a JSON object"),
    ];
    for (text, expected) in cases {
        let message = jsonl_error(&text).to_string();
        assert!(
            message.starts_with(expected),
            "\n  input: {text}\n   got: {message}\nwanted: {expected}"
        );
    }
}

#[test]
fn lines_over_the_limit_are_refused() {
    let mut text = String::from("{\"seq\":0,\"t\":0}\n{\"seq\":1,\"t\":0,\"label\":\"");
    text.push_str(&"a".repeat(MAX_LINE_BYTES));
    text.push_str("\"}\n");
    assert_eq!(
        jsonl_error(&text).to_string(),
        format!("line 2: line is longer than {MAX_LINE_BYTES} bytes")
    );
}

#[test]
fn errors_from_files_name_the_file() {
    let mask = Mask::candide3();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.jsonl");
    std::fs::write(
        &path,
        "{\"seq\":0,\"t\":0}\n{\"seq\":1,\"t\":0,\"au\":{\"x\":1}}\n",
    )
    .unwrap();
    let message = open_stream(&path, &mask)
        .unwrap()
        .find_map(Result::err)
        .unwrap()
        .to_string();
    assert!(
        message.starts_with(&format!(
            "{}: line 2: au.x: unknown animation unit",
            path.display()
        )),
        "{message}"
    );

    let path = dir.path().join("frames.bvh");
    std::fs::write(&path, "").unwrap();
    let err = open_stream(&path, &mask).err().unwrap();
    assert!(matches!(err, StreamError::UnknownFormat { .. }), "{err}");
    let err = open_stream(&dir.path().join("missing.fap"), &mask).err().unwrap();
    assert!(matches!(err, StreamError::Open { .. }), "{err}");
}
