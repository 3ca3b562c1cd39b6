//! The CANDIDE-3 face mask: its wireframe, animation units (FACS AUVs and MPEG-4 FAPs),
//! shape units, and the pose equation that moves it.
//!
//! Coordinates here are **mask units** in CANDIDE's model frame: +x is the face's left,
//! +y up, +z out of the face; the face is about 2 units tall. A [`MaskPose`] carries mask
//! units into a head's frame (head units).

pub mod fap;
mod pose;
mod region;
mod wfm;

use std::path::Path;

use glam::Vec3;

use crate::input::{read_file, ReadError, MAX_TEXT_BYTES};

pub use fap::{Fapu, FapuValues};
pub use pose::MaskPose;
pub use region::FaceRegion;
pub use wfm::WfmError;

/// The CANDIDE-3.1.6 model shipped with facewire (`data/candide3/candide3.wfm`).
pub const CANDIDE3_WFM: &[u8] = include_bytes!("../../../data/candide3/candide3.wfm");

/// The 18 lip vertices: the corners of the upper- and lower-lip triangles.
pub const LIP_VERTICES: [usize; 18] = [
    7, 8, 31, 33, 40, 64, 66, 79, 80, 81, 82, 83, 84, 85, 86, 87, 88, 89,
];
/// Upper-lip vertices, corners excluded (outer contour then inner contour).
pub const UPPER_LIP: [usize; 8] = [7, 33, 66, 79, 80, 81, 82, 87];
/// Lower-lip vertices, corners excluded.
pub const LOWER_LIP: [usize; 6] = [8, 40, 83, 84, 85, 86];
/// Upper-lip outer contour, corners excluded.
pub const UPPER_LIP_OUTER: [usize; 5] = [79, 33, 7, 66, 80];
/// Lower-lip outer contour, corners excluded.
pub const LOWER_LIP_OUTER: [usize; 3] = [86, 8, 85];
/// Upper-lip inner contour, corners excluded.
pub const UPPER_LIP_INNER: [usize; 3] = [81, 87, 82];
/// Lower-lip inner contour, corners excluded.
pub const LOWER_LIP_INNER: [usize; 3] = [83, 40, 84];
/// Inner-lip midpoints: upper (MPEG-4 2.2) and lower (2.3).
pub const INNER_LIP_MID_UPPER: usize = 87;
pub const INNER_LIP_MID_LOWER: usize = 40;
/// Inner-lip corners: left (MPEG-4 2.4) and right (2.5).
pub const INNER_LIP_CORNERS: [usize; 2] = [88, 89];
/// Outer-lip corners (MPEG-4 8.3 and 8.4): the mouth's width at rest.
pub const OUTER_LIP_CORNERS: [usize; 2] = [31, 64];
/// The nose tip (MPEG-4 9.3) and the chin's lowest point (2.1), which every fit holds.
pub const NOSE_TIP: usize = 5;
pub const CHIN: usize = 10;
/// Every vertex facewire addresses by number (the lips above, the pupils and FAPU
/// measures of [`fap::FapuValues::measure`]) is below this: the `.wfm` reader refuses a
/// mask with fewer vertices rather than let a fit index past its end.
pub const MIN_VERTICES: usize = 90;

/// A CANDIDE-3 wireframe with its deformation units.
#[derive(Debug, Clone)]
pub struct Mask {
    /// Neutral vertex positions `g0`, mask units.
    pub vertices: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    pub animation_units: Vec<Unit>,
    pub shape_units: Vec<Unit>,
    /// `ANIMATION PARAMETERS` section: (unit index, value) pairs stored in the file.
    pub animation_params: Vec<(usize, f32)>,
    /// `SHAPE PARAMETERS` section.
    pub shape_params: Vec<(usize, f32)>,
    /// `TEXTURE` section: (vertex, [u, v]).
    pub texture: Vec<(u32, [f32; 2])>,
    pub texture_file: Option<String>,
    pub global_motion: GlobalMotion,
}

/// The `GLOBAL MOTION` section: rotation (radians), per-axis scale, translation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlobalMotion {
    pub rotation_rad: Vec3,
    pub scale: Vec3,
    pub translation: Vec3,
}

/// A sparse displacement field: an animation unit (AUV or FAP) or a shape unit.
#[derive(Debug, Clone)]
pub struct Unit {
    /// The first comment line of the unit in the file (`AUV11 Jaw drop (AU26/27)`).
    pub title: String,
    /// Stable lower-case name (`jaw_drop`, `fap3_open_jaw`, `head_height`).
    pub key: String,
    pub kind: UnitKind,
    /// (mask vertex, displacement per unit weight in mask units).
    pub displacements: Vec<(u32, Vec3)>,
}

#[derive(Debug, Clone, PartialEq)]
pub enum UnitKind {
    /// A FACS action unit vector, `AUV<n>`.
    Auv {
        auv: u32,
    },
    /// An MPEG-4 FAP. `fapu` is the standard's unit; `file_fapu` the one the file's
    /// comment names, if any (they differ only for FAP 15, which the file marks MNS).
    Fap {
        fap: u8,
        fapu: Fapu,
        file_fapu: Option<Fapu>,
    },
    /// An animation unit whose title names neither an AUV nor a FAP.
    Other,
    Shape,
}

impl UnitKind {
    fn from_title(title: &str, fapu_comment: Option<&str>) -> UnitKind {
        let lower = title.to_ascii_lowercase();
        if let Some(rest) = lower.strip_prefix("auv") {
            if let Some(auv) = leading_number(rest) {
                return UnitKind::Auv { auv };
            }
        }
        if let Some(rest) = lower.strip_prefix("fap") {
            if let Some(number) = leading_number(rest.trim_start()) {
                if let Some(info) = u8::try_from(number).ok().and_then(fap::fap_info) {
                    if let Some(fapu) = info.fapu {
                        return UnitKind::Fap {
                            fap: info.number,
                            fapu,
                            file_fapu: fapu_comment.and_then(Fapu::parse),
                        };
                    }
                }
            }
        }
        UnitKind::Other
    }
}

fn leading_number(text: &str) -> Option<u32> {
    let digits: String = text.chars().take_while(|c| c.is_ascii_digit()).collect();
    digits.parse().ok()
}

/// Lower-case words joined by `_`: `Eyes, width` -> `eyes_width`.
fn slug(text: &str) -> String {
    text.split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|w| !w.is_empty())
        .map(str::to_ascii_lowercase)
        .collect::<Vec<_>>()
        .join("_")
}

impl Unit {
    fn new(title: String, kind: UnitKind, displacements: Vec<(u32, Vec3)>) -> Unit {
        let key = match &kind {
            UnitKind::Auv { .. } => {
                // "AUV11 Jaw drop (AU26/27)" -> "jaw_drop"
                let words = title.split_once(char::is_whitespace).map_or("", |(_, r)| r);
                let name = words.split('(').next().unwrap_or(words);
                slug(name)
            }
            UnitKind::Fap { fap, .. } => {
                let info = fap::fap_info(*fap).expect("FapKind holds a valid FAP number");
                format!("fap{}_{}", fap, info.name)
            }
            UnitKind::Other | UnitKind::Shape => slug(&title),
        };
        Unit {
            title,
            key,
            kind,
            displacements,
        }
    }

    /// Every name this unit answers to, its key first: `jaw_drop`, `auv11`;
    /// `fap3_open_jaw`, `fap3`, `open_jaw`.
    pub fn names(&self) -> Vec<String> {
        let mut names = vec![self.key.clone()];
        match &self.kind {
            UnitKind::Auv { auv } => names.push(format!("auv{auv}")),
            UnitKind::Fap { fap, .. } => {
                names.push(format!("fap{fap}"));
                if let Some(info) = fap::fap_info(*fap) {
                    names.push(info.name.to_string());
                }
            }
            UnitKind::Other | UnitKind::Shape => {}
        }
        names
    }
}

/// A unit name or index that the mask does not have.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("unknown {what} {name}; valid: an index 0..{count} or one of {valid}")]
pub struct UnknownUnit {
    pub what: &'static str,
    /// The name as given, quoted and cut by [`crate::quote::quote`].
    pub name: String,
    pub count: usize,
    pub valid: String,
}

/// Errors from loading a mask file.
#[derive(Debug, thiserror::Error)]
pub enum MaskLoadError {
    #[error(transparent)]
    Read(#[from] ReadError),
    #[error("{path}: {source}")]
    Parse { path: String, source: WfmError },
}

impl Mask {
    /// The CANDIDE-3.1.6 model embedded in the binary.
    pub fn candide3() -> Mask {
        Mask::from_wfm_bytes(CANDIDE3_WFM).expect("the embedded candide3.wfm parses")
    }

    /// Parses `.wfm` bytes, decoding them as ISO-8859-1.
    pub fn from_wfm_bytes(bytes: &[u8]) -> Result<Mask, WfmError> {
        let text: String = bytes.iter().map(|&b| char::from(b)).collect();
        wfm::parse(&text)
    }

    /// Loads a `.wfm` file: a regular file of at most [`MAX_TEXT_BYTES`].
    pub fn load(path: &Path) -> Result<Mask, MaskLoadError> {
        let bytes = read_file(path, MAX_TEXT_BYTES)?;
        Mask::from_wfm_bytes(&bytes).map_err(|source| MaskLoadError::Parse {
            path: path.display().to_string(),
            source,
        })
    }

    /// Vertices used by at least one triangle.
    pub fn used_vertices(&self) -> Vec<bool> {
        let mut used = vec![false; self.vertices.len()];
        for tri in &self.triangles {
            for &v in tri {
                used[v as usize] = true;
            }
        }
        used
    }

    /// The vertex that mirrors `vertex` across the mask's midline (x = 0, mask units): the
    /// left side's for the right's and back, itself on the midline.
    pub fn mirror_partner(&self, vertex: u32) -> u32 {
        let p = self.vertices[vertex as usize];
        let mirrored = Vec3::new(-p.x, p.y, p.z);
        let (nearest, _) = self
            .vertices
            .iter()
            .enumerate()
            .map(|(j, q)| (j, q.distance_squared(mirrored)))
            .fold((0, f32::INFINITY), |best, c| if c.1 < best.1 { c } else { best });
        nearest as u32
    }

    /// Whether `vertex` lies at one of the face's openings, the eyes or the lips: a mesh's
    /// edge near it can be the opening's rim rather than the end of the face.
    pub fn at_an_opening(&self, vertex: usize) -> bool {
        LIP_VERTICES.contains(&vertex) || FaceRegion::of(self.vertices[vertex]) == FaceRegion::Eyes
    }

    /// Resolves an animation unit by index (`"1"`), key (`jaw_drop`) or alias (`auv11`,
    /// `fap3`, `open_jaw`), case-insensitively.
    pub fn animation_unit(&self, name: &str) -> Result<usize, UnknownUnit> {
        find_unit(&self.animation_units, name, "animation unit")
    }

    /// Resolves a shape unit by index or key (`head_height`).
    pub fn shape_unit(&self, name: &str) -> Result<usize, UnknownUnit> {
        find_unit(&self.shape_units, name, "shape unit")
    }

    /// The animation unit implementing MPEG-4 FAP `fap`, if CANDIDE-3 has one.
    pub fn fap_unit(&self, fap: u8) -> Option<usize> {
        self.animation_units
            .iter()
            .position(|u| matches!(u.kind, UnitKind::Fap { fap: f, .. } if f == fap))
    }

    /// `g0 + SU * sigma`: the neutral mask of one person, mask units.
    pub fn shaped(&self, shape: &[f32]) -> Vec<Vec3> {
        let mut out = self.vertices.clone();
        add_units(&self.shape_units, shape, &mut out);
        out
    }

    /// Full pose equation `g = R S (g0 + SU sigma + AU alpha) + t` into `out`
    /// (resized to the vertex count).
    pub fn pose(&self, shape: &[f32], animation: &[f32], pose: &MaskPose, out: &mut Vec<Vec3>) {
        out.clear();
        out.extend_from_slice(&self.vertices);
        add_units(&self.shape_units, shape, out);
        add_units(&self.animation_units, animation, out);
        pose.apply_all(out);
    }
}

/// `out += sum_k weights[k] * units[k]`. Weights beyond `units.len()` are ignored and
/// missing weights count as zero. Allocates nothing.
pub fn add_units(units: &[Unit], weights: &[f32], out: &mut [Vec3]) {
    for (unit, &w) in units.iter().zip(weights) {
        if w != 0.0 {
            for &(v, d) in &unit.displacements {
                out[v as usize] += w * d;
            }
        }
    }
}

fn find_unit(units: &[Unit], name: &str, what: &'static str) -> Result<usize, UnknownUnit> {
    let wanted = name.trim();
    if let Ok(index) = wanted.parse::<usize>() {
        if index < units.len() {
            return Ok(index);
        }
    }
    let lower = wanted.to_ascii_lowercase();
    if let Some(i) = units.iter().position(|u| u.names().contains(&lower)) {
        return Ok(i);
    }
    Err(UnknownUnit {
        what,
        name: crate::quote::quote(name),
        count: units.len(),
        valid: units
            .iter()
            .map(|u| u.key.as_str())
            .collect::<Vec<_>>()
            .join(", "),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mirror_partners_swap_the_sides_and_keep_the_midline() {
        let mask = Mask::candide3();
        // Eye corners and mouth corners, left (FP 3.7, 3.11, 8.3) and right (3.12, 3.8, 8.4).
        for (left, right) in [(20, 53), (23, 56), (31, 64)] {
            assert_eq!(mask.mirror_partner(left), right);
            assert_eq!(mask.mirror_partner(right), left);
        }
        // Nose tip and chin lie on the midline.
        assert_eq!(mask.mirror_partner(5), 5);
        assert_eq!(mask.mirror_partner(10), 10);
    }

    #[test]
    fn masks_too_small_for_the_named_vertices_are_refused() {
        let named = LIP_VERTICES
            .iter()
            .chain(&fap::LEFT_PUPIL)
            .chain(&fap::RIGHT_PUPIL)
            .chain(&[6, 31, 64, 87]);
        assert_eq!(named.max(), Some(&(MIN_VERTICES - 1)));
        let text = "# VERTEX LIST:\n3\n0 0 0\n1 0 0\n0 1 0\n";
        assert_eq!(
            wfm::parse(text).unwrap_err().to_string(),
            "line 2: 3 vertices; facewire addresses CANDIDE-3 vertices up to 89 by number (lips, \
             pupils, FAPU), so a mask needs at least 90"
        );
    }

    #[test]
    fn keys_are_stable_names() {
        let mask = Mask::candide3();
        let keys: Vec<&str> = mask.animation_units.iter().map(|u| u.key.as_str()).collect();
        assert_eq!(keys[0], "upper_lip_raiser");
        assert_eq!(keys[1], "jaw_drop");
        assert_eq!(keys[11], "fap3_open_jaw");
        assert_eq!(mask.shape_units[3].key, "eyes_width");
        assert_eq!(mask.animation_unit("auv11"), Ok(1));
        assert_eq!(mask.animation_unit("OPEN_JAW"), Ok(11));
        assert_eq!(mask.animation_unit("fap3"), Ok(11));
        assert_eq!(mask.animation_unit("12"), Ok(12));
        assert_eq!(mask.shape_unit("head_height"), Ok(0));
        let err = mask.animation_unit("smile").unwrap_err();
        assert!(err.to_string().contains("jaw_drop"), "{err}");
    }

    #[test]
    fn keys_are_unique() {
        let mask = Mask::candide3();
        for units in [&mask.animation_units, &mask.shape_units] {
            let mut names: Vec<String> = units.iter().flat_map(Unit::names).collect();
            let total = names.len();
            names.sort();
            names.dedup();
            assert_eq!(names.len(), total);
        }
    }

    #[test]
    fn fap_units_carry_the_standard_fapu() {
        let mask = Mask::candide3();
        let open_jaw = &mask.animation_units[mask.fap_unit(3).unwrap()];
        assert_eq!(
            open_jaw.kind,
            UnitKind::Fap {
                fap: 3,
                fapu: Fapu::Mns,
                file_fapu: Some(Fapu::Mns)
            }
        );
        // The file marks shift_jaw MNS; the standard says MW.
        let shift_jaw = &mask.animation_units[mask.fap_unit(15).unwrap()];
        assert_eq!(
            shift_jaw.kind,
            UnitKind::Fap {
                fap: 15,
                fapu: Fapu::Mw,
                file_fapu: Some(Fapu::Mns)
            }
        );
        let implemented: Vec<u8> = (1..=68).filter(|&f| mask.fap_unit(f).is_some()).collect();
        let expected: Vec<u8> = (3..=42).chain(51..=64).collect();
        assert_eq!(implemented, expected);
    }

    #[test]
    fn fapu_values_match_the_report() {
        let mask = Mask::candide3();
        let fapu = FapuValues::measure(&mask.vertices);
        assert!((fapu.mw - 0.492).abs() < 1e-6, "{fapu:?}");
        assert!((fapu.mns - 0.196).abs() < 1e-6, "{fapu:?}");
        assert!((fapu.ens - 0.4225).abs() < 1e-6, "{fapu:?}");
        assert!((fapu.es - 0.613).abs() < 1e-6, "{fapu:?}");
        assert!((fapu.irisd - 0.085).abs() < 1e-6, "{fapu:?}");
    }
}
