//! A fit's report, for people deciding whether to trust it: how far the fitted mask lies
//! from the head (mm), overall and per face region, and what looks wrong: mask vertices far
//! off the surface, parts of the mask with no head under them (a face-only mesh that ends
//! before the mask does), lips apart at rest (p, b and m may then not close them).
//!
//! Regions are [`FaceRegion`]s, fixed sets of CANDIDE-3 vertices, so every head's report
//! speaks of the same vertices.

use serde::Serialize;

use super::mouth_opening::{mouth_opening, MouthCalibration};
use super::residuals::DistanceStats;
use super::FittedMask;
use crate::head::Head;
use crate::mask::FaceRegion;

/// A mask vertex further than this from the surface (mm) is far off it.
pub const FAR_FROM_SURFACE_MM: f32 = 8.0;
/// Inner lips further apart than this at rest (mm) are apart.
pub const LIPS_APART_MM: f32 = 2.0;
/// A mask vertex whose nearest surface point is at the mesh's edge and further than this
/// (mm) has no head under it.
const PAST_EDGE_MM: f32 = 2.0;

/// Distances from one region's mask vertices to the surface, mm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RegionResidual {
    pub region: FaceRegion,
    #[serde(flatten)]
    pub distances: DistanceStats,
}

/// Something about a fit that a person should look at.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum FitWarning {
    /// Mask vertices more than [`FAR_FROM_SURFACE_MM`] from the surface.
    FarFromSurface {
        mask_vertices: Vec<u32>,
        worst_mask_vertex: u32,
        worst_mm: f32,
    },
    /// Mask vertices of `region` past the mesh's edge.
    NoHeadUnder {
        region: FaceRegion,
        mask_vertices: Vec<u32>,
    },
    /// The head's inner lips (at the mask's inner-lip middle) are `gap_mm` apart at rest.
    LipsApartAtRest { gap_mm: f32 },
    /// What the fit's maker asked a person to check (the fit file's `warnings`: the
    /// automatic fit's, [`crate::fit::AutomaticFitWarning`]).
    FromFit { note: String },
}

impl FitWarning {
    /// The warning as a sentence.
    pub fn message(&self) -> String {
        match self {
            FitWarning::FarFromSurface {
                mask_vertices,
                worst_mask_vertex,
                worst_mm,
            } => format!(
                "{} mask vertices lie more than {FAR_FROM_SURFACE_MM} mm from the surface, the worst \
                 (vertex {worst_mask_vertex}) {worst_mm:.1} mm: the mask does not follow the head there",
                mask_vertices.len()
            ),
            FitWarning::NoHeadUnder {
                region,
                mask_vertices,
            } => format!(
                "{}: {} mask vertices have no head under them (the mesh ends first); their motion \
                 moves nothing",
                region.name(),
                mask_vertices.len()
            ),
            FitWarning::FromFit { note } => note.clone(),
            FitWarning::LipsApartAtRest { gap_mm } => {
                format!("the inner lips are {gap_mm:.1} mm apart at rest: registering the head closes them (raising the jaw until they meet) so that p, b and m can")
            }
        }
    }
}

/// A warning with its sentence, as reports carry it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Warning {
    #[serde(flatten)]
    pub warning: FitWarning,
    pub message: String,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FitReport {
    pub mm_per_unit: f32,
    /// Every mask vertex a triangle uses, to the surface.
    pub surface: DistanceStats,
    pub regions: Vec<RegionResidual>,
    /// The mouth's opening at rest on the midline, mm: how far apart the inner lips are.
    pub inner_lip_gap_mm: f32,
    pub warnings: Vec<Warning>,
    /// For a registered head given with its lips apart: how registration closed them (the
    /// rest of the report is then about the closed head). `None` from [`report`].
    pub mouth_closed: Option<MouthCalibration>,
}

impl FitReport {
    /// The report with the notes a fit file carries (its `warnings`) added to its warnings.
    pub fn with_fit_notes(mut self, notes: &[String]) -> FitReport {
        self.warnings.extend(notes.iter().map(|note| {
            let warning = FitWarning::FromFit { note: note.clone() };
            Warning {
                message: warning.message(),
                warning,
            }
        }));
        self
    }
}

/// The report of `fitted` on `head`.
pub fn report(head: &Head, fitted: &FittedMask) -> FitReport {
    let mm = fitted.fit.mm_per_unit;
    let used = fitted.mask.used_vertices();
    let at_edge = edge_vertices(head);
    // (mask vertex, distance mm, nearest point at the mesh's edge)
    let distances: Vec<(u32, f32, bool)> = fitted
        .neutral
        .iter()
        .enumerate()
        .filter(|&(j, _)| used[j])
        .map(|(j, &p)| match head.surface.closest_point(p) {
            Some(s) => {
                let corners = head.triangles[s.triangle as usize];
                let edge = corners.iter().any(|&v| at_edge[v as usize]);
                (j as u32, s.distance * mm, edge && s.distance * mm > PAST_EDGE_MM)
            }
            None => (j as u32, f32::INFINITY, true),
        })
        .collect();
    let region_of = |j: u32| FaceRegion::of(fitted.mask.vertices[j as usize]);
    let surface = DistanceStats::of(distances.iter().map(|&(j, d, _)| (j, d)));
    let regions = FaceRegion::ALL
        .iter()
        .map(|&region| RegionResidual {
            region,
            distances: DistanceStats::of(
                distances
                    .iter()
                    .filter(|&&(j, ..)| region_of(j) == region)
                    .map(|&(j, d, _)| (j, d)),
            ),
        })
        .collect();
    let inner_lip_gap_mm =
        mouth_opening(&head.positions, &head.triangles, fitted).height() * fitted.mm_per_mask_unit() as f64;
    let inner_lip_gap_mm = inner_lip_gap_mm as f32;

    let mut warnings = Vec::new();
    // Eyes are often openings in the mesh (the eyeballs are separate meshes, or none):
    // mask vertices over them are expected to find the mesh's edge.
    let no_head_under = |j: u32, past_edge: bool| past_edge && region_of(j) != FaceRegion::Eyes;
    for region in FaceRegion::ALL {
        let mask_vertices: Vec<u32> = distances
            .iter()
            .filter(|&&(j, _, past_edge)| no_head_under(j, past_edge) && region_of(j) == region)
            .map(|&(j, ..)| j)
            .collect();
        if !mask_vertices.is_empty() {
            warnings.push(FitWarning::NoHeadUnder {
                region,
                mask_vertices,
            });
        }
    }
    let far: Vec<(u32, f32)> = distances
        .iter()
        .filter(|&&(j, d, past_edge)| !no_head_under(j, past_edge) && d > FAR_FROM_SURFACE_MM)
        .map(|&(j, d, _)| (j, d))
        .collect();
    if let Some(&(worst_mask_vertex, worst_mm)) = far.iter().max_by(|a, b| a.1.total_cmp(&b.1)) {
        warnings.push(FitWarning::FarFromSurface {
            mask_vertices: far.iter().map(|&(j, _)| j).collect(),
            worst_mask_vertex,
            worst_mm,
        });
    }
    if inner_lip_gap_mm > LIPS_APART_MM {
        warnings.push(FitWarning::LipsApartAtRest {
            gap_mm: inner_lip_gap_mm,
        });
    }
    FitReport {
        mm_per_unit: mm,
        surface,
        regions,
        inner_lip_gap_mm,
        warnings: warnings
            .into_iter()
            .map(|warning| Warning {
                message: warning.message(),
                warning,
            })
            .collect(),
        mouth_closed: None,
    }
}

/// Per head vertex: on the mesh's edge (an edge used by one triangle).
pub(crate) fn edge_vertices(head: &Head) -> Vec<bool> {
    let mut at_edge = vec![false; head.positions.len()];
    for edge in head.topology.edges.iter().filter(|e| e.triangles == 1) {
        at_edge[edge.a as usize] = true;
        at_edge[edge.b as usize] = true;
    }
    at_edge
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warnings_read_as_sentences() {
        let lips = FitWarning::LipsApartAtRest { gap_mm: 5.84 };
        assert_eq!(
            lips.message(),
            "the inner lips are 5.8 mm apart at rest: registering the head closes them (raising the jaw until they meet) so that p, b and m can"
        );
        let edge = FitWarning::NoHeadUnder {
            region: FaceRegion::ForeheadAndCheeks,
            mask_vertices: vec![0, 1],
        };
        assert!(edge.message().starts_with("forehead and cheeks: 2 mask vertices"));
        let note = FitWarning::FromFit {
            note: "automatic fit: check it".into(),
        };
        assert_eq!(note.message(), "automatic fit: check it");
    }
}
