//! Parameter frames and stream ends between nodes. A producer's node publishes each
//! accepted frame, as one line of facewire's JSONL (docs/STREAMS.md), on
//! `facewire.params.<head>.<stream>`; every node subscribes to `facewire.params.*.*` and
//! publishes what arrives into its own copy of the stream, where its pipelines deform it
//! for its viewers. Vertex arrays never cross the bus.
//!
//! Sending never waits on the network: frames go through a bounded queue to one task that
//! owns the publishing, so one node's frames keep their order, and a queue full because
//! NATS is away drops frames (counted in `facewire_bus_dropped_total{code="queue_full"}`)
//! instead of holding a producer up.

use std::future::Future;
use std::sync::Arc;

use async_nats::HeaderMap;
use bytes::Bytes;
use futures_util::StreamExt;
use tokio::sync::mpsc;

use super::lease::Lease;
use super::{ClusterError, PREFIX};
use crate::mask::Mask;
use crate::server::registry::Registry;
use crate::server::stream::{ReceivedFrame, Relay};
use crate::server::telemetry::Telemetry;
use crate::stream::jsonl::{parse_message, JsonlWriter};
use facewire_proto::codes::EndReason;

/// Header with the producer's node's receive time, µs since the Unix epoch.
const RECEIVED_US: &str = "Facewire-Received-Us";
/// Header that makes a message a stream end; its value is the end reason's wire name.
const END: &str = "Facewire-End";
/// Frames waiting to be published, over all of this node's producers: 2 s of 64 streams
/// at 30 fps.
const QUEUE: usize = 4096;

fn subject(head: &str, stream: &str) -> String {
    format!("{PREFIX}.params.{head}.{stream}")
}

enum Outgoing {
    Frame {
        subject: Arc<str>,
        frame: Arc<ReceivedFrame>,
    },
    End {
        subject: Arc<str>,
        reason: EndReason,
    },
}

/// The sending side: a queue and the task that publishes what is in it.
pub struct Outbox {
    queue: mpsc::Sender<Outgoing>,
    telemetry: Arc<Telemetry>,
}

impl Outbox {
    pub fn start(client: async_nats::Client, mask: Arc<Mask>, telemetry: Arc<Telemetry>) -> Outbox {
        let (queue, outgoing) = mpsc::channel(QUEUE);
        tokio::spawn(publish(client, mask, outgoing, telemetry.clone()));
        Outbox { queue, telemetry }
    }

    /// A relay for one producer of `head`'s `stream`, holding its lease.
    pub fn relay(&self, head: &str, stream: &str, lease: Lease) -> BusRelay {
        BusRelay {
            subject: subject(head, stream).into(),
            queue: self.queue.clone(),
            telemetry: self.telemetry.clone(),
            _lease: lease,
        }
    }
}

/// One producer's frames onto the bus; dropping it releases the stream's lease.
pub struct BusRelay {
    subject: Arc<str>,
    queue: mpsc::Sender<Outgoing>,
    telemetry: Arc<Telemetry>,
    _lease: Lease,
}

impl BusRelay {
    fn send(&self, outgoing: Outgoing) {
        if self.queue.try_send(outgoing).is_err() {
            self.telemetry.bus_dropped("queue_full");
        }
    }
}

impl Relay for BusRelay {
    fn frame(&self, frame: &Arc<ReceivedFrame>) {
        self.send(Outgoing::Frame {
            subject: self.subject.clone(),
            frame: frame.clone(),
        });
    }

    fn end(&self, reason: EndReason) {
        // A node shutting down is not the stream ending: its producer may go on from
        // another node, and the other nodes' viewers keep watching.
        if reason != EndReason::ServerShutdown {
            self.send(Outgoing::End {
                subject: self.subject.clone(),
                reason,
            });
        }
    }
}

async fn publish(
    client: async_nats::Client,
    mask: Arc<Mask>,
    mut outgoing: mpsc::Receiver<Outgoing>,
    telemetry: Arc<Telemetry>,
) {
    let mut line = Vec::new();
    while let Some(message) = outgoing.recv().await {
        let mut headers = HeaderMap::new();
        let (subject, payload) = match message {
            Outgoing::Frame { subject, frame } => {
                line.clear();
                let mut writer = JsonlWriter::new(&mut line, &mask);
                if let Err(e) = writer.write_frame(&frame.frame) {
                    // Frames were checked on the way in; this is a defect, not input.
                    tracing::error!(error = %e, "frame not relayed");
                    telemetry.bus_dropped("unwritable");
                    continue;
                }
                headers.insert(RECEIVED_US, frame.received_us.to_string().as_str());
                (subject, Bytes::copy_from_slice(&line))
            }
            Outgoing::End { subject, reason } => {
                headers.insert(END, reason.as_str());
                (subject, Bytes::new())
            }
        };
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

/// Subscribes this node to every stream's frames; the returned future relays them into
/// `registry`'s streams until the connection closes.
pub async fn inbound(
    client: &async_nats::Client,
    registry: Registry,
    mask: Arc<Mask>,
    telemetry: Arc<Telemetry>,
) -> Result<impl Future<Output = ()>, ClusterError> {
    let wildcard = format!("{PREFIX}.params.*.*");
    let mut messages =
        client
            .subscribe(wildcard.clone())
            .await
            .map_err(|source| ClusterError::Subscribe {
                subject: wildcard,
                source,
            })?;
    Ok(async move {
        while let Some(message) = messages.next().await {
            telemetry.bus_messages_in.inc();
            if let Err(code) = deliver(&message, &registry, &mask, &telemetry) {
                telemetry.bus_dropped(code);
            }
        }
    })
}

/// Publishes one bus message into its local stream; the error is why it was dropped.
fn deliver(
    message: &async_nats::Message,
    registry: &Registry,
    mask: &Mask,
    telemetry: &Telemetry,
) -> Result<(), &'static str> {
    let mut tokens = message.subject.split('.').skip(2);
    let (Some(head), Some(stream)) = (tokens.next(), tokens.next()) else {
        return Err("bad_subject");
    };
    let header = |name: &str| {
        message
            .headers
            .as_ref()
            .and_then(|h| h.get(name))
            .map(|v| v.as_str().to_string())
    };
    let head = registry.get(head).ok_or("unknown_head")?;
    let stream = head.stream(stream).map_err(|_| "stream_limit")?;
    if let Some(reason) = header(END) {
        let reason: EndReason =
            serde_json::from_value(serde_json::Value::String(reason)).map_err(|_| "bad_end")?;
        stream.end(reason);
        return Ok(());
    }
    let received_us = header(RECEIVED_US)
        .and_then(|v| v.parse::<u64>().ok())
        .ok_or("bad_header")?;
    let text = std::str::from_utf8(&message.payload).map_err(|_| "bad_frame")?;
    let frame = parse_message("bus", text.trim_end(), mask).map_err(|e| {
        tracing::warn!(subject = %message.subject, error = %e, "bus frame refused");
        "bad_frame"
    })?;
    telemetry
        .bus_hop_seconds
        .observe(crate::server::now_us().saturating_sub(received_us) as f64 * 1e-6);
    stream.publish_relayed(Arc::new(ReceivedFrame { frame, received_us }));
    Ok(())
}
