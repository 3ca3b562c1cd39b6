//! A head's recorded streams, for replay: a producer that asks (`record=1`, or a name)
//! has the parameter frames it sends kept, in order, as a recording of the head, with the
//! voice it sends (as PCM on the same timeline, Opus decoded), which viewers then play at
//! their own pace (`super::replay`). Recordings live in memory with
//! the head; each head holds at most `max_recordings_per_head`, each at most
//! `max_recording_frames` frames, and all of the server's together at most
//! `max_recording_bytes`, voices included (a producer that goes past either goes on,
//! unrecorded past it, and its recording says it was cut; a voice past the memory, or
//! changing its sample rate, is kept up to there). A producer whose head holds the most is refused
//! before it starts; a recording is listed once its producer ends, and deleted on request
//! or with its head (its memory is given back when the last replay of it ends).

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use super::error::ApiError;
use super::ids::valid_id;
use super::opus_decode::OpusStreamDecoder;
use super::recorded_voice::RecordedVoice;
use super::recording_shelf::{RecordingShelf, ShelvedMeta};
use crate::mask::Mask;
use crate::stream::Frame;
use crate::voice::Voice;
use facewire_proto::audio_chunk::{AudioBody, AudioChunk, OPUS_RATE};
use facewire_proto::messages::{RecordingInfo, RecordingLabel};

/// `record=` on a producer socket or a batch: `1` or `true` records under the name
/// `{stream}-{n}`, any other id under that name; absent, `0` or `false`, nothing is kept.
#[derive(Debug, Default, serde::Deserialize)]
pub struct RecordQuery {
    pub record: Option<String>,
}

impl RecordQuery {
    /// A recorder for a producer of `stream` on head `head`, whose recordings are
    /// `recordings`, when one was asked for.
    pub fn recorder(
        &self,
        recordings: &Arc<Recordings>,
        head: &str,
        stream: &str,
    ) -> Result<Option<Recorder>, ApiError> {
        let name = match self.record.as_deref() {
            None | Some("" | "0" | "false") => return Ok(None),
            Some("1" | "true") => None,
            Some(name) => Some(name),
        };
        recordings.recorder(head, stream, name).map(Some)
    }
}

/// The limits of a head's recordings (from the configuration), the memory all of the
/// server's recordings share, and the mask their files on disk name animation units by.
#[derive(Clone)]
pub struct RecordingLimits {
    pub max_per_head: usize,
    pub max_frames: usize,
    pub budget: Arc<RecordingBudget>,
    pub mask: Arc<Mask>,
}

impl std::fmt::Debug for RecordingLimits {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RecordingLimits")
            .field("max_per_head", &self.max_per_head)
            .field("max_frames", &self.max_frames)
            .field("budget", &self.budget)
            .finish_non_exhaustive()
    }
}

/// The memory every recording of a server takes together, bytes, and the most it may.
#[derive(Debug)]
pub struct RecordingBudget {
    used: AtomicUsize,
    max: usize,
}

impl RecordingBudget {
    pub fn new(max_bytes: usize) -> Arc<RecordingBudget> {
        Arc::new(RecordingBudget {
            used: AtomicUsize::new(0),
            max: max_bytes,
        })
    }

    /// Takes `bytes` if they fit; false (nothing taken) if not.
    fn take(&self, bytes: usize) -> bool {
        self.used
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |used| {
                used.checked_add(bytes).filter(|&total| total <= self.max)
            })
            .is_ok()
    }

    fn give(&self, bytes: usize) {
        self.used.fetch_sub(bytes, Ordering::AcqRel);
    }

    /// Bytes all recordings hold now.
    pub fn used(&self) -> usize {
        self.used.load(Ordering::Acquire)
    }
}

/// What keeping `frame` costs in memory, bytes: the frame and what its vectors hold.
fn frame_bytes(frame: &Frame) -> usize {
    std::mem::size_of::<Frame>()
        + frame.label.as_ref().map_or(0, String::len)
        + frame.animation.len() * std::mem::size_of::<(u16, f32)>()
        + frame.faps.len() * std::mem::size_of::<(u8, f32)>()
        + frame.arkit.len() * std::mem::size_of::<(u8, f32)>()
        + frame
            .controls
            .as_ref()
            .map_or(0, |c| c.len() * std::mem::size_of::<[f32; 3]>())
}

/// What keeping `samples` of a voice costs in memory, bytes.
fn voice_bytes(samples: usize) -> usize {
    samples * std::mem::size_of::<i16>()
}

/// A finished recording: the frames as the producer sent them, and its voice.
#[derive(Debug)]
pub struct Recording {
    pub name: String,
    /// The stream it was recorded from.
    pub stream: String,
    pub frames: Vec<Frame>,
    pub voice: Option<RecordedVoice>,
    /// Whether the producer sent more frames than a recording holds.
    pub cut: bool,
    /// The memory its frames take, held in `budget` while it lives.
    bytes: usize,
    budget: Arc<RecordingBudget>,
}

impl Drop for Recording {
    fn drop(&mut self) {
        self.budget.give(self.bytes);
    }
}

impl Recording {
    /// What the list and a replay's snapshot say about it: its frames, its length in the
    /// producer's seconds, and each run of frames with the same label.
    pub fn info(&self) -> RecordingInfo {
        let mut labels: Vec<RecordingLabel> = Vec::new();
        for (index, frame) in self.frames.iter().enumerate() {
            let Some(label) = &frame.label else { continue };
            match labels.last_mut() {
                Some(run) if run.label == *label && run.last + 1 == index as u64 => run.last = index as u64,
                _ => labels.push(RecordingLabel {
                    label: label.clone(),
                    first: index as u64,
                    last: index as u64,
                }),
            }
        }
        let time = |f: Option<&Frame>| f.map_or(0.0, |f| f.time_s);
        RecordingInfo {
            name: self.name.clone(),
            stream: self.stream.clone(),
            frames: self.frames.len() as u64,
            duration_s: time(self.frames.last()) - time(self.frames.first()),
            cut: self.cut,
            labels,
            voice_s: self.voice.as_ref().map(|v| v.voice.duration_s()),
        }
    }
}

/// The recordings of one head, and the places taken by producers still recording.
pub struct Recordings {
    limits: RecordingLimits,
    inner: Mutex<Inner>,
    /// Where they are kept beyond this process, on a server with a data directory.
    shelf: Option<RecordingShelf>,
}

#[derive(Default)]
struct Inner {
    done: BTreeMap<String, Arc<Recording>>,
    /// Names taken by producers still recording.
    recording: Vec<String>,
    /// Numbers the automatic names (`{stream}-{n}`) go on from.
    next: u64,
}

impl Recordings {
    /// A head's recordings, kept in `dir` beyond this process when it is given.
    pub fn new(limits: RecordingLimits, dir: Option<std::path::PathBuf>) -> Recordings {
        Recordings {
            shelf: dir.map(|dir| RecordingShelf::new(dir, limits.mask.clone())),
            limits,
            inner: Mutex::new(Inner::default()),
        }
    }

    /// Reads the recordings kept on disk back into memory, within the limits (what does
    /// not fit, or cannot be read, stays on disk and is named in the log). Blocking.
    pub fn restore(&self, head: &str) {
        let Some(shelf) = &self.shelf else { return };
        let (found, problems) = shelf.load_all();
        for problem in problems {
            tracing::warn!(%head, %problem, "kept recording not read");
        }
        let mut inner = self.inner.lock().expect("recordings lock");
        for shelved in found {
            let held = inner.done.len() + inner.recording.len();
            let voice_samples = shelved.voice.as_ref().map_or(0, |v| v.voice.samples.len());
            let bytes: usize =
                shelved.frames.iter().map(frame_bytes).sum::<usize>() + voice_bytes(voice_samples);
            if inner.done.contains_key(&shelved.name) {
                continue;
            }
            if held >= self.limits.max_per_head || !self.limits.budget.take(bytes) {
                tracing::warn!(%head, recording = %shelved.name, "kept recording past the recording limits: left on disk, not listed");
                continue;
            }
            let recording = Recording {
                name: shelved.name,
                stream: shelved.meta.stream,
                frames: shelved.frames,
                voice: shelved.voice,
                cut: shelved.meta.cut,
                bytes,
                budget: self.limits.budget.clone(),
            };
            inner.done.insert(recording.name.clone(), Arc::new(recording));
        }
    }

    /// Writes `recording` to disk, if this head keeps recordings there. A recording
    /// deleted (or replaced) while it was written is removed again.
    fn shelve(self: &Arc<Self>, recording: Arc<Recording>) {
        if self.shelf.is_none() {
            return;
        }
        let recordings = self.clone();
        let write = move || {
            let Some(shelf) = &recordings.shelf else { return };
            let meta = ShelvedMeta {
                stream: recording.stream.clone(),
                cut: recording.cut,
                voice_start_s: recording.voice.as_ref().map(|v| v.start_t_s),
            };
            if let Err(e) = shelf.save(
                &recording.name,
                &meta,
                &recording.frames,
                recording.voice.as_ref(),
            ) {
                tracing::warn!(recording = %recording.name, error = %e, "recording not kept on disk");
            }
            let inner = recordings.inner.lock().expect("recordings lock");
            let current = inner.done.get(&recording.name);
            if !current.is_some_and(|kept| Arc::ptr_eq(kept, &recording)) {
                if let Err(e) = shelf.remove(&recording.name) {
                    tracing::warn!(recording = %recording.name, error = %e, "deleted recording left on disk");
                }
            }
        };
        match tokio::runtime::Handle::try_current() {
            Ok(runtime) => drop(runtime.spawn_blocking(write)),
            Err(_) => write(),
        }
    }

    /// A recorder for a producer of `stream` on head `head`: named `name`, or
    /// `{stream}-{n}` for `None`. Refused when the name is taken or not an id, or when the
    /// head holds the most recordings.
    pub fn recorder(
        self: &Arc<Self>,
        head: &str,
        stream: &str,
        name: Option<&str>,
    ) -> Result<Recorder, ApiError> {
        let mut inner = self.inner.lock().expect("recordings lock");
        let held = inner.done.len() + inner.recording.len();
        if held >= self.limits.max_per_head {
            return Err(ApiError::LimitReached(format!(
                "head {head:?} holds {held} recordings, the most it keeps; delete one \
                 (DELETE /v1/heads/{head}/recordings/NAME) or produce without record="
            )));
        }
        let name = match name {
            Some(name) => {
                if !valid_id(name) {
                    return Err(ApiError::BadId {
                        what: "recording name",
                        id: name.to_string(),
                    });
                }
                if inner.done.contains_key(name) || inner.recording.iter().any(|n| n == name) {
                    return Err(ApiError::BadRequest(format!(
                        "record={name}: head {head:?} has a recording of that name; delete it or choose another"
                    )));
                }
                name.to_string()
            }
            None => loop {
                inner.next += 1;
                let name = format!("{stream}-{}", inner.next);
                // A 64-character stream name leaves no room for the number.
                let name = if valid_id(&name) {
                    name
                } else {
                    format!("recording-{}", inner.next)
                };
                if !inner.done.contains_key(&name) && !inner.recording.contains(&name) {
                    break name;
                }
            },
        };
        inner.recording.push(name.clone());
        Ok(Recorder {
            recordings: self.clone(),
            recording: Some(Recording {
                name,
                stream: stream.to_string(),
                frames: Vec::new(),
                voice: None,
                cut: false,
                bytes: 0,
                budget: self.limits.budget.clone(),
            }),
            max_frames: self.limits.max_frames,
            opus: None,
            voice_stopped: false,
        })
    }

    /// Keeps `frames` of `stream` and their `voice` as recording `name`, made elsewhere
    /// (the demo's syllable stream), replacing one of the same name; it counts towards the
    /// limits like the others, but is kept even past them. Nothing is kept without frames.
    pub fn keep(&self, name: &str, stream: &str, frames: Vec<Frame>, voice: Option<RecordedVoice>) {
        if frames.is_empty() {
            return; // a recording has at least one frame: a replay shows one at a time
        }
        let budget = self.limits.budget.clone();
        let voice_samples = voice.as_ref().map_or(0, |v| v.voice.samples.len());
        let bytes = frames.iter().map(frame_bytes).sum::<usize>() + voice_bytes(voice_samples);
        budget.used.fetch_add(bytes, Ordering::AcqRel);
        let recording = Recording {
            name: name.to_string(),
            stream: stream.to_string(),
            frames,
            voice,
            cut: false,
            bytes,
            budget,
        };
        let mut inner = self.inner.lock().expect("recordings lock");
        inner.done.insert(recording.name.clone(), Arc::new(recording));
    }

    /// Every finished recording, by name.
    pub fn list(&self) -> Vec<RecordingInfo> {
        let inner = self.inner.lock().expect("recordings lock");
        inner.done.values().map(|r| r.info()).collect()
    }

    pub fn get(&self, head: &str, name: &str) -> Result<Arc<Recording>, ApiError> {
        let inner = self.inner.lock().expect("recordings lock");
        inner
            .done
            .get(name)
            .cloned()
            .ok_or_else(|| ApiError::NotFound(format!("recording {name:?} of head {head:?}")))
    }

    pub fn delete(&self, head: &str, name: &str) -> Result<(), ApiError> {
        let mut inner = self.inner.lock().expect("recordings lock");
        inner
            .done
            .remove(name)
            .ok_or_else(|| ApiError::NotFound(format!("recording {name:?} of head {head:?}")))?;
        // Under the lock: a recording of the same name written meanwhile is not removed.
        if let Some(shelf) = &self.shelf {
            shelf.remove(name).map_err(ApiError::internal)?;
        }
        Ok(())
    }
}

/// A producer's recording in the making; kept (listed) when dropped, if it holds a frame.
pub struct Recorder {
    recordings: Arc<Recordings>,
    recording: Option<Recording>,
    max_frames: usize,
    /// Decodes an Opus voice to keep it as PCM, made at its first packet.
    opus: Option<OpusStreamDecoder>,
    /// The voice is kept no further: the memory ran out, its rate changed, or a packet
    /// did not decode.
    voice_stopped: bool,
}

impl Recorder {
    /// The recording's name.
    pub fn name(&self) -> &str {
        self.recording.as_ref().map_or("", |r| r.name.as_str())
    }

    /// Keeps `frame`, unless the recording is full or the server's recordings hold all
    /// the memory they may.
    pub fn push(&mut self, frame: &Frame) {
        if let Some(recording) = &mut self.recording {
            let bytes = frame_bytes(frame);
            if recording.frames.len() < self.max_frames && recording.budget.take(bytes) {
                recording.frames.push(frame.clone());
                recording.bytes += bytes;
            } else {
                recording.cut = true;
            }
        }
    }

    /// Keeps `chunk`'s samples in the recording's voice, at its `t`: a gap before it is
    /// silence, what overlaps samples already kept is dropped. Opus is decoded (48 kHz). A
    /// chunk at another rate than the voice's, or past the memory the recordings may take,
    /// ends the voice there (logged).
    pub fn push_audio(&mut self, chunk: &AudioChunk) {
        let Some(recording) = &mut self.recording else {
            return;
        };
        if self.voice_stopped {
            return;
        }
        let (rate, samples) = match &chunk.body {
            AudioBody::Pcm { sample_rate, samples } => (*sample_rate, samples.as_slice()),
            AudioBody::Opus { packet } => {
                let decoder = match self.opus.take().map_or_else(OpusStreamDecoder::new, Ok) {
                    Ok(decoder) => self.opus.insert(decoder),
                    Err(e) => return stop_voice(&mut self.voice_stopped, &recording.name, &e.to_string()),
                };
                match decoder.decode(packet) {
                    Ok(samples) => (OPUS_RATE, samples),
                    Err(e) => return stop_voice(&mut self.voice_stopped, &recording.name, &e.to_string()),
                }
            }
        };
        let voice = recording.voice.get_or_insert_with(|| RecordedVoice {
            start_t_s: chunk.t_s,
            voice: Voice {
                sample_rate: rate,
                samples: Vec::new(),
            },
        });
        if voice.voice.sample_rate != rate {
            let why = format!(
                "the voice changed from {} Hz to {rate} Hz",
                voice.voice.sample_rate
            );
            return stop_voice(&mut self.voice_stopped, &recording.name, &why);
        }
        let at = ((chunk.t_s - voice.start_t_s) * f64::from(rate)).round().max(0.0) as usize;
        let kept = voice.voice.samples.len();
        let gap = at.saturating_sub(kept);
        let fresh = &samples[(kept.saturating_sub(at)).min(samples.len())..];
        let bytes = voice_bytes(gap + fresh.len());
        if !recording.budget.take(bytes) {
            return stop_voice(
                &mut self.voice_stopped,
                &recording.name,
                "the recordings hold all the memory they may",
            );
        }
        recording.bytes += bytes;
        voice.voice.samples.resize(kept + gap, 0);
        voice.voice.samples.extend_from_slice(fresh);
    }
}

/// Keeps a recording's voice no further, saying why in the log.
fn stop_voice(stopped: &mut bool, recording: &str, why: &str) {
    *stopped = true;
    tracing::warn!(%recording, %why, "recording's voice kept up to here");
}

impl Drop for Recorder {
    fn drop(&mut self) {
        let Some(recording) = self.recording.take() else {
            return;
        };
        let kept = {
            let mut inner = self.recordings.inner.lock().expect("recordings lock");
            inner.recording.retain(|n| *n != recording.name);
            if recording.frames.is_empty() {
                return;
            }
            let kept = Arc::new(recording);
            inner.done.insert(kept.name.clone(), kept.clone());
            kept
        };
        self.recordings.shelve(kept);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits() -> RecordingLimits {
        RecordingLimits {
            max_per_head: 4,
            max_frames: 100,
            budget: RecordingBudget::new(1 << 20),
            mask: Arc::new(Mask::candide3()),
        }
    }

    /// A 20 ms chunk of 16 kHz PCM at `t_s`, every sample `value`.
    fn chunk(t_s: f64, rate: u32, value: i16) -> AudioChunk {
        AudioChunk {
            t_s,
            server_receive_us: 0,
            body: AudioBody::Pcm {
                sample_rate: rate,
                samples: vec![value; (rate / 50) as usize],
            },
            ignored: Vec::new(),
        }
    }

    #[test]
    fn a_voice_is_kept_on_its_timeline_gaps_silent_overlaps_dropped() {
        let recordings = Arc::new(Recordings::new(limits(), None));
        let mut recorder = recordings.recorder("h", "s", Some("r")).unwrap();
        recorder.push(&Frame::default());
        recorder.push_audio(&chunk(1.0, 16_000, 1));
        // 20 ms of silence, then a chunk that overlaps the one before by 10 ms.
        recorder.push_audio(&chunk(1.04, 16_000, 2));
        recorder.push_audio(&chunk(1.05, 16_000, 3));
        // Another rate ends the voice there.
        recorder.push_audio(&chunk(1.1, 24_000, 4));
        recorder.push_audio(&chunk(1.2, 16_000, 5));
        drop(recorder);
        let recording = recordings.get("h", "r").unwrap();
        let voice = recording.voice.as_ref().unwrap();
        assert_eq!(voice.start_t_s, 1.0);
        let s = &voice.voice.samples;
        assert_eq!(s.len(), 320 * 3 + 160);
        assert!(s[..320].iter().all(|&x| x == 1) && s[320..640].iter().all(|&x| x == 0));
        assert!(s[640..960].iter().all(|&x| x == 2) && s[960..].iter().all(|&x| x == 3));
        assert_eq!(recording.info().voice_s, Some(0.07));
        // From before the voice: silence first; past its end: nothing.
        let from_half = voice.between(0.99, 2.0);
        assert_eq!(from_half.samples.len(), 160 + s.len());
        assert!(from_half.samples[..160].iter().all(|&x| x == 0) && from_half.samples[160] == 1);
        assert_eq!(voice.between(0.5, 0.6).samples.len(), 1600);
        assert!((voice.end_t_s() - 1.07).abs() < 1e-12);
    }
}
