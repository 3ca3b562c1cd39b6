//! The audio message (`FWA1`): a piece of the stream's voice on the stream's own timeline,
//! as a producer sends it and as the server relays it to the viewers that ask for audio.
//! Sectioned from its first version (PROTOCOL.md, "Versions and growth").
//!
//! ```text
//! offset  size  field
//!      0     4  magic "FWA1"
//!      4     8  t_s (f64): the stream time of the chunk's first sample, the producer's
//!               seconds (the clock of the parameter frames' `t`)
//!     12     8  server_receive_us (u64): when the server received it; 0 from producers
//!     20     1  section count, then each section: kind (u8), length (u32), body
//!
//! kind  name  body
//!    1  pcm   sample_rate u32 (16000, 24000 or 48000), count u32, count x i16 (mono)
//!    2  opus  length u16, one Opus packet (RFC 6716), decoded at 48 kHz, mono
//! ```
//! A chunk carries exactly one of `pcm` and `opus`.

use crate::sections::{read_sections, KindsSeen, SectionsOut};
use crate::{DecodeError, Reader, Writer};

pub const AUDIO_MAGIC: [u8; 4] = *b"FWA1";
const PCM: u8 = 1;
const OPUS: u8 = 2;

/// The sample rates a PCM chunk may have, Hz.
pub const PCM_RATES: [u32; 3] = [16_000, 24_000, 48_000];
/// Opus packets are timed (and decoded) at 48 kHz.
pub const OPUS_RATE: u32 = 48_000;
/// RFC 6716's largest packet, bytes.
pub const MAX_OPUS_PACKET: usize = 1275;

/// The sound of one chunk.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum AudioBody {
    /// 16-bit PCM, mono.
    Pcm { sample_rate: u32, samples: Vec<i16> },
    /// One Opus packet.
    Opus { packet: Vec<u8> },
}

impl AudioBody {
    /// The codecs' names, as a viewer's `audio=` names them.
    pub const PCM: &'static str = "pcm";
    pub const OPUS: &'static str = "opus";

    /// Its codec's name.
    pub fn codec(&self) -> &'static str {
        match self {
            AudioBody::Pcm { .. } => AudioBody::PCM,
            AudioBody::Opus { .. } => AudioBody::OPUS,
        }
    }

    /// Its sample rate, Hz.
    pub fn sample_rate(&self) -> u32 {
        match self {
            AudioBody::Pcm { sample_rate, .. } => *sample_rate,
            AudioBody::Opus { .. } => OPUS_RATE,
        }
    }

    /// How many samples (at [`AudioBody::sample_rate`]) it plays for.
    pub fn samples(&self) -> Result<u32, DecodeError> {
        match self {
            AudioBody::Pcm { samples, .. } => Ok(samples.len() as u32),
            AudioBody::Opus { packet } => opus_packet_samples(packet, 0),
        }
    }
}

/// A chunk of a stream's audio.
#[derive(Debug, Clone, PartialEq)]
pub struct AudioChunk {
    /// Stream time of the first sample, the producer's seconds.
    pub t_s: f64,
    /// When the server received it (µs since the Unix epoch); 0 from a producer.
    pub server_receive_us: u64,
    pub body: AudioBody,
    /// Section kinds the decoder did not know and skipped (from a later sender).
    pub ignored: Vec<u8>,
}

impl AudioChunk {
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(32 + self.body_len());
        out.extend_from_slice(&AUDIO_MAGIC);
        out.put_f64(self.t_s);
        out.put_u64(self.server_receive_us);
        let mut sections = SectionsOut::start(&mut out);
        match &self.body {
            AudioBody::Pcm { sample_rate, samples } => {
                let slot = sections.open(&mut out, PCM);
                out.put_u32(*sample_rate);
                out.put_u32(samples.len() as u32);
                for &s in samples {
                    out.extend_from_slice(&s.to_le_bytes());
                }
                SectionsOut::close(&mut out, slot);
            }
            AudioBody::Opus { packet } => {
                let slot = sections.open(&mut out, OPUS);
                out.put_u16(packet.len() as u16);
                out.extend_from_slice(packet);
                SectionsOut::close(&mut out, slot);
            }
        }
        sections.finish(&mut out);
        out
    }

    fn body_len(&self) -> usize {
        match &self.body {
            AudioBody::Pcm { samples, .. } => 8 + 2 * samples.len(),
            AudioBody::Opus { packet } => 2 + packet.len(),
        }
    }

    /// Decodes an audio message, checking its layout: a finite `t_s`, exactly one of
    /// `pcm` and `opus`, a PCM rate of [`PCM_RATES`], an Opus packet whose table of
    /// contents parses (RFC 6716, section 3) and is at most [`MAX_OPUS_PACKET`] bytes.
    pub fn decode(bytes: &[u8]) -> Result<AudioChunk, DecodeError> {
        let mut r = Reader::new(bytes);
        let magic = r.array::<4>("magic")?;
        if magic != AUDIO_MAGIC {
            return Err(DecodeError::Magic {
                found: magic,
                expected: "FWA1",
            });
        }
        let t_s = r.f64("t_s")?;
        if !t_s.is_finite() {
            return Err(DecodeError::Invalid {
                field: "t_s",
                at: 4,
                problem: format!("{t_s} is not a time"),
            });
        }
        let server_receive_us = r.u64("server_receive_us")?;
        let mut seen = KindsSeen::new();
        let (mut body, mut ignored) = (None, Vec::new());
        for mut section in read_sections(&mut r)? {
            let (kind, at) = (section.kind, section.at);
            let b = &mut section.body;
            let read = match kind {
                PCM => read_pcm(b)?,
                OPUS => read_opus(b)?,
                _ => {
                    ignored.push(kind);
                    continue;
                }
            };
            seen.mark(kind, at, "sound")?;
            if body.replace(read).is_some() {
                return Err(DecodeError::Invalid {
                    field: "sound",
                    at,
                    problem: "a chunk carries one of pcm and opus, not both".into(),
                });
            }
        }
        let body = body.ok_or(DecodeError::Invalid {
            field: "sound",
            at: 20,
            problem: "the chunk has neither a pcm nor an opus section".into(),
        })?;
        Ok(AudioChunk {
            t_s,
            server_receive_us,
            body,
            ignored,
        })
    }
}

fn read_pcm(r: &mut Reader<'_>) -> Result<AudioBody, DecodeError> {
    let at = r.position();
    let sample_rate = r.u32("sample_rate")?;
    if !PCM_RATES.contains(&sample_rate) {
        return Err(DecodeError::Invalid {
            field: "sample_rate",
            at,
            problem: format!("{sample_rate} Hz: expected 16000, 24000 or 48000"),
        });
    }
    let count = r.u32("pcm count")? as usize;
    let bytes = r.take(count.saturating_mul(2), "pcm")?;
    let samples = bytes
        .chunks_exact(2)
        .map(|b| i16::from_le_bytes([b[0], b[1]]))
        .collect();
    Ok(AudioBody::Pcm { sample_rate, samples })
}

fn read_opus(r: &mut Reader<'_>) -> Result<AudioBody, DecodeError> {
    let length = usize::from(r.u16("opus length")?);
    let at = r.position();
    if length > MAX_OPUS_PACKET {
        return Err(DecodeError::Invalid {
            field: "opus",
            at,
            problem: format!("{length} bytes: an Opus packet has at most {MAX_OPUS_PACKET}"),
        });
    }
    let packet = r.take(length, "opus")?.to_vec();
    opus_packet_samples(&packet, at)?;
    Ok(AudioBody::Opus { packet })
}

/// How many 48 kHz samples an Opus packet plays for, from its table of contents (RFC 6716,
/// section 3.1): the frame size its configuration names times its frame count. `at` is the
/// packet's offset, for errors. Refuses an empty packet, a frame count of 0 or over 48, and
/// more than 120 ms.
pub fn opus_packet_samples(packet: &[u8], at: usize) -> Result<u32, DecodeError> {
    let invalid = |problem: String| DecodeError::Invalid {
        field: "opus",
        at,
        problem,
    };
    let toc = *packet.first().ok_or_else(|| invalid("an empty packet".into()))?;
    let config = toc >> 3;
    // Frame sizes at 48 kHz: SILK-only (configs 0-11) 10, 20, 40, 60 ms; hybrid (12-15)
    // 10, 20 ms; CELT-only (16-31) 2.5, 5, 10, 20 ms.
    let frame = match config {
        0..=11 => [480, 960, 1920, 2880][usize::from(config % 4)],
        12..=15 => [480, 960][usize::from(config % 2)],
        _ => [120, 240, 480, 960][usize::from(config % 4)],
    };
    let frames = match toc & 3 {
        0 => 1,
        1 | 2 => 2,
        _ => {
            let count = *packet
                .get(1)
                .ok_or_else(|| invalid("code 3 packet without its frame count".into()))?;
            u32::from(count & 0x3f)
        }
    };
    let samples = frame * frames;
    if frames == 0 || samples > 5_760 {
        return Err(invalid(format!(
            "{frames} frame(s) of {frame} samples: a packet holds 1 to 120 ms"
        )));
    }
    Ok(samples)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pcm(t_s: f64, samples: Vec<i16>) -> AudioChunk {
        AudioChunk {
            t_s,
            server_receive_us: 0,
            body: AudioBody::Pcm {
                sample_rate: 16_000,
                samples,
            },
            ignored: Vec::new(),
        }
    }

    #[test]
    fn chunks_round_trip_with_their_layout() {
        let chunk = pcm(0.25, vec![0, -1, 32_767, -32_768]);
        let bytes = chunk.encode();
        // Header 21, section 5 + rate 4 + count 4 + 8 bytes of samples.
        assert_eq!(bytes.len(), 21 + 5 + 8 + 8);
        assert_eq!(&bytes[..4], b"FWA1");
        assert_eq!(&bytes[21..26], &[1, 16, 0, 0, 0]);
        assert_eq!(&bytes[34..36], &0i16.to_le_bytes());
        assert_eq!(AudioChunk::decode(&bytes), Ok(chunk.clone()));
        assert_eq!(chunk.body.samples(), Ok(4));
        // 20 ms of CELT (config 31: 20 ms, code 0: one frame).
        let opus = AudioChunk {
            body: AudioBody::Opus {
                packet: vec![31 << 3, 0xaa, 0xbb],
            },
            ..chunk
        };
        let back = AudioChunk::decode(&opus.encode()).unwrap();
        assert_eq!((back.body.samples(), back.body.sample_rate()), (Ok(960), 48_000));
        assert_eq!(back, opus);
    }

    #[test]
    fn opus_durations_come_from_the_table_of_contents() {
        // SILK 10 ms x1, SILK 60 ms x2 (code 1), hybrid 20 ms, CELT 2.5 ms x 48 (code 3).
        assert_eq!(opus_packet_samples(&[0], 0), Ok(480));
        assert_eq!(opus_packet_samples(&[(3 << 3) | 1], 0), Ok(5_760));
        assert_eq!(opus_packet_samples(&[13 << 3], 0), Ok(960));
        assert_eq!(opus_packet_samples(&[(16 << 3) | 3, 48], 0), Ok(5_760));
        for bad in [
            &[][..],
            &[(16 << 3) | 3],
            &[(16 << 3) | 3, 0],
            &[(19 << 3) | 3, 7],
        ] {
            assert!(opus_packet_samples(bad, 0).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn malformed_chunks_name_the_field_and_later_sections_are_skipped() {
        let good = pcm(1.0, vec![5; 3]).encode();
        let field = |bytes: &[u8]| AudioChunk::decode(bytes).unwrap_err().field();
        let mut rate = good.clone();
        rate[26..30].copy_from_slice(&44_100u32.to_le_bytes());
        assert_eq!(field(&rate), Some("sample_rate"));
        let mut count = good.clone();
        count[30..34].copy_from_slice(&4u32.to_le_bytes());
        assert_eq!(field(&count), Some("pcm"));
        let mut time = good.clone();
        time[4..12].copy_from_slice(&f64::NAN.to_le_bytes());
        assert_eq!(field(&time), Some("t_s"));
        let mut none = good[..21].to_vec();
        none[20] = 0;
        assert_eq!(field(&none), Some("sound"));
        let mut both = good.clone();
        both[20] = 2;
        both.extend_from_slice(&[2, 3, 0, 0, 0, 1, 0, 0]);
        assert_eq!(field(&both), Some("sound"));
        let mut later = good.clone();
        later[20] = 2;
        later.extend_from_slice(&[77, 1, 0, 0, 0, 9]);
        let decoded = AudioChunk::decode(&later).unwrap();
        assert_eq!(decoded.ignored, [77]);
        assert_eq!(decoded.body, AudioChunk::decode(&good).unwrap().body);
        assert!(matches!(
            AudioChunk::decode(b"FWP2xxxx"),
            Err(DecodeError::Magic { .. })
        ));
    }
}
