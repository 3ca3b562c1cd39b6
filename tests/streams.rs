//! The parameter-stream formats end to end: the real Xface `.fap` file, round trips through
//! every writer, one error per kind of bad input (each naming its line and field), and the
//! shipped syllable stream.
//!
//! `FACEWIRE_BLESS=1 cargo test --test streams` rewrites `data/streams/syllables.jsonl`
//! from the generator.

mod common;

use common::repo_path;

use std::io::Write;
use std::path::{Path, PathBuf};

use facewire::mask::Mask;
use facewire::stream::syllables::{self, ANTICIPATION, CHANNELS, CONSONANTS, KEYFRAMES, SYLLABLES, VOWELS};
use facewire::stream::{
    open_stream, summarize, AuTextOptions, AuTextReader, AuTextWriter, ExpressionFap, FapHeader, FapReader,
    FapWriter, Frame, JsonlReader, JsonlWriter, StreamError, VisemeFap, MAX_LINE_BYTES,
};

fn xface_joy() -> PathBuf {
    repo_path("data/candide3/xface_joy.fap")
}

fn fap_value(frame: &Frame, fap: u8) -> Option<f32> {
    frame.faps.iter().find(|(f, _)| *f == fap).map(|(_, v)| *v)
}

fn read_all(stream: impl Iterator<Item = Result<Frame, StreamError>>) -> Vec<Frame> {
    stream.collect::<Result<_, _>>().unwrap()
}

fn jsonl_error(text: &str) -> String {
    let mask = Mask::candide3();
    JsonlReader::new(text.as_bytes(), &mask)
        .find_map(Result::err)
        .expect("the input is bad")
        .to_string()
}

fn fap_error(text: &str) -> String {
    FapReader::new(text.as_bytes())
        .find_map(Result::err)
        .expect("the input is bad")
        .to_string()
}

fn au_error(text: &str, options: AuTextOptions) -> String {
    let mask = Mask::candide3();
    AuTextReader::new(text.as_bytes(), &mask, options)
        .unwrap()
        .find_map(Result::err)
        .expect("the input is bad")
        .to_string()
}

// ---------------------------------------------------------------- .fap

#[test]
fn xface_joy_reads_108_frames_at_25_fps() {
    let file = std::fs::File::open(xface_joy()).unwrap();
    let mut reader = FapReader::new(std::io::BufReader::new(file));
    let header = reader.header().unwrap().clone();
    assert_eq!(header.version, "2.1");
    assert_eq!(header.name, r"C:\Users\balci\Work\FACE\exml2fap\files\TempFile");
    assert_eq!((header.fps, header.frame_count), (25.0, 108));
    let frames = read_all(reader);
    assert_eq!(frames.len(), 108);

    // Every frame masks the same 42 FAPs: 3-26, 39-42, 48-60 and 63.
    let masked: Vec<u8> = (3..=26).chain(39..=42).chain(48..=60).chain([63]).collect();
    for (i, frame) in frames.iter().enumerate() {
        assert_eq!(frame.seq, i as u64);
        assert_eq!(frame.time_s, i as f64 / 25.0);
        let faps: Vec<u8> = frame.faps.iter().map(|(f, _)| *f).collect();
        assert_eq!(faps, masked, "frame {i}");
    }

    // Hand-checked against the file's lines 2-3 and 100-101.
    let first = &frames[0];
    assert_eq!(fap_value(first, 3), Some(0.0));
    assert_eq!(fap_value(first, 4), Some(10.0));
    assert_eq!(fap_value(first, 51), Some(10.0));
    assert_eq!(fap_value(first, 6), Some(0.0));
    let f49 = &frames[49];
    assert_eq!(f49.time_s, 1.96);
    for (fap, value) in [
        (3, 111.0),
        (4, -84.0),
        (5, -234.0),
        (6, 59.0),
        (12, 150.0),
        (14, 11.0),
        (19, 128.0),
        (25, -2451.0),
        (41, 107.0),
        (48, 183.0),
        (49, -295.0),
        (50, -2184.0),
        (52, -234.0),
        (60, 150.0),
        (63, 0.0),
    ] {
        assert_eq!(fap_value(f49, fap), Some(value), "FAP {fap}");
    }
    let [rx, ry, rz] = f49.head_rotation();
    assert!((rx - 0.00183).abs() < 1e-7 && (ry + 0.00295).abs() < 1e-7 && (rz + 0.02184).abs() < 1e-7);
}

#[test]
fn xface_joy_opens_by_extension_and_summarizes() {
    let mask = Mask::candide3();
    let summary = summarize(open_stream(&xface_joy(), &mask).unwrap()).unwrap();
    assert_eq!(summary.frames, 108);
    assert!((summary.duration_s - 107.0 / 25.0).abs() < 1e-12);
    assert!((summary.fps_estimate.unwrap() - 25.0).abs() < 1e-9);
    let open_jaw = summary
        .channels
        .iter()
        .find(|c| c.name.as_deref() == Some("open_jaw"))
        .unwrap();
    assert_eq!(open_jaw.frames, 108);
    assert_eq!((open_jaw.min, open_jaw.max), (-6.0, 315.0));
    assert!(summary.labels.is_empty());
}

#[test]
fn a_written_fap_file_reads_back_equal() {
    let mut reader = FapReader::new(std::io::BufReader::new(std::fs::File::open(xface_joy()).unwrap()));
    let header = reader.header().unwrap().clone();
    let frames = read_all(reader);

    let mut writer = FapWriter::new(Vec::new(), &header).unwrap();
    for frame in &frames {
        writer.write_frame(frame).unwrap();
    }
    let bytes = writer.finish().unwrap();
    let text = String::from_utf8(bytes.clone()).unwrap();
    assert!(text.starts_with("2.1 C:\\Users\\balci\\Work\\FACE\\exml2fap\\files\\TempFile 25 108\n"));
    // Frame 49's values line, as in the original file (which has CRLF and a trailing blank).
    assert!(text.contains(
        "\n49 111 -84 -234 59 59 -84 -84 -234 -234 150 150 11 0 3 -6 0 128 128 64 64 135 135 \
         -2451 -2451 0 0 107 107 183 -295 -2184 -42 -234 59 59 -42 -42 -234 -234 150 150 0\n"
    ));

    let mut again = FapReader::new(&bytes[..]);
    assert_eq!(again.header().unwrap(), &header);
    assert_eq!(read_all(again), frames);
}

#[test]
fn high_level_faps_count_4_and_6_values_and_round_trip() {
    let header = FapHeader {
        version: "2.1".into(),
        name: "visemes and expressions".into(),
        fps: 25.0,
        frame_count: 2,
    };
    let frames = vec![
        Frame {
            viseme: Some(VisemeFap {
                select1: 3,
                select2: 7,
                blend: 40,
                definition: 0,
            }),
            expression: Some(ExpressionFap {
                select1: 1,
                intensity1: 63,
                select2: 0,
                intensity2: 0,
                init_face: 0,
                definition: 0,
            }),
            faps: vec![(3, 120.0), (68, -5.0)],
            ..Frame::at(0, 0.0)
        },
        Frame {
            faps: vec![(48, 1000.0)],
            ..Frame::at(3, 0.12)
        },
    ];
    let mut writer = FapWriter::new(Vec::new(), &header).unwrap();
    for frame in &frames {
        writer.write_frame(frame).unwrap();
    }
    let text = String::from_utf8(writer.finish().unwrap()).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "2.1 visemes and expressions 25 2");
    assert!(lines[1].starts_with("1 1 1 0 "));
    assert_eq!(lines[2], "0 3 7 40 0 1 63 0 0 0 0 120 -5");
    assert_eq!(lines[4], "3 1000");
    assert_eq!(read_all(FapReader::new(text.as_bytes())), frames);
}

#[test]
fn greta_69_entry_masks_and_comments_are_accepted() {
    // Greta's `bin/AU Interpolation_2.fap` (NOTES.md section 7), with a comment added.
    let text = "2.1 AU Interpolation_2.fap 25 1\n# written by Greta\n\
        0 0 1 1 1 1 1 1 1 1 1 1 1 0 0 1 1 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 1 1 0 0 0 0 0 0 0 0 1 1 1 1 1 1 1 1 1 1 1 1 1 0 0 0 0 0 0\n\
        0 73 -43 -362 52 52 -43 -43 -362 -362 0 0 -3 -6 36 36 -34 -120 52 52 -34 -34 -120 -120 0 0 2 2 0\n";
    let mut reader = FapReader::new(text.as_bytes());
    assert_eq!(reader.header().unwrap().name, "AU Interpolation_2.fap");
    let frames = read_all(reader);
    assert_eq!(frames.len(), 1);
    let frame = &frames[0];
    assert_eq!(frame.faps.len(), 28);
    assert_eq!(fap_value(frame, 3), Some(73.0));
    assert_eq!(fap_value(frame, 5), Some(-362.0));
    assert_eq!(fap_value(frame, 16), Some(-3.0));
    assert_eq!(fap_value(frame, 41), Some(36.0));
    assert_eq!(fap_value(frame, 63), Some(0.0));
    assert_eq!(fap_value(frame, 64), None);
}

#[test]
fn fap_errors_name_the_line_and_field() {
    let mask68 = |on: &[usize]| {
        (1..=68)
            .map(|f| if on.contains(&f) { "1" } else { "0" })
            .collect::<Vec<_>>()
            .join(" ")
    };
    let m = mask68(&[3, 4, 5]);

    // Truncated: the header promises 3 frames, the file holds 1 and a mask line.
    let text = format!("2.1 t 25 3\n{m}\n0 1 2 3\n{m}\n");
    assert_eq!(
        fap_error(&text),
        "line 5: values: file ends early, expected the values line of frame 2 of 3"
    );
    let text = format!("2.1 t 25 2\n{m}\n0 1 2 3\n");
    assert_eq!(
        fap_error(&text),
        "line 4: mask: file ends early, expected the mask line of frame 2 of 2"
    );
    assert_eq!(
        fap_error(""),
        "line 1: header: file ends early, expected the header line \"version name fps frames\""
    );

    let short_mask = vec!["0"; 67].join(" ");
    assert_eq!(
        fap_error(&format!("2.1 t 25 1\n{short_mask}\n0\n")),
        "line 2: mask: has 67 entries, expected 68 (or Greta's 69)"
    );
    let bad_bit = m.replacen("1", "2", 1);
    assert_eq!(
        fap_error(&format!("2.1 t 25 1\n{bad_bit}\n0 1 2\n")),
        "line 2: mask[2] (FAP 3): \"2\" is out of range (expected 0 or 1)"
    );
    assert_eq!(
        fap_error(&format!("2.1 t 25 1\n{m}\n0 1 x 3\n")),
        "line 3: values[1] (FAP 4 lower_t_midlip): \"x\" is not a number"
    );
    assert_eq!(
        fap_error(&format!("2.1 t 25 1\n{m}\n0 1 2 NaN\n")),
        "line 3: values[2] (FAP 5 raise_b_midlip): NaN is not a finite number"
    );
    assert_eq!(
        fap_error(&format!("2.1 t 25 1\n{m}\n0 1 2 1e39\n")),
        "line 3: values[2] (FAP 5 raise_b_midlip): 1e39 is not a finite number"
    );
    assert_eq!(
        fap_error(&format!("2.1 t 25 1\n{m}\n0 1 2\n")),
        "line 3: values: has 3 entries, expected 4 (the frame number and 3 values for the 3 \
         FAPs the mask switches on)"
    );
    assert_eq!(
        fap_error(&format!("2.1 t 25 2\n{m}\n5 1 2 3\n{m}\n4 1 2 3\n")),
        "line 5: frame number: 4 does not increase on the previous frame's 5"
    );
    assert_eq!(
        fap_error(&format!("2.1 t 25 1\n{m}\n0 1 2 3\n{m}\n")),
        "line 4: data after the 1 frames the header announces"
    );
    assert_eq!(
        fap_error("2.1 t 0 1\n"),
        "line 1: header fps: 0 is out of range (expected a frame rate from 0.01 to 1000 frames per second)"
    );
    let viseme = mask68(&[1]);
    assert_eq!(
        fap_error(&format!("2.1 t 25 1\n{viseme}\n0 1 2 3.5 0\n")),
        "line 3: values[0] (FAP 1 viseme): \"3.5\" is not an integer"
    );
}

#[test]
fn fap_writer_refuses_what_the_format_cannot_carry() {
    let header = FapHeader {
        version: "2.1".into(),
        name: "x".into(),
        fps: 25.0,
        frame_count: 1,
    };
    let mut writer = FapWriter::new(Vec::new(), &header).unwrap();
    let err = writer
        .write_frame(&Frame {
            animation: vec![(1, 0.2)],
            ..Frame::at(4, 0.0)
        })
        .unwrap_err();
    assert_eq!(err.to_string(), "frame 4: au: the .fap format cannot carry it");
    let err = writer.finish().unwrap_err();
    assert_eq!(
        err.to_string(),
        "the header announces 1 frames but 0 were written"
    );
}

#[test]
fn writers_name_the_first_field_their_format_cannot_carry() {
    let mask = Mask::candide3();
    let turned = Frame {
        animation: vec![(1, 0.2)],
        head_rotation_rad: Some([0.0, 0.1, 0.0]),
        arkit: vec![(3, 0.5)],
        ..Frame::at(3, 0.0)
    };
    let viseme_only = Frame {
        viseme: Some(VisemeFap {
            select1: 1,
            select2: 2,
            blend: 10,
            definition: 0,
        }),
        ..Frame::at(5, 0.0)
    };
    let mut au = AuTextWriter::new(Vec::new(), &mask, 11, false).unwrap();
    assert_eq!(
        au.write_frame(&turned).unwrap_err().to_string(),
        "frame 3: arkit: the AU text format cannot carry it"
    );
    assert_eq!(
        au.write_frame(&viseme_only).unwrap_err().to_string(),
        "frame 5: fap: the AU text format cannot carry it"
    );
    let header = FapHeader {
        version: "2.1".into(),
        name: "x".into(),
        fps: 25.0,
        frame_count: 1,
    };
    let mut fap = FapWriter::new(Vec::new(), &header).unwrap();
    let turned_by_faps = Frame {
        head_rotation_rad: Some([0.0, 0.1, 0.0]),
        arkit: vec![(3, 0.5)],
        ..Frame::at(3, 0.0)
    };
    assert_eq!(
        fap.write_frame(&turned_by_faps).unwrap_err().to_string(),
        "frame 3: arkit: the .fap format cannot carry it"
    );
    fap.write_frame(&viseme_only).unwrap();
}

// ---------------------------------------------------------------- JSONL

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
        let message = jsonl_error(&text);
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
        jsonl_error(&text),
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

// ---------------------------------------------------------------- AU text

#[test]
fn au_text_without_time_column_runs_at_the_default_30_fps() {
    let mask = Mask::candide3();
    let text = "# legacy animation\n0 0.5 0\n\n0.1 0.25 -0.2\n# end\n0 0 0\n";
    let frames = read_all(AuTextReader::new(text.as_bytes(), &mask, AuTextOptions::default()).unwrap());
    assert_eq!(
        frames,
        [
            Frame {
                animation: vec![(1, 0.5)],
                ..Frame::at(0, 0.0)
            },
            Frame {
                animation: vec![(0, 0.1), (1, 0.25), (2, -0.2)],
                ..Frame::at(1, 1.0 / 30.0)
            },
            Frame::at(2, 2.0 / 30.0),
        ]
    );
}

#[test]
fn au_text_time_column_from_header_or_option() {
    let mask = Mask::candide3();
    let with_header = "# columns: time jaw_drop lip_stretcher fap17_push_t_lip\n\
                       0.0 0.2 0.1 0.01\n0.04 0.3 0 0.02\n";
    let frames =
        read_all(AuTextReader::new(with_header.as_bytes(), &mask, AuTextOptions::default()).unwrap());
    assert_eq!(
        frames,
        [
            Frame {
                animation: vec![(1, 0.2), (2, 0.1), (25, 0.01)],
                ..Frame::at(0, 0.0)
            },
            Frame {
                animation: vec![(1, 0.3), (25, 0.02)],
                ..Frame::at(1, 0.04)
            },
        ]
    );

    let headerless = "0.5 0 0.2\n0.75 0 0.4\n";
    let options = AuTextOptions {
        headerless_time_column: true,
        ..AuTextOptions::default()
    };
    let frames = read_all(AuTextReader::new(headerless.as_bytes(), &mask, options).unwrap());
    assert_eq!(
        frames[1],
        Frame {
            animation: vec![(1, 0.4)],
            ..Frame::at(1, 0.75)
        }
    );

    // Without the option, the same file is three weight columns at 25 fps.
    let options = AuTextOptions {
        fps: 25.0,
        ..AuTextOptions::default()
    };
    let frames = read_all(AuTextReader::new(headerless.as_bytes(), &mask, options).unwrap());
    assert_eq!(
        frames[1],
        Frame {
            animation: vec![(0, 0.75), (2, 0.4)],
            ..Frame::at(1, 0.04)
        }
    );
}

#[test]
fn au_text_round_trips_with_and_without_time() {
    let mask = Mask::candide3();
    let frames = vec![
        Frame {
            animation: vec![(0, 0.1), (1, 1.0 / 3.0), (10, -0.7)],
            ..Frame::at(0, 0.0)
        },
        Frame::at(1, 0.1),
        Frame {
            animation: vec![(4, 1e-7)],
            ..Frame::at(2, 0.2)
        },
    ];
    for time_column in [true, false] {
        let mut writer = AuTextWriter::new(Vec::new(), &mask, 11, time_column).unwrap();
        for frame in &frames {
            writer.write_frame(frame).unwrap();
        }
        let bytes = writer.into_inner().unwrap();
        let text = std::str::from_utf8(&bytes).unwrap();
        let header = text.lines().next().unwrap();
        assert_eq!(
            header.starts_with("# columns: time upper_lip_raiser"),
            time_column
        );
        assert!(header.ends_with("lip_presser upper_lid_raiser"));
        let options = AuTextOptions {
            fps: 10.0,
            ..AuTextOptions::default()
        };
        let back = read_all(AuTextReader::new(&bytes[..], &mask, options).unwrap());
        assert_eq!(back, frames, "time column {time_column}:\n{text}");
    }
    let mut writer = AuTextWriter::new(Vec::new(), &mask, 11, false).unwrap();
    let err = writer
        .write_frame(&Frame {
            animation: vec![(11, 0.5)],
            ..Frame::at(8, 0.0)
        })
        .unwrap_err();
    assert_eq!(
        err.to_string(),
        "frame 8: au[11]: only the first 11 units are written"
    );
}

#[test]
fn au_text_errors_name_the_line_and_field() {
    let default = AuTextOptions::default();
    let timed = AuTextOptions {
        headerless_time_column: true,
        ..default
    };
    let too_many = format!("{}\n", vec!["0"; 66].join(" "));
    let cases = [
        (
            "0 0.5\n0 x\n",
            default,
            "line 2: column 2 (jaw_drop): \"x\" is not a number",
        ),
        (
            "0 0.5\n0 nan\n",
            default,
            "line 2: column 2 (jaw_drop): nan is not a finite number",
        ),
        (
            "0 0.5\n0 -inf\n",
            default,
            "line 2: column 2 (jaw_drop): -inf is not a finite number",
        ),
        (
            "0 0.5\n0\n",
            default,
            "line 2: values: has 1 entries, expected 2 (2 animation unit weights)",
        ),
        (
            "0.1 0.5\n0.05 0.5\n",
            timed,
            "line 2: column 1 (time): time 0.05 s is before the previous frame's 0.1 s",
        ),
        (
            "# columns: time jaw_drop smile\n",
            default,
            "line 1: columns[3]: unknown animation unit \"smile\"; valid: an index 0..65 or one \
             of upper_lip_raiser, jaw_drop,",
        ),
        (
            "# columns: jaw_drop auv11\n",
            default,
            "line 1: columns[2]: names the same animation unit as \"columns[1]\"",
        ),
        (
            "# columns: jaw_drop time\n",
            default,
            "line 1: columns[2]: time can only be the first column",
        ),
        (
            too_many.as_str(),
            default,
            "line 1: values: has 66 entries, expected 1 to 65 weights",
        ),
    ];
    for (text, options, expected) in cases {
        let message = au_error(text, options);
        assert!(
            message.starts_with(expected),
            "\n  input: {text}\n   got: {message}\nwanted: {expected}"
        );
    }
    let mask = Mask::candide3();
    let bad_fps = AuTextOptions { fps: 0.0, ..default };
    assert!(AuTextReader::new(&b""[..], &mask, bad_fps).is_err());
}

// ---------------------------------------------------------------- syllables

#[test]
fn syllables_cover_all_27_in_order_with_a_label_on_every_frame() {
    let frames = syllables::generate(30.0).unwrap();
    // 27 syllables of 0.6 s at 30 fps, rest to rest, both ends included.
    assert_eq!(frames.len(), 487);
    assert!(frames.iter().all(|f| f.label.is_some()));
    let summary = summarize(frames.iter().cloned().map(Ok)).unwrap();
    let labels: Vec<&str> = summary.labels.iter().map(|l| l.label.as_str()).collect();
    assert_eq!(labels, SYLLABLES);
    // 18 frames each; the closing rest frame belongs to the last syllable.
    assert!(summary.labels[..26].iter().all(|l| l.frames == 18));
    assert_eq!(summary.labels[26].frames, 19);
    assert_eq!(frames[0].animation, []);
    assert_eq!(frames[486].animation, []);
    assert!((summary.fps_estimate.unwrap() - 30.0).abs() < 1e-9);
    for (i, frame) in frames.iter().enumerate() {
        assert_eq!((frame.seq, frame.time_s), (i as u64, i as f64 / 30.0));
    }
}

#[test]
fn syllable_weights_stay_in_the_table_ranges_and_reach_the_vowels() {
    let frames = syllables::generate(30.0).unwrap();
    let mut peak = [0.0f32; 8];
    for frame in &frames {
        for &(unit, weight) in &frame.animation {
            let k = CHANNELS
                .iter()
                .position(|c| c.unit == unit)
                .unwrap_or_else(|| panic!("unit {unit} is not a viseme channel"));
            let channel = CHANNELS[k];
            assert!(
                channel.min <= weight && weight <= channel.max,
                "frame {} {}: {weight}",
                frame.seq,
                channel.key
            );
            peak[k] = peak[k].max(weight.abs());
        }
    }
    // The jaw opens fully for "a", the lips press fully for "p", "u" protrudes.
    assert_eq!(peak[1], 0.55);
    assert_eq!(peak[4], 0.6);
    assert_eq!(peak[7], 0.04);
}

#[test]
fn syllable_motion_has_no_jumps() {
    // Between keyframes a weight follows a smoothstep, whose slope is at most 1.5 times
    // the change over the transition. The shortest transition is 0.10 s and no change
    // exceeds the channel's range, so between frames 1/fps apart
    //     |dw| <= 1.5 * (max - min) / 0.10 s / fps   (+ the 1e-4 rounding step).
    let shortest = KEYFRAMES
        .windows(2)
        .filter(|pair| pair[0].1 != pair[1].1)
        .map(|pair| pair[1].0 - pair[0].0)
        .fold(f64::INFINITY, f64::min);
    assert!((shortest - 0.10).abs() < 1e-12);
    for fps in [25.0, 30.0, 120.0] {
        let frames = syllables::generate(fps).unwrap();
        let weights: Vec<[f32; 8]> = frames
            .iter()
            .map(|f| {
                let mut w = [0.0; 8];
                for &(unit, weight) in &f.animation {
                    let k = CHANNELS.iter().position(|c| c.unit == unit).unwrap();
                    w[k] = weight;
                }
                w
            })
            .collect();
        for (k, channel) in CHANNELS.iter().enumerate() {
            let bound = 1.5 * f64::from(channel.max - channel.min) / shortest / fps + 1e-4;
            let largest = weights
                .windows(2)
                .map(|pair| f64::from((pair[1][k] - pair[0][k]).abs()))
                .fold(0.0, f64::max);
            assert!(
                largest <= bound,
                "{} at {fps} fps: step {largest} > {bound}",
                channel.key
            );
        }
        // At 30 fps that allows the jaw 0.27 per frame; a step function would move it 0.55.
    }
}

#[test]
fn consonants_anticipate_the_vowel() {
    let frames = syllables::generate(30.0).unwrap();
    // Frame 4 of a syllable (0.133 s) is in the consonant hold.
    let hold = |syllable: &str| {
        let index = SYLLABLES.iter().position(|s| *s == syllable).unwrap();
        let frame = &frames[index * 18 + 4];
        assert_eq!(frame.label.as_deref(), Some(syllable));
        let weight = |unit: u16| {
            frame
                .animation
                .iter()
                .find(|(u, _)| *u == unit)
                .map_or(0.0, |(_, w)| *w)
        };
        (weight(1), weight(2), weight(9))
    };
    let (pi_jaw, pi_stretch, pi_press) = hold("pi");
    let (pu_jaw, pu_stretch, pu_press) = hold("pu");
    assert_eq!((pi_jaw, pu_jaw), (0.0, 0.0));
    assert_eq!((pi_press, pu_press), (0.6, 0.6));
    assert!(pi_stretch > 0.3, "{pi_stretch}");
    assert!(pu_stretch < -0.3, "{pu_stretch}");
}

#[test]
fn shipped_syllable_stream_matches_the_generator() {
    let mask = Mask::candide3();
    let frames = syllables::generate(syllables::SHIPPED_FPS).unwrap();
    let mut writer = JsonlWriter::new(Vec::new(), &mask);
    for frame in &frames {
        writer.write_frame(frame).unwrap();
    }
    let generated = writer.into_inner().unwrap();
    let path = repo_path("data/streams/syllables.jsonl");
    if std::env::var_os("FACEWIRE_BLESS").is_some_and(|v| v == "1") {
        let mut file = std::fs::File::create(&path).unwrap();
        file.write_all(&generated).unwrap();
        file.sync_all().unwrap();
    }
    let shipped = std::fs::read(&path).unwrap();
    assert!(
        shipped == generated,
        "{} differs from the generator; rerun with FACEWIRE_BLESS=1 if the change is intended",
        path.display()
    );
    // And it reads back as the very frames it was written from.
    let read_back = read_all(open_stream(&path, &mask).unwrap());
    assert_eq!(read_back.len(), frames.len());
    for (read, written) in read_back.iter().zip(&frames) {
        assert_eq!(read, written);
    }
}

#[test]
fn the_documented_viseme_table_is_the_one_in_the_code() {
    let full = std::fs::read_to_string(repo_path("docs/STREAMS.md")).unwrap();
    assert!(full.contains(&format!("`ANTICIPATION` = {ANTICIPATION}")));
    let docs = &full[full.find("### Viseme table").unwrap()..];
    let cells = |name: &str| -> Vec<String> {
        let prefix = format!("| `{name}` |");
        let line = docs
            .lines()
            .find(|l| l.starts_with(&prefix))
            .unwrap_or_else(|| panic!("no row for {name} in docs/STREAMS.md"));
        line.split('|').map(|c| c.trim().to_string()).collect()
    };
    let targets = |name: &str| -> Vec<Option<f32>> {
        cells(name)[2..2 + CHANNELS.len()]
            .iter()
            .map(|cell| match cell.as_str() {
                "vowel" => None,
                number => Some(number.parse().unwrap()),
            })
            .collect()
    };
    for vowel in VOWELS {
        let documented: Vec<Option<f32>> = vowel.targets.iter().map(|&t| Some(t)).collect();
        assert_eq!(targets(vowel.name), documented, "{}", vowel.name);
    }
    for consonant in CONSONANTS {
        assert_eq!(targets(consonant.name), consonant.targets, "{}", consonant.name);
        assert_eq!(cells(consonant.name)[2 + CHANNELS.len()], consonant.articulation);
    }
    for channel in CHANNELS {
        let range = format!("| {} | {} .. {} |", channel.unit, channel.min, channel.max);
        assert!(docs.contains(&range), "{}: {range}", channel.key);
    }
}

// ---------------------------------------------------------------- command line

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
