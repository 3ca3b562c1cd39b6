//! A producer's voice in the other codec, for the viewers that ask for it: PCM chunks are
//! encoded to Opus and Opus packets decoded to PCM, once per stream (in the producer's
//! task), and published beside the chunks as sent. A codec that fails is logged, counted
//! (`facewire_frames_rejected_total{code="transcode"}`) and made anew at the next chunk;
//! the chunks as sent go on. When the voice ends, its last partial Opus frame is sent.
//! Nothing is transcoded while nobody would hear it: no viewer of the other codec on this
//! node and no cluster relay (other nodes' viewers may ask).

use super::frames::RelayedAudio;
use super::opus_decode::OpusStreamDecoder;
use super::opus_encode::OpusStreamEncoder;
use super::stream::ProducerPermit;
use super::telemetry::Telemetry;
use facewire_proto::audio_chunk::{AudioBody, AudioChunk, OPUS_RATE};
use std::collections::VecDeque;

/// One producer connection's codecs, made at the first chunk that needs them.
#[derive(Default)]
pub struct Transcoder {
    encoder: Option<OpusStreamEncoder>,
    decoder: Option<OpusStreamDecoder>,
    /// The receipts of the PCM chunks whose samples the encoder may still hold.
    receipts: Receipts,
}

/// `(t_s, server_receive_us)` of the latest PCM chunks, so that an Opus packet is stamped
/// with the receipt of the chunk that brought its first sample: a viewer's producer-to-ear
/// latency then counts from when the server had that sound, not from the chunk that
/// completed the packet (20 ms later for 40 ms packets of 20 ms chunks).
#[derive(Default)]
struct Receipts(VecDeque<(f64, u64)>);

impl Receipts {
    /// Chunks kept: far more than one packet holds, whatever the chunks' size.
    const KEPT: usize = 64;
    /// Times closer than this are one, seconds.
    const EPSILON_S: f64 = 1e-6;

    fn push(&mut self, t_s: f64, receive_us: u64) {
        if self.0.len() == Self::KEPT {
            self.0.pop_front();
        }
        self.0.push_back((t_s, receive_us));
    }

    /// The receipt of the chunk holding stream time `t_s`: the newest that starts by it.
    /// Older chunks are forgotten (packets come in time order); 0 when none is known.
    fn of(&mut self, t_s: f64) -> u64 {
        while self.0.len() > 1 && self.0[1].0 <= t_s + Self::EPSILON_S {
            self.0.pop_front();
        }
        self.0.front().map_or(0, |&(_, receive_us)| receive_us)
    }
}

impl Transcoder {
    /// Publishes `chunk` (accepted, stamped with its receipt) in the other codec.
    pub fn publish(&mut self, chunk: &AudioChunk, permit: &ProducerPermit, telemetry: &Telemetry) {
        let other = match chunk.body {
            AudioBody::Pcm { .. } => AudioBody::OPUS,
            AudioBody::Opus { .. } => AudioBody::PCM,
        };
        if !permit.is_heard_in(other) {
            // A listener who comes later gets a codec started afresh at its first chunk.
            *self = Transcoder::default();
            return;
        }
        let publish = |t_s: f64, server_receive_us: u64, body: AudioBody| {
            let out = AudioChunk {
                t_s,
                server_receive_us,
                body,
                ignored: Vec::new(),
            };
            permit.publish_audio(RelayedAudio::of(&out));
        };
        let failed = match &chunk.body {
            AudioBody::Pcm { sample_rate, samples } => {
                self.receipts.push(chunk.t_s, chunk.server_receive_us);
                let receipts = &mut self.receipts;
                let encoder = match self.encoder.take() {
                    Some(encoder) => Ok(encoder),
                    None => OpusStreamEncoder::new(*sample_rate),
                };
                match encoder.and_then(|mut encoder| {
                    encoder.push(chunk.t_s, samples, |t_s, packet| {
                        publish(
                            t_s,
                            receipts.of(t_s),
                            AudioBody::Opus {
                                packet: packet.to_vec(),
                            },
                        )
                    })?;
                    Ok(encoder)
                }) {
                    Ok(encoder) => {
                        self.encoder = Some(encoder);
                        None
                    }
                    Err(e) => Some(e.to_string()),
                }
            }
            AudioBody::Opus { packet } => {
                let decoder = match self.decoder.take() {
                    Some(decoder) => Ok(decoder),
                    None => OpusStreamDecoder::new(),
                };
                match decoder.and_then(|mut decoder| {
                    let samples = decoder.decode(packet)?.to_vec();
                    publish(
                        chunk.t_s,
                        chunk.server_receive_us,
                        AudioBody::Pcm {
                            sample_rate: OPUS_RATE,
                            samples,
                        },
                    );
                    Ok(decoder)
                }) {
                    Ok(decoder) => {
                        self.decoder = Some(decoder);
                        None
                    }
                    Err(e) => Some(e.to_string()),
                }
            }
        };
        if let Some(error) = failed {
            tracing::warn!(%error, "a chunk was not transcoded for this stream");
            telemetry.reject("transcode");
        }
    }

    /// Ends the voice: the PCM still waiting for a whole Opus frame is closed with silence
    /// and published, stamped with the receipt of the chunk that brought its first sample.
    pub fn finish(&mut self, permit: &ProducerPermit, telemetry: &Telemetry) {
        let Some(mut encoder) = self.encoder.take() else {
            return;
        };
        let receipts = &mut self.receipts;
        let ended = encoder.finish(|t_s, packet| {
            permit.publish_audio(RelayedAudio::of(&AudioChunk {
                t_s,
                server_receive_us: receipts.of(t_s),
                body: AudioBody::Opus {
                    packet: packet.to_vec(),
                },
                ignored: Vec::new(),
            }))
        });
        if let Err(error) = ended {
            tracing::warn!(%error, "the voice's last samples were not transcoded for this stream");
            telemetry.reject("transcode");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Receipts;

    #[test]
    fn a_packet_carries_the_receipt_of_the_chunk_that_brought_its_first_sample() {
        // 20 ms chunks, 40 ms packets: each packet starts with an even chunk.
        let mut receipts = Receipts::default();
        receipts.push(0.0, 100);
        receipts.push(0.02, 120);
        assert_eq!(receipts.of(0.0), 100);
        receipts.push(0.04, 141);
        receipts.push(0.06, 160);
        assert_eq!(receipts.of(0.04), 141);
        // 30 ms chunks: the packets from 0.04 and 0.08 s start inside the chunks from 0.03
        // and 0.06 s.
        let mut receipts = Receipts::default();
        for (i, receipt) in [10, 40, 70, 100, 130].into_iter().enumerate() {
            receipts.push(i as f64 * 0.03, receipt);
        }
        assert_eq!(receipts.of(0.04), 40);
        assert_eq!(receipts.of(0.08), 70);
        assert_eq!(receipts.of(0.12), 130);
        assert_eq!(Receipts::default().of(1.0), 0, "none known");
    }

    #[test]
    fn only_the_latest_chunks_are_kept() {
        let mut receipts = Receipts::default();
        for i in 0..1000 {
            receipts.push(f64::from(i) * 0.02, i as u64);
        }
        assert_eq!(receipts.0.len(), Receipts::KEPT);
        assert_eq!(receipts.of(0.0), 1000 - Receipts::KEPT as u64);
    }
}
