//! One named stream of one head: the timeline of its parameter frames, its audio (relayed
//! to the viewers that ask for it, never skipped for one that keeps up), the single
//! producer slot, and the pipelines its viewers watch (one per algorithm and face-roughness
//! choice, however many viewers). A stream lives while it has a producer, a viewer, or a
//! frame newer than `stream_linger_s`; the head's sweep drops it after that.

use std::collections::HashMap;
use std::future::Future;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use tokio::sync::{broadcast, watch, Notify, OnceCell};
use tokio::time::Instant;
use tokio_util::sync::CancellationToken;

use super::frames::{ParamTimeline, ReceivedFrame, RelayedAudio};
use super::pipeline::{Encoded, Pipeline, PipelineKey};
use super::recordings::Recorder;
use super::timeline::Timeline;
use crate::stream::Frame;
use facewire_proto::audio_chunk::{AudioBody, AudioChunk};
use facewire_proto::codes::EndReason;

/// Audio chunks a viewer may fall behind by before it is resynchronised to the newest
/// (64 chunks of 20 ms: 1.3 s).
const AUDIO_BACKLOG: usize = 64;

/// Where a producer's frames, audio and end go besides this node's viewers: the cluster
/// bus (`super::cluster`), attached to a permit once the stream's cluster-wide lease is
/// held. The calls return at once; they never wait on the network.
pub trait Relay: Send + Sync {
    fn frame(&self, frame: &Arc<ReceivedFrame>);
    fn audio(&self, audio: &Arc<RelayedAudio>);
    fn end(&self, reason: EndReason);
}

pub struct Stream {
    pub name: String,
    params: watch::Sender<ParamTimeline>,
    /// The stream's audio, a channel per codec (`pcm`, `opus`): a viewer wakes for its
    /// own codec's chunks only.
    audio: [broadcast::Sender<Arc<RelayedAudio>>; 2],
    /// Cancels the current producer (`DELETE .../producer`); a new token per producer.
    producer: Mutex<Option<CancellationToken>>,
    /// Told when a producer gives the slot back.
    released: Notify,
    /// One slot per key: its pipeline once started (`OnceCell`: the first viewer starts
    /// it, the others wait for it).
    pipelines: Mutex<HashMap<PipelineKey, Arc<OnceCell<Arc<Pipeline>>>>>,
    viewers: AtomicUsize,
    last_activity: Mutex<Instant>,
    /// When the last frame from another node's producer came, while the stream has not
    /// ended since: such a stream's end must come over the bus, or from its lease
    /// expiring (`super::follow`).
    relayed_at: Mutex<Option<Instant>>,
    /// What this node has admitted from the bus for the stream.
    fence: Mutex<RelayFence>,
    /// A producer here holds the stream's cluster lease (its relay is attached): the
    /// stream is this node's, and nothing from the bus goes into it. A producer whose
    /// claim is still being decided does not count.
    leased_here: AtomicBool,
}

/// The newest producer lease (fencing token) a stream's bus messages came under, and the
/// last frame's seq and time under it: what arrives from the bus is held to the rules a
/// producer's socket is (seq increasing, time never going back), and nothing from an
/// earlier lease's holder is admitted.
#[derive(Debug, Default)]
struct RelayFence {
    lease: u64,
    last: Option<(u64, f64)>,
}

impl Stream {
    pub fn new(name: &str) -> Stream {
        Stream {
            name: name.to_string(),
            params: watch::Sender::new(Timeline::default()),
            audio: [
                broadcast::Sender::new(AUDIO_BACKLOG),
                broadcast::Sender::new(AUDIO_BACKLOG),
            ],
            producer: Mutex::new(None),
            released: Notify::new(),
            pipelines: Mutex::new(HashMap::new()),
            viewers: AtomicUsize::new(0),
            last_activity: Mutex::new(Instant::now()),
            relayed_at: Mutex::new(None),
            fence: Mutex::new(RelayFence::default()),
            leased_here: AtomicBool::new(false),
        }
    }

    /// Takes the producer slot; `None` when another producer holds it. The slot is
    /// released, and the stream ended if the producer did not end it, when the permit drops.
    pub fn claim_producer(self: &Arc<Self>) -> Option<ProducerPermit> {
        let mut slot = self.producer.lock().expect("producer lock");
        if slot.is_some() {
            return None;
        }
        let cancel = CancellationToken::new();
        *slot = Some(cancel.clone());
        self.touch();
        Some(ProducerPermit {
            stream: self.clone(),
            cancel,
            ended: false,
            relay: None,
            recorder: Mutex::new(None),
        })
    }

    /// Cancels the current producer and waits until it has given the slot back, or for
    /// `patience` at most; false when there is none. A producer cancelled in the middle of
    /// a frame or a close handshake retires on its own task; waiting for it means that the
    /// stream takes a new producer as soon as the cancel is answered.
    pub async fn cancel_producer(&self, patience: Duration) -> bool {
        match self.producer.lock().expect("producer lock").as_ref() {
            Some(token) => token.cancel(),
            None => return false,
        }
        let _ = tokio::time::timeout(patience, async {
            loop {
                let released = self.released.notified();
                tokio::pin!(released);
                released.as_mut().enable();
                if !self.retiring() {
                    return;
                }
                released.await;
            }
        })
        .await;
        true
    }

    /// The slot is held by a producer that has been cancelled.
    fn retiring(&self) -> bool {
        self.producer
            .lock()
            .expect("producer lock")
            .as_ref()
            .is_some_and(CancellationToken::is_cancelled)
    }

    pub fn has_producer(&self) -> bool {
        self.producer.lock().expect("producer lock").is_some()
    }

    /// Ends the stream for its viewers (once: a second end with no frame between is
    /// ignored).
    pub fn end(&self, reason: EndReason) {
        self.params.send_if_modified(|t| t.end(reason).is_some());
        *self.relayed_at.lock().expect("relayed lock") = None;
        self.touch();
    }

    /// Publishes a frame whose producer is on another node (it came over the bus).
    pub fn publish_relayed(&self, frame: Arc<ReceivedFrame>) {
        self.params.send_modify(|t| {
            t.publish(frame);
        });
        *self.relayed_at.lock().expect("relayed lock") = Some(Instant::now());
        self.touch();
    }

    /// Admits a bus message for this stream sent under lease `lease`: a frame (`frame`:
    /// its seq and time) or an end or audio chunk (`None`). `fenced` when an earlier
    /// lease's, `stale` when the frame's seq does not increase or its time goes back.
    pub fn admit_relayed(&self, lease: u64, frame: Option<(u64, f64)>) -> Result<(), &'static str> {
        let mut fence = self.fence.lock().expect("fence lock");
        if lease < fence.lease {
            return Err("fenced");
        }
        if lease > fence.lease {
            *fence = RelayFence { lease, last: None };
        }
        if let Some((seq, time_s)) = frame {
            if fence.last.is_some_and(|(s, t)| seq <= s || time_s < t) {
                return Err("stale");
            }
            fence.last = Some((seq, time_s));
        }
        Ok(())
    }

    /// Whether a producer on this node holds the stream's cluster lease.
    pub fn is_leased_here(&self) -> bool {
        self.leased_here.load(Ordering::Acquire)
    }

    /// How long ago the last frame from another node's producer came, if the stream has
    /// not ended since and no producer is on this node.
    pub fn relay_silent_for(&self, now: Instant) -> Option<Duration> {
        if self.has_producer() {
            return None;
        }
        let at = (*self.relayed_at.lock().expect("relayed lock"))?;
        Some(now.saturating_duration_since(at))
    }

    pub fn subscribe(&self) -> watch::Receiver<ParamTimeline> {
        self.params.subscribe()
    }

    /// The stream's audio in `codec` (`pcm` or `opus`) from now on.
    pub fn subscribe_audio(&self, codec: &str) -> broadcast::Receiver<Arc<RelayedAudio>> {
        self.audio_channel(codec).subscribe()
    }

    /// Whether a viewer on this node listens to the stream's audio in `codec`.
    pub fn has_listeners(&self, codec: &str) -> bool {
        self.audio_channel(codec).receiver_count() > 0
    }

    fn audio_channel(&self, codec: &str) -> &broadcast::Sender<Arc<RelayedAudio>> {
        &self.audio[usize::from(codec == AudioBody::OPUS)]
    }

    /// Publishes an audio chunk, this node's producer's or another node's, to the viewers
    /// that asked for audio (a chunk with none listening is dropped: audio has no history).
    pub fn publish_audio_relayed(&self, audio: Arc<RelayedAudio>) {
        let _ = self.audio_channel(audio.codec).send(audio);
        self.touch();
    }

    fn touch(&self) {
        *self.last_activity.lock().expect("activity lock") = Instant::now();
    }

    /// A viewer's hold on the stream: counted while it lives.
    pub fn hold(self: &Arc<Self>) -> ViewerHold {
        self.viewers.fetch_add(1, Ordering::AcqRel);
        ViewerHold { stream: self.clone() }
    }

    /// A receiver of the running pipeline for `key`, or of a new one made by `start`. One
    /// viewer starts a key's pipeline while the others asking for it wait, and no lock is
    /// held while it starts (`start` may build its job on the blocking pool). Retired
    /// pipelines (no viewer left) are replaced. `full()` when `max_pipelines` run or start
    /// already and none is `key`'s.
    pub async fn pipeline<E, F>(
        &self,
        key: PipelineKey,
        max_pipelines: usize,
        full: impl FnOnce() -> E,
        start: impl FnOnce(watch::Receiver<ParamTimeline>) -> F,
    ) -> Result<watch::Receiver<Timeline<Encoded>>, E>
    where
        F: Future<Output = Result<(Arc<Pipeline>, watch::Receiver<Timeline<Encoded>>), E>>,
    {
        let mut start = Some(start);
        loop {
            let slot = {
                let mut pipelines = self.pipelines.lock().expect("pipelines lock");
                pipelines.retain(|_, slot| slot.get().is_none_or(|p| !p.is_retired()));
                match pipelines.get(&key) {
                    Some(slot) => slot.clone(),
                    None if pipelines.len() >= max_pipelines => return Err(full()),
                    None => pipelines.entry(key.clone()).or_default().clone(),
                }
            };
            let mut first = None;
            let started = slot
                .get_or_try_init(|| async {
                    let start = start.take().expect("a pipeline is started once per call");
                    let (pipeline, rx) = start(self.subscribe()).await?;
                    first = Some(rx);
                    Ok(pipeline)
                })
                .await;
            match started {
                Ok(pipeline) => match first.or_else(|| pipeline.subscribe()) {
                    Some(rx) => return Ok(rx),
                    // Retired between starting and joining: replaced on the next turn.
                    None => continue,
                },
                Err(e) => {
                    let mut pipelines = self.pipelines.lock().expect("pipelines lock");
                    if pipelines
                        .get(&key)
                        .is_some_and(|s| Arc::ptr_eq(s, &slot) && s.get().is_none())
                    {
                        pipelines.remove(&key);
                    }
                    return Err(e);
                }
            }
        }
    }

    /// Pipelines running or starting now (retired ones are dropped on the way).
    pub fn pipeline_count(&self) -> usize {
        let mut pipelines = self.pipelines.lock().expect("pipelines lock");
        pipelines.retain(|_, slot| slot.get().is_none_or(|p| !p.is_retired()));
        pipelines.len()
    }

    /// Whether the stream is still in use: a producer, a viewer, or activity within
    /// `linger`.
    pub fn is_live(&self, now: Instant, linger: std::time::Duration) -> bool {
        self.has_producer()
            || self.viewers.load(Ordering::Acquire) > 0
            || self.pipeline_count() > 0
            || now.saturating_duration_since(*self.last_activity.lock().expect("activity lock")) < linger
    }
}

/// The producer slot of a stream, held by a producer socket or a playing batch.
pub struct ProducerPermit {
    stream: Arc<Stream>,
    cancel: CancellationToken,
    ended: bool,
    relay: Option<Box<dyn Relay>>,
    /// Keeps every frame published, when the producer asked for a recording.
    recorder: Mutex<Option<Recorder>>,
}

impl ProducerPermit {
    /// Publishes a frame: viewers' pipelines deform the newest one, here and, with a
    /// relay, on every other node; a recording keeps it.
    pub fn publish(&self, frame: Frame, received_us: u64) {
        if let Some(recorder) = self.recorder.lock().expect("recorder lock").as_mut() {
            recorder.push(&frame);
        }
        let frame = Arc::new(ReceivedFrame { frame, received_us });
        if let Some(relay) = &self.relay {
            relay.frame(&frame);
        }
        self.stream.publish_relayed(frame);
    }

    /// Whether audio in `codec` would be heard: by a viewer here, or, with a relay, by
    /// any on another node.
    pub fn is_heard_in(&self, codec: &str) -> bool {
        self.relay.is_some() || self.stream.has_listeners(codec)
    }

    /// Keeps a chunk of the producer's voice (as it sent it, before any transcoding) in
    /// its recording, when it asked for one.
    pub fn record_audio(&self, chunk: &AudioChunk) {
        if let Some(recorder) = self.recorder.lock().expect("recorder lock").as_mut() {
            recorder.push_audio(chunk);
        }
    }

    /// Publishes an audio chunk to the viewers that asked for audio, here and, with a
    /// relay, on every other node.
    pub fn publish_audio(&self, audio: RelayedAudio) {
        let audio = Arc::new(audio);
        if let Some(relay) = &self.relay {
            relay.audio(&audio);
        }
        self.stream.publish_audio_relayed(audio);
    }

    /// Ends the stream with `reason` and gives the slot back.
    pub fn end(mut self, reason: EndReason) {
        self.end_everywhere(reason);
        self.ended = true;
    }

    fn end_everywhere(&self, reason: EndReason) {
        if let Some(relay) = &self.relay {
            relay.end(reason);
        }
        self.stream.end(reason);
    }

    /// Keeps every frame this producer publishes in `recorder`'s recording, listed when
    /// the producer is done.
    pub fn record(&mut self, recorder: Recorder) {
        *self.recorder.get_mut().expect("recorder lock") = Some(recorder);
    }

    /// Sends this producer's frames and end to `relay` too.
    pub fn relay_to(&mut self, relay: Box<dyn Relay>) {
        self.relay = Some(relay);
        self.stream.leased_here.store(true, Ordering::Release);
    }

    /// Gives the slot back without ending the stream (the producer was refused before
    /// it sent anything: the stream may be running from another node).
    pub fn abandon(mut self) {
        self.ended = true;
    }

    /// The token that cancels this producer (as `DELETE .../producer` does).
    pub fn cancel_token(&self) -> CancellationToken {
        self.cancel.clone()
    }

    /// Resolves when the producer is cancelled (`DELETE .../producer`).
    pub fn cancelled(&self) -> tokio_util::sync::WaitForCancellationFuture<'_> {
        self.cancel.cancelled()
    }

    pub fn stream(&self) -> &Arc<Stream> {
        &self.stream
    }
}

impl Drop for ProducerPermit {
    fn drop(&mut self) {
        if !self.ended {
            self.end_everywhere(EndReason::ProducerDisconnected);
        }
        if self.relay.is_some() {
            self.stream.leased_here.store(false, Ordering::Release);
        }
        *self.stream.producer.lock().expect("producer lock") = None;
        self.stream.released.notify_waiters();
        self.stream.touch();
    }
}

/// Keeps a stream live while a viewer watches it.
pub struct ViewerHold {
    stream: Arc<Stream>,
}

impl Drop for ViewerHold {
    fn drop(&mut self) {
        self.stream.viewers.fetch_sub(1, Ordering::AcqRel);
        self.stream.touch();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test(start_paused = true)]
    async fn a_cancel_returns_once_the_producer_has_let_go() {
        let stream = Arc::new(Stream::new("s"));
        let permit = stream.claim_producer().unwrap();
        let retiring = tokio::spawn(async move {
            permit.cancelled().await;
            tokio::time::sleep(Duration::from_millis(50)).await;
            permit.end(EndReason::ProducerCancelled);
        });
        assert!(stream.cancel_producer(Duration::from_secs(1)).await);
        assert!(!stream.has_producer(), "the slot is free when the cancel returns");
        assert!(stream.claim_producer().is_some());
        retiring.await.unwrap();
        assert!(
            !stream.cancel_producer(Duration::from_secs(1)).await,
            "none left to cancel"
        );
    }

    #[tokio::test(start_paused = true)]
    async fn a_producer_that_does_not_let_go_is_waited_for_a_bounded_time() {
        let stream = Arc::new(Stream::new("s"));
        let _stuck = stream.claim_producer().unwrap();
        let started = Instant::now();
        assert!(stream.cancel_producer(Duration::from_secs(1)).await);
        assert_eq!(started.elapsed(), Duration::from_secs(1));
        assert!(stream.has_producer());
    }
}
