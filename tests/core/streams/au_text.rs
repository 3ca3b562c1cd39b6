//! AU text: with and without a time column, round trips, errors by line and field.

use super::read_all;
use crate::common::streams::au_error;
use facewire::mask::Mask;
use facewire::stream::{AuTextOptions, AuTextReader, AuTextWriter, Frame};

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
        let message = au_error(text, options).to_string();
        assert!(
            message.starts_with(expected),
            "\n  input: {text}\n   got: {message}\nwanted: {expected}"
        );
    }
    let mask = Mask::candide3();
    let bad_fps = AuTextOptions { fps: 0.0, ..default };
    assert!(AuTextReader::new(&b""[..], &mask, bad_fps).is_err());
}
