//! The syllable stream's voice: `data/streams/syllables.wav` (16 kHz, 16.2 s), spoken by
//! eSpeak NG (`data/streams/speak_syllables.py`), embedded so that the demo talks from
//! the binary alone. Its phonemes time the stream (core/src/stream/syllable_phonemes.rs).

use super::{read_wav, Voice, WavError};

const SYLLABLES_WAV: &[u8] = include_bytes!("../../../data/streams/syllables.wav");

/// The voice of the 27 syllables, on the stream's timeline (the first syllable's slot
/// starts at 0 s).
pub fn syllable_voice() -> Result<Voice, WavError> {
    read_wav(SYLLABLES_WAV, "data/streams/syllables.wav")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stream::syllable_phonemes::VOICE_RATE;
    use crate::stream::syllables::{timings, SYLLABLES, SYLLABLE_S};

    #[test]
    fn the_voice_sounds_where_its_phonemes_are_and_is_silent_between_syllables() {
        let voice = syllable_voice().unwrap();
        assert_eq!(voice.sample_rate, VOICE_RATE);
        assert!((voice.duration_s() - SYLLABLE_S * SYLLABLES.len() as f64).abs() < 1e-9);
        let rms = |from_s: f64, to_s: f64| {
            let rate = f64::from(voice.sample_rate);
            let part = &voice.samples[(from_s * rate) as usize..(to_s * rate) as usize];
            (part.iter().map(|&s| f64::from(s).powi(2)).sum::<f64>() / part.len() as f64).sqrt()
        };
        for (i, (name, timing)) in SYLLABLES.iter().zip(timings().unwrap()).enumerate() {
            let slot = i as f64 * SYLLABLE_S;
            // The vowel is loud, the slot's first 50 ms and the end after the voice are quiet.
            let vowel = rms(slot + timing.vowel_s, slot + timing.vowel_end_s);
            assert!(vowel > 1000.0, "{name}: vowel rms {vowel}");
            assert!(rms(slot, slot + 0.05) < 30.0, "{name}");
            assert!(
                rms(slot + timing.vowel_end_s + 0.03, slot + SYLLABLE_S) < 100.0,
                "{name}"
            );
        }
    }
}
