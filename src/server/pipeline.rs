//! A deform pipeline: for one stream and one algorithm, runs the per-frame job
//! ([`crate::animate::FrameJob`]) on the newest parameters (a heavy job off the async runtime), and
//! publishes each encoded frame once for all its viewers through a watch channel. Busy, it
//! skips to the newest parameters; it never skips the last frame before an end. It
//! retires itself when its last viewer leaves.

use std::panic::AssertUnwindSafe;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use axum::extract::ws::{Message, Utf8Bytes};
use bytes::Bytes;
use tokio::sync::watch;

use super::frames::{ParamTimeline, ReceivedFrame};
use super::telemetry::Telemetry;
use super::timeline::{Step, Timeline};
use super::trim::Trimmer;
use crate::animate::{FrameJob, FrameTimes, Heat};
use facewire_proto::viewer_frame::FrameLayout;

/// What a pipeline computes: an algorithm (canonical spec), the per-vertex values its
/// frames carry and how they go on the wire.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct PipelineKey {
    pub spec: String,
    pub heat: Heat,
    pub format: FrameFormat,
}

/// How a pipeline's frames go on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FrameFormat {
    /// Binary frames (proto/PROTOCOL.md): `FWF2` for the page and today's clients, the
    /// frozen `FWF1` for clients built before it.
    Binary(FrameLayout),
    /// Every position as JSON text, the naive baseline the binary frames are measured
    /// against.
    Json,
}

impl FrameFormat {
    /// Its name in a viewer's `format=` and the snapshot's `format`.
    pub fn name(self) -> &'static str {
        match self {
            FrameFormat::Binary(layout) => layout.name(),
            FrameFormat::Json => "json",
        }
    }
}

/// An encoded viewer frame, shared by every viewer of a pipeline.
#[derive(Debug)]
pub struct Encoded {
    /// The producer's sequence number.
    pub seq: u64,
    /// The WebSocket message: cloning it shares the bytes.
    pub message: Message,
    /// Its payload's length in bytes.
    pub bytes: usize,
    /// When it was published, for the publish-to-send latency.
    pub published: Instant,
}

pub struct Pipeline {
    output: watch::Sender<Timeline<Encoded>>,
    /// Set, under this lock, when the pipeline has no viewer and stops; viewers join
    /// under the same lock, so none joins a stopped pipeline.
    retired: Mutex<bool>,
}

impl Pipeline {
    /// Starts the pipeline's task: `job` turns each frame of `params` into a viewer frame.
    /// Returns the first viewer's receiver with it, so the pipeline never starts unwatched.
    pub fn start(
        job: FrameJob,
        format: FrameFormat,
        params: watch::Receiver<ParamTimeline>,
        trimmer: Arc<Trimmer>,
        telemetry: Arc<Telemetry>,
    ) -> (Arc<Pipeline>, watch::Receiver<Timeline<Encoded>>) {
        let (output, first) = watch::channel(Timeline::default());
        let pipeline = Arc::new(Pipeline {
            output,
            retired: Mutex::new(false),
        });
        let stages = Stages {
            format,
            trimmer,
            telemetry,
        };
        tokio::spawn(run(pipeline.clone(), Box::new(job), params, stages));
        (pipeline, first)
    }

    /// A receiver of the encoded frames; `None` once the pipeline has retired.
    pub fn subscribe(&self) -> Option<watch::Receiver<Timeline<Encoded>>> {
        let retired = self.retired.lock().expect("retired lock");
        (!*retired).then(|| self.output.subscribe())
    }

    pub fn is_retired(&self) -> bool {
        *self.retired.lock().expect("retired lock")
    }

    /// Retires the pipeline if nobody watches it; true when it did.
    fn retire_if_unwatched(&self) -> bool {
        let mut retired = self.retired.lock().expect("retired lock");
        if self.output.receiver_count() == 0 {
            *retired = true;
        }
        *retired
    }
}

/// A frame job that took less than this last time runs in the pipeline's own task; a
/// longer one goes to the blocking pool. Handing a job to the pool and back costs two
/// thread switches, which at the load budget (1,500 jobs a second of about 200 µs, the
/// default algorithm on the MakeHuman head) were a tenth of the server's CPU; a job this
/// short holds a runtime thread for less time than one viewer frame takes to send to a
/// few dozen viewers. Heavy jobs (dense heads, slow algorithms) stay off the runtime.
const RUN_IN_PLACE_UNDER: Duration = Duration::from_micros(500);

/// What a pipeline's task works with besides its job and its input.
struct Stages {
    format: FrameFormat,
    trimmer: Arc<Trimmer>,
    telemetry: Arc<Telemetry>,
}

async fn run(
    pipeline: Arc<Pipeline>,
    mut job: Box<FrameJob>,
    mut params: watch::Receiver<ParamTimeline>,
    stages: Stages,
) {
    let Stages {
        format,
        trimmer,
        telemetry,
    } = stages;
    telemetry.pipelines.inc();
    // The first frame's cost is unknown: it goes to the blocking pool.
    let mut last_job = RUN_IN_PLACE_UNDER;
    // Start from the newest frame, as a viewer joining now does.
    let mut done = params.borrow().join_point();
    params.mark_changed();
    loop {
        tokio::select! {
            changed = params.changed() => if changed.is_err() { break },
            _ = pipeline.output.closed() => {
                if pipeline.retire_if_unwatched() {
                    break;
                }
                continue;
            }
        }
        // The steps own their frames: the channel's lock is released before any await.
        let steps = params.borrow_and_update().steps_after(done);
        for step in steps {
            match step {
                Step::Frame(received) => {
                    let skipped = received.serial.saturating_sub(done + 1);
                    if skipped > 0 {
                        telemetry.skipped("deform", skipped);
                    }
                    done = received.serial;
                    let started = Instant::now();
                    let outcome = if last_job < RUN_IN_PLACE_UNDER {
                        std::panic::catch_unwind(AssertUnwindSafe(|| {
                            process(&mut job, format, &received.value, &telemetry)
                        }))
                        .map_err(|_| "the frame job panicked".to_string())
                    } else {
                        let job_telemetry = telemetry.clone();
                        let value = received.value.clone();
                        let handed = tokio::task::spawn_blocking(move || {
                            let encoded = process(&mut job, format, &value, &job_telemetry);
                            (job, encoded)
                        })
                        .await;
                        match handed {
                            Ok((returned, encoded)) => {
                                job = returned;
                                Ok(encoded)
                            }
                            Err(e) => return fail(&pipeline, &telemetry, &e.to_string()),
                        }
                    };
                    last_job = started.elapsed();
                    match outcome {
                        Ok(Some(encoded)) => pipeline
                            .output
                            .send_modify(|t| t.publish_at(received.serial, Arc::new(encoded))),
                        Ok(None) => {}
                        Err(e) => return fail(&pipeline, &telemetry, &e),
                    }
                }
                Step::End { serial, reason } => {
                    done = serial;
                    pipeline.output.send_modify(|t| t.end_at(serial, reason));
                }
            }
        }
    }
    *pipeline.retired.lock().expect("retired lock") = true;
    telemetry.pipelines.dec();
    drop(job);
    trimmer.request();
}

/// Stops a pipeline whose frame job failed (a bug: logged as an error).
fn fail(pipeline: &Pipeline, telemetry: &Telemetry, error: &str) {
    tracing::error!(error, "deform pipeline task failed");
    *pipeline.retired.lock().expect("retired lock") = true;
    telemetry.pipelines.dec();
}

fn message_len(message: &Message) -> usize {
    match message {
        Message::Binary(bytes) => bytes.len(),
        Message::Text(text) => text.len(),
        _ => 0,
    }
}

/// One frame through the job's stages, each timed apart; `None` (logged and counted) when
/// it cannot be shown. JSON frames carry no measures, so their pipelines measure nothing.
pub(super) fn process(
    job: &mut FrameJob,
    format: FrameFormat,
    received: &ReceivedFrame,
    telemetry: &Telemetry,
) -> Option<Encoded> {
    let frame = &received.frame;
    let started = Instant::now();
    job.deform(frame);
    let deformed_at = Instant::now();
    telemetry
        .deform_seconds
        .observe((deformed_at - started).as_secs_f64());
    let measured = match format {
        FrameFormat::Binary(_) => job.measure(frame).map(drop),
        FrameFormat::Json => Ok(()),
    };
    let measured_at = Instant::now();
    if format != FrameFormat::Json {
        telemetry
            .measure_seconds
            .observe((measured_at - deformed_at).as_secs_f64());
    }
    let times = FrameTimes {
        received_us: received.received_us,
        send_us: super::now_us(),
    };
    let encoded = measured.and_then(|()| match format {
        FrameFormat::Binary(layout) => job.encode(frame, times, layout),
        FrameFormat::Json => job.encode_json(frame),
    });
    let message = match encoded.map(Bytes::copy_from_slice) {
        Ok(bytes) if format != FrameFormat::Json => Message::Binary(bytes),
        Ok(bytes) => Message::Text(Utf8Bytes::try_from(bytes).expect("serde_json writes UTF-8")),
        Err(e) => {
            tracing::warn!(error = %e, "frame not shown");
            telemetry.reject("not_shown");
            return None;
        }
    };
    let published = Instant::now();
    telemetry
        .encode_seconds
        .observe((published - measured_at).as_secs_f64());
    telemetry.latency(
        "receive_to_publish",
        times.send_us.saturating_sub(received.received_us) as f64 * 1e-6,
    );
    Some(Encoded {
        seq: received.frame.seq,
        bytes: message_len(&message),
        message,
        published,
    })
}
