//! What a frame measures on the deformed head: lip roughness (a row per lip vertex and the
//! summary), lip folds, optionally the face's folds, and the per-vertex heat a viewer asked
//! for. Built once per head (the edge maps and regions are made here) and run once per
//! frame by [`super::FrameJob::measure`], allocating nothing. The server's viewer frames,
//! `facewire deform`'s `metrics.tsv` and `folds.tsv`, and `facewire compare`'s report all
//! read these meters, so their numbers agree by construction.

use super::{AnimatedHead, Heat};
use crate::metrics::{
    FoldMeter, Folds, LipRoughness, LipRoughnessRow, RegionError, Roughness, RoughnessError, LIP_ROWS,
};
use glam::Vec3;

#[derive(Debug, thiserror::Error)]
pub enum MeterError {
    #[error("roughness: {0}")]
    Roughness(#[from] RoughnessError),
    #[error("folds: {0}")]
    Folds(#[from] RegionError),
}

/// The meter behind a frame's per-vertex values.
enum HeatMeter {
    Roughness(Roughness),
    Folds(FoldMeter),
}

/// A frame's measures, as the last [`FrameMeters::measure`] left them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameMeasures<'a> {
    /// Lip roughness: the 18 lip vertices in `LIP_VERTICES` order, then the summary row.
    pub lip_rows: &'a [LipRoughnessRow; LIP_ROWS],
    /// Lip triangles turned from rest.
    pub lip_folds: Folds,
    /// The face's triangles turned from rest, when the meters were made with a face.
    pub face_folds: Option<Folds>,
    /// One value per head vertex: the heat asked for ([`Heat`]), `None` for none.
    pub heat: Option<&'a [f32]>,
}

/// The meters of one head, and their last frame's measures.
pub struct FrameMeters {
    lip: LipRoughness,
    lip_folds: FoldMeter,
    face_folds: Option<FoldMeter>,
    heat: Option<(HeatMeter, Vec<f32>)>,
    lip_rows: [LipRoughnessRow; LIP_ROWS],
    last_lip_folds: Folds,
    last_face_folds: Option<Folds>,
}

impl FrameMeters {
    /// The meters of `head`'s lips, with `heat`'s per-vertex values.
    pub fn new(head: &AnimatedHead, heat: Heat) -> Result<FrameMeters, MeterError> {
        let mesh = &head.registration.head;
        let n = mesh.positions.len();
        let lip = LipRoughness::new(mesh, &head.lip_region)?;
        let lip_folds = FoldMeter::new(mesh, head.lip_region.union())?;
        let heat = match heat {
            Heat::None => None,
            Heat::Roughness => Some((HeatMeter::Roughness(Roughness::whole_mesh(mesh)?), vec![0.0; n])),
            Heat::Folds => {
                let all_triangles: Vec<u32> = (0..mesh.triangles.len() as u32).collect();
                Some((
                    HeatMeter::Folds(FoldMeter::new(mesh, &all_triangles)?),
                    vec![0.0; n],
                ))
            }
        };
        let empty = LipRoughnessRow {
            frame: 0,
            time_s: 0.0,
            mask_vertex: 0,
            min: 0.0,
            max: 0.0,
            mean: 0.0,
        };
        Ok(FrameMeters {
            lip,
            lip_folds,
            face_folds: None,
            heat,
            lip_rows: [empty; LIP_ROWS],
            last_lip_folds: Folds::default(),
            last_face_folds: None,
        })
    }

    /// Also measures the folds of `face_triangles` (head triangle indices), as `facewire
    /// deform` and `facewire compare` report them.
    pub fn with_face_folds(
        mut self,
        head: &AnimatedHead,
        face_triangles: &[u32],
    ) -> Result<FrameMeters, MeterError> {
        self.face_folds = Some(FoldMeter::new(&head.registration.head, face_triangles)?);
        Ok(self)
    }

    /// Measures the deformed head `positions` (head units, before the head's own motion)
    /// of frame `seq` at `time_s`. Allocates nothing.
    pub fn measure(
        &mut self,
        positions: &[Vec3],
        seq: u64,
        time_s: f64,
    ) -> Result<FrameMeasures<'_>, MeterError> {
        self.lip_rows = self.lip.rows(positions, seq, time_s)?;
        self.last_lip_folds = self.lip_folds.measure(positions)?;
        self.last_face_folds = match &mut self.face_folds {
            Some(meter) => Some(meter.measure(positions)?),
            None => None,
        };
        match &mut self.heat {
            Some((HeatMeter::Roughness(roughness), values)) => {
                roughness.face_vertex_roughness(positions, values)?;
            }
            Some((HeatMeter::Folds(meter), values)) => {
                meter.measure(positions)?;
                meter.vertex_turns_deg(values);
            }
            None => {}
        }
        Ok(self.last())
    }

    /// The measures of the last [`FrameMeters::measure`].
    pub fn last(&self) -> FrameMeasures<'_> {
        FrameMeasures {
            lip_rows: &self.lip_rows,
            lip_folds: self.last_lip_folds,
            face_folds: self.last_face_folds,
            heat: self.heat.as_ref().map(|(_, values)| values.as_slice()),
        }
    }
}
