//! `.fap` files: the real Xface file, high-level FAPs, masks and comments, round trips,
//! and one error per kind of bad input.

use super::{fap_value, read_all, xface_joy};
use crate::common::streams::fap_error;
use facewire::mask::Mask;
use facewire::stream::{
    open_stream, summarize, AuTextWriter, ExpressionFap, FapHeader, FapReader, FapWriter, Frame, VisemeFap,
};

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
        fap_error(&text).to_string(),
        "line 5: values: file ends early, expected the values line of frame 2 of 3"
    );
    let text = format!("2.1 t 25 2\n{m}\n0 1 2 3\n");
    assert_eq!(
        fap_error(&text).to_string(),
        "line 4: mask: file ends early, expected the mask line of frame 2 of 2"
    );
    assert_eq!(
        fap_error("").to_string(),
        "line 1: header: file ends early, expected the header line \"version name fps frames\""
    );

    let short_mask = vec!["0"; 67].join(" ");
    assert_eq!(
        fap_error(&format!("2.1 t 25 1\n{short_mask}\n0\n")).to_string(),
        "line 2: mask: has 67 entries, expected 68 (or Greta's 69)"
    );
    let bad_bit = m.replacen("1", "2", 1);
    assert_eq!(
        fap_error(&format!("2.1 t 25 1\n{bad_bit}\n0 1 2\n")).to_string(),
        "line 2: mask[2] (FAP 3): \"2\" is out of range (expected 0 or 1)"
    );
    assert_eq!(
        fap_error(&format!("2.1 t 25 1\n{m}\n0 1 x 3\n")).to_string(),
        "line 3: values[1] (FAP 4 lower_t_midlip): \"x\" is not a number"
    );
    assert_eq!(
        fap_error(&format!("2.1 t 25 1\n{m}\n0 1 2 NaN\n")).to_string(),
        "line 3: values[2] (FAP 5 raise_b_midlip): NaN is not a finite number"
    );
    assert_eq!(
        fap_error(&format!("2.1 t 25 1\n{m}\n0 1 2 1e39\n")).to_string(),
        "line 3: values[2] (FAP 5 raise_b_midlip): 1e39 is not a finite number"
    );
    assert_eq!(
        fap_error(&format!("2.1 t 25 1\n{m}\n0 1 2\n")).to_string(),
        "line 3: values: has 3 entries, expected 4 (the frame number and 3 values for the 3 \
         FAPs the mask switches on)"
    );
    assert_eq!(
        fap_error(&format!("2.1 t 25 2\n{m}\n5 1 2 3\n{m}\n4 1 2 3\n")).to_string(),
        "line 5: frame number: 4 does not increase on the previous frame's 5"
    );
    assert_eq!(
        fap_error(&format!("2.1 t 25 1\n{m}\n0 1 2 3\n{m}\n")).to_string(),
        "line 4: data after the 1 frames the header announces"
    );
    assert_eq!(
        fap_error("2.1 t 0 1\n").to_string(),
        "line 1: header fps: 0 is out of range (expected a frame rate from 0.01 to 1000 frames per second)"
    );
    let viseme = mask68(&[1]);
    assert_eq!(
        fap_error(&format!("2.1 t 25 1\n{viseme}\n0 1 2 3.5 0\n")).to_string(),
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
