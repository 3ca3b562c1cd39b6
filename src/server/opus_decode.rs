//! A producer's Opus voice as PCM, for the viewers that ask for PCM: each packet decoded
//! once per stream (never per viewer) by libopus at 48 kHz, mono, into a chunk at the
//! packet's own `t`.

use facewire_proto::audio_chunk::OPUS_RATE;

/// The most samples one packet decodes to (120 ms at 48 kHz).
const MAX_PACKET_SAMPLES: usize = 5_760;

#[derive(Debug, thiserror::Error)]
#[error("decoding the stream's Opus as PCM: {0}")]
pub struct OpusDecodeError(#[from] opus::Error);

pub struct OpusStreamDecoder {
    decoder: opus::Decoder,
    pcm: Vec<i16>,
}

impl OpusStreamDecoder {
    pub fn new() -> Result<OpusStreamDecoder, OpusDecodeError> {
        Ok(OpusStreamDecoder {
            decoder: opus::Decoder::new(OPUS_RATE, opus::Channels::Mono)?,
            pcm: vec![0; MAX_PACKET_SAMPLES],
        })
    }

    /// The packet's samples at 48 kHz (valid until the next call).
    pub fn decode(&mut self, packet: &[u8]) -> Result<&[i16], OpusDecodeError> {
        let samples = self.decoder.decode(packet, &mut self.pcm, false)?;
        Ok(&self.pcm[..samples])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_packet_decodes_to_the_samples_its_table_of_contents_names() {
        let mut encoder = opus::Encoder::new(48_000, opus::Channels::Mono, opus::Application::Voip).unwrap();
        let tone: Vec<i16> = (0..960)
            .map(|i| (8_000.0 * (f64::from(i) * 440.0 * std::f64::consts::TAU / 48_000.0).sin()) as i16)
            .collect();
        let packet = encoder.encode_vec(&tone, 1275).unwrap();
        let mut decoder = OpusStreamDecoder::new().unwrap();
        assert_eq!(decoder.decode(&packet).unwrap().len(), 960);
        // A packet whose table of contents parses but whose frame does not.
        assert!(decoder.decode(&[31 << 3 | 3, 0]).is_err());
    }
}
