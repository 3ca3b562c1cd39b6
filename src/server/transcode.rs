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

/// One producer connection's codecs, made at the first chunk that needs them.
#[derive(Default)]
pub struct Transcoder {
    encoder: Option<OpusStreamEncoder>,
    decoder: Option<OpusStreamDecoder>,
    /// The newest chunk's receipt, server clock (us since the epoch).
    last_receive_us: u64,
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
        self.last_receive_us = chunk.server_receive_us;
        let publish = |t_s: f64, body: AudioBody| {
            let out = AudioChunk {
                t_s,
                server_receive_us: chunk.server_receive_us,
                body,
                ignored: Vec::new(),
            };
            permit.publish_audio(RelayedAudio::of(&out));
        };
        let failed = match &chunk.body {
            AudioBody::Pcm { sample_rate, samples } => {
                let encoder = match self.encoder.take() {
                    Some(encoder) => Ok(encoder),
                    None => OpusStreamEncoder::new(*sample_rate),
                };
                match encoder.and_then(|mut encoder| {
                    encoder.push(chunk.t_s, samples, |t_s, packet| {
                        publish(
                            t_s,
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
    /// and published, stamped with the receipt of the chunk that brought it.
    pub fn finish(&mut self, permit: &ProducerPermit, telemetry: &Telemetry) {
        let Some(mut encoder) = self.encoder.take() else {
            return;
        };
        let server_receive_us = self.last_receive_us;
        let ended = encoder.finish(|t_s, packet| {
            permit.publish_audio(RelayedAudio::of(&AudioChunk {
                t_s,
                server_receive_us,
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
