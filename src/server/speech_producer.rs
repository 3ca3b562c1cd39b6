//! An audio-only producer's face (`derive=visemes`): each accepted chunk (PCM, or Opus
//! decoded once here) goes through the core's [`SpeechStream`], and the frames it makes
//! are published as a parameter producer's would be, so every viewer, algorithm, node and
//! recording sees an ordinary stream. Each frame is stamped with the receipt of the audio
//! it shows (not of the chunk that completed its look-ahead), so a viewer frame's
//! `server_send_us - server_receive_us` is the whole delay the server adds: the model's
//! look-ahead, the chunking and the deform.

use std::collections::VecDeque;
use std::sync::Arc;

use super::ingest::Refusal;
use super::opus_decode::OpusStreamDecoder;
use super::stream::ProducerPermit;
use super::telemetry::Telemetry;
use crate::speech::{SpeechEvent, SpeechStream, VisemeModel};
use crate::stream::visemes::VISEMES;
use crate::stream::Frame;
use facewire_proto::audio_chunk::{AudioBody, AudioChunk, OPUS_RATE};
use facewire_proto::codes::ErrorCode;
use facewire_proto::messages::{DerivedViseme, ServerMessage};

/// Chunks whose receipt is remembered: more than the look-ahead holds even in Opus's
/// shortest 2.5 ms packets (64 x 2.5 ms = 160 ms).
const HEARD: usize = 64;

pub struct SpeechProducer {
    speech: SpeechStream,
    decoder: Option<OpusStreamDecoder>,
    out: Derived,
}

/// Where derived frames go, and what stamps them.
struct Derived {
    /// The recent chunks' `t` and receipt, µs since the Unix epoch.
    heard: VecDeque<(f64, u64)>,
    /// Whether the producer asked for its derived frames (`derived=1`).
    report: bool,
    /// Derived frames not yet sent to the producer.
    reports: Vec<ServerMessage>,
    /// The probability of the viseme last decided.
    confidence: f32,
}

impl SpeechProducer {
    pub fn new(model: Arc<VisemeModel>, fps: f64, report: bool) -> SpeechProducer {
        SpeechProducer {
            speech: SpeechStream::new(model, fps),
            decoder: None,
            out: Derived {
                heard: VecDeque::with_capacity(HEARD),
                report,
                reports: Vec::new(),
                confidence: 0.0,
            },
        }
    }

    /// Derives the frames `chunk` (accepted, stamped with its receipt) completes and
    /// publishes them.
    pub fn publish(
        &mut self,
        chunk: &AudioChunk,
        permit: &ProducerPermit,
        telemetry: &Telemetry,
    ) -> Result<(), Refusal> {
        let heard = &mut self.out.heard;
        if heard.len() == HEARD {
            heard.pop_front();
        }
        heard.push_back((chunk.t_s, chunk.server_receive_us));
        let bad = |e: String| Refusal::new(ErrorCode::BadFrame, Some("sound"), e);
        let (rate, samples): (u32, &[i16]) = match &chunk.body {
            AudioBody::Pcm { sample_rate, samples } => (*sample_rate, samples),
            AudioBody::Opus { packet } => {
                let decoder = match &mut self.decoder {
                    Some(decoder) => decoder,
                    None => self
                        .decoder
                        .insert(OpusStreamDecoder::new().map_err(|e| bad(e.to_string()))?),
                };
                (OPUS_RATE, decoder.decode(packet).map_err(|e| bad(e.to_string()))?)
            }
        };
        let out = &mut self.out;
        self.speech
            .push(chunk.t_s, rate, samples, |event| {
                out.take(event, permit, telemetry)
            })
            .map_err(|e| bad(e.to_string()))
    }

    /// The voice has ended: publishes the frames still waiting for their look-ahead.
    pub fn finish(&mut self, permit: &ProducerPermit, telemetry: &Telemetry) {
        let out = &mut self.out;
        self.speech.finish(|event| out.take(event, permit, telemetry));
    }

    /// The derived frames the producer asked for and has not been sent yet.
    pub fn reports(&mut self) -> std::vec::Drain<'_, ServerMessage> {
        self.out.reports.drain(..)
    }
}

impl Derived {
    fn take(&mut self, event: SpeechEvent, permit: &ProducerPermit, telemetry: &Telemetry) {
        match event {
            SpeechEvent::Decided(d) => self.confidence = d.probability[usize::from(d.viseme)],
            SpeechEvent::Frame(frame) => {
                if self.report {
                    self.reports.push(derived(&frame, self.confidence));
                }
                let received_us = self
                    .heard
                    .iter()
                    .rev()
                    .find(|&&(t_s, _)| t_s <= frame.time_s)
                    .or(self.heard.front())
                    .map_or(0, |&(_, us)| us);
                permit.publish(frame, received_us);
                telemetry.frames_in.inc();
            }
        }
    }
}

/// `frame` as the producer is told of it.
fn derived(frame: &Frame, confidence: f32) -> ServerMessage {
    let number = frame.viseme.map_or(0, |v| v.select1);
    let oculus = usize::try_from(number)
        .ok()
        .and_then(|n| VISEMES.get(n))
        .map_or("sil", |v| v.oculus);
    ServerMessage::Derived {
        seq: frame.seq,
        t: frame.time_s,
        viseme: DerivedViseme {
            oculus: oculus.to_string(),
        },
        confidence,
    }
}
