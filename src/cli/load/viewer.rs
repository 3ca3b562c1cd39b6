//! One load viewer: a WebSocket reading a stream's frames until the stream ends or the run
//! is over, counting what a person watching would notice: latency from the producer,
//! skipped frames, stalls and frames that arrive older than one already shown; and, when it
//! asked for the voice, what a person listening would notice: chunks missing, gaps, chunks
//! out of order, and the producer-to-viewer latency of each chunk.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use futures_util::StreamExt;
use tokio::time::Instant;
use tokio_tungstenite::tungstenite::protocol::WebSocketConfig;
use tokio_tungstenite::tungstenite::Message;

use super::latency::Latencies;
use super::send_times::SendTimes;
use crate::voice::CHUNK_S;
use facewire_proto::audio_chunk::{opus_packet_samples, AUDIO_MAGIC, OPUS_RATE};
use facewire_proto::messages::ServerMessage;
use facewire_proto::viewer_frame::decode_header;

/// Most stall gaps one viewer keeps for [`super::pauses`]; later stalls are counted but
/// not set against the machine's pauses.
pub const MAX_STALL_WINDOWS: usize = 64;

/// What one viewer saw.
#[derive(Debug, Default)]
pub struct ViewerOutcome {
    pub algorithm: Option<String>,
    pub frames: u64,
    pub bytes: u64,
    /// Frames the stream had that this viewer never got (sequence gaps).
    pub skipped: u64,
    /// Frames older than one already received.
    pub regressions: u64,
    /// Gaps of more than `stall_after` between two frames.
    pub stalls: u64,
    /// Those of `stalls` where the producer's own sends were as far apart: the generator
    /// paused, not the server.
    pub producer_stalls: u64,
    /// Those of `stalls` where the server published the two frames as far apart (the
    /// frames' `server_send_us`): its pipeline was late (deform, encode, or a task waiting
    /// for a core). The others were published in time and delivered late: the fan-out to
    /// the sockets, the kernel, or this generator reading them.
    pub publish_stalls: u64,
    /// Stalls by the second of the run they began in (whole seconds since the producers
    /// started): a burst shows as one second with many.
    pub stall_seconds: BTreeMap<u64, u64>,
    /// The first [`MAX_STALL_WINDOWS`] stalls' gaps, µs since the producers started (to
    /// set against the machine's pauses).
    pub stall_windows: Vec<(u64, u64)>,
    pub latencies: Latencies,
    pub audio: AudioOutcome,
    /// The refusal or failure that ended it early, if any.
    pub failure: Option<String>,
}

/// What one viewer heard.
#[derive(Debug, Default)]
pub struct AudioOutcome {
    pub chunks: u64,
    /// Seconds of sound in them.
    pub seconds: f64,
    pub bytes: u64,
    /// Chunks at or before one already heard (must be 0).
    pub regressions: u64,
    /// Gaps of more than `stall_after` between two chunks' arrivals.
    pub gaps: u64,
    pub latencies: Latencies,
    last: Option<(u64, Instant)>,
}

impl AudioOutcome {
    /// Counts an `FWA1` message of `length` bytes for `seconds` of sound from `t_s`,
    /// received now.
    fn record(&mut self, t_s: f64, seconds: f64, length: usize, plan: &ViewerPlan) {
        let now = Instant::now();
        let index = (t_s / CHUNK_S).round().max(0.0) as u64;
        self.chunks += 1;
        self.seconds += seconds;
        self.bytes += length as u64;
        if let Some(age) = plan.audio_times.as_ref().and_then(|t| t.age_ms(index)) {
            self.latencies.record(age);
        }
        match self.last {
            Some((previous, _)) if index <= previous => {
                self.regressions += 1;
                return;
            }
            Some((_, at)) if now - at > plan.stall_after => self.gaps += 1,
            _ => {}
        }
        self.last = Some((index, now));
    }
}

impl ViewerOutcome {
    /// Counts `frame`, received now; `last` is the newest frame so far and when it came.
    fn record(
        &mut self,
        frame: ReceivedFrame,
        last: &mut Option<(ReceivedFrame, Instant)>,
        plan: &ViewerPlan,
    ) {
        let ReceivedFrame { seq, length, .. } = frame;
        let now = Instant::now();
        self.frames += 1;
        self.bytes += length as u64;
        plan.received.fetch_add(1, Ordering::Relaxed);
        if let Some(age) = plan.times.age_ms(seq) {
            self.latencies.record(age);
        }
        match *last {
            Some((previous, _)) if seq <= previous.seq => self.regressions += 1,
            Some((previous, at)) => {
                self.skipped += seq - previous.seq - 1;
                if now - at > plan.stall_after {
                    self.stalls += 1;
                    let stall_us = plan.stall_after.as_micros() as u64;
                    let producer_paused = plan
                        .times
                        .send_gap_us(previous.seq, seq)
                        .is_some_and(|gap| gap > stall_us);
                    self.producer_stalls += u64::from(producer_paused);
                    let published_late = previous
                        .published_us
                        .zip(frame.published_us)
                        .is_some_and(|(before, after)| after.saturating_sub(before) > stall_us);
                    self.publish_stalls += u64::from(published_late);
                    let since = |t: Instant| t.saturating_duration_since(plan.start);
                    *self.stall_seconds.entry(since(at).as_secs()).or_default() += 1;
                    if self.stall_windows.len() < MAX_STALL_WINDOWS {
                        let us = |t: Instant| since(t).as_micros() as u64;
                        self.stall_windows.push((us(at), us(now)));
                    }
                }
            }
            None => {}
        }
        if last.is_none_or(|(previous, _)| seq > previous.seq) {
            *last = Some((frame, now));
        }
    }
}

/// What the generator reads of a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ReceivedFrame {
    seq: u64,
    length: usize,
    /// When the server published it (µs, Unix epoch); the JSON baseline does not say.
    published_us: Option<u64>,
}

pub struct ViewerPlan {
    pub times: Arc<SendTimes>,
    /// When the stream's producer sent each audio chunk, when the viewer asked for audio.
    pub audio_times: Option<Arc<SendTimes>>,
    /// Frames received by every viewer, for the progress line.
    pub received: Arc<AtomicU64>,
    pub stall_after: Duration,
    /// When the producers started: stalls are timed from here.
    pub start: Instant,
    /// When to stop if the stream has not ended.
    pub deadline: Instant,
}

/// Connects to viewer `url` and waits for the snapshot; the socket and the algorithm it
/// runs, or why it failed.
pub async fn connect(url: &str) -> Result<(Socket, String), String> {
    let (mut socket, _) = tokio_tungstenite::connect_async_with_config(url, Some(socket_config()), false)
        .await
        .map_err(|e| format!("cannot connect: {e}"))?;
    match tokio::time::timeout(Duration::from_secs(10), socket.next()).await {
        Ok(Some(Ok(Message::Text(text)))) => match serde_json::from_str::<ServerMessage>(text.as_str()) {
            Ok(ServerMessage::Snapshot(snapshot)) => Ok((socket, snapshot.algorithm)),
            Ok(ServerMessage::Error { code, message, .. }) => Err(format!("{code}: {message}")),
            other => Err(format!("expected a snapshot, got {other:?}")),
        },
        other => Err(format!("expected a snapshot, got {other:?}")),
    }
}

/// The `seq` of a JSON baseline frame (`{"type":"frame","seq":N,...}`), read without
/// parsing the positions.
fn json_frame_seq(text: &str) -> Option<u64> {
    let rest = text.strip_prefix(r#"{"type":"frame","seq":"#)?;
    let digits = rest.find(|c: char| !c.is_ascii_digit())?;
    rest[..digits].parse().ok()
}

/// An `FWA1` chunk's `t_s` and length in seconds, read from its header and first section
/// without copying the sound (proto/PROTOCOL.md "Audio").
fn chunk_time_and_length(bytes: &[u8]) -> Option<(f64, f64)> {
    let u32_at = |at: usize| Some(u32::from_le_bytes(bytes.get(at..at + 4)?.try_into().ok()?));
    let t_s = f64::from_le_bytes(bytes.get(4..12)?.try_into().ok()?);
    let (kind, body) = (*bytes.get(21)?, 26);
    let seconds = match kind {
        1 => f64::from(u32_at(body + 4)?) / f64::from(u32_at(body)?.max(1)),
        2 => {
            let packet = bytes.get(body + 2..)?;
            f64::from(opus_packet_samples(packet, 0).ok()?) / f64::from(OPUS_RATE)
        }
        _ => return None,
    };
    Some((t_s, seconds))
}

/// A read buffer the size of a few frames: the WebSocket layer zeroes the whole buffer on
/// every read, and its 128 KiB default made the generator's thousand viewers cost more CPU
/// than the server they measure.
fn socket_config() -> WebSocketConfig {
    WebSocketConfig::default().read_buffer_size(16 << 10)
}

pub type Socket =
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

/// Reads frames until the stream ends, the socket closes or the deadline passes.
pub async fn watch(plan: ViewerPlan, mut socket: Socket, algorithm: String) -> ViewerOutcome {
    let mut outcome = ViewerOutcome {
        algorithm: Some(algorithm),
        ..ViewerOutcome::default()
    };
    let mut last: Option<(ReceivedFrame, Instant)> = None;
    loop {
        let message = match tokio::time::timeout_at(plan.deadline, socket.next()).await {
            Err(_) | Ok(None) => break,
            Ok(Some(Err(e))) => {
                outcome.failure = Some(format!("connection failed: {e}"));
                break;
            }
            Ok(Some(Ok(message))) => message,
        };
        // Only the sequence number: the generator measures the server, not its own decoding.
        let frame = match message {
            Message::Binary(bytes) if bytes.starts_with(&AUDIO_MAGIC) => {
                match chunk_time_and_length(&bytes) {
                    Some((t_s, seconds)) => outcome.audio.record(t_s, seconds, bytes.len(), &plan),
                    None => {
                        outcome.failure = Some("an audio chunk did not decode".into());
                        break;
                    }
                }
                continue;
            }
            Message::Binary(bytes) => match decode_header(&bytes) {
                Ok(header) => ReceivedFrame {
                    seq: header.seq,
                    length: bytes.len(),
                    published_us: Some(header.server_send_us),
                },
                Err(_) => {
                    outcome.failure = Some("a frame header did not decode".into());
                    break;
                }
            },
            Message::Text(text) => match json_frame_seq(text.as_str()) {
                Some(seq) => ReceivedFrame {
                    seq,
                    length: text.len(),
                    published_us: None,
                },
                None => match serde_json::from_str::<ServerMessage>(text.as_str()) {
                    Ok(ServerMessage::End { .. }) => break,
                    Ok(ServerMessage::Error { code, message, .. }) => {
                        outcome.failure = Some(format!("{code}: {message}"));
                        break;
                    }
                    _ => continue,
                },
            },
            Message::Close(_) => break,
            _ => continue,
        };
        outcome.record(frame, &mut last, &plan);
    }
    let _ = socket.close(None).await;
    outcome
}

#[cfg(test)]
mod tests {
    use super::*;
    use facewire_proto::audio_chunk::{AudioBody, AudioChunk};

    #[test]
    fn a_chunk_s_time_and_length_come_from_its_header() {
        let pcm = AudioChunk {
            t_s: 1.25,
            server_receive_us: 7,
            body: AudioBody::Pcm {
                sample_rate: 24_000,
                samples: vec![3; 480],
            },
            ignored: Vec::new(),
        };
        assert_eq!(chunk_time_and_length(&pcm.encode()), Some((1.25, 0.02)));
        // An Opus packet of one 40 ms SILK frame (configuration 2, code 0).
        let opus = AudioChunk {
            body: AudioBody::Opus {
                packet: vec![2 << 3, 0xaa, 0xbb],
            },
            ..pcm
        };
        assert_eq!(chunk_time_and_length(&opus.encode()), Some((1.25, 0.04)));
        assert_eq!(chunk_time_and_length(&opus.encode()[..20]), None);
    }

    #[tokio::test(start_paused = true)]
    async fn a_stall_is_counted_in_the_second_it_began() {
        let start = Instant::now();
        let plan = ViewerPlan {
            times: Arc::new(SendTimes::new(std::time::Instant::now())),
            audio_times: None,
            received: Arc::default(),
            stall_after: Duration::from_millis(100),
            start,
            deadline: start + Duration::from_secs(10),
        };
        let mut outcome = ViewerOutcome::default();
        let mut last = None;
        // Published every 33 ms, except the 200 ms before `late_publish`.
        let frame = |seq: u64, late_publish: u64| ReceivedFrame {
            seq,
            length: 100,
            published_us: Some(seq * 33_000 + if seq >= late_publish { 167_000 } else { 0 }),
        };
        // A frame every 33 ms for 2.5 s (the last at 2.508 s), then 200 ms with none:
        // published in time, delivered late.
        for seq in 0..76 {
            tokio::time::advance(Duration::from_millis(33)).await;
            outcome.record(frame(seq, u64::MAX), &mut last, &plan);
        }
        tokio::time::advance(Duration::from_millis(200)).await;
        outcome.record(frame(76, u64::MAX), &mut last, &plan);
        tokio::time::advance(Duration::from_millis(33)).await;
        outcome.record(frame(77, u64::MAX), &mut last, &plan);
        assert_eq!((outcome.frames, outcome.stalls, outcome.skipped), (78, 1, 0));
        assert_eq!(outcome.publish_stalls, 0);
        assert_eq!(outcome.stall_seconds, BTreeMap::from([(2, 1)]));
        assert_eq!(outcome.stall_windows, [(2_508_000, 2_708_000)]);
        // Then the server publishes one frame 200 ms after the one before.
        tokio::time::advance(Duration::from_millis(200)).await;
        outcome.record(frame(78, 78), &mut last, &plan);
        assert_eq!((outcome.stalls, outcome.publish_stalls), (2, 1));
    }
}
