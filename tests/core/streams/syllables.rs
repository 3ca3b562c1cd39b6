//! The syllable generator and the shipped syllable stream built from it.

use facewire::mask::Mask;
use facewire::stream::mouth_shapes::{ANTICIPATION, CHANNELS, CONSONANTS, VOWELS};
use facewire::stream::syllables::{self, SYLLABLES};
use std::io::Write;

use super::read_all;
use crate::common::repo_path;
use facewire::stream::{open_stream, summarize, JsonlWriter};

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
    // the change over the transition. The shortest transition of the voice's timing is
    // 0.10 s and no change exceeds the channel's range, so between frames 1/fps apart
    //     |dw| <= 1.5 * (max - min) / 0.10 s / fps   (+ the 1e-4 rounding step).
    let shortest = syllables::timings()
        .unwrap()
        .iter()
        .flat_map(|timing| {
            let frames = syllables::keyframes(timing);
            (1..frames.len())
                .filter(move |&k| frames[k - 1].1 != frames[k].1)
                .map(move |k| frames[k].0 - frames[k - 1].0)
        })
        .fold(f64::INFINITY, f64::min);
    assert!((shortest - 0.10).abs() < 1e-12, "{shortest}");
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
    // The tongue's table: the row after the channels' table with the same name.
    let tongue_docs = &docs[docs.find("| viseme | raise_tongue_tip").unwrap()..];
    let tongue = |name: &str| -> Vec<Option<f32>> {
        let prefix = format!("| `{name}` |");
        let line = tongue_docs.lines().find(|l| l.starts_with(&prefix)).unwrap();
        line.split('|').map(str::trim).collect::<Vec<_>>()[2..5]
            .iter()
            .map(|cell| match *cell {
                "vowel" => None,
                number => Some(number.parse().unwrap()),
            })
            .collect()
    };
    for vowel in VOWELS {
        assert_eq!(tongue(vowel.name), vowel.tongue.map(Some), "{}", vowel.name);
    }
    for consonant in CONSONANTS {
        let documented = consonant.tongue.map_or(vec![None; 3], |t| t.map(Some).to_vec());
        assert_eq!(tongue(consonant.name), documented, "{}", consonant.name);
    }
}
