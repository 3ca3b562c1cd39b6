//! What a producer's audio must respect before it is relayed: one codec and rate per
//! stream, chunks in order on the stream's timeline (no overlap), no chunk longer than
//! [`MAX_CHUNK_S`], audio no further than [`MAX_LEAD_S`] ahead of real time since the
//! stream's first chunk (so a producer cannot push more than the voice's own rate), and no
//! further than [`MAX_SKEW_S`] from the newest parameter frame's `t` (a clock mix-up, not
//! speech). Chunks that break a rule are refused with a code and a field; the stream runs
//! on.

use std::time::Instant;

use super::ingest::Refusal;
use facewire_proto::audio_chunk::AudioChunk;
use facewire_proto::codes::ErrorCode;

/// Longest chunk, seconds (WebRTC sends 20 ms; 200 ms of 48 kHz PCM is 19 kB).
pub const MAX_CHUNK_S: f64 = 0.2;
/// How far audio may run ahead of real time, seconds: a producer's buffer of speech.
pub const MAX_LEAD_S: f64 = 2.0;
/// How far a chunk's `t` may lie from the newest parameter frame's, seconds.
pub const MAX_SKEW_S: f64 = 10.0;
/// Rounding slack when a chunk starts where the previous one ended, seconds.
const OVERLAP_SLACK_S: f64 = 1e-3;

pub struct AudioGate {
    /// The stream's codec and sample rate, from its first chunk.
    format: Option<(&'static str, u32)>,
    /// Where the previous chunk ended on the stream's timeline, seconds.
    end_t: Option<f64>,
    /// The first chunk's arrival and `t`.
    start: Option<(Instant, f64)>,
}

impl AudioGate {
    pub fn new() -> AudioGate {
        AudioGate {
            format: None,
            end_t: None,
            start: None,
        }
    }

    /// Lets `chunk` through, or says why not; `param_t` is the newest accepted parameter
    /// frame's `t`, if any.
    pub fn admit(&mut self, chunk: &AudioChunk, param_t: Option<f64>) -> Result<(), Refusal> {
        self.admit_at(chunk, param_t, Instant::now())
    }

    fn admit_at(&mut self, chunk: &AudioChunk, param_t: Option<f64>, now: Instant) -> Result<(), Refusal> {
        let bad = |field: &str, message: String| Refusal::new(ErrorCode::BadFrame, Some(field), message);
        let body = &chunk.body;
        let format = (body.codec(), body.sample_rate());
        if let Some(first) = self.format.filter(|&f| f != format) {
            return Err(bad(
                "sound",
                format!(
                    "this stream's audio is {} at {} Hz; a chunk of {} at {} Hz cannot join it",
                    first.0, first.1, format.0, format.1
                ),
            ));
        }
        let samples = body
            .samples()
            .map_err(|e| bad(e.field().unwrap_or("sound"), e.to_string()))?;
        let duration = f64::from(samples) / f64::from(format.1);
        if samples == 0 || duration > MAX_CHUNK_S {
            return Err(bad(
                body.codec(),
                format!(
                    "{samples} samples ({:.1} ms): a chunk holds 1 sample to {MAX_CHUNK_S} s",
                    duration * 1e3
                ),
            ));
        }
        let t = chunk.t_s;
        if !(0.0..=crate::stream::MAX_TIME_S).contains(&t) {
            return Err(bad(
                "t",
                format!("t {t} s: expected 0 to {} s", crate::stream::MAX_TIME_S),
            ));
        }
        if let Some(end) = self.end_t.filter(|&end| t < end - OVERLAP_SLACK_S) {
            return Err(Refusal::new(
                ErrorCode::OutOfOrder,
                Some("t"),
                format!("audio at t {t} s overlaps the previous chunk, which plays until {end} s"),
            ));
        }
        if let Some(param_t) = param_t.filter(|p| (t - p).abs() > MAX_SKEW_S) {
            return Err(bad(
                "t",
                format!("audio at t {t} s is more than {MAX_SKEW_S} s from the parameters' t {param_t} s"),
            ));
        }
        let (started, t0) = *self.start.get_or_insert((now, t));
        let ahead = (t + duration - t0) - now.duration_since(started).as_secs_f64();
        if ahead > MAX_LEAD_S {
            return Err(Refusal::new(
                ErrorCode::RateLimited,
                None,
                format!("audio runs {ahead:.2} s ahead of real time; at most {MAX_LEAD_S} s"),
            ));
        }
        self.format = Some(format);
        self.end_t = Some(t + duration);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use facewire_proto::audio_chunk::AudioBody;
    use std::time::Duration;

    fn pcm(t_s: f64, rate: u32, samples: usize) -> AudioChunk {
        AudioChunk {
            t_s,
            server_receive_us: 0,
            body: AudioBody::Pcm {
                sample_rate: rate,
                samples: vec![0; samples],
            },
            ignored: Vec::new(),
        }
    }

    fn refused(result: Result<(), Refusal>) -> (ErrorCode, Option<String>) {
        let refusal = result.expect_err("refused");
        (refusal.code, refusal.field)
    }

    #[test]
    fn chunks_follow_each_other_on_one_format_at_the_voice_s_own_rate() {
        let mut gate = AudioGate::new();
        let start = Instant::now();
        // 20 ms chunks at 16 kHz, back to back; a gap is silence and allowed.
        for (i, t) in [0.0, 0.02, 0.04, 0.5].into_iter().enumerate() {
            let at = start + Duration::from_millis(20 * i as u64);
            assert!(gate.admit_at(&pcm(t, 16_000, 320), Some(t), at).is_ok(), "{t}");
        }
        let at = start + Duration::from_millis(100);
        // Overlapping the previous chunk (0.5 to 0.52 s).
        assert_eq!(
            refused(gate.admit_at(&pcm(0.51, 16_000, 320), None, at)),
            (ErrorCode::OutOfOrder, Some("t".into()))
        );
        // Another rate, a chunk too long, empty, far from the parameters.
        assert_eq!(
            refused(gate.admit_at(&pcm(0.6, 48_000, 960), None, at)),
            (ErrorCode::BadFrame, Some("sound".into()))
        );
        assert_eq!(
            refused(gate.admit_at(&pcm(0.6, 16_000, 3_201), None, at)),
            (ErrorCode::BadFrame, Some("pcm".into()))
        );
        assert_eq!(
            refused(gate.admit_at(&pcm(0.6, 16_000, 0), None, at)),
            (ErrorCode::BadFrame, Some("pcm".into()))
        );
        assert_eq!(
            refused(gate.admit_at(&pcm(0.6, 16_000, 320), Some(20.0), at)),
            (ErrorCode::BadFrame, Some("t".into()))
        );
        // 2 s of audio in 0.1 s of real time: the lead is full.
        assert_eq!(
            refused(gate.admit_at(&pcm(2.2, 16_000, 320), None, at)),
            (ErrorCode::RateLimited, None)
        );
        // ... and fills again as time passes.
        let later = start + Duration::from_millis(400);
        assert!(gate.admit_at(&pcm(2.2, 16_000, 320), None, later).is_ok());
    }
}
