//! The per-frame job for one head and one algorithm, in three stages a caller runs in
//! order and may time apart:
//!
//! 1. [`FrameJob::deform`]: pose the mask from a frame, deform the head, find the head's
//!    own rigid motion and the jaw's (kept apart from the deformation), shape the tongue,
//!    bring the lower lip to the upper teeth on f and v, keep the lips and the tongue out
//!    of the teeth, turn the eyes with the gaze and keep the lids out of them;
//! 2. [`FrameJob::measure`]: the frame's [`FrameMeters`] (lip roughness and folds, the
//!    heat asked for);
//! 3. [`FrameJob::encode`]: quantize the deltas and encode the viewer frame with those
//!    measures (or [`FrameJob::encode_json`], the baseline, which carries none).
//!
//! Every buffer is made once, in [`FrameJob::new`].

use std::sync::Arc;

use glam::Vec3;

use super::frame_meters::{FrameMeasures, FrameMeters, MeterError};
use super::json_frame::write_json_frame;
use super::{head_motion, jaw_motion, AnimatedHead, ContactScratch, Gaze, LabiodentalScratch, RigidMotion};
use crate::deform::{Binding, DeformScratch};
use crate::mask::LIP_VERTICES;
use crate::stream::{ArkitBasis, Frame, FramePoser};
use facewire_proto::viewer_frame::{
    EyeMotion, FrameContent, FrameEncoder, FrameHeader, FrameLayout, LipFolds, LipRoughness as WireLip,
};

/// What a frame's per-vertex values (the page's heat-map) measure.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum Heat {
    /// No per-vertex values.
    #[default]
    None,
    /// Face roughness: mean `1 - n.n` around each vertex.
    Roughness,
    /// Folds: the largest turn of each vertex's triangles from rest, degrees, after the
    /// head's own rigid motion is taken out (docs/METRICS.md, "Folds").
    Folds,
}

impl Heat {
    /// Its name in a viewer's query and the snapshot (`None` for no values).
    pub fn name(self) -> Option<&'static str> {
        match self {
            Heat::None => None,
            Heat::Roughness => Some("roughness"),
            Heat::Folds => Some("folds"),
        }
    }
}

/// The server's clock readings a viewer frame carries (µs since the Unix epoch).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FrameTimes {
    /// When the parameters were received.
    pub received_us: u64,
    /// When the frame is published to viewers.
    pub send_us: u64,
}

#[derive(Debug, thiserror::Error)]
pub enum FrameJobError {
    #[error(transparent)]
    Meter(#[from] MeterError),
    /// Cannot happen for frames within the documented parameter ranges; checked so that
    /// nothing non-finite ever reaches a viewer.
    #[error("frame {seq}: the deformed head has a non-finite position at vertex {vertex}")]
    NonFinite { seq: u64, vertex: usize },
}

/// One head seen through one algorithm, frame after frame.
pub struct FrameJob {
    head: Arc<AnimatedHead>,
    binding: Arc<Binding>,
    basis: Arc<ArkitBasis>,
    poser: FramePoser,
    scratch: DeformScratch,
    deformed: Vec<Vec3>,
    head_motion: RigidMotion,
    jaw_motion: RigidMotion,
    deltas: Vec<[f32; 3]>,
    /// The tongue's deltas (head units, before the jaw's motion), when the last frame
    /// shaped it; empty for a head without a tongue.
    tongue: Vec<Vec3>,
    tongue_shaped: bool,
    tongue_wire: Vec<[f32; 3]>,
    /// Buffers of the head's contact constraint; `None` for a head without teeth.
    contact: Option<ContactScratch>,
    /// Buffers of the lower lip's contact with the upper teeth on f and v.
    labiodental: Option<LabiodentalScratch>,
    /// Each eyeball's motion in the last frame (the head's `eyes` order), and the turned
    /// ones as a viewer frame carries them.
    eye_motions: Vec<RigidMotion>,
    eye_wire: Vec<EyeMotion>,
    meters: FrameMeters,
    /// The last deformed frame was measured: [`FrameJob::encode`] may send its measures.
    measured: bool,
    lip_wire: WireLip,
    encoder: FrameEncoder,
    /// The last [`FrameJob::encode_json`] frame.
    json: Vec<u8>,
}

impl FrameJob {
    /// A job for `head` deformed by `binding` (bound on that head), retargeting ARKit
    /// weights through `basis`; `heat` adds per-vertex values to every frame.
    pub fn new(
        head: Arc<AnimatedHead>,
        binding: Arc<Binding>,
        basis: Arc<ArkitBasis>,
        heat: Heat,
    ) -> Result<FrameJob, FrameJobError> {
        let meters = FrameMeters::new(&head, heat)?;
        Ok(FrameJob::with_meters(head, binding, basis, meters))
    }

    /// A job whose frames are measured by `meters` (made for `head`).
    pub fn with_meters(
        head: Arc<AnimatedHead>,
        binding: Arc<Binding>,
        basis: Arc<ArkitBasis>,
        meters: FrameMeters,
    ) -> FrameJob {
        let reg = &head.registration;
        let n = reg.vertex_count();
        let tongue_n = head.tongue.as_ref().map_or(0, |(_, t)| t.vertex_count());
        FrameJob {
            poser: FramePoser::new(&reg.fitted),
            scratch: binding.scratch(reg.mask_rest().len(), reg.mask_triangles().len()),
            deformed: vec![Vec3::ZERO; n],
            head_motion: RigidMotion::IDENTITY,
            jaw_motion: RigidMotion::IDENTITY,
            deltas: vec![[0.0; 3]; n],
            tongue: vec![Vec3::ZERO; tongue_n],
            tongue_shaped: false,
            tongue_wire: vec![[0.0; 3]; tongue_n],
            contact: head.contact.as_ref().map(|c| c.scratch(n, tongue_n)),
            labiodental: head.labiodental.as_ref().map(|c| c.scratch(n)),
            eye_motions: vec![RigidMotion::IDENTITY; head.eyes.len()],
            eye_wire: Vec::with_capacity(head.eyes.len()),
            meters,
            measured: false,
            lip_wire: WireLip {
                per_vertex: vec![0.0; LIP_VERTICES.len()],
                ..WireLip::default()
            },
            encoder: FrameEncoder::for_head(n + tongue_n, LIP_VERTICES.len()),
            json: Vec::new(),
            head,
            binding,
            basis,
        }
    }

    pub fn head(&self) -> &AnimatedHead {
        &self.head
    }

    /// Poses the mask from `frame` and deforms the head: the deformed vertices, head
    /// units, in the head's vertex order, before the head's own motion
    /// ([`FrameJob::head_motion`] has that).
    pub fn deform(&mut self, frame: &Frame) -> &[Vec3] {
        self.measured = false;
        let reg = &self.head.registration;
        self.head_motion = head_motion(frame, &reg.fitted.fit.pose);
        let mask_now = self.poser.pose(&reg.fitted, &self.basis, frame);
        self.binding.deform(
            &reg.head.positions,
            reg.mask_rest(),
            mask_now,
            reg.mask_triangles(),
            &mut self.scratch,
            &mut self.deformed,
        );
        if self.head.has_jaw_parts() {
            self.jaw_motion = jaw_motion(reg.mask_rest(), mask_now, &reg.fitted.fit.pose);
        }
        if let Some((_, shaper)) = &self.head.tongue {
            self.tongue_shaped = shaper.shape(frame, &mut self.tongue);
        }
        if let (Some(labiodental), Some(scratch)) = (&self.head.labiodental, &mut self.labiodental) {
            let share = labiodental.share(self.poser.weights());
            labiodental.apply(&reg.head.topology, &mut self.deformed, share, scratch);
        }
        if let (Some(contact), Some(scratch)) = (&self.head.contact, &mut self.contact) {
            let tongue = self.head.tongue.as_ref().map(|_| self.tongue.as_mut_slice());
            let applied = contact.apply(&mut self.deformed, self.jaw_motion.affine(), tongue, scratch);
            self.tongue_shaped |= applied.tongue_pushed > 0;
        }
        for (motion, eye) in self.eye_motions.iter_mut().zip(&self.head.eyes) {
            *motion = Gaze::of(frame, eye.side).motion_of(eye, &reg.fitted.fit.pose);
        }
        if let Some(eyelids) = &self.head.eyelids {
            eyelids.apply(&mut self.deformed, &self.eye_motions);
        }
        &self.deformed
    }

    /// Each eyeball's motion (the head's `eyes` order) in the frame of the last
    /// [`FrameJob::deform`], before the head's motion; empty for a head without eyes.
    pub fn eye_motions(&self) -> &[RigidMotion] {
        &self.eye_motions
    }

    /// The head's own motion in the frame of the last [`FrameJob::deform`]: where the
    /// deformed head is placed.
    pub fn head_motion(&self) -> RigidMotion {
        self.head_motion
    }

    /// The jaw's motion in the frame of the last [`FrameJob::deform`], before the head's
    /// (parts that move with the jaw are placed by the head's motion after it); the
    /// identity for a head without such parts, which has nothing for it to move.
    pub fn jaw_motion(&self) -> RigidMotion {
        self.jaw_motion
    }

    /// The tongue's deltas in the frame of the last [`FrameJob::deform`] (head units,
    /// before the jaw's and the head's motions; add them to the tongue part's rest
    /// positions); empty for a head without a tongue, all zero for a tongue at rest.
    pub fn tongue_deltas(&self) -> &[Vec3] {
        &self.tongue
    }

    /// The head as the last [`FrameJob::deform`] left it, before the head's motion (head
    /// units).
    pub fn deformed(&self) -> &[Vec3] {
        &self.deformed
    }

    /// The moved mask of the last [`FrameJob::deform`], before the head's motion (head
    /// units).
    pub fn mask(&self) -> &[Vec3] {
        self.poser.posed()
    }

    /// Measures the head as [`FrameJob::deform`] left it, for `frame` (the rows carry its
    /// `seq` and time): what [`FrameJob::encode`] sends with it.
    pub fn measure(&mut self, frame: &Frame) -> Result<FrameMeasures<'_>, FrameJobError> {
        self.check_finite(frame)?;
        self.meters.measure(&self.deformed, frame.seq, frame.time_s)?;
        self.measured = true;
        Ok(self.meters.last())
    }

    /// Whether the tongue moved in the last [`FrameJob::deform`] (shaped by the frame or
    /// pushed out of the teeth).
    pub fn tongue_shaped(&self) -> bool {
        self.tongue_shaped
    }

    /// The head as [`FrameJob::deform`] left it as the naive JSON baseline: every position
    /// as a number, nothing else (`format=json` viewers, `facewire load --format json`).
    pub fn encode_json(&mut self, frame: &Frame) -> Result<&[u8], FrameJobError> {
        self.check_finite(frame)?;
        write_json_frame(frame.seq, frame.time_s, &self.deformed, &mut self.json);
        Ok(&self.json)
    }

    fn check_finite(&self, frame: &Frame) -> Result<(), FrameJobError> {
        match self.deformed.iter().position(|p| !p.is_finite()) {
            Some(vertex) => Err(FrameJobError::NonFinite {
                seq: frame.seq,
                vertex,
            }),
            None => Ok(()),
        }
    }

    /// Encodes the head as [`FrameJob::deform`] left it and [`FrameJob::measure`] measured
    /// it, for `frame`, as a viewer frame in `layout`: quantized deltas against the rest
    /// mesh, the head's and the jaw's motions, the tongue's deltas, lip roughness and folds,
    /// the label, per-vertex heat values if asked for.
    pub fn encode(
        &mut self,
        frame: &Frame,
        times: FrameTimes,
        layout: FrameLayout,
    ) -> Result<&[u8], FrameJobError> {
        debug_assert!(self.measured, "encode follows measure");
        // A measured frame was checked finite by the measure.
        if !self.measured {
            self.check_finite(frame)?;
        }
        let rest = &self.head.registration.head.positions;
        for ((d, now), rest) in self.deltas.iter_mut().zip(&self.deformed).zip(rest) {
            *d = (*now - *rest).to_array();
        }
        for (wire, delta) in self.tongue_wire.iter_mut().zip(&self.tongue) {
            *wire = delta.to_array();
        }
        let tongue_part = self.head.tongue.as_ref().map(|(part, _)| *part as u8);
        let measures = self.meters.last();
        let rows = measures.lip_rows;
        for (slot, row) in self.lip_wire.per_vertex.iter_mut().zip(rows) {
            *slot = row.mean as f32;
        }
        let summary = rows[rows.len() - 1];
        let folds = measures.lip_folds;
        self.lip_wire.min = summary.min as f32;
        self.lip_wire.max = summary.max as f32;
        self.lip_wire.mean = summary.mean as f32;
        let heat = measures.heat;
        self.eye_wire.clear();
        for (eye, motion) in self.eye_motions.iter().enumerate() {
            if let Some(motion) = motion.to_wire() {
                self.eye_wire.push(EyeMotion {
                    eye: eye as u8,
                    motion,
                });
            }
        }
        let header = FrameHeader {
            seq: frame.seq,
            producer_time_s: frame.time_s,
            server_receive_us: times.received_us,
            server_send_us: times.send_us,
        };
        Ok(self.encoder.encode(
            layout,
            &header,
            &FrameContent {
                step: self.head.step,
                deltas: &self.deltas,
                lip: &self.lip_wire,
                label: frame.label.as_deref(),
                heat,
                deflate: true,
                head: self.head_motion.to_wire(),
                jaw: self.jaw_motion.to_wire(),
                tongue: tongue_part
                    .filter(|_| self.tongue_shaped)
                    .map(|part| (part, self.tongue_wire.as_slice())),
                folds: Some(LipFolds {
                    turned_over_60: folds.turned_over_60.min(u32::from(u16::MAX)) as u16,
                    turned_over_90: folds.turned_over_90.min(u32::from(u16::MAX)) as u16,
                    max_dihedral_increase_deg: folds.max_dihedral_increase_deg as f32,
                }),
                eyes: &self.eye_wire,
                viseme: frame.viseme.and_then(|v| v.to_wire()),
            },
        ))
    }
}
