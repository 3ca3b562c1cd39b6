//! Both parameter frame layouts: round trips, refusals, and how FWP2 grows.

use super::*;

#[test]
fn fwp1_round_trip_and_errors() {
    let frame = ParamFrame {
        seq: 7,
        time_s: 0.25,
        animation: vec![(1, 0.5), (2, -0.25)],
        faps: vec![(3, 120.0)],
        arkit: vec![(24, 1.0)],
        head_rotation_rad: Some([0.1, 0.0, -0.1]),
        label: Some("pa".into()),
        ..ParamFrame::default()
    };
    let bytes = frame.encode_fwp1().unwrap();
    assert_eq!(bytes.len(), 4 + 8 + 8 + 1 + 2 + 12 + 2 + 5 + 2 + 5 + 12 + 3);
    for viseme in [
        ParamViseme::Fap1 {
            select1: 10,
            select2: 12,
            blend: 21,
            definition: 0,
        },
        ParamViseme::Oculus(1),
        ParamViseme::Microsoft(18),
    ] {
        let with = ParamFrame {
            viseme: Some(viseme),
            ..frame.clone()
        };
        let encoded = with.encode_fwp1().unwrap();
        assert_eq!(encoded.len(), bytes.len() + 5);
        assert_eq!(ParamFrame::decode(&encoded), Ok(with));
    }
    let mut unknown = ParamFrame {
        viseme: Some(ParamViseme::Oculus(1)),
        ..frame.clone()
    }
    .encode_fwp1()
    .unwrap();
    let scheme_at = unknown.len() - 5;
    unknown[scheme_at] = 3;
    assert!(matches!(
        ParamFrame::decode(&unknown),
        Err(DecodeError::Invalid { field: "viseme", .. })
    ));
    unknown[scheme_at] = 1;
    unknown[scheme_at + 2] = 7;
    assert!(matches!(
        ParamFrame::decode(&unknown),
        Err(DecodeError::Invalid { field: "viseme", .. })
    ));
    assert_eq!(ParamFrame::decode(&bytes), Ok(frame));
    assert!(matches!(
        ParamFrame::decode(&bytes[..25]),
        Err(DecodeError::Truncated {
            field: "au weight",
            ..
        })
    ));
    for undefined in [8u8, 0x10, 0x80] {
        let mut flagged = bytes.clone();
        flagged[20] |= undefined;
        assert_eq!(
            ParamFrame::decode(&flagged),
            Err(DecodeError::Invalid {
                field: "flags",
                at: 20,
                problem: format!(
                    "undefined bits {undefined:#04x} are set (bit 0 rotation, bit 1 label, bit 2 viseme)"
                ),
            })
        );
        assert_eq!(ParamFrame::decode(&flagged).unwrap_err().field(), Some("flags"));
    }
    let mut extra = bytes.clone();
    extra.push(1);
    assert_eq!(
        ParamFrame::decode(&extra),
        Err(DecodeError::Trailing { extra: 1 })
    );
}

fn full_frame() -> ParamFrame {
    ParamFrame {
        seq: 9,
        time_s: 1.25,
        animation: vec![(1, 0.5), (2, -0.25)],
        faps: vec![(3, 120.0), (48, 0.1)],
        arkit: vec![(17, 0.75)],
        head_rotation_rad: Some([0.1, 0.0, -0.1]),
        head_translation: Some([0.0, 0.02, -0.01]),
        label: Some("pa".into()),
        viseme: Some(ParamViseme::Oculus(4)),
        ignored: Vec::new(),
    }
}

#[test]
fn fwp2_round_trips_what_fwp1_cannot_carry() {
    let frame = full_frame();
    let bytes = frame.encode();
    assert_eq!(&bytes[..4], b"FWP2");
    // Header 21; sections: au 5 + 2 + 12, fap 5 + 2 + 10, arkit 5 + 2 + 5, rotation and
    // translation 5 + 12 each, label 5 + 3, viseme 5 + 5.
    assert_eq!(bytes.len(), 21 + 19 + 17 + 12 + 17 + 17 + 8 + 10);
    assert_eq!(bytes[20], 7);
    assert_eq!(ParamFrame::decode(&bytes), Ok(frame.clone()));
    assert_eq!(frame.encode_fwp1(), Err(Unrepresentable("head_translation")));
    // An empty frame has no sections.
    let empty = ParamFrame::default().encode();
    assert_eq!(empty.len(), 21);
    assert_eq!(ParamFrame::decode(&empty), Ok(ParamFrame::default()));
}

/// `bytes` with a section of `kind` and `body` appended.
fn with_section(bytes: &[u8], kind: u8, body: &[u8]) -> Vec<u8> {
    let mut out = bytes.to_vec();
    out[20] += 1;
    out.push(kind);
    out.extend_from_slice(&(body.len() as u32).to_le_bytes());
    out.extend_from_slice(body);
    out
}

#[test]
fn fwp2_skips_and_names_unknown_sections_and_reads_grown_ones() {
    let frame = full_frame();
    let bytes = frame.encode();
    let later = with_section(&with_section(&bytes, 99, &[1, 2, 3]), 200, &[]);
    let decoded = ParamFrame::decode(&later).unwrap();
    assert_eq!(decoded.ignored, [99, 200]);
    assert_eq!(
        ParamFrame {
            ignored: vec![],
            ..decoded
        },
        frame
    );
    // A head_translation section grown by a field a later producer added: read as far as
    // its three numbers go.
    let grown = with_section(
        &ParamFrame::default().encode(),
        5,
        &[0, 0, 128, 63, 0, 0, 0, 0, 0, 0, 0, 0, 7, 7],
    );
    assert_eq!(
        ParamFrame::decode(&grown).unwrap().head_translation,
        Some([1.0, 0.0, 0.0])
    );
}

#[test]
fn fwp2_refusals_name_the_section() {
    let base = ParamFrame::default().encode();
    let twice = with_section(&with_section(&base, 6, &[1, b'a']), 6, &[1, b'b']);
    assert!(matches!(
        ParamFrame::decode(&twice),
        Err(DecodeError::Invalid {
            field: "label",
            at: 28,
            ..
        })
    ));
    let short = with_section(&base, 4, &[0; 8]);
    assert!(matches!(
        ParamFrame::decode(&short),
        Err(DecodeError::Truncated {
            field: "head_rotation",
            ..
        })
    ));
    let mut overrun = with_section(&base, 1, &[0, 0]);
    overrun[22] = 9;
    assert!(matches!(
        ParamFrame::decode(&overrun),
        Err(DecodeError::Invalid {
            field: "section",
            at: 21,
            ..
        })
    ));
    let mut trailing = base.clone();
    trailing.push(0);
    assert_eq!(
        ParamFrame::decode(&trailing),
        Err(DecodeError::Trailing { extra: 1 })
    );
    let mut bad_viseme = with_section(&base, 7, &[3, 1, 0, 0, 0]);
    assert!(matches!(
        ParamFrame::decode(&bad_viseme),
        Err(DecodeError::Invalid { field: "viseme", .. })
    ));
    bad_viseme[0] = b'X';
    assert!(matches!(
        ParamFrame::decode(&bad_viseme),
        Err(DecodeError::Magic { .. })
    ));
    assert!(matches!(
        ParamFrame::decode(b"FW"),
        Err(DecodeError::Truncated { field: "magic", .. })
    ));
}
