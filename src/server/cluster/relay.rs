//! Parameter frames, audio and stream ends between nodes. A producer's node publishes each
//! accepted frame, as one line of facewire's JSONL (docs/STREAMS.md), on
//! `facewire.params.<head>.<stream>`, and each audio chunk in both codecs, as the `FWA1`
//! message its own viewers get, on `facewire.audio.<head>.<stream>`; every node subscribes
//! to both and publishes what arrives into its own copy of the stream, where its pipelines
//! deform it for its viewers and its viewers hear it. Vertex arrays never cross the bus,
//! and audio is encoded once, on the producer's node.
//!
//! Sending never waits on the network: frames go through a bounded queue to one task that
//! owns the publishing, so one node's frames keep their order, and a queue full because
//! NATS is away drops frames (counted in `facewire_bus_dropped_total{code="queue_full"}`)
//! instead of holding a producer up.
//!
//! A node that was stalled (frozen, or starved of the CPU) for longer than [`STALL`] may
//! have missed a liveness check and lost a lease it still relays under, before the other
//! nodes have a message of the new lease to fence the old one by: after a stall, each
//! lease is confirmed with the bucket before anything more is published under it, and
//! what a lost lease still sends is dropped (`code="lease_lost"`).

use std::future::Future;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use async_nats::HeaderMap;
use bytes::Bytes;
use futures_util::StreamExt;
use tokio::sync::mpsc;

use super::lease::{Lease, LeaseCheck};
use super::seal::Seal;
use super::{ClusterError, PREFIX};
use crate::mask::Mask;
use crate::server::frames::{ReceivedFrame, RelayedAudio};
use crate::server::stream::Relay;
use crate::server::telemetry::Telemetry;
use crate::stream::jsonl::{parse_message, JsonlWriter};
use facewire_proto::audio_chunk::AudioChunk;
use facewire_proto::codes::EndReason;

/// Header with the producer's node's receive time, µs since the Unix epoch.
const RECEIVED_US: &str = "Facewire-Received-Us";
/// Header that makes a message a stream end; its value is the end reason's wire name.
const END: &str = "Facewire-End";
/// Header with the fencing token of the producer's lease the message was sent under.
const LEASE: &str = "Facewire-Lease";
/// A producer's node's receive time is taken as at most this old (µs); older or future
/// stamps are held to the range, so no header can throw the hop histogram.
const MAX_HOP_US: u64 = 60_000_000;
/// Messages waiting to be published, over all of this node's producers: 1 s of 64
/// streams at 30 fps, each with 50 audio chunks a second in two codecs.
const QUEUE: usize = 8192;
/// A gap this long in the stall watch's ticks (or since its last tick, seen by the
/// publisher) is a stall: half of the time a liveness check waits for an answer.
const STALL: Duration = Duration::from_millis(500);
/// How often the stall watch ticks.
const STALL_TICK: Duration = Duration::from_millis(100);
/// Subject kinds: `facewire.<kind>.<head>.<stream>`.
const PARAMS: &str = "params";
const AUDIO: &str = "audio";

fn subject(kind: &str, head: &str, stream: &str) -> String {
    format!("{PREFIX}.{kind}.{head}.{stream}")
}

/// A message to publish, with the fencing token of the lease it goes under.
struct Outgoing {
    subject: Arc<str>,
    fence: u64,
    lease: Arc<LeaseCheck>,
    body: Body,
}

/// Counts the process's stalls: a task ticks every [`STALL_TICK`] and counts a gap longer
/// than [`STALL`]; the publisher counts one too when the last tick is that old (it may run
/// first after the process wakes).
struct StallWatch {
    started: Instant,
    /// When the watch last ticked, ms since `started`.
    last_tick_ms: AtomicU64,
    stalls: AtomicU64,
}

impl StallWatch {
    fn start() -> Arc<StallWatch> {
        let watch = Arc::new(StallWatch {
            started: Instant::now(),
            last_tick_ms: AtomicU64::new(0),
            stalls: AtomicU64::new(0),
        });
        let ticking = Arc::downgrade(&watch);
        tokio::spawn(async move {
            let mut ticks = tokio::time::interval(STALL_TICK);
            ticks.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
            loop {
                ticks.tick().await;
                let Some(watch) = ticking.upgrade() else { return };
                watch.stalled_now();
                watch.last_tick_ms.store(watch.now_ms(), Ordering::Release);
            }
        });
        watch
    }

    fn now_ms(&self) -> u64 {
        self.started.elapsed().as_millis() as u64
    }

    /// The number of stalls so far, counting one now if the last tick is older than
    /// [`STALL`] (it is then set to now, so one gap counts once).
    fn stalled_now(&self) -> u64 {
        let now = self.now_ms();
        let last = self.last_tick_ms.load(Ordering::Acquire);
        let gap = Duration::from_millis(now.saturating_sub(last));
        if gap > STALL
            && self
                .last_tick_ms
                .compare_exchange(last, now, Ordering::AcqRel, Ordering::Acquire)
                .is_ok()
        {
            return self.stalls.fetch_add(1, Ordering::AcqRel) + 1;
        }
        self.stalls.load(Ordering::Acquire)
    }
}

enum Body {
    Frame(Arc<ReceivedFrame>),
    Audio(Arc<RelayedAudio>),
    End(EndReason),
}

/// The sending side: a queue and the task that publishes what is in it.
pub struct Outbox {
    queue: mpsc::Sender<Outgoing>,
    telemetry: Arc<Telemetry>,
}

impl Outbox {
    pub fn start(
        client: async_nats::Client,
        seal: Arc<Seal>,
        mask: Arc<Mask>,
        telemetry: Arc<Telemetry>,
    ) -> Outbox {
        let (queue, outgoing) = mpsc::channel(QUEUE);
        let stalls = StallWatch::start();
        tokio::spawn(publish(client, seal, mask, outgoing, stalls, telemetry.clone()));
        Outbox { queue, telemetry }
    }

    /// A relay for one producer of `head`'s `stream`, holding its lease.
    pub fn relay(&self, head: &str, stream: &str, lease: Lease) -> BusRelay {
        BusRelay {
            subject: subject(PARAMS, head, stream).into(),
            audio_subject: subject(AUDIO, head, stream).into(),
            queue: self.queue.clone(),
            telemetry: self.telemetry.clone(),
            lease,
        }
    }
}

/// One producer's frames onto the bus; dropping it releases the stream's lease.
pub struct BusRelay {
    subject: Arc<str>,
    audio_subject: Arc<str>,
    queue: mpsc::Sender<Outgoing>,
    telemetry: Arc<Telemetry>,
    lease: Lease,
}

impl BusRelay {
    fn send(&self, subject: &Arc<str>, body: Body) {
        let outgoing = Outgoing {
            subject: subject.clone(),
            fence: self.lease.fence(),
            lease: self.lease.check(),
            body,
        };
        if self.queue.try_send(outgoing).is_err() {
            self.telemetry.bus_dropped("queue_full");
        }
    }
}

impl Relay for BusRelay {
    fn frame(&self, frame: &Arc<ReceivedFrame>) {
        self.send(&self.subject, Body::Frame(frame.clone()));
    }

    fn audio(&self, audio: &Arc<RelayedAudio>) {
        self.send(&self.audio_subject, Body::Audio(audio.clone()));
    }

    fn end(&self, reason: EndReason) {
        // A node shutting down is not the stream ending: its producer may go on from
        // another node, and the other nodes' viewers keep watching.
        if reason != EndReason::ServerShutdown {
            self.send(&self.subject, Body::End(reason));
        }
    }
}

async fn publish(
    client: async_nats::Client,
    seal: Arc<Seal>,
    mask: Arc<Mask>,
    mut outgoing: mpsc::Receiver<Outgoing>,
    stalls: Arc<StallWatch>,
    telemetry: Arc<Telemetry>,
) {
    let mut line = Vec::new();
    while let Some(Outgoing {
        subject,
        fence,
        lease,
        body,
    }) = outgoing.recv().await
    {
        let stall = stalls.stalled_now();
        if stall > 0 && !lease.held_after(stall).await {
            telemetry.bus_dropped("lease_lost");
            continue;
        }
        let mut headers = HeaderMap::new();
        headers.insert(LEASE, fence.to_string().as_str());
        let payload = match body {
            Body::Frame(frame) => {
                line.clear();
                let mut writer = JsonlWriter::new(&mut line, &mask);
                if let Err(e) = writer.write_frame(&frame.frame) {
                    // Frames were checked on the way in; this is a defect, not input.
                    tracing::error!(error = %e, "frame not relayed");
                    telemetry.bus_dropped("unwritable");
                    continue;
                }
                headers.insert(RECEIVED_US, frame.received_us.to_string().as_str());
                Bytes::copy_from_slice(&line)
            }
            Body::Audio(audio) => audio.bytes.clone(),
            Body::End(reason) => {
                headers.insert(END, reason.as_str());
                Bytes::new()
            }
        };
        seal.sign(&subject, &mut headers, &payload);
        match client
            .publish_with_headers(subject.to_string(), headers, payload)
            .await
        {
            Ok(()) => {
                telemetry.bus_messages_out.inc();
            }
            Err(e) => {
                tracing::warn!(error = %e, "bus publish failed");
                telemetry.bus_dropped("publish_failed");
            }
        }
    }
}

/// A checked message from another node's producer: its stream, the fencing token of the
/// lease it was sent under, and what it carries. What it does to this node's copy of the
/// stream is the follower's (`crate::server::follow`).
#[derive(Debug)]
pub struct Remote<'a> {
    pub head: &'a str,
    pub stream: &'a str,
    pub lease: u64,
    pub body: RemoteBody,
}

#[derive(Debug)]
pub enum RemoteBody {
    /// A parameter frame, its producer's node's receive time held to the last
    /// [`MAX_HOP_US`].
    Frame(ReceivedFrame),
    /// An audio chunk checked as a producer's is, its bytes as they came.
    Audio(RelayedAudio),
    End(EndReason),
}

/// Subscribes this node to every stream's frames and audio; the returned future checks
/// each message and hands it to `deliver` until the connection closes. `deliver`'s error
/// is why a message was dropped, counted as the checks' own are.
pub async fn inbound(
    client: &async_nats::Client,
    seal: Arc<Seal>,
    mask: Arc<Mask>,
    telemetry: Arc<Telemetry>,
    deliver: impl Fn(Remote<'_>) -> Result<(), &'static str> + Send + 'static,
) -> Result<impl Future<Output = ()>, ClusterError> {
    let subscribe = |kind: &str| {
        let wildcard = subject(kind, "*", "*");
        async move {
            client
                .subscribe(wildcard.clone())
                .await
                .map_err(|source| ClusterError::Subscribe {
                    subject: wildcard,
                    source,
                })
        }
    };
    let params = subscribe(PARAMS).await?;
    let audio = subscribe(AUDIO).await?;
    let mut messages = futures_util::stream::select(params, audio);
    Ok(async move {
        while let Some(message) = messages.next().await {
            telemetry.bus_messages_in.inc();
            if let Err(code) = read(&message, &seal, &mask).and_then(&deliver) {
                telemetry.bus_dropped(code);
            }
        }
    })
}

/// One bus message after the checks a producer's socket makes (and the cluster key's
/// proof, when set); the error is why it was dropped.
fn read<'a>(message: &'a async_nats::Message, seal: &Seal, mask: &Mask) -> Result<Remote<'a>, &'static str> {
    if !seal.admits(&message.subject, message.headers.as_ref(), &message.payload) {
        return Err("bad_mac");
    }
    let mut tokens = message.subject.split('.').skip(1);
    let (Some(kind), Some(head), Some(stream), None) =
        (tokens.next(), tokens.next(), tokens.next(), tokens.next())
    else {
        return Err("bad_subject");
    };
    if kind != PARAMS && kind != AUDIO {
        return Err("bad_subject");
    }
    let header = |name: &str| {
        message
            .headers
            .as_ref()
            .and_then(|h| h.get(name))
            .map(|v| v.as_str().to_string())
    };
    let lease = header(LEASE)
        .and_then(|v| v.parse::<u64>().ok())
        .ok_or("bad_header")?;
    let body = if kind == AUDIO {
        let chunk = AudioChunk::decode(&message.payload).map_err(|e| {
            tracing::warn!(subject = %message.subject, error = %e, "bus audio refused");
            "bad_audio"
        })?;
        RemoteBody::Audio(RelayedAudio {
            codec: chunk.body.codec(),
            bytes: message.payload.clone(),
        })
    } else if let Some(reason) = header(END) {
        RemoteBody::End(serde_json::from_value(serde_json::Value::String(reason)).map_err(|_| "bad_end")?)
    } else {
        let received_us = header(RECEIVED_US)
            .and_then(|v| v.parse::<u64>().ok())
            .ok_or("bad_header")?;
        let text = std::str::from_utf8(&message.payload).map_err(|_| "bad_frame")?;
        let frame = parse_message("bus", text.trim_end(), mask).map_err(|e| {
            tracing::warn!(subject = %message.subject, error = %e, "bus frame refused");
            "bad_frame"
        })?;
        let now = crate::server::now_us();
        let received_us = received_us.clamp(now.saturating_sub(MAX_HOP_US), now);
        RemoteBody::Frame(ReceivedFrame { frame, received_us })
    };
    Ok(Remote {
        head,
        stream,
        lease,
        body,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A runtime whose one thread is held (as a frozen or starved process's is) shows one
    /// stall, counted once whoever sees it first; a runtime that ticks shows none.
    #[tokio::test(flavor = "current_thread")]
    async fn a_held_runtime_is_one_stall_and_a_ticking_one_none() {
        let watch = StallWatch::start();
        tokio::time::sleep(Duration::from_millis(300)).await;
        assert_eq!(watch.stalled_now(), 0, "ticking every {STALL_TICK:?}");
        std::thread::sleep(STALL + Duration::from_millis(200));
        assert_eq!(watch.stalled_now(), 1);
        assert_eq!(watch.stalled_now(), 1, "one gap counts once");
        // The ticker, running again, finds its own gap already counted.
        tokio::time::sleep(Duration::from_millis(300)).await;
        assert_eq!(watch.stalled_now(), 1);
    }
}
