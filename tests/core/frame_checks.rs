//! One check for every frame, whatever format brought it (`Frame::check`): the same
//! content is refused with the same error kind and field as a JSONL text message and as a
//! binary FWP1 message, extreme but finite values are refused in every format, a JSON
//! object may not name a key twice, and a `.fap` header with an absurd frame rate is
//! refused at its line.

use crate::common::streams::{au_error, fap_error};
use facewire::mask::Mask;
use facewire::stream::jsonl::parse_message;
use facewire::stream::{AuTextOptions, Frame, StreamError, MAX_LABEL_BYTES, MAX_SEQ};
use facewire_proto::param_frame::ParamFrame;

/// The variant of an error, to compare errors from different formats.
fn kind(e: &StreamError) -> &'static str {
    match e {
        StreamError::Syntax { .. } => "Syntax",
        StreamError::NotANumber { .. } => "NotANumber",
        StreamError::NotFinite { .. } => "NotFinite",
        StreamError::OutOfRange { .. } => "OutOfRange",
        StreamError::WrongLength { .. } => "WrongLength",
        StreamError::UnknownUnit { .. } => "UnknownUnit",
        StreamError::UnknownName { .. } => "UnknownName",
        StreamError::Duplicate { .. } => "Duplicate",
        other => panic!("unexpected error {other}"),
    }
}

fn from_json(text: &str, mask: &Mask) -> Result<Frame, StreamError> {
    parse_message("message 1", text, mask)
}

/// `p` through FWP2, checked to come out of the frozen FWP1 the same way.
fn from_binary(p: &ParamFrame, mask: &Mask) -> Result<Frame, StreamError> {
    let decoded = ParamFrame::decode(&p.encode()).expect("the test frames are well formed");
    let fwp2 = Frame::from_param_frame(decoded, mask);
    let fwp1 = ParamFrame::decode(&p.encode_fwp1().expect("no head translation")).unwrap();
    let fwp1 = Frame::from_param_frame(fwp1, mask);
    assert_eq!(format!("{fwp1:?}"), format!("{fwp2:?}"), "FWP1 and FWP2 differ");
    fwp2
}

fn param(change: impl FnOnce(&mut ParamFrame)) -> ParamFrame {
    let mut p = ParamFrame {
        seq: 1,
        time_s: 0.5,
        ..ParamFrame::default()
    };
    change(&mut p);
    p
}

#[test]
fn jsonl_and_binary_frames_refuse_the_same_content_the_same_way() {
    let mask = Mask::candide3();
    // (JSONL members after seq and t, the same content as FWP1, error kind, field)
    let cases: Vec<(&str, ParamFrame, &str, &str)> = vec![
        (
            r#""au":{"jaw_drop":3.4e38}"#,
            param(|p| p.animation = vec![(1, 3.4e38)]),
            "OutOfRange",
            "au",
        ),
        (
            r#""au":{"jaw_drop":10.5}"#,
            param(|p| p.animation = vec![(1, 10.5)]),
            "OutOfRange",
            "au",
        ),
        (
            r#""au":{"jaw_drop":1e39}"#,
            param(|p| p.animation = vec![(1, f32::INFINITY)]),
            "NotFinite",
            "au",
        ),
        (
            r#""au":{"65":0.1}"#,
            param(|p| p.animation = vec![(65, 0.1)]),
            "UnknownUnit",
            "au",
        ),
        (
            r#""au":{"jaw_drop":0.3,"1":0.1}"#,
            param(|p| p.animation = vec![(1, 0.3), (1, 0.1)]),
            "Duplicate",
            "au",
        ),
        (
            r#""fap":{"1":5}"#,
            param(|p| p.faps = vec![(1, 5.0)]),
            "OutOfRange",
            "fap",
        ),
        (
            r#""fap":{"expression":5}"#,
            param(|p| p.faps = vec![(2, 5.0)]),
            "OutOfRange",
            "fap",
        ),
        (
            r#""fap":{"69":1}"#,
            param(|p| p.faps = vec![(69, 1.0)]),
            "UnknownName",
            "fap",
        ),
        (
            r#""fap":{"0":1}"#,
            param(|p| p.faps = vec![(0, 1.0)]),
            "UnknownName",
            "fap",
        ),
        (
            r#""fap":{"open_jaw":1,"3":2}"#,
            param(|p| p.faps = vec![(3, 1.0), (3, 2.0)]),
            "Duplicate",
            "fap",
        ),
        (
            r#""fap":{"open_jaw":100001}"#,
            param(|p| p.faps = vec![(3, 100_001.0)]),
            "OutOfRange",
            "fap",
        ),
        (
            r#""fap":{"head_yaw":700000}"#,
            param(|p| p.faps = vec![(49, 700_000.0)]),
            "OutOfRange",
            "fap",
        ),
        (
            r#""arkit":{"52":1}"#,
            param(|p| p.arkit = vec![(52, 1.0)]),
            "UnknownName",
            "arkit",
        ),
        (
            r#""arkit":{"jawOpen":11}"#,
            param(|p| p.arkit = vec![(17, 11.0)]),
            "OutOfRange",
            "arkit",
        ),
        (
            r#""arkit":{"jawOpen":0.5,"17":0.1}"#,
            param(|p| p.arkit = vec![(17, 0.5), (17, 0.1)]),
            "Duplicate",
            "arkit",
        ),
        (
            r#""head_rotation_rad":[0,7,0]"#,
            param(|p| p.head_rotation_rad = Some([0.0, 7.0, 0.0])),
            "OutOfRange",
            "head_rotation_rad",
        ),
        (
            r#""head_rotation_rad":[0,0,-1e39]"#,
            param(|p| p.head_rotation_rad = Some([0.0, 0.0, f32::NEG_INFINITY])),
            "NotFinite",
            "head_rotation_rad",
        ),
    ];
    for (members, binary, expected_kind, expected_field) in &cases {
        let json = format!(r#"{{"seq":1,"t":0.5,{members}}}"#);
        let from_json = from_json(&json, &mask).expect_err(&json);
        let from_binary = from_binary(binary, &mask).expect_err(&json);
        for (format, err) in [("JSONL", &from_json), ("FWP1", &from_binary)] {
            assert_eq!(
                (kind(err), err.field()),
                (*expected_kind, Some(*expected_field)),
                "{format} {json}: {err}"
            );
        }
    }

    // Frame-level fields, which FWP1 carries in its fixed header.
    let frame_cases: [(&str, ParamFrame, &str); 4] = [
        (r#"{"seq":1,"t":-1}"#, param(|p| p.time_s = -1.0), "t"),
        (r#"{"seq":1,"t":1e11}"#, param(|p| p.time_s = 1e11), "t"),
        (
            r#"{"seq":9007199254740992,"t":0}"#,
            param(|p| p.seq = MAX_SEQ + 1),
            "seq",
        ),
        (
            r#"{"seq":18446744073709551615,"t":0}"#,
            param(|p| p.seq = u64::MAX),
            "seq",
        ),
    ];
    for (json, binary, field) in &frame_cases {
        let from_json = from_json(json, &mask).expect_err(json);
        let from_binary = from_binary(binary, &mask).expect_err(json);
        for err in [&from_json, &from_binary] {
            assert_eq!(
                (kind(err), err.field()),
                ("OutOfRange", Some(*field)),
                "{json}: {err}"
            );
        }
    }
    let nan_time = from_binary(&param(|p| p.time_s = f64::NAN), &mask).unwrap_err();
    assert_eq!((kind(&nan_time), nan_time.field()), ("NotFinite", Some("t")));
}

#[test]
fn jsonl_and_binary_frames_accept_the_same_frame_alike() {
    let mask = Mask::candide3();
    let json = r#"{"seq":3,"t":0.25,"label":"pa","au":{"jaw_drop":0.3,"0":-10},"fap":{"open_jaw":100000,"head_yaw":-628318},"arkit":{"jawOpen":0.5,"eyeBlinkLeft":2},"head_rotation_rad":[0,0,6.25]}"#;
    let binary = ParamFrame {
        seq: 3,
        time_s: 0.25,
        // In any order: FWP1 lists are sorted by index.
        animation: vec![(1, 0.3), (0, -10.0)],
        faps: vec![(49, -628_318.0), (3, 100_000.0)],
        arkit: vec![(17, 0.5), (0, 2.0)],
        head_rotation_rad: Some([0.0, 0.0, 6.25]),
        label: Some("pa".into()),
        ..ParamFrame::default()
    };
    let frame = from_json(json, &mask).unwrap();
    assert_eq!(from_binary(&binary, &mask).unwrap(), frame);
    assert_eq!(frame.animation, [(0, -10.0), (1, 0.3)]);
}

#[test]
fn json_objects_name_each_key_once() {
    let mask = Mask::candide3();
    for (text, field, message) in [
        (
            r#"{"seq":1,"seq":2,"t":0}"#,
            "seq",
            "message 1: line 1: seq: the key appears twice; name it once",
        ),
        (
            r#"{"seq":1,"t":0,"au":{"jaw_drop":0.1,"jaw_drop":0.9}}"#,
            "au",
            "message 1: line 1: au.jaw_drop: the key appears twice; name it once",
        ),
        (
            r#"{"seq":1,"t":0,"viseme":{"select1":1,"select1":2,"select2":0,"blend":0,"definition":0}}"#,
            "viseme",
            "message 1: line 1: viseme.select1: the key appears twice; name it once",
        ),
    ] {
        let err = from_json(text, &mask).unwrap_err();
        assert_eq!(
            (err.field(), err.to_string()),
            (Some(field), message.to_string()),
            "{text}"
        );
    }
}

#[test]
fn extreme_values_are_refused_in_jsonl() {
    let mask = Mask::candide3();
    let controls = |value: &str| {
        let mut rows = vec!["[0,0,0]".to_string(); mask.vertices.len()];
        rows[40] = format!("[0,{value},0]");
        format!(r#"{{"seq":0,"t":0,"controls":[{}]}}"#, rows.join(","))
    };
    let long_label = format!(
        r#"{{"seq":0,"t":0,"label":"{}"}}"#,
        "a".repeat(MAX_LABEL_BYTES + 1)
    );
    for (text, message) in [
        (
            controls("3.4e38"),
            "line 1: controls[40][1]: 3.4e38 is out of range (expected -10 to 10 mask units)",
        ),
        (
            controls("-3.4e38"),
            "line 1: controls[40][1]: -3.4e38 is out of range (expected -10 to 10 mask units)",
        ),
        (
            r#"{"seq":0,"t":0,"head_translation":[101,0,0]}"#.to_string(),
            "line 1: head_translation[0]: 101.0 is out of range (expected -100 to 100 mask units)",
        ),
        (
            long_label,
            "line 1: label: 256 bytes is out of range (expected at most 255 bytes of UTF-8)",
        ),
        (
            r#"{"seq":0,"t":0,"viseme":{"select1":1,"select2":2,"blend":64,"definition":0}}"#.to_string(),
            "line 1: viseme.blend: 64 is out of range (expected 0..=63)",
        ),
        (
            r#"{"seq":0,"t":0,"expression":{"select1":7,"intensity1":0,"select2":0,"intensity2":0,"init_face":0,"definition":0}}"#
                .to_string(),
            "line 1: expression.select1: 7 is out of range (expected 0..=6)",
        ),
        (
            r#"{"seq":0,"t":1e300}"#.to_string(),
            "line 1: t: 1e300 is out of range (expected 0 to 1e10 s)",
        ),
    ] {
        let err = facewire::stream::JsonlReader::new(text.as_bytes(), &mask)
            .next()
            .unwrap()
            .unwrap_err();
        assert_eq!(err.to_string(), message);
    }
}

#[test]
fn fap_headers_with_absurd_frame_rates_are_refused_at_their_line() {
    for fps in ["1e-300", "0", "-25", "0.001", "1001", "1e300"] {
        let err = fap_error(&format!("# a comment first\n2.1 name {fps} 1\n"));
        assert_eq!(
            err.to_string(),
            format!(
                "line 2: header fps: {fps} is out of range (expected a frame rate from 0.01 to \
                 1000 frames per second)"
            )
        );
        assert_eq!(err.field(), Some("header fps"));
    }
    for fps in ["NaN", "inf", "-inf", "1e400"] {
        let err = fap_error(&format!("2.1 name {fps} 1\n"));
        assert_eq!(
            err.to_string(),
            format!("line 1: header fps: {fps} is not a finite number")
        );
    }
}

#[test]
fn fap_values_beyond_the_bounds_are_refused_at_their_line() {
    let mask68 = |on: &[usize]| {
        (1..=68)
            .map(|f| if on.contains(&f) { "1" } else { "0" })
            .collect::<Vec<_>>()
            .join(" ")
    };
    let open_jaw = mask68(&[3]);
    let viseme = mask68(&[1]);
    for (text, message) in [
        (
            format!("2.1 t 25 1\n{open_jaw}\n0 100001\n"),
            "line 3: fap.open_jaw: 100001.0 is out of range (expected -100000 to 100000 counts)".to_string(),
        ),
        (
            format!("2.1 t 25 1\n{open_jaw}\n9007199254740992 0\n"),
            "line 3: seq: 9007199254740992 is out of range (expected at most 9007199254740991 (2^53 - 1))"
                .to_string(),
        ),
        (
            format!("2.1 t 0.01 1\n{open_jaw}\n1000000000 0\n"),
            "line 3: t: 100000000000.0 is out of range (expected 0 to 1e10 s)".to_string(),
        ),
        (
            format!("2.1 t 25 1\n{viseme}\n0 15 0 0 0\n"),
            "line 3: viseme.select1: 15 is out of range (expected 0..=14)".to_string(),
        ),
    ] {
        assert_eq!(fap_error(&text).to_string(), message, "{text}");
    }
}

#[test]
fn au_text_values_beyond_the_bounds_are_refused_at_their_line() {
    let error = |text: &str| au_error(text, AuTextOptions::default()).to_string();
    assert_eq!(
        error("0 0\n1e30 0\n"),
        "line 2: au.upper_lip_raiser: 1e30 is out of range (expected -10 to 10)"
    );
    assert_eq!(
        error("# columns: time jaw_drop\n-1 0.5\n"),
        "line 2: t: -1.0 is out of range (expected 0 to 1e10 s)"
    );
    for fps in [1e-300, 0.0, f64::NAN, 1e6] {
        let options = AuTextOptions {
            fps,
            headerless_time_column: false,
        };
        assert!(
            au_error("", options).to_string().contains("fps"),
            "{fps}: {}",
            au_error("", options)
        );
    }
}
