//! A replay's voice: the recording's voice played from the frame the replay plays, at the
//! replay's speed with its pitch kept, stretched chunk by chunk as it is sent
//! ([`crate::voice::Stretching`]: each chunk costs only its own samples' work, and a run
//! starts at once however long it is), in chunks (20 ms of PCM, or 40 ms Opus packets as
//! the live streams' encoder makes them) each sent when it is due, on the same clock as
//! the frames, so a viewer hears each frame's sound
//! when the frame is shown. Each chunk's `t` is the recording time of its first sample (it
//! covers its length times the speed of the recording): with the replay's
//! `speed` a viewer places it on its own clock. Any change of place or pace (play, seek,
//! a loop starting over, a new speed) starts a new run of chunks; a pause stops them.
//! Opus is encoded here, once for this one viewer.

use std::sync::Arc;
use std::time::Duration;

use axum::extract::ws::Message;
use tokio::time::Instant;

use super::now_us;
use super::opus_encode::{OpusEncodeError, OpusStreamEncoder, FRAME_S as OPUS_PACKET_S};
use super::recordings::Recording;
use crate::voice::{Stretching, CHUNK_S};
use facewire_proto::audio_chunk::{AudioBody, AudioChunk};

/// Where a run of chunks stands.
struct Run {
    /// The voice from where the run started, being stretched; its first sample plays at
    /// `started`.
    stretching: Stretching,
    sample_rate: u32,
    /// The recording time of its first sample, seconds.
    from_t_s: f64,
    speed: f64,
    started: Instant,
    /// The next chunk to send.
    next: usize,
    /// A chunk's length, seconds of the stretched voice.
    chunk_s: f64,
    /// The next chunk's samples.
    samples: Vec<i16>,
    encoder: Option<OpusStreamEncoder>,
}

/// The voice of one replay viewer.
pub struct ReplayVoice {
    recording: Arc<Recording>,
    /// `pcm` or `opus`, as the viewer asked.
    codec: &'static str,
    run: Option<Run>,
}

impl ReplayVoice {
    /// The voice of `recording` in `codec`, or `None` when it has none.
    pub fn new(recording: Arc<Recording>, codec: &'static str) -> Option<ReplayVoice> {
        recording.voice.as_ref()?;
        Some(ReplayVoice {
            recording,
            codec,
            run: None,
        })
    }

    /// Plays from recording time `from_t_s` to `until_t_s` at `speed`, the first sample
    /// heard at `at` (the instant the frame of `from_t_s` is shown). Silent at speeds the
    /// voice cannot be played at (under a quarter of its pace).
    pub fn play(&mut self, from_t_s: f64, until_t_s: f64, speed: f64, at: Instant) {
        self.run = None;
        let recorded = self.recording.voice.as_ref().expect("a replay's voice has one");
        let stretching = match recorded.stretching(from_t_s, until_t_s, speed) {
            Ok(stretching) => stretching,
            Err(e) => {
                tracing::debug!(error = %e, "replay voice silent");
                return;
            }
        };
        let sample_rate = recorded.voice.sample_rate;
        let chunk_s = if self.codec == AudioBody::OPUS {
            OPUS_PACKET_S
        } else {
            CHUNK_S
        };
        let samples_per_chunk = (chunk_s * f64::from(sample_rate)).round() as usize;
        self.run = Some(Run {
            stretching,
            sample_rate,
            from_t_s,
            speed,
            started: at,
            next: 0,
            chunk_s,
            samples: vec![0; samples_per_chunk],
            encoder: None,
        });
    }

    /// Stops the voice (a pause).
    pub fn stop(&mut self) {
        self.run = None;
    }

    /// When the next chunk is due, or `None` when none is.
    pub fn due(&self) -> Option<Instant> {
        let run = self.run.as_ref()?;
        Some(run.started + Duration::from_secs_f64(run.next as f64 * run.chunk_s))
    }

    /// The next chunk, as the viewer's message. `None` when the voice is played to its end
    /// (the run stops), or Opus fails (logged; the voice stops).
    pub fn next_message(&mut self) -> Option<Message> {
        let run = self.run.as_mut()?;
        let source = &self.recording.voice.as_ref()?.voice.samples;
        let given = run.stretching.fill(source, &mut run.samples);
        if given == 0 {
            self.run = None;
            return None;
        }
        let t_s = run.from_t_s + run.next as f64 * run.chunk_s * run.speed;
        run.next += 1;
        let (t_s, body) = if self.codec == AudioBody::OPUS {
            // Opus takes whole frames: the last is padded with silence.
            match opus_packet(run, t_s) {
                Ok((t_s, packet)) => (t_s, AudioBody::Opus { packet }),
                Err(e) => {
                    tracing::warn!(error = %e, "replay voice stopped");
                    self.run = None;
                    return None;
                }
            }
        } else {
            let body = AudioBody::Pcm {
                sample_rate: run.sample_rate,
                samples: run.samples[..given].to_vec(),
            };
            (t_s, body)
        };
        let chunk = AudioChunk {
            t_s,
            server_receive_us: now_us(),
            body,
            ignored: Vec::new(),
        };
        Some(Message::Binary(chunk.encode().into()))
    }
}

/// The chunk in `run.samples`, whose first sample is at recording time `t_s`, as an Opus
/// packet from the run's own encoder, with the recording time of its first decoded sample.
fn opus_packet(run: &mut Run, t_s: f64) -> Result<(f64, Vec<u8>), OpusEncodeError> {
    let encoder = match run.encoder.take() {
        Some(encoder) => encoder,
        None => OpusStreamEncoder::new(run.sample_rate)?,
    };
    let encoder = run.encoder.insert(encoder);
    let mut packet = Vec::new();
    encoder.push(t_s, &run.samples, |_, bytes| packet = bytes.to_vec())?;
    // Its samples decode the look-ahead late, on the voice as played: that much earlier on
    // the recording's timeline, at the replay's speed.
    Ok((t_s - encoder.lookahead_s() * run.speed, packet))
}
