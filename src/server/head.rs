//! One registered head: its registration status (awaited through a watch, never polled),
//! what viewers download once it is ready, its bound algorithms, and its live streams.
//! Deleting a head cancels its token: its registration stops, its producers and viewers
//! close, and a head registered again under the same id is a new entry.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Duration;

use bytes::Bytes;
use tokio::sync::watch;
use tokio_util::sync::CancellationToken;

use super::auth::TokenDigest;
use super::bindings::BindingCache;
use super::error::ApiError;
use super::ids::valid_id;
use super::recordings::{RecordingLimits, Recordings};
use super::store::HeadMeta;
use super::stream::Stream;
use crate::animate::AnimatedHead;
use crate::fit::FitReport;
use crate::stream::ArkitBasis;
use facewire_proto::codes::EndReason;
use facewire_proto::messages::{EyeInfo, FitSummary, HeadInfo, PartInfo};

/// An adult's iris and pupil radii (12 mm and 4 mm across), for drawing the eyes.
const IRIS_RADIUS_MM: f32 = 6.0;
const PUPIL_RADIUS_MM: f32 = 2.0;

/// A head's texture, for viewers: where the rest mesh sits on it (`uv.bin`, FWU1) and the
/// image as uploaded.
pub struct HeadTexture {
    pub uv_bin: Bytes,
    pub image: Bytes,
    pub content_type: &'static str,
}

/// A head ready to animate.
pub struct ReadyHead {
    pub animated: Arc<AnimatedHead>,
    /// `mesh.bin` (FWM1) and OBJ of the rest mesh.
    pub rest_bin: Bytes,
    pub rest_obj: Bytes,
    /// `lips.bin` (FWL1): where the rest mesh's lips are, for drawing them.
    pub lips_bin: Bytes,
    /// `mesh.bin` of each part, in `animated.parts` order, then of each eyeball.
    pub part_bins: Vec<Bytes>,
    /// `tongue.bin` (FWL1) of the part the tongue's shapes move, by its index in
    /// `animated.parts`: which of its vertices are the tongue itself.
    pub tongue_bin: Option<(usize, Bytes)>,
    /// Its texture, when it was registered with one and with texture coordinates.
    pub texture: Option<HeadTexture>,
    /// The fit's residuals and warnings, for head info.
    pub fit: FitSummary,
    /// The whole fit report, for `GET /v1/heads/{id}/fit`.
    pub fit_report: FitReport,
    /// `fit.png` from the front and the side, drawn when first asked for.
    pub fit_pictures: [OnceLock<Bytes>; 2],
    pub bindings: BindingCache,
    /// What ARKit weights do to its mask: its own targets' basis where it has them, the
    /// shipped basis elsewhere.
    pub arkit: Arc<ArkitBasis>,
}

impl ReadyHead {
    /// The parts as the snapshot and head info list them.
    pub fn part_infos(&self, head_id: &str) -> Vec<PartInfo> {
        let tongue_part = self.tongue_bin.as_ref().map(|(index, _)| *index);
        self.animated
            .parts
            .iter()
            .enumerate()
            .map(|(index, p)| PartInfo {
                name: p.name.clone(),
                role: p.role.name().to_string(),
                vertices: p.mesh.positions.len() as u32,
                triangles: p.mesh.triangles.len() as u32,
                mesh: format!("/v1/heads/{head_id}/parts/{}/mesh.bin", p.name),
                split_from: p.split_from.clone(),
                closed_pieces: Some(p.closed_pieces as u32),
                tongue_proper: (tongue_part == Some(index))
                    .then(|| format!("/v1/heads/{head_id}/parts/{}/tongue.bin", p.name)),
            })
            .collect()
    }

    /// The eyeballs as the snapshot and head info list them.
    pub fn eye_infos(&self, head_id: &str) -> Vec<EyeInfo> {
        let mm = self.animated.registration.mm_per_unit();
        self.animated
            .eyes
            .iter()
            .map(|e| EyeInfo {
                name: e.name.clone(),
                side: e.side.name().to_string(),
                vertices: e.mesh.positions.len() as u32,
                triangles: e.mesh.triangles.len() as u32,
                mesh: format!("/v1/heads/{head_id}/parts/{}/mesh.bin", e.name),
                centre: e.centre.to_array(),
                forward: e.forward.to_array(),
                radius: e.radius,
                iris_radius: IRIS_RADIUS_MM / mm,
                pupil_radius: PUPIL_RADIUS_MM / mm,
                split_from: e.split_from.clone(),
            })
            .collect()
    }

    /// A part's or an eyeball's `mesh.bin`, by name.
    pub fn part_bin(&self, name: &str) -> Option<&Bytes> {
        let animated = &self.animated;
        let index = animated
            .parts
            .iter()
            .map(|p| p.name.as_str())
            .chain(animated.eyes.iter().map(|e| e.name.as_str()))
            .position(|n| n == name)?;
        self.part_bins.get(index)
    }

    /// `tongue.bin` of part `name`, when the tongue's shapes move it.
    pub fn tongue_bin(&self, name: &str) -> Option<&Bytes> {
        let (index, bin) = self.tongue_bin.as_ref()?;
        (self.animated.parts[*index].name == name).then_some(bin)
    }
}

#[derive(Clone)]
pub enum HeadStatus {
    Registering { progress: f32 },
    Ready(Arc<ReadyHead>),
    Failed(String),
}

/// Per-head stream and recording limits (from the configuration).
#[derive(Debug, Clone)]
pub struct StreamLimits {
    pub max_streams: usize,
    pub linger: Duration,
    pub recordings: RecordingLimits,
}

pub struct HeadEntry {
    pub id: String,
    meta: HeadMeta,
    status: watch::Sender<HeadStatus>,
    streams: Mutex<HashMap<String, Arc<Stream>>>,
    limits: StreamLimits,
    /// Its recorded streams, for replay.
    pub recordings: Arc<Recordings>,
    /// Cancelled when the head is deleted.
    pub deleted: CancellationToken,
}

impl HeadEntry {
    /// A head entry; its recordings are kept in `recordings_dir` beyond this process when
    /// it is given.
    pub fn new(
        id: String,
        meta: HeadMeta,
        status: HeadStatus,
        limits: StreamLimits,
        recordings_dir: Option<std::path::PathBuf>,
    ) -> HeadEntry {
        HeadEntry {
            id,
            meta,
            status: watch::Sender::new(status),
            streams: Mutex::new(HashMap::new()),
            recordings: Arc::new(Recordings::new(limits.recordings.clone(), recordings_dir)),
            limits,
            deleted: CancellationToken::new(),
        }
    }

    pub fn status(&self) -> HeadStatus {
        self.status.borrow().clone()
    }

    pub fn set_status(&self, status: HeadStatus) {
        self.status.send_replace(status);
    }

    pub fn producer_token(&self) -> Option<TokenDigest> {
        self.meta.producer_token()
    }

    /// What tells this registration apart from another of the same id in the cluster.
    pub fn registration_tag(&self) -> Option<&str> {
        self.meta.registration_tag.as_deref()
    }

    /// The ready head, or why there is none now.
    pub fn ready(&self) -> Result<Arc<ReadyHead>, ApiError> {
        match self.status() {
            HeadStatus::Ready(ready) => Ok(ready),
            HeadStatus::Registering { progress } => Err(ApiError::Registering {
                id: self.id.clone(),
                percent: progress * 100.0,
            }),
            HeadStatus::Failed(error) => Err(ApiError::RegistrationFailed {
                id: self.id.clone(),
                error,
            }),
        }
    }

    /// Waits up to `limit` for the registration to finish.
    pub async fn wait_ready(&self, limit: Duration) -> Result<Arc<ReadyHead>, ApiError> {
        let mut status = self.status.subscribe();
        let finished = |s: &HeadStatus| !matches!(s, HeadStatus::Registering { .. });
        let _ = tokio::time::timeout(limit, status.wait_for(finished)).await;
        self.ready()
    }

    /// The stream `name`, made if it does not exist and the head has room for it.
    pub fn stream(&self, name: &str) -> Result<Arc<Stream>, ApiError> {
        if !valid_id(name) {
            return Err(ApiError::BadId {
                what: "stream name",
                id: name.to_string(),
            });
        }
        let mut streams = self.streams.lock().expect("streams lock");
        if let Some(stream) = streams.get(name) {
            return Ok(stream.clone());
        }
        if streams.len() >= self.limits.max_streams {
            let now = tokio::time::Instant::now();
            streams.retain(|_, s| s.is_live(now, self.limits.linger));
            if streams.len() >= self.limits.max_streams {
                return Err(ApiError::LimitReached(format!(
                    "head {:?} has {} live streams, the most it takes; end one or wait {} s after it ends",
                    self.id,
                    streams.len(),
                    self.limits.linger.as_secs_f64()
                )));
            }
        }
        let stream = Arc::new(Stream::new(name));
        streams.insert(name.to_string(), stream.clone());
        Ok(stream)
    }

    /// Every stream of the head now.
    pub fn streams(&self) -> Vec<Arc<Stream>> {
        self.streams
            .lock()
            .expect("streams lock")
            .values()
            .cloned()
            .collect()
    }

    /// The stream `name` if it exists.
    pub fn existing_stream(&self, name: &str) -> Option<Arc<Stream>> {
        self.streams.lock().expect("streams lock").get(name).cloned()
    }

    /// Drops streams with no producer, no viewer and nothing for `stream_linger_s`.
    pub fn sweep(&self, now: tokio::time::Instant) {
        self.streams
            .lock()
            .expect("streams lock")
            .retain(|_, s| s.is_live(now, self.limits.linger));
    }

    /// Ends every stream (the head is going away).
    pub fn end_streams(&self, reason: EndReason) {
        for stream in self.streams.lock().expect("streams lock").values() {
            stream.end(reason);
        }
    }

    pub fn stream_count(&self) -> usize {
        self.streams.lock().expect("streams lock").len()
    }

    pub fn info(&self) -> HeadInfo {
        let (status, progress, error, ready) = match self.status() {
            HeadStatus::Registering { progress } => ("registering", progress, None, None),
            HeadStatus::Ready(r) => ("ready", 1.0, None, Some(r)),
            HeadStatus::Failed(e) => ("failed", 0.0, Some(e), None),
        };
        let now = tokio::time::Instant::now();
        let mut streams: Vec<String> = self
            .streams
            .lock()
            .expect("streams lock")
            .values()
            .filter(|s| s.is_live(now, self.limits.linger))
            .map(|s| s.name.clone())
            .collect();
        streams.sort();
        let reg = ready.as_ref().map(|r| &r.animated.registration);
        HeadInfo {
            id: self.id.clone(),
            vertices: reg.map_or(0, |r| r.vertex_count() as u32),
            triangles: reg.map_or(0, |r| r.head.triangles.len() as u32),
            mm_per_unit: reg.map_or(0.0, |r| r.mm_per_unit()),
            status: status.into(),
            progress,
            error,
            streams,
            parts: ready.as_ref().map(|r| r.part_infos(&self.id)).unwrap_or_default(),
            eyes: ready.as_ref().map(|r| r.eye_infos(&self.id)).unwrap_or_default(),
            fit: ready.as_ref().map(|r| r.fit.clone()),
            algorithms: ready.map(|r| r.bindings.bound()).unwrap_or_default(),
            source: None,
            arkit_blendshapes: self.meta.arkit_blendshapes.clone(),
        }
    }
}
