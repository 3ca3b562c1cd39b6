//! Ogg Opus files (RFC 7845), the voice an HTTP batch may carry instead of a WAV, as
//! `opusenc`, ffmpeg and browsers' `MediaRecorder` write it: the container read page by
//! page (each page's checksum checked by the `ogg` crate), its `OpusHead` checked (one
//! logical stream, channel mapping family 0: mono or stereo), its `OpusTags` skipped, and
//! its audio packets checked and kept in order with what the decoder's output must lose:
//! the encoder's pre-skip at the start and, by the last page's granule position, the
//! padding at the end. Nothing is decoded here (the service decodes with libopus); every
//! count is at Opus's 48 kHz.

use std::io::Cursor;

use facewire_proto::audio_chunk::{opus_packet_samples, MAX_OPUS_PACKET, OPUS_RATE};

/// An Ogg Opus file's voice, not yet decoded.
#[derive(Debug, Clone, PartialEq)]
pub struct OggOpus {
    /// The audio packets, in order.
    pub packets: Vec<Vec<u8>>,
    /// Samples the decoded output starts with that are not the voice (48 kHz).
    pub pre_skip: u32,
    /// Samples of voice after the pre-skip (48 kHz): the decoded output is cut there.
    pub samples: u64,
    /// Gain to apply to the decoded samples, dB.
    pub output_gain_db: f32,
    /// 1 or 2; a mono decoder mixes a stereo file down.
    pub channels: u8,
}

impl OggOpus {
    /// The voice's length, s.
    pub fn duration_s(&self) -> f64 {
        self.samples as f64 / f64::from(OPUS_RATE)
    }
}

#[derive(Debug, thiserror::Error)]
pub enum OggOpusError {
    #[error("{file}: not a readable Ogg file: {problem}")]
    Container { file: String, problem: String },
    #[error("{file}: is empty, or holds no Ogg packets")]
    Empty { file: String },
    #[error("{file}: the first packet is not an OpusHead (RFC 7845, section 5.1): not an Ogg Opus file")]
    NotOpus { file: String },
    #[error("{file}: OpusHead: {problem}")]
    Head { file: String, problem: String },
    #[error("{file}: the second packet is not OpusTags (RFC 7845, section 5.2)")]
    NoTags { file: String },
    #[error(
        "{file}: packet {index} belongs to logical stream {serial:#x}, not the voice's {voice:#x}: \
         chained or multiplexed Ogg files are not read; give one Opus stream"
    )]
    OtherStream {
        file: String,
        index: usize,
        serial: u32,
        voice: u32,
    },
    #[error("{file}: audio packet {index}: {problem}")]
    Packet {
        file: String,
        index: usize,
        problem: String,
    },
    #[error("{file}: holds no audio packets")]
    NoAudio { file: String },
    #[error(
        "{file}: the last page's granule position {granule} is not between the pre-skip {pre_skip} \
         and the {decoded} samples its packets decode to"
    )]
    Granule {
        file: String,
        granule: u64,
        pre_skip: u32,
        decoded: u64,
    },
}

/// Reads `bytes`, an Ogg Opus file named `file` in errors.
pub fn read_ogg_opus(bytes: &[u8], file: &str) -> Result<OggOpus, OggOpusError> {
    let file_name = || file.to_string();
    if bytes.is_empty() {
        return Err(OggOpusError::Empty { file: file_name() });
    }
    let mut reader = ogg::PacketReader::new(Cursor::new(bytes));
    let mut next = || {
        reader.read_packet().map_err(|e| OggOpusError::Container {
            file: file_name(),
            problem: e.to_string(),
        })
    };
    let head = next()?.ok_or_else(|| OggOpusError::Empty { file: file_name() })?;
    let voice = head.stream_serial();
    let (pre_skip, output_gain_db, channels) = read_head(&head.data, file)?;
    let tags = next()?.ok_or_else(|| OggOpusError::NoTags { file: file_name() })?;
    if !tags.data.starts_with(b"OpusTags") || tags.stream_serial() != voice {
        return Err(OggOpusError::NoTags { file: file_name() });
    }
    let (mut packets, mut decoded, mut granule) = (Vec::new(), 0u64, 0u64);
    while let Some(packet) = next()? {
        let index = packets.len();
        if packet.stream_serial() != voice {
            return Err(OggOpusError::OtherStream {
                file: file_name(),
                index,
                serial: packet.stream_serial(),
                voice,
            });
        }
        let bad = |problem: String| OggOpusError::Packet {
            file: file_name(),
            index,
            problem,
        };
        if packet.data.len() > MAX_OPUS_PACKET {
            return Err(bad(format!(
                "{} bytes: an Opus packet has at most {MAX_OPUS_PACKET}",
                packet.data.len()
            )));
        }
        decoded += u64::from(opus_packet_samples(&packet.data, 0).map_err(|e| bad(e.to_string()))?);
        granule = packet.absgp_page();
        packets.push(packet.data);
    }
    if packets.is_empty() {
        return Err(OggOpusError::NoAudio { file: file_name() });
    }
    if granule < u64::from(pre_skip) || granule > decoded {
        return Err(OggOpusError::Granule {
            file: file_name(),
            granule,
            pre_skip,
            decoded,
        });
    }
    Ok(OggOpus {
        packets,
        pre_skip,
        samples: granule - u64::from(pre_skip),
        output_gain_db,
        channels,
    })
}

/// The pre-skip (samples), output gain (dB) and channel count of an `OpusHead` packet.
fn read_head(data: &[u8], file: &str) -> Result<(u32, f32, u8), OggOpusError> {
    let head = |problem: String| OggOpusError::Head {
        file: file.to_string(),
        problem,
    };
    if !data.starts_with(b"OpusHead") {
        return Err(OggOpusError::NotOpus {
            file: file.to_string(),
        });
    }
    if data.len() < 19 {
        return Err(head(format!("{} bytes, at least 19 expected", data.len())));
    }
    let version = data[8];
    if version >> 4 != 0 {
        return Err(head(format!(
            "version {version}: only major version 0 (versions 0 to 15) is defined"
        )));
    }
    let channels = data[9];
    let pre_skip = u32::from(u16::from_le_bytes([data[10], data[11]]));
    let output_gain_db = f32::from(i16::from_le_bytes([data[16], data[17]])) / 256.0;
    let family = data[18];
    if family != 0 {
        return Err(head(format!(
            "channel mapping family {family} (multichannel): a voice is mono or stereo, family 0"
        )));
    }
    if !(1..=2).contains(&channels) {
        return Err(head(format!(
            "{channels} channels with mapping family 0, which allows 1 or 2"
        )));
    }
    Ok((pre_skip, output_gain_db, channels))
}

#[cfg(test)]
mod tests {
    use super::*;
    use ogg::writing::{PacketWriteEndInfo, PacketWriter};

    /// A CELT-only 20 ms packet (configuration 31, one frame): 960 samples at 48 kHz.
    fn packet(fill: u8) -> Vec<u8> {
        vec![31 << 3, fill, fill, fill]
    }

    fn head(channels: u8, pre_skip: u16, gain_q8: i16, family: u8) -> Vec<u8> {
        let mut head = b"OpusHead".to_vec();
        head.push(1);
        head.push(channels);
        head.extend(pre_skip.to_le_bytes());
        head.extend(48_000u32.to_le_bytes());
        head.extend(gain_q8.to_le_bytes());
        head.push(family);
        head
    }

    /// An Ogg file of `packets` (header packets first) on stream `serial`, two audio
    /// packets a page; the last page's granule position is `final_granule`.
    fn ogg(packets: &[(u32, Vec<u8>)], final_granule: u64) -> Vec<u8> {
        let mut writer = PacketWriter::new(Cursor::new(Vec::new()));
        let mut granule = 0;
        for (i, (serial, data)) in packets.iter().enumerate() {
            let last = i + 1 == packets.len();
            let end = if last {
                PacketWriteEndInfo::EndStream
            } else if i < 2 || i % 2 == 1 {
                PacketWriteEndInfo::EndPage
            } else {
                PacketWriteEndInfo::NormalPacket
            };
            if i >= 2 {
                granule += 960;
            }
            let at = if last { final_granule } else { granule };
            writer.write_packet(data.clone(), *serial, end, at).unwrap();
        }
        writer.into_inner().into_inner()
    }

    fn voice(audio: usize) -> Vec<(u32, Vec<u8>)> {
        let mut packets = vec![(7, head(1, 312, 0, 0)), (7, b"OpusTags\0\0\0\0\0\0\0\0".to_vec())];
        packets.extend((0..audio).map(|i| (7, packet(i as u8))));
        packets
    }

    #[test]
    fn a_file_s_packets_come_in_order_less_its_pre_skip_and_end_padding() {
        // Five 20 ms packets (4,800 samples); the granule position ends the voice at 4,500
        // including the 312 samples of pre-skip: 4,188 samples of voice.
        let file = read_ogg_opus(&ogg(&voice(5), 4_500), "v.opus").unwrap();
        assert_eq!(file.packets, (0..5).map(packet).collect::<Vec<_>>());
        assert_eq!((file.pre_skip, file.samples, file.channels), (312, 4_188, 1));
        assert_eq!(file.output_gain_db, 0.0);
        assert!((file.duration_s() - 4_188.0 / 48_000.0).abs() < 1e-12);
    }

    #[test]
    fn stereo_and_a_gain_are_read_multichannel_is_refused_by_name() {
        let mut packets = voice(1);
        packets[0].1 = head(2, 0, -512, 0);
        let file = read_ogg_opus(&ogg(&packets, 960), "s.opus").unwrap();
        assert_eq!((file.channels, file.output_gain_db, file.samples), (2, -2.0, 960));
        packets[0].1 = head(6, 0, 0, 1);
        let error = read_ogg_opus(&ogg(&packets, 960), "m.opus")
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("m.opus") && error.contains("mapping family 1"),
            "{error}"
        );
    }

    #[test]
    fn what_is_not_a_voice_is_refused_with_the_reason() {
        let refused = |bytes: &[u8], expect: &str| {
            let error = read_ogg_opus(bytes, "x.opus").unwrap_err().to_string();
            assert!(
                error.starts_with("x.opus: ") && error.contains(expect),
                "{expect}: {error}"
            );
        };
        refused(b"RIFF....WAVEfmt ", "not a readable Ogg file");
        refused(&[], "is empty");
        let whole = ogg(&voice(3), 2_880);
        // A flipped byte breaks a page's checksum; a cut file ends inside a page.
        let mut flipped = whole.clone();
        let last = flipped.len() - 1;
        flipped[last] ^= 1;
        refused(&flipped, "not a readable Ogg file");
        refused(&whole[..whole.len() - 2], "not a readable Ogg file");
        let mut vorbis = voice(1);
        vorbis[0].1 = b"\x01vorbis\0\0\0\0\x01\x44\xac\0\0".to_vec();
        refused(&ogg(&vorbis, 960), "not an Ogg Opus file");
        let mut short = voice(1);
        short[0].1.truncate(12);
        refused(&ogg(&short, 960), "12 bytes, at least 19");
        let mut untagged = voice(2);
        untagged.remove(1);
        refused(&ogg(&untagged, 1_920), "not OpusTags");
        refused(&ogg(&voice(0), 0), "no audio packets");
        let mut chained = voice(3);
        chained[3].0 = 9;
        refused(&ogg(&chained, 2_880), "chained or multiplexed");
        let mut empty = voice(2);
        empty[3].1 = vec![31 << 3 | 3, 0];
        refused(&ogg(&empty, 1_920), "audio packet 1");
        let mut huge = voice(1);
        huge[2].1 = vec![31 << 3; MAX_OPUS_PACKET + 1];
        refused(&ogg(&huge, 960), "at most 1275");
        // A granule past what the packets hold, or inside the pre-skip.
        refused(&ogg(&voice(2), 5_000), "granule position 5000");
        refused(&ogg(&voice(2), 100), "granule position 100");
    }
}
