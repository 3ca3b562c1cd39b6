//! A replay's voice: the recording's voice played from the frame the replay plays, at the
//! replay's speed with its pitch kept ([`crate::voice::Voice::at_speed`]), cut into chunks
//! (20 ms of PCM, or 40 ms Opus packets as the live streams' encoder makes them) each sent
//! when it is due, on the same clock as the frames, so a viewer hears each frame's sound
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
use crate::voice::{Voice, CHUNK_S, STRETCH_SPEEDS};
use facewire_proto::audio_chunk::{AudioBody, AudioChunk};

/// The most recording time one run stretches at once, seconds: longer runs go on with the
/// next when this one is played (a seam every this long), so a long recording slowed down
/// is never stretched whole. Stretching is not cheap: a run of 30 s at 0.25x took 0.62 s
/// at 16 kHz and 5.5 s at 48 kHz here (release build), which is why it runs off the
/// runtime's workers ([`off_the_workers`]).
const RUN_S: f64 = 30.0;

/// Runs `work` where it holds up no other task: on a multi-threaded runtime the worker
/// hands its other tasks on first (`block_in_place`); elsewhere (a single-threaded
/// runtime, no runtime) it simply runs.
fn off_the_workers<T>(work: impl FnOnce() -> T) -> T {
    use tokio::runtime::{Handle, RuntimeFlavor};
    match Handle::try_current().map(|h| h.runtime_flavor()) {
        Ok(RuntimeFlavor::MultiThread) => tokio::task::block_in_place(work),
        _ => work(),
    }
}

/// Where a run of chunks stands.
struct Run {
    /// The stretched voice; its first sample plays at `started`.
    voice: Voice,
    /// The recording time of its first sample, seconds.
    from_t_s: f64,
    /// Where the recording time goes on once it is played (the next run, if playing).
    to_t_s: f64,
    speed: f64,
    started: Instant,
    /// The next chunk to send.
    next: usize,
    /// A chunk's length, seconds of the stretched voice, and its samples.
    chunk_s: f64,
    samples_per_chunk: usize,
    encoder: Option<OpusStreamEncoder>,
}

/// The voice of one replay viewer.
pub struct ReplayVoice {
    recording: Arc<Recording>,
    /// `pcm` or `opus`, as the viewer asked.
    codec: &'static str,
    run: Option<Run>,
    /// The end of what is being played (the last frame's time, or the loop's end).
    until_t_s: f64,
}

impl ReplayVoice {
    /// The voice of `recording` in `codec`, or `None` when it has none.
    pub fn new(recording: Arc<Recording>, codec: &'static str) -> Option<ReplayVoice> {
        recording.voice.as_ref()?;
        Some(ReplayVoice {
            recording,
            codec,
            run: None,
            until_t_s: 0.0,
        })
    }

    /// Plays from recording time `from_t_s` to `until_t_s` at `speed`, the first sample
    /// heard at `at` (the instant the frame of `from_t_s` is shown). Silent at speeds the
    /// voice cannot be played at (under a quarter of its pace).
    pub fn play(&mut self, from_t_s: f64, until_t_s: f64, speed: f64, at: Instant) {
        self.until_t_s = until_t_s;
        self.run = None;
        if !(STRETCH_SPEEDS[0]..=STRETCH_SPEEDS[1]).contains(&speed) || until_t_s <= from_t_s {
            return;
        }
        let recorded = self.recording.voice.as_ref().expect("a replay's voice has one");
        let to_t_s = until_t_s.min(from_t_s + RUN_S);
        let voice = match off_the_workers(|| recorded.between(from_t_s, to_t_s).at_speed(speed)) {
            Ok(voice) => voice,
            Err(e) => {
                tracing::warn!(error = %e, "replay voice not played");
                return;
            }
        };
        let chunk_s = if self.codec == AudioBody::OPUS {
            OPUS_PACKET_S
        } else {
            CHUNK_S
        };
        let samples_per_chunk = (chunk_s * f64::from(voice.sample_rate)).round() as usize;
        self.run = Some(Run {
            voice,
            from_t_s,
            to_t_s,
            speed,
            started: at,
            next: 0,
            chunk_s,
            samples_per_chunk,
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

    /// The next chunk, as the viewer's message, and the run moved on (to the next run at
    /// its end). `None` when there is nothing to send now, or Opus fails (logged; the voice
    /// stops).
    pub fn next_message(&mut self) -> Option<Message> {
        let run = self.run.as_mut()?;
        let first = run.next * run.samples_per_chunk;
        if first >= run.voice.samples.len() {
            // This run is played: the next goes on from where it ended, when it was due.
            let at = run.started + Duration::from_secs_f64(run.next as f64 * run.chunk_s);
            let (from, speed) = (run.to_t_s, run.speed);
            self.play(from, self.until_t_s, speed, at);
            return None;
        }
        let last = (first + run.samples_per_chunk).min(run.voice.samples.len());
        let mut samples = run.voice.samples[first..last].to_vec();
        let t_s = run.from_t_s + run.next as f64 * run.chunk_s * run.speed;
        run.next += 1;
        let body = if self.codec == AudioBody::OPUS {
            samples.resize(run.samples_per_chunk, 0); // Opus takes whole frames
            match opus_packet(run, t_s, &samples) {
                Ok(packet) => AudioBody::Opus { packet },
                Err(e) => {
                    tracing::warn!(error = %e, "replay voice stopped");
                    self.run = None;
                    return None;
                }
            }
        } else {
            AudioBody::Pcm {
                sample_rate: run.voice.sample_rate,
                samples,
            }
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

/// One frame of `run`'s voice as an Opus packet, from the run's own encoder.
fn opus_packet(run: &mut Run, t_s: f64, samples: &[i16]) -> Result<Vec<u8>, OpusEncodeError> {
    let encoder = match run.encoder.take() {
        Some(encoder) => encoder,
        None => OpusStreamEncoder::new(run.voice.sample_rate)?,
    };
    let encoder = run.encoder.insert(encoder);
    let mut packet = Vec::new();
    encoder.push(t_s, samples, |_, bytes| packet = bytes.to_vec())?;
    Ok(packet)
}
