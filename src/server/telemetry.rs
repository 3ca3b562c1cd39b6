//! Service metrics in Prometheus text format (`GET /metrics`): frames in and out, skipped
//! frames, deform and encode time, viewers, producers, per-hop latency, and the process's
//! CPU time and resident memory. One registry per server instance, so tests can run
//! several servers in one process.

use std::sync::atomic::AtomicU64;

use prometheus_client::encoding::text::encode;
use prometheus_client::encoding::EncodeLabelSet;
use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::family::Family;
use prometheus_client::metrics::gauge::Gauge;
use prometheus_client::metrics::histogram::{exponential_buckets, Histogram};
use prometheus_client::registry::Registry;

use super::process;

#[derive(Debug, Clone, Hash, PartialEq, Eq, EncodeLabelSet)]
pub struct CodeLabel {
    pub code: String,
}

#[derive(Debug, Clone, Hash, PartialEq, Eq, EncodeLabelSet)]
pub struct StageLabel {
    pub stage: &'static str,
}

#[derive(Debug, Clone, Hash, PartialEq, Eq, EncodeLabelSet)]
pub struct HopLabel {
    pub hop: &'static str,
}

/// Every metric the service exports.
pub struct Telemetry {
    registry: Registry,
    /// Producer frames accepted.
    pub frames_in: Counter,
    /// Producer messages refused, by error code.
    pub frames_rejected: Family<CodeLabel, Counter>,
    /// Frames sent to viewers (one per viewer per frame).
    pub frames_out: Counter,
    /// Bytes of frames sent to viewers.
    pub bytes_out: Counter,
    /// Producer audio chunks accepted.
    pub audio_in: Counter,
    /// Audio chunks sent to viewers (one per viewer per chunk).
    pub audio_out: Counter,
    /// Times a viewer fell more than the backlog behind a stream's audio and was moved to
    /// its newest chunk.
    pub audio_resyncs: Counter,
    /// Frames skipped: `deform` (a pipeline was busy when newer parameters came) or
    /// `viewer` (a viewer was slower than the stream).
    pub frames_skipped: Family<StageLabel, Counter>,
    /// A frame's stages in a pipeline (`FrameJob`): deform, measure (lip roughness and
    /// folds, heat; binary frames only), encode.
    pub deform_seconds: Histogram,
    pub measure_seconds: Histogram,
    pub encode_seconds: Histogram,
    /// Latency per hop: `receive_to_publish` (parameters in to encoded frame out) and
    /// `publish_to_send` (encoded to written to a viewer socket).
    pub latency_seconds: Family<HopLabel, Histogram>,
    pub viewers: Gauge,
    pub producers: Gauge,
    /// Deform pipelines running (one per stream and algorithm with viewers).
    pub pipelines: Gauge,
    pub heads: Gauge,
    /// Automatic fits stopped because their request ended first.
    pub fits_cancelled: Counter,
    /// Cluster bus messages (frames and ends) published by this node's producers.
    pub bus_messages_out: Counter,
    /// Cluster bus messages received from other nodes.
    pub bus_messages_in: Counter,
    /// Bus messages dropped, by cause (`queue_full`, `unknown_head`, `bad_frame`, ...).
    pub bus_dropped: Family<CodeLabel, Counter>,
    /// Frames from other nodes: the producer's node's receipt to this node's, seconds, in
    /// buckets 20 % apart (the NATS hop is measured from these).
    pub bus_hop_seconds: Histogram,
    /// CPU seconds of the whole process, read when the metrics are rendered.
    process_cpu_seconds: Gauge<f64, AtomicU64>,
    /// Resident memory of the whole process, bytes, read when the metrics are rendered.
    process_resident_bytes: Gauge,
}

fn seconds_histogram() -> Histogram {
    // 10 us .. ~5 s
    Histogram::new(exponential_buckets(1e-5, 2.0, 20))
}

impl Default for Telemetry {
    fn default() -> Self {
        let mut registry = Registry::with_prefix("facewire");
        let t = Telemetry {
            frames_in: Counter::default(),
            frames_rejected: Family::default(),
            frames_out: Counter::default(),
            bytes_out: Counter::default(),
            audio_in: Counter::default(),
            audio_out: Counter::default(),
            audio_resyncs: Counter::default(),
            frames_skipped: Family::default(),
            deform_seconds: seconds_histogram(),
            measure_seconds: seconds_histogram(),
            encode_seconds: seconds_histogram(),
            latency_seconds: Family::new_with_constructor(seconds_histogram),
            viewers: Gauge::default(),
            producers: Gauge::default(),
            pipelines: Gauge::default(),
            heads: Gauge::default(),
            fits_cancelled: Counter::default(),
            bus_messages_out: Counter::default(),
            bus_messages_in: Counter::default(),
            bus_dropped: Family::default(),
            // 50 us .. ~0.45 s, each bucket 1.2 x the one before.
            bus_hop_seconds: Histogram::new(exponential_buckets(5e-5, 1.2, 50)),
            process_cpu_seconds: Gauge::default(),
            process_resident_bytes: Gauge::default(),
            registry: Registry::default(),
        };
        registry.register("frames_in", "Producer frames accepted", t.frames_in.clone());
        registry.register(
            "frames_rejected",
            "Producer messages refused, by code",
            t.frames_rejected.clone(),
        );
        registry.register("frames_out", "Frames sent to viewers", t.frames_out.clone());
        registry.register("audio_in", "Producer audio chunks accepted", t.audio_in.clone());
        registry.register("audio_out", "Audio chunks sent to viewers", t.audio_out.clone());
        registry.register(
            "audio_resyncs",
            "Viewers moved to a stream's newest audio after falling behind",
            t.audio_resyncs.clone(),
        );
        registry.register(
            "bytes_out",
            "Bytes of frames sent to viewers",
            t.bytes_out.clone(),
        );
        registry.register(
            "frames_skipped",
            "Frames skipped, by stage",
            t.frames_skipped.clone(),
        );
        registry.register(
            "deform_seconds",
            "Deform time per frame and algorithm",
            t.deform_seconds.clone(),
        );
        registry.register(
            "measure_seconds",
            "Measure time per frame (lip roughness and folds, heat)",
            t.measure_seconds.clone(),
        );
        registry.register(
            "encode_seconds",
            "Encode time per frame (quantize and write the viewer frame)",
            t.encode_seconds.clone(),
        );
        registry.register("latency_seconds", "Latency per hop", t.latency_seconds.clone());
        registry.register("viewers", "Connected viewers", t.viewers.clone());
        registry.register("producers", "Connected producers", t.producers.clone());
        registry.register("pipelines", "Deform pipelines running", t.pipelines.clone());
        registry.register("heads", "Registered heads", t.heads.clone());
        registry.register(
            "fits_cancelled",
            "Automatic fits stopped because their request ended first",
            t.fits_cancelled.clone(),
        );
        registry.register(
            "bus_messages_out",
            "Cluster bus messages published",
            t.bus_messages_out.clone(),
        );
        registry.register(
            "bus_messages_in",
            "Cluster bus messages received",
            t.bus_messages_in.clone(),
        );
        registry.register(
            "bus_dropped",
            "Cluster bus messages dropped, by cause",
            t.bus_dropped.clone(),
        );
        registry.register(
            "bus_hop_seconds",
            "Frames from other nodes: producer's node's receipt to this node's",
            t.bus_hop_seconds.clone(),
        );
        registry.register(
            "process_cpu_seconds",
            "CPU time of the server process, user and system",
            t.process_cpu_seconds.clone(),
        );
        registry.register(
            "process_resident_bytes",
            "Resident memory of the server process",
            t.process_resident_bytes.clone(),
        );
        Telemetry { registry, ..t }
    }
}

impl Telemetry {
    pub fn reject(&self, code: &str) {
        self.frames_rejected
            .get_or_create(&CodeLabel {
                code: code.to_string(),
            })
            .inc();
    }

    pub fn bus_dropped(&self, code: &'static str) {
        self.bus_dropped
            .get_or_create(&CodeLabel { code: code.into() })
            .inc();
    }

    pub fn skipped(&self, stage: &'static str, count: u64) {
        self.frames_skipped
            .get_or_create(&StageLabel { stage })
            .inc_by(count);
    }

    pub fn latency(&self, hop: &'static str, seconds: f64) {
        self.latency_seconds
            .get_or_create(&HopLabel { hop })
            .observe(seconds);
    }

    /// The exposition text, with the process's CPU time and memory read now.
    pub fn render(&self) -> String {
        self.process_cpu_seconds.set(process::cpu_seconds());
        self.process_resident_bytes
            .set(i64::try_from(process::resident_bytes()).unwrap_or(i64::MAX));
        let mut out = String::new();
        encode(&mut out, &self.registry).expect("writing to a String cannot fail");
        out
    }
}
