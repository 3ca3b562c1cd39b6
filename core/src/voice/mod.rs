//! Voices: the speech that goes with a parameter stream, as mono 16-bit samples on the
//! stream's own timeline (seconds from its `t = 0`). Read from WAV files ([`wav`]) (Ogg
//! Opus files, [`ogg_opus`], are read here and decoded by the service) and cut
//! into the chunks producers send (`FWA1`, proto/PROTOCOL.md), or played slower or faster
//! at the same pitch ([`stretch`]). The syllable stream's own
//! voice ships in `data/streams/syllables.wav` ([`syllable_voice`]).
//!
//! Plain synchronous Rust, as the rest of the core.

mod ogg_opus;
mod stretch;
mod syllable_voice;
mod wav;

pub use ogg_opus::{read_ogg_opus, OggOpus, OggOpusError};
pub use stretch::{StretchError, Stretching, STRETCH_SPEEDS};
pub use syllable_voice::syllable_voice;
pub use wav::{read_wav, WavError};

use facewire_proto::audio_chunk::{AudioBody, AudioChunk};

/// The length of the chunks producers send: 20 ms, an Opus frame, as WebRTC sends.
pub const CHUNK_S: f64 = 0.02;

/// Mono speech: `samples` at `sample_rate` Hz, the first at `t = 0` s.
#[derive(Debug, Clone, PartialEq)]
pub struct Voice {
    pub sample_rate: u32,
    pub samples: Vec<i16>,
}

impl Voice {
    /// Length, seconds.
    pub fn duration_s(&self) -> f64 {
        self.samples.len() as f64 / f64::from(self.sample_rate)
    }

    /// The samples in chunks of `chunk_s` seconds (the last may be shorter), each with the
    /// time of its first sample, seconds.
    pub fn chunks(&self, chunk_s: f64) -> impl Iterator<Item = (f64, &[i16])> {
        let per_chunk = ((chunk_s * f64::from(self.sample_rate)).round() as usize).max(1);
        let rate = f64::from(self.sample_rate);
        self.samples
            .chunks(per_chunk)
            .enumerate()
            .map(move |(i, chunk)| ((i * per_chunk) as f64 / rate, chunk))
    }

    /// The voice as a producer sends it: [`CHUNK_S`] PCM chunks (`FWA1`), the first
    /// sample at `start_t_s` on the stream's timeline (s), not yet stamped with a receipt.
    pub fn audio_chunks(&self, start_t_s: f64) -> impl Iterator<Item = AudioChunk> + '_ {
        self.chunks(CHUNK_S).map(move |(t_s, samples)| AudioChunk {
            t_s: start_t_s + t_s,
            server_receive_us: 0,
            body: AudioBody::Pcm {
                sample_rate: self.sample_rate,
                samples: samples.to_vec(),
            },
            ignored: Vec::new(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_carry_the_time_of_their_first_sample() {
        let voice = Voice {
            sample_rate: 16_000,
            samples: (0..800).map(|i| i as i16).collect(),
        };
        let chunks: Vec<_> = voice.chunks(0.02).collect();
        assert_eq!(chunks.len(), 3);
        assert_eq!((chunks[1].0, chunks[1].1[0]), (0.02, 320));
        assert_eq!((chunks[2].0, chunks[2].1.len()), (0.04, 160));
        assert_eq!(voice.duration_s(), 0.05);
    }

    #[test]
    fn audio_chunks_are_20_ms_of_pcm_on_the_stream_s_timeline() {
        let voice = Voice {
            sample_rate: 24_000,
            samples: (0..1000).map(|i| i as i16).collect(),
        };
        let chunks: Vec<_> = voice.audio_chunks(1.5).collect();
        assert_eq!(chunks.len(), 3);
        assert_eq!(chunks[1].t_s, 1.52);
        match &chunks[2].body {
            AudioBody::Pcm { sample_rate, samples } => {
                assert_eq!((*sample_rate, samples.len(), samples[0]), (24_000, 40, 960))
            }
            other => panic!("{other:?}"),
        }
    }
}
