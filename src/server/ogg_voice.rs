//! An Ogg Opus file's voice as the 48 kHz PCM a batch plays: every packet decoded in order
//! by one libopus decoder (a stereo file mixed down to mono by it), the file's output gain
//! applied by libopus, the encoder's pre-skip dropped from the start and the output cut
//! where the last page's granule position ends the voice, so that its first sample plays
//! at the batch's `audio_t_s` as a WAV's would.

use super::opus_decode::OpusDecodeError;
use crate::voice::{OggOpus, Voice};
use facewire_proto::audio_chunk::OPUS_RATE;

/// The most samples one packet decodes to (120 ms at 48 kHz).
const MAX_PACKET_SAMPLES: usize = 5_760;

/// Decodes `file` (its length already held to the batch's bound by the caller).
pub fn decode_ogg_opus(file: &OggOpus) -> Result<Voice, OpusDecodeError> {
    let mut decoder = opus::Decoder::new(OPUS_RATE, opus::Channels::Mono)?;
    decoder.set_gain((file.output_gain_db * 256.0).round() as i32)?;
    let keep = file.pre_skip as usize + file.samples as usize;
    let mut samples = Vec::with_capacity(keep + MAX_PACKET_SAMPLES);
    let mut pcm = vec![0i16; MAX_PACKET_SAMPLES];
    for packet in &file.packets {
        let decoded = decoder.decode(packet, &mut pcm, false)?;
        samples.extend_from_slice(&pcm[..decoded]);
        if samples.len() >= keep {
            break;
        }
    }
    samples.truncate(keep);
    samples.drain(..(file.pre_skip as usize).min(samples.len()));
    Ok(Voice {
        sample_rate: OPUS_RATE,
        samples,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::voice::read_ogg_opus;
    use ogg::writing::{PacketWriteEndInfo, PacketWriter};

    /// `samples` at 48 kHz as an Ogg Opus file the way opusenc writes one: the encoder's
    /// look-ahead as pre-skip, 20 ms packets, the voice padded to whole packets and the
    /// last granule position where it ends; `gain_q8` in the head.
    fn encode(samples: &[i16], channels: u8, gain_q8: i16) -> Vec<u8> {
        let layout = if channels == 2 {
            opus::Channels::Stereo
        } else {
            opus::Channels::Mono
        };
        let mut encoder = opus::Encoder::new(48_000, layout, opus::Application::Audio).unwrap();
        let pre_skip = encoder.get_lookahead().unwrap() as usize;
        let mut head = b"OpusHead".to_vec();
        head.extend([1, channels]);
        head.extend((pre_skip as u16).to_le_bytes());
        head.extend(48_000u32.to_le_bytes());
        head.extend(gain_q8.to_le_bytes());
        head.push(0);
        let mut writer = PacketWriter::new(std::io::Cursor::new(Vec::new()));
        writer
            .write_packet(head, 1, PacketWriteEndInfo::EndPage, 0)
            .unwrap();
        writer
            .write_packet(
                b"OpusTags\0\0\0\0\0\0\0\0".to_vec(),
                1,
                PacketWriteEndInfo::EndPage,
                0,
            )
            .unwrap();
        let mut padded: Vec<i16> = vec![0; 0];
        padded.extend_from_slice(samples);
        padded.resize((samples.len() + pre_skip).div_ceil(960) * 960, 0);
        let frames: Vec<&[i16]> = padded.chunks(960).collect();
        for (i, frame) in frames.iter().enumerate() {
            let interleaved: Vec<i16> = frame
                .iter()
                .flat_map(|&s| std::iter::repeat_n(s, usize::from(channels)))
                .collect();
            let packet = encoder.encode_vec(&interleaved, 1275).unwrap();
            let last = i + 1 == frames.len();
            let granule = if last {
                (pre_skip + samples.len()) as u64
            } else {
                ((i + 1) * 960) as u64
            };
            let end = if last {
                PacketWriteEndInfo::EndStream
            } else {
                PacketWriteEndInfo::NormalPacket
            };
            writer.write_packet(packet, 1, end, granule).unwrap();
        }
        writer.into_inner().into_inner()
    }

    /// 250 ms of a 300 Hz tone with a 1 ms click at 100 ms.
    fn voice() -> Vec<i16> {
        (0..12_000)
            .map(|i| {
                if (4_800..4_848).contains(&i) {
                    20_000
                } else {
                    (3_000.0 * (f64::from(i) * 300.0 * std::f64::consts::TAU / 48_000.0).sin()) as i16
                }
            })
            .collect()
    }

    /// Where `samples` is loudest.
    fn loudest(samples: &[i16]) -> usize {
        (0..samples.len())
            .max_by_key(|&i| samples[i].unsigned_abs())
            .unwrap()
    }

    #[test]
    fn the_decoded_voice_is_as_long_as_the_file_says_and_its_click_where_it_was() {
        let sent = voice();
        let file = read_ogg_opus(&encode(&sent, 1, 0), "v.opus").unwrap();
        assert_eq!(file.samples, 12_000);
        let heard = decode_ogg_opus(&file).unwrap();
        assert_eq!((heard.sample_rate, heard.samples.len()), (48_000, 12_000));
        // The pre-skip taken off: the click plays where it was sent, to a few samples.
        let at = loudest(&heard.samples);
        assert!((4_790..4_860).contains(&at), "the click at sample {at}");
    }

    #[test]
    fn a_stereo_file_is_mixed_down_and_its_gain_applied() {
        let sent = voice();
        let plain = decode_ogg_opus(&read_ogg_opus(&encode(&sent, 2, 0), "s.opus").unwrap()).unwrap();
        assert_eq!(plain.samples.len(), 12_000);
        let at = loudest(&plain.samples);
        assert!((4_790..4_860).contains(&at), "the click at sample {at}");
        // -6.02 dB (Q7.8: -1541) halves every sample.
        let quiet = decode_ogg_opus(&read_ogg_opus(&encode(&sent, 2, -1541), "q.opus").unwrap()).unwrap();
        let peak = |s: &[i16]| f64::from(s.iter().map(|x| x.unsigned_abs()).max().unwrap());
        let ratio = peak(&quiet.samples) / peak(&plain.samples);
        assert!((0.45..0.55).contains(&ratio), "gain ratio {ratio}");
    }
}
