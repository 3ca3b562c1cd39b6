//! A deform pipeline: for one stream and one algorithm, turns the newest parameters into
//! an encoded viewer frame (pose the mask, deform, lip roughness, quantize) once, and
//! publishes it to every viewer through a watch channel, so a slow viewer skips to the
//! newest frame and never holds anyone up. The work runs off the async runtime.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use bytes::Bytes;
use glam::Vec3;
use tokio::sync::watch;

use super::channel::{Channel, Event, Params};
use super::registry::ReadyHead;
use super::telemetry::Telemetry;
use crate::deform::{Binding, DeformScratch};
use crate::mask::LIP_VERTICES;
use crate::metrics::{LipRoughness, Roughness};
use facewire_proto::frame::{FrameContent, FrameEncoder, FrameHeader, LipRoughness as WireLip};

/// An encoded frame, shared by every viewer of a pipeline.
#[derive(Debug)]
pub struct Encoded {
    pub seq: u64,
    pub bytes: Bytes,
    /// When it was published, for the publish-to-send latency.
    pub published: Instant,
}

#[derive(Debug, Clone)]
pub enum Output {
    Waiting,
    Frame(Arc<Encoded>),
    Ended(String),
}

pub struct Pipeline {
    output: watch::Sender<Output>,
    stopped: AtomicBool,
}

impl Pipeline {
    pub fn subscribe(&self) -> watch::Receiver<Output> {
        self.output.subscribe()
    }

    pub fn viewer_count(&self) -> usize {
        self.output.receiver_count()
    }

    pub fn is_stopped(&self) -> bool {
        self.stopped.load(Ordering::Acquire)
    }

    pub fn stop(&self) {
        self.stopped.store(true, Ordering::Release);
    }

    /// Starts a pipeline task for `channel` with `binding`.
    pub fn start(
        channel: Arc<Channel>,
        key: (String, bool),
        head: Arc<ReadyHead>,
        binding: Arc<Binding>,
        events: watch::Receiver<Event>,
        telemetry: Arc<Telemetry>,
    ) -> Arc<Pipeline> {
        let pipeline = Arc::new(Pipeline {
            output: watch::Sender::new(Output::Waiting),
            stopped: AtomicBool::new(false),
        });
        let worker = Worker::new(head, binding, key.1);
        tokio::spawn(run(channel, key, pipeline.clone(), worker, events, telemetry));
        pipeline
    }
}

async fn run(
    channel: Arc<Channel>,
    key: (String, bool),
    pipeline: Arc<Pipeline>,
    mut worker: Box<Worker>,
    mut events: watch::Receiver<Event>,
    telemetry: Arc<Telemetry>,
) {
    let mut last_seq: Option<u64> = None;
    while events.changed().await.is_ok() {
        let event = events.borrow_and_update().clone();
        match event {
            Event::Idle => {}
            Event::Ended(reason) => {
                last_seq = None;
                pipeline.output.send_replace(Output::Ended(reason));
            }
            Event::Frame(params) => {
                if let Some(previous) = last_seq {
                    if params.seq > previous + 1 {
                        telemetry.skipped("deform", params.seq - previous - 1);
                    }
                }
                last_seq = Some(params.seq);
                let telemetry_for_job = telemetry.clone();
                let job = tokio::task::spawn_blocking(move || {
                    let encoded = worker.process(&params, &telemetry_for_job);
                    (worker, encoded)
                });
                let (returned, encoded) = match job.await {
                    Ok(done) => done,
                    Err(e) => {
                        tracing::error!(error = %e, "deform pipeline failed");
                        pipeline
                            .output
                            .send_replace(Output::Ended("internal error".into()));
                        pipeline.stop();
                        return;
                    }
                };
                worker = returned;
                pipeline.output.send_replace(Output::Frame(Arc::new(encoded)));
            }
        }
        if pipeline.viewer_count() == 0 && channel.retire_pipeline(&key, &pipeline) {
            return;
        }
    }
    pipeline.stop();
}

/// The per-frame state of a pipeline, moved into a blocking task for each frame.
struct Worker {
    head: Arc<ReadyHead>,
    binding: Arc<Binding>,
    scratch: DeformScratch,
    mask_now: Vec<Vec3>,
    deformed: Vec<Vec3>,
    deltas: Vec<[f32; 3]>,
    lip: LipRoughness,
    lip_wire: WireLip,
    face: Option<(Roughness, Vec<f32>)>,
    encoder: FrameEncoder,
}

impl Worker {
    fn new(head: Arc<ReadyHead>, binding: Arc<Binding>, face: bool) -> Box<Worker> {
        let reg = &head.registration;
        let n = reg.vertex_count();
        let lip = LipRoughness::new(&reg.head, &head.lip_region).expect("lip region belongs to this head");
        let face = face.then(|| {
            (
                Roughness::whole_mesh(&reg.head).expect("whole mesh region"),
                vec![0.0; n],
            )
        });
        Box::new(Worker {
            scratch: binding.scratch(reg.mask_rest().len(), reg.mask_triangles().len()),
            mask_now: vec![Vec3::ZERO; reg.mask_rest().len()],
            deformed: vec![Vec3::ZERO; n],
            deltas: vec![[0.0; 3]; n],
            lip,
            lip_wire: WireLip {
                per_vertex: vec![0.0; LIP_VERTICES.len()],
                ..WireLip::default()
            },
            face,
            encoder: FrameEncoder::default(),
            head,
            binding,
        })
    }

    fn process(&mut self, params: &Params, telemetry: &Telemetry) -> Encoded {
        let started = Instant::now();
        let reg = &self.head.registration;
        reg.fitted
            .pose_with_offsets_into(&params.animation, &params.offsets, &mut self.mask_now);
        self.binding.deform(
            &reg.head.positions,
            reg.mask_rest(),
            &self.mask_now,
            reg.mask_triangles(),
            &mut self.scratch,
            &mut self.deformed,
        );
        let deformed_at = Instant::now();
        telemetry
            .deform_seconds
            .observe((deformed_at - started).as_secs_f64());

        for ((d, now), rest) in self
            .deltas
            .iter_mut()
            .zip(&self.deformed)
            .zip(&reg.head.positions)
        {
            *d = (*now - *rest).to_array();
        }
        if let Ok(rows) = self.lip.rows(&self.deformed, params.seq, params.time_s) {
            for (slot, row) in self.lip_wire.per_vertex.iter_mut().zip(&rows) {
                *slot = row.mean as f32;
            }
            let summary = rows[rows.len() - 1];
            self.lip_wire.min = summary.min as f32;
            self.lip_wire.max = summary.max as f32;
            self.lip_wire.mean = summary.mean as f32;
        }
        let face = match &mut self.face {
            Some((roughness, values)) => roughness
                .face_vertex_roughness(&self.deformed, values)
                .ok()
                .map(|_| values.as_slice()),
            None => None,
        };
        let header = FrameHeader {
            seq: params.seq,
            producer_time_s: params.time_s,
            server_receive_us: params.received_us,
            server_send_us: super::now_us(),
        };
        let bytes = Bytes::copy_from_slice(self.encoder.encode(
            &header,
            &FrameContent {
                step: self.head.step,
                deltas: &self.deltas,
                lip: &self.lip_wire,
                label: params.label.as_deref(),
                face,
                deflate: true,
            },
        ));
        let published = Instant::now();
        telemetry
            .encode_seconds
            .observe((published - deformed_at).as_secs_f64());
        telemetry.latency(
            "receive_to_publish",
            (header.server_send_us.saturating_sub(params.received_us)) as f64 * 1e-6,
        );
        Encoded {
            seq: params.seq,
            bytes,
            published,
        }
    }
}
