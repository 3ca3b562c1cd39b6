//! A stream's PCM voice as Opus packets, for the viewers that ask for Opus while the
//! producer sends PCM: encoded once per stream (never per viewer) in 40 ms packets (a
//! packet time WebRTC offers too), at 20 kbit/s in libopus's VoIP mode, complexity 5.
//! Chunks of any length are cut into 40 ms frames on the stream's timeline; a gap in it
//! (silence the producer did not send) closes the pending frame with zeros, and the
//! voice's end does too. A packet's `t` is the stream time of its first decoded sample:
//! the encoder's look-ahead (6.5 ms at 16 kHz in VoIP mode) before the first sample it
//! was given, since a decoder plays every sample that much after the packet's start, as
//! RTP timestamps Opus; so a click plays at its own `t`.

use facewire_proto::audio_chunk::MAX_OPUS_PACKET;

/// Opus's bit rate for speech here, bits per second: 2.5 kB/s of packets, which with
/// 28 bytes of FWA1 framing per packet stays under 4 kB/s a viewer.
pub const OPUS_BITRATE: i32 = 20_000;
/// libopus's encoder complexity (0-10, default 10): 5 encodes a 20 ms packet of the
/// syllable voice in 79 µs against 118 µs, for 0.3 dB less segmental SNR (10.1 against
/// 10.4 dB), so 50 streams take 20 % of a core rather than 30 % (`cargo bench --bench
/// opus_encode`, docs/PERFORMANCE.md "Audio").
const OPUS_COMPLEXITY: i32 = 5;
/// Samples a packet covers, seconds: 40 ms rather than 20 halves the messages every Opus
/// viewer is sent and the encoder calls, for 20 ms more latency before the first sample
/// of a packet can leave; at the load budget (1,000 viewers on 50 streams, with audio),
/// frames' p99 latency went from 21 to 8 ms and the server from 114 to 99 % of a core
/// (docs/PERFORMANCE.md "Audio").
pub const FRAME_S: f64 = 0.04;
/// Slack when a chunk starts where the pending samples end, seconds.
const CONTIGUOUS_S: f64 = 1e-3;

#[derive(Debug, thiserror::Error)]
#[error("encoding the stream's PCM as Opus: {0}")]
pub struct OpusEncodeError(#[from] opus::Error);

pub struct OpusStreamEncoder {
    encoder: opus::Encoder,
    rate: f64,
    /// Samples of a frame ([`FRAME_S`]) at the stream's rate.
    frame: usize,
    /// Samples of the frame being filled, and the stream time of its first.
    pending: Vec<i16>,
    pending_t: f64,
    /// The encoder's look-ahead: how long after its packet's start a sample decodes, s.
    lookahead_s: f64,
    packet: Vec<u8>,
}

impl OpusStreamEncoder {
    /// An encoder for mono PCM at `sample_rate` (16, 24 or 48 kHz).
    pub fn new(sample_rate: u32) -> Result<OpusStreamEncoder, OpusEncodeError> {
        let mut encoder = opus::Encoder::new(sample_rate, opus::Channels::Mono, opus::Application::Voip)?;
        encoder.set_bitrate(opus::Bitrate::Bits(OPUS_BITRATE))?;
        encoder.set_complexity(OPUS_COMPLEXITY)?;
        let frame = (f64::from(sample_rate) * FRAME_S).round() as usize;
        let lookahead_s = f64::from(encoder.get_lookahead()?) / f64::from(sample_rate);
        Ok(OpusStreamEncoder {
            encoder,
            lookahead_s,
            rate: f64::from(sample_rate),
            frame,
            pending: Vec::with_capacity(frame),
            pending_t: 0.0,
            packet: vec![0; MAX_OPUS_PACKET],
        })
    }

    /// How long after a packet's `t` the first sample given for it decodes, seconds (the
    /// encoder's look-ahead): the time a caller on another clock (a replay at a speed)
    /// takes off its own `t` instead of the one `emit` gets.
    pub fn lookahead_s(&self) -> f64 {
        self.lookahead_s
    }

    /// Adds a chunk of `samples` whose first plays at stream time `t_s`; `emit` gets each
    /// packet completed, with the stream time of its first decoded sample (the look-ahead
    /// before the first sample it was given).
    pub fn push(
        &mut self,
        t_s: f64,
        samples: &[i16],
        mut emit: impl FnMut(f64, &[u8]),
    ) -> Result<(), OpusEncodeError> {
        let pending_end = self.pending_t + self.pending.len() as f64 / self.rate;
        if !self.pending.is_empty() && (t_s - pending_end).abs() > CONTIGUOUS_S {
            self.pending.resize(self.frame, 0);
            self.encode_pending(&mut emit)?;
        }
        let mut t = t_s;
        let mut rest = samples;
        while !rest.is_empty() {
            if self.pending.is_empty() {
                self.pending_t = t;
            }
            let take = (self.frame - self.pending.len()).min(rest.len());
            self.pending.extend_from_slice(&rest[..take]);
            rest = &rest[take..];
            t += take as f64 / self.rate;
            if self.pending.len() == self.frame {
                self.encode_pending(&mut emit)?;
            }
        }
        Ok(())
    }

    /// Ends the voice: the frame being filled, if any, is closed with silence and
    /// emitted, so that its last samples are heard.
    pub fn finish(&mut self, mut emit: impl FnMut(f64, &[u8])) -> Result<(), OpusEncodeError> {
        if self.pending.is_empty() {
            return Ok(());
        }
        self.pending.resize(self.frame, 0);
        self.encode_pending(&mut emit)
    }

    fn encode_pending(&mut self, emit: &mut impl FnMut(f64, &[u8])) -> Result<(), OpusEncodeError> {
        let length = self.encoder.encode(&self.pending, &mut self.packet)?;
        emit(self.pending_t - self.lookahead_s, &self.packet[..length]);
        self.pending.clear();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use facewire_proto::audio_chunk::opus_packet_samples;

    /// A 440 Hz tone at 16 kHz from sample `from`, `n` samples.
    fn tone(from: usize, n: usize) -> Vec<i16> {
        (from..from + n)
            .map(|i| (8_000.0 * (i as f64 * 440.0 * std::f64::consts::TAU / 16_000.0).sin()) as i16)
            .collect()
    }

    #[test]
    fn chunks_of_any_length_become_40_ms_packets_on_the_stream_s_timeline() {
        let mut encoder = OpusStreamEncoder::new(16_000).unwrap();
        let mut packets: Vec<(f64, Vec<u8>)> = Vec::new();
        let mut at = 0;
        for n in [200, 500, 580, 20] {
            let t = at as f64 / 16_000.0;
            encoder
                .push(t, &tone(at, n), |t, p| packets.push((t, p.to_vec())))
                .unwrap();
            at += n;
        }
        // 1,300 samples: two full frames of 640; 20 pending. Each packet's time is its
        // first sample's less the look-ahead (104 samples at 16 kHz).
        assert_eq!(encoder.lookahead_s(), 104.0 / 16_000.0);
        let ahead = encoder.lookahead_s();
        assert_eq!(packets.len(), 2);
        assert!((packets[0].0 + ahead).abs() < 1e-12 && (packets[1].0 + ahead - 0.04).abs() < 1e-12);
        // A chunk a second later: the pending 20 samples close with silence first.
        encoder
            .push(1.0, &tone(16_000, 640), |t, p| packets.push((t, p.to_vec())))
            .unwrap();
        let times: Vec<f64> = packets.iter().map(|p| p.0).collect();
        assert_eq!(times.len(), 4);
        assert!(
            (times[2] + ahead - 0.08).abs() < 1e-12 && (times[3] + ahead - 1.0).abs() < 1e-12,
            "{times:?}"
        );

        // Every packet is 40 ms (1,920 samples at Opus's 48 kHz) and decodes to the tone.
        let mut decoder = opus::Decoder::new(16_000, opus::Channels::Mono).unwrap();
        let mut out = vec![0i16; 640];
        for (i, (_, packet)) in packets.iter().enumerate() {
            assert_eq!(opus_packet_samples(packet, 0), Ok(1920));
            assert_eq!(decoder.decode(packet, &mut out, false).unwrap(), 640);
            if i == 1 {
                let energy = out.iter().map(|&s| f64::from(s).powi(2)).sum::<f64>() / 640.0;
                // The tone's mean square is 8000^2 / 2; a voice codec keeps most of it.
                assert!(energy > 0.5 * 32e6 && energy < 1.5 * 32e6, "{energy}");
            }
        }
    }

    #[test]
    fn a_click_decodes_at_its_own_time() {
        // A 2 ms click at 0.5125 s (not on a packet's edge) in a second of silence, sent in
        // 20 ms chunks: decoded at 48 kHz from each packet's time, the click's first loud
        // sample is heard within a millisecond of when it was sent (the encoder's
        // look-ahead, 6.5 ms, is in the packets' times).
        const CLICK_S: f64 = 0.5125;
        let mut voice = vec![0i16; 16_000];
        let at = (CLICK_S * 16_000.0) as usize;
        voice[at..at + 32].fill(24_000);
        let mut encoder = OpusStreamEncoder::new(16_000).unwrap();
        let mut packets: Vec<(f64, Vec<u8>)> = Vec::new();
        for (c, chunk) in voice.chunks(320).enumerate() {
            encoder
                .push(c as f64 * 0.02, chunk, |t, p| packets.push((t, p.to_vec())))
                .unwrap();
        }
        let mut decoder = opus::Decoder::new(48_000, opus::Channels::Mono).unwrap();
        let mut out = vec![0i16; 1920];
        let mut heard = None;
        for (t, packet) in &packets {
            let n = decoder.decode(packet, &mut out, false).unwrap();
            if let Some(i) = out[..n].iter().position(|&s| s.unsigned_abs() > 8_000) {
                heard = heard.or(Some(t + i as f64 / 48_000.0));
            }
        }
        let heard = heard.expect("the click is heard");
        assert!(
            (heard - CLICK_S).abs() < 1e-3,
            "the click heard at {heard} s, sent at {CLICK_S} s"
        );
    }

    #[test]
    fn the_voice_s_last_partial_frame_is_heard_when_it_ends() {
        // 50 ms of tone: one 40 ms packet while it plays, then its last 10 ms (160
        // samples) as a packet padded with silence when the voice ends.
        let mut encoder = OpusStreamEncoder::new(16_000).unwrap();
        let mut packets: Vec<(f64, Vec<u8>)> = Vec::new();
        encoder
            .push(0.0, &tone(0, 800), |t, p| packets.push((t, p.to_vec())))
            .unwrap();
        assert_eq!(packets.len(), 1);
        encoder.finish(|t, p| packets.push((t, p.to_vec()))).unwrap();
        assert_eq!(packets.len(), 2);
        assert!(
            (packets[1].0 + encoder.lookahead_s() - 0.04).abs() < 1e-12,
            "{}",
            packets[1].0
        );
        assert_eq!(opus_packet_samples(&packets[1].1, 0), Ok(1920));
        // Nothing is pending now: ending again sends nothing.
        encoder.finish(|t, p| packets.push((t, p.to_vec()))).unwrap();
        assert_eq!(packets.len(), 2);
        // The last packet decodes to the tone's 10 ms, then silence (the encoder's 6.5 ms
        // look-ahead shifts it; the first 5 ms are loud, the last 20 ms quiet).
        let mut decoder = opus::Decoder::new(16_000, opus::Channels::Mono).unwrap();
        let mut out = vec![0i16; 640];
        for (_, packet) in &packets {
            assert_eq!(decoder.decode(packet, &mut out, false).unwrap(), 640);
        }
        let mean_square = |s: &[i16]| s.iter().map(|&x| f64::from(x).powi(2)).sum::<f64>() / s.len() as f64;
        assert!(
            mean_square(&out[..80]) > 0.25 * 32e6,
            "{}",
            mean_square(&out[..80])
        );
        assert!(
            mean_square(&out[320..]) < 0.01 * 32e6,
            "{}",
            mean_square(&out[320..])
        );
    }

    #[test]
    fn a_second_of_voice_costs_a_viewer_under_4_kb() {
        let mut encoder = OpusStreamEncoder::new(16_000).unwrap();
        let mut bytes = 0;
        for i in 0..50 {
            encoder
                .push(i as f64 * 0.02, &tone(i * 320, 320), |_, p| bytes += p.len() + 26)
                .unwrap();
        }
        // Packets and their FWA1 framing (21 header + 5 section + 2 length bytes, minus the
        // packet's own 2 counted above): the budget is 4 kB/s per viewer.
        eprintln!("Opus for one viewer: {bytes} bytes a second with FWA1 framing");
        assert!(bytes < 4_000, "{bytes} bytes a second");
    }
}
