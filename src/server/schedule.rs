//! What a producer inside the server sends (the demo's loop, an HTTP batch): parameter
//! frames and audio chunks merged into one schedule on the stream's timeline, and each
//! item published as a producer socket would publish it, with its receipt stamped when it
//! goes out.

use super::frames::RelayedAudio;
use super::now_us;
use super::stream::ProducerPermit;
use super::telemetry::Telemetry;
use super::transcode::Transcoder;
use crate::stream::Frame;
use facewire_proto::audio_chunk::AudioChunk;

/// One thing to send at its `t`.
#[derive(Debug, Clone)]
pub enum Scheduled {
    Frame(Frame),
    Audio(AudioChunk),
}

impl Scheduled {
    /// Its time on the stream's timeline, s.
    pub fn t_s(&self) -> f64 {
        match self {
            Scheduled::Frame(frame) => frame.time_s,
            Scheduled::Audio(chunk) => chunk.t_s,
        }
    }

    /// Moves it `by_s` seconds later on the timeline.
    pub fn shift(&mut self, by_s: f64) {
        match self {
            Scheduled::Frame(frame) => frame.time_s += by_s,
            Scheduled::Audio(chunk) => chunk.t_s += by_s,
        }
    }
}

/// `frames` and `audio` (each in time order) as one schedule in time order; at the same
/// `t` a frame goes before a chunk.
pub fn merge(frames: Vec<Frame>, audio: Vec<AudioChunk>) -> Vec<Scheduled> {
    let mut merged = Vec::with_capacity(frames.len() + audio.len());
    let (mut frames, mut audio) = (frames.into_iter().peekable(), audio.into_iter().peekable());
    loop {
        let frame_first = match (frames.peek(), audio.peek()) {
            (Some(frame), Some(chunk)) => frame.time_s <= chunk.t_s,
            (Some(_), None) => true,
            (None, Some(_)) => false,
            (None, None) => return merged,
        };
        merged.push(if frame_first {
            Scheduled::Frame(frames.next().expect("peeked"))
        } else {
            Scheduled::Audio(audio.next().expect("peeked"))
        });
    }
}

/// A server-side producer of one stream: its permit and its voice's other codec.
pub struct ScheduledProducer {
    pub permit: ProducerPermit,
    transcoder: Transcoder,
}

impl ScheduledProducer {
    pub fn new(permit: ProducerPermit) -> ScheduledProducer {
        ScheduledProducer {
            permit,
            transcoder: Transcoder::default(),
        }
    }

    /// Publishes `item` now: a frame to the stream's pipelines, a chunk (stamped with the
    /// time it goes out) to its listeners in both codecs.
    pub fn publish(&mut self, item: Scheduled, telemetry: &Telemetry) {
        match item {
            Scheduled::Frame(frame) => {
                self.permit.publish(frame, now_us());
                telemetry.frames_in.inc();
            }
            Scheduled::Audio(mut chunk) => {
                chunk.server_receive_us = now_us();
                self.permit.publish_audio(RelayedAudio::of(&chunk));
                self.permit.record_audio(&chunk);
                telemetry.audio_in.inc();
                self.transcoder.publish(&chunk, &self.permit, telemetry);
            }
        }
    }

    /// Ends the voice: its last samples are heard in the other codec too.
    pub fn finish(&mut self, telemetry: &Telemetry) {
        self.transcoder.finish(&self.permit, telemetry);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use facewire_proto::audio_chunk::AudioBody;

    fn chunk(t_s: f64) -> AudioChunk {
        AudioChunk {
            t_s,
            server_receive_us: 0,
            body: AudioBody::Pcm {
                sample_rate: 16_000,
                samples: vec![0; 320],
            },
            ignored: Vec::new(),
        }
    }

    #[test]
    fn frames_and_chunks_merge_in_time_order_frames_first_at_a_tie() {
        let frames = vec![Frame::at(0, 0.0), Frame::at(1, 0.04), Frame::at(2, 0.1)];
        let audio = vec![chunk(0.0), chunk(0.02), chunk(0.04), chunk(0.06)];
        let order: Vec<(char, f64)> = merge(frames, audio)
            .iter()
            .map(|item| match item {
                Scheduled::Frame(_) => ('f', item.t_s()),
                Scheduled::Audio(_) => ('a', item.t_s()),
            })
            .collect();
        assert_eq!(
            order,
            [
                ('f', 0.0),
                ('a', 0.0),
                ('a', 0.02),
                ('f', 0.04),
                ('a', 0.04),
                ('a', 0.06),
                ('f', 0.1)
            ]
        );
    }

    #[test]
    fn a_shift_moves_frames_and_chunks_alike() {
        let mut items = merge(vec![Frame::at(0, 1.0)], vec![chunk(1.5)]);
        for item in &mut items {
            item.shift(16.2);
        }
        assert_eq!(items.iter().map(Scheduled::t_s).collect::<Vec<_>>(), [17.2, 17.7]);
    }
}
