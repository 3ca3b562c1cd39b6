//! When the syllable stream's voice sounds each phoneme: the table
//! `data/streams/syllables.phonemes.tsv`, which `data/streams/speak_syllables.py` wrote
//! from eSpeak NG's phoneme events while it spoke `data/streams/syllables.wav`. The
//! syllable stream takes its timing from it, so the mouth closes for `p` where the voice
//! says `p` (core/src/stream/syllables.rs). The table is embedded and checked when read: a row
//! per syllable in order, times increasing, each inside its syllable's slot.

use std::sync::Arc;

use super::error::{Location, StreamError};
use crate::text_table;

/// The embedded table.
pub const PHONEMES_TSV: &str = include_str!("../../../data/streams/syllables.phonemes.tsv");

/// Its path in the repository, named in errors.
pub const PHONEMES_PATH: &str = "data/streams/syllables.phonemes.tsv";

/// Sample rate of the voice the table counts samples of, Hz.
pub const VOICE_RATE: u32 = 16_000;

/// Where one syllable's phonemes sound, seconds from the start of its slot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SyllableTiming {
    /// The consonant begins.
    pub consonant_s: f64,
    /// The vowel begins (the consonant's release).
    pub vowel_s: f64,
    /// The vowel ends and the voice falls silent.
    pub vowel_end_s: f64,
}

/// Reads the table: one row per name of `syllables`, in that order, each slot
/// `slot_s` long. A row's times must increase and stay within its slot.
pub fn read_timings(text: &str, syllables: &[&str], slot_s: f64) -> Result<Vec<SyllableTiming>, StreamError> {
    let file: Arc<str> = Arc::from(PHONEMES_PATH);
    let at = |line: usize| Location::line(Some(file.clone()), line as u64);
    let mut timings = Vec::with_capacity(syllables.len());
    let mut last_line = 0;
    for row in text_table::rows(text) {
        last_line = row.line;
        let index = timings.len();
        let Some(&expected) = syllables.get(index) else {
            return Err(StreamError::syntax(
                &at(row.line),
                "syllable",
                format!("a row after the {} syllables", syllables.len()),
            ));
        };
        let [name, consonant, vowel, vowel_end, _phonemes] = row.fields[..] else {
            return Err(StreamError::WrongLength {
                at: at(row.line),
                field: "row".into(),
                found: row.fields.len(),
                expected: "5 (syllable, consonant, vowel, vowel_end, phonemes)".into(),
            });
        };
        if name != expected {
            return Err(StreamError::syntax(
                &at(row.line),
                "syllable",
                format!("{name:?} where syllable {} is {expected:?}", index + 1),
            ));
        }
        let slot_start = index as f64 * slot_s;
        let seconds = |field: &str, text: &str| -> Result<f64, StreamError> {
            let sample: u64 = text.parse().map_err(|_| StreamError::NotANumber {
                at: at(row.line),
                field: field.to_string(),
                found: format!("{text:?}"),
                expected: "a sample index",
            })?;
            Ok(sample as f64 / f64::from(VOICE_RATE) - slot_start)
        };
        let timing = SyllableTiming {
            consonant_s: seconds("consonant", consonant)?,
            vowel_s: seconds("vowel", vowel)?,
            vowel_end_s: seconds("vowel_end", vowel_end)?,
        };
        let ordered = 0.0 <= timing.consonant_s
            && timing.consonant_s < timing.vowel_s
            && timing.vowel_s < timing.vowel_end_s
            && timing.vowel_end_s <= slot_s;
        if !ordered {
            return Err(StreamError::OutOfRange {
                at: at(row.line),
                field: "consonant".into(),
                found: format!("{timing:?}"),
                expected: format!("0 <= consonant < vowel < vowel_end <= {slot_s} s into the slot"),
            });
        }
        timings.push(timing);
    }
    if timings.len() != syllables.len() {
        return Err(StreamError::Truncated {
            at: at(last_line),
            field: "syllable".into(),
            expected: format!("{} syllables, found {}", syllables.len(), timings.len()),
        });
    }
    Ok(timings)
}

#[cfg(test)]
mod tests {
    use super::*;

    const TWO: [&str; 2] = ["pa", "ma"];

    #[test]
    fn sample_positions_become_seconds_into_each_slot() {
        let text = "# comment\npa\t1600\t2186\t5958\tp+a\nma\t11200\t13600\t16000\tm+a\n";
        let timings = read_timings(text, &TWO, 0.6).unwrap();
        assert_eq!(timings[0].consonant_s, 0.1);
        assert!((timings[0].vowel_s - 0.136_625).abs() < 1e-12);
        assert!((timings[1].consonant_s - 0.1).abs() < 1e-12);
        assert!((timings[1].vowel_end_s - 0.4).abs() < 1e-12);
    }

    #[test]
    fn a_bad_table_is_refused_with_its_line() {
        let cases = [
            ("pa\t1600\t2186\t5958\tp+a\n", "ends early"),
            (
                "pa\t1600\t2186\t5958\tp+a\nmi\t11200\t13600\t16000\tm+i\n",
                "\"mi\" where syllable 2",
            ),
            (
                "pa\t1600\t2186\tx\tp+a\nma\t11200\t13600\t16000\tm+a\n",
                "vowel_end: \"x\"",
            ),
            (
                "pa\t2186\t1600\t5958\tp+a\nma\t11200\t13600\t16000\tm+a\n",
                "line 1: consonant",
            ),
            (
                "pa\t1600\t2186\t9958\tp+a\nma\t11200\t13600\t16000\tm+a\n",
                "out of range",
            ),
            ("pa\t1600\t2186\nma\t11200\t13600\t16000\tm+a\n", "has 3 entries"),
        ];
        for (text, expected) in cases {
            let message = read_timings(text, &TWO, 0.6).unwrap_err().to_string();
            assert!(message.contains(expected), "{message}");
            assert!(message.starts_with(PHONEMES_PATH), "{message}");
        }
    }
}
