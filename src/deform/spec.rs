//! Algorithm spec strings: one string selects any variant and its parameters, in the CLI,
//! config files and the wire protocol. `name[:key=value,...]` or a preset letter:
//!
//! ```text
//! renato2                      bary2:weights=distance,r_mm=10
//! planar_bones:r_pct=30        rbf:kernel=wendland,r_mm=40
//! E                            point_distance:k=all
//! ```
//!
//! [`AlgoSpec`]'s `Display` prints the canonical form (every parameter), which round-trips.

use std::fmt;
use std::str::FromStr;

/// How several control elements (triangles, or feature points for `geometric`) are
/// blended. Distances are surface distances in mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Weights {
    /// The single nearest element.
    None,
    /// Singh's `w = 1 / (1 + d^local)` for `d < r_mm`, normalized.
    Distance { r_mm: f32, local: f32 },
    /// Planar bones' `w = (0.5 (1 + cos(pi d / r)))^n` for `d < r`, `r = r_pct %` of each
    /// triangle's longest edge, normalized.
    PlanarBones { r_pct: f32, n: f32 },
    /// Kshirsagar's `W = sin(pi/2 (1 - d / r_mm))` with eq. 5's `1/d^2` blend
    /// (`geometric` only).
    Kshirsagar { r_mm: f32 },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kernel {
    Gaussian,
    Multiquadric,
    InverseMultiquadric,
    ThinPlate,
    Wendland,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Metric {
    Euclidean,
    Surface,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RbfParams {
    pub kernel: Kernel,
    pub metric: Metric,
    /// Kernel scale (Gaussian, multiquadrics) or support radius (Wendland), mm.
    pub r_mm: f32,
    /// Add the linear polynomial term (reproduces affine motions exactly).
    pub polynomial: bool,
}

/// One interpolation variant with all its parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AlgoSpec {
    Bary1 {
        alpha: f32,
    },
    Bary2 {
        weights: Weights,
    },
    Geometric {
        weights: Weights,
    },
    PointDistance {
        k: Option<u32>,
        local: f32,
        /// Blend corrected values so the controls are reproduced at their anchors.
        interpolate: bool,
    },
    PlanarBones {
        weights: Weights,
    },
    Renato1,
    Renato2 {
        alpha: f32,
    },
    Renato3 {
        weights: Weights,
    },
    Kshirsagar,
    Rbf(RbfParams),
    Biharmonic {
        /// How far along the surface an anchor reaches, mm: a vertex beyond its nearest
        /// anchor's reach is held still. This one is for every anchor but the eyes'.
        hold_mm: f32,
        /// The reach of the eye controls' anchors ([`FaceRegion::Eyes`](crate::mask::FaceRegion)),
        /// mm: the fold of the upper eyelid overshoots when they reach far.
        eyes_hold_mm: f32,
        /// Weights kept per vertex (the largest), rescaled to their full sum.
        k: u32,
    },
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SpecError {
    #[error("unknown algorithm {name:?}; valid: {valid} or a preset letter A-V")]
    UnknownAlgorithm { name: String, valid: String },
    #[error("{algorithm}: unknown parameter {key:?}; valid: {valid}")]
    UnknownParameter {
        algorithm: &'static str,
        key: String,
        valid: String,
    },
    #[error("{algorithm}: parameter {key}={value:?}: {problem}")]
    BadValue {
        algorithm: &'static str,
        key: String,
        value: String,
        problem: String,
    },
    #[error("{algorithm}: {problem}")]
    Inconsistent {
        algorithm: &'static str,
        problem: String,
    },
}

/// The algorithm facewire recommends (preset V, `biharmonic` with the eyes' reach cut
/// short): every control reproduced, the artists' expression targets followed closest of
/// every preset (mean RMS 0.54 mm on MakeHuman, 0.51 mm on ICT), no lip triangle turned
/// over 60 degrees on the syllable stream of any shipped head, and smoother lips than the
/// thesis's smoothest exact method. See the README's "Which algorithm" and docs/reports/.
pub const DEFAULT_ALGORITHM: &str = "biharmonic";

/// Most weights a `biharmonic` vertex may keep.
pub const MAX_BIHARMONIC_K: u32 = 128;

/// Names of every algorithm, in catalogue order.
pub const ALGORITHM_NAMES: [&str; 11] = [
    "bary1",
    "bary2",
    "geometric",
    "point_distance",
    "planar_bones",
    "renato1",
    "renato2",
    "renato3",
    "kshirsagar",
    "rbf",
    "biharmonic",
];

/// The thesis's table 4.5 presets plus `kshirsagar` (S), `rbf` (T), the interpolating
/// `point_distance` (U) and `biharmonic` (V), each with a line saying what it does to a head
/// vertex.
pub const PRESETS: [(char, &str, &str); 22] = [
    (
        'A',
        "bary1",
        "rides on its mask triangle's local frame inside the mask; outside, the 3 nearest controls with an exponential falloff",
    ),
    (
        'B',
        "bary2",
        "rides on the local frame of the nearest mask triangle, everywhere (extrapolates outside the mask)",
    ),
    (
        'C',
        "bary2:weights=distance,r_mm=10",
        "rides on the local frames of the mask triangles within 10 mm, blended by distance (surface-oriented FFD)",
    ),
    (
        'D',
        "bary2:weights=distance,r_mm=30",
        "rides on the local frames of the mask triangles within 30 mm, blended by distance (surface-oriented FFD)",
    ),
    (
        'E',
        "geometric",
        "moves rigidly with the single nearest control",
    ),
    (
        'F',
        "geometric:weights=kshirsagar,r_mm=10",
        "blends the controls within 10 mm, weights falling smoothly to zero at 10 mm",
    ),
    (
        'G',
        "point_distance:k=3,interpolate=false",
        "blends the 3 nearest controls along the surface, weights 1/(1+d^2)",
    ),
    (
        'H',
        "point_distance:k=all,interpolate=false",
        "blends every control reachable along the surface, weights 1/(1+d^2)",
    ),
    (
        'I',
        "planar_bones:weights=planar_bones,r_pct=10",
        "each mask triangle carries nearby vertices like a bone, by region of its plane; bones within 10% of the longest edge blended",
    ),
    (
        'J',
        "planar_bones:weights=planar_bones,r_pct=30",
        "triangle bones as I, blended within 30% of the longest edge",
    ),
    (
        'K',
        "planar_bones:weights=planar_bones,r_pct=100",
        "triangle bones as I, blended within 100% of the longest edge (smoothest lips, squashes the mouth)",
    ),
    (
        'L',
        "planar_bones:weights=distance,r_mm=10",
        "triangle bones as I, those within 10 mm blended by surface distance",
    ),
    (
        'M',
        "planar_bones:weights=distance,r_mm=30",
        "triangle bones as I, those within 30 mm blended by surface distance",
    ),
    (
        'N',
        "renato1",
        "follows its mask triangle by barycentric weights inside; outside, by their absolute values (overshoots)",
    ),
    (
        'O',
        "renato2",
        "follows its mask triangle by barycentric weights inside; outside, the nearest corners with an exponential falloff",
    ),
    (
        'P',
        "renato3",
        "follows the nearest mask triangle by barycentric weights, everywhere",
    ),
    (
        'Q',
        "renato3:weights=distance,r_mm=10",
        "barycentric weights of the mask triangles within 10 mm, blended by distance",
    ),
    (
        'R',
        "renato3:weights=distance,r_mm=30",
        "barycentric weights of the mask triangles within 30 mm, blended by distance",
    ),
    (
        'S',
        "kshirsagar",
        "each control moves a region grown over the surface around it, with weights falling across the region (the published feature-point method)",
    ),
    (
        'T',
        "rbf",
        "smooth interpolation through every control: radial basis functions (Wendland C2 over surface distance, 30 mm) plus a linear term",
    ),
    (
        'U',
        "point_distance",
        "blends the 3 nearest controls along the surface (1/(1+d^2)), corrected to move every control exactly",
    ),
    (
        'V',
        "biharmonic",
        "the smoothest field through every control (least bi-Laplacian energy), the head held still beyond its nearest anchor's reach: 50 mm, 20 mm for the eyes (recommended)",
    ),
];

impl AlgoSpec {
    pub fn name(&self) -> &'static str {
        match self {
            AlgoSpec::Bary1 { .. } => "bary1",
            AlgoSpec::Bary2 { .. } => "bary2",
            AlgoSpec::Geometric { .. } => "geometric",
            AlgoSpec::PointDistance { .. } => "point_distance",
            AlgoSpec::PlanarBones { .. } => "planar_bones",
            AlgoSpec::Renato1 => "renato1",
            AlgoSpec::Renato2 { .. } => "renato2",
            AlgoSpec::Renato3 { .. } => "renato3",
            AlgoSpec::Kshirsagar => "kshirsagar",
            AlgoSpec::Rbf(_) => "rbf",
            AlgoSpec::Biharmonic { .. } => "biharmonic",
        }
    }

    /// Whether deforming is one sparse matrix-vector product over control displacements.
    pub fn is_linear(&self) -> bool {
        !matches!(
            self,
            AlgoSpec::Bary1 { .. } | AlgoSpec::Bary2 { .. } | AlgoSpec::PlanarBones { .. }
        )
    }

    /// The preset letter of this exact variant, if it is a preset.
    pub fn letter(&self) -> Option<char> {
        PRESETS
            .iter()
            .find(|(_, spec, _)| spec.parse::<AlgoSpec>().as_ref() == Ok(self))
            .map(|(l, _, _)| *l)
    }

    /// Every preset, parsed.
    pub fn presets() -> Vec<(char, AlgoSpec, &'static str)> {
        PRESETS
            .iter()
            .map(|&(l, s, d)| (l, s.parse().expect("presets parse"), d))
            .collect()
    }

    fn defaults(name: &str) -> Option<AlgoSpec> {
        Some(match name {
            "bary1" => AlgoSpec::Bary1 { alpha: 0.4 },
            "bary2" => AlgoSpec::Bary2 {
                weights: Weights::None,
            },
            "geometric" => AlgoSpec::Geometric {
                weights: Weights::None,
            },
            "point_distance" => AlgoSpec::PointDistance {
                k: Some(3),
                local: 2.0,
                interpolate: true,
            },
            "planar_bones" => AlgoSpec::PlanarBones {
                weights: Weights::PlanarBones { r_pct: 10.0, n: 1.0 },
            },
            "renato1" => AlgoSpec::Renato1,
            "renato2" => AlgoSpec::Renato2 { alpha: 0.4 },
            "renato3" => AlgoSpec::Renato3 {
                weights: Weights::None,
            },
            "kshirsagar" => AlgoSpec::Kshirsagar,
            "rbf" => AlgoSpec::Rbf(RbfParams {
                kernel: Kernel::Wendland,
                metric: Metric::Surface,
                r_mm: 30.0,
                polynomial: true,
            }),
            "biharmonic" => AlgoSpec::Biharmonic {
                hold_mm: 50.0,
                eyes_hold_mm: 20.0,
                k: 32,
            },
            _ => return None,
        })
    }

    /// Parameter keys each algorithm accepts.
    fn valid_keys(&self) -> &'static [&'static str] {
        match self {
            AlgoSpec::Bary1 { .. } | AlgoSpec::Renato2 { .. } => &["alpha"],
            AlgoSpec::Bary2 { .. } | AlgoSpec::PlanarBones { .. } | AlgoSpec::Renato3 { .. } => {
                &["weights", "r_mm", "local", "r_pct", "n"]
            }
            AlgoSpec::Geometric { .. } => &["weights", "r_mm", "local"],
            AlgoSpec::PointDistance { .. } => &["k", "local", "interpolate"],
            AlgoSpec::Renato1 | AlgoSpec::Kshirsagar => &[],
            AlgoSpec::Rbf(_) => &["kernel", "distance", "r_mm", "poly"],
            AlgoSpec::Biharmonic { .. } => &["hold_mm", "eyes_hold_mm", "k"],
        }
    }
}

impl FromStr for AlgoSpec {
    type Err = SpecError;

    fn from_str(text: &str) -> Result<AlgoSpec, SpecError> {
        let text = text.trim();
        let mut chars = text.chars();
        if let (Some(letter), None) = (chars.next(), chars.next()) {
            let letter = letter.to_ascii_uppercase();
            if let Some((_, spec, _)) = PRESETS.iter().find(|(l, _, _)| *l == letter) {
                return spec.parse();
            }
        }
        let (name, params) = text.split_once(':').unwrap_or((text, ""));
        let name = name.trim().to_ascii_lowercase();
        let mut spec = AlgoSpec::defaults(&name).ok_or_else(|| SpecError::UnknownAlgorithm {
            name: name.clone(),
            valid: ALGORITHM_NAMES.join(", "),
        })?;
        let mut pairs = Vec::new();
        for item in params.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (key, value) = item.split_once('=').ok_or_else(|| SpecError::BadValue {
                algorithm: spec.name(),
                key: item.to_string(),
                value: String::new(),
                problem: "expected key=value".into(),
            })?;
            let key = key.trim().to_ascii_lowercase();
            if !spec.valid_keys().contains(&key.as_str()) {
                return Err(SpecError::UnknownParameter {
                    algorithm: spec.name(),
                    key,
                    valid: if spec.valid_keys().is_empty() {
                        "none".into()
                    } else {
                        spec.valid_keys().join(", ")
                    },
                });
            }
            pairs.push((key, value.trim().to_string()));
        }
        apply(&mut spec, &pairs)?;
        Ok(spec)
    }
}

fn number(algorithm: &'static str, key: &str, value: &str, positive: bool) -> Result<f32, SpecError> {
    let bad = |problem: &str| SpecError::BadValue {
        algorithm,
        key: key.to_string(),
        value: value.to_string(),
        problem: problem.to_string(),
    };
    let x: f32 = value.parse().map_err(|_| bad("not a number"))?;
    if !x.is_finite() || (positive && x <= 0.0) {
        return Err(bad(if positive {
            "must be a positive number"
        } else {
            "must be finite"
        }));
    }
    Ok(x)
}

fn apply(spec: &mut AlgoSpec, pairs: &[(String, String)]) -> Result<(), SpecError> {
    let algorithm = spec.name();
    let get = |key: &str| pairs.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str());
    let num = |key: &str| get(key).map(|v| number(algorithm, key, v, true)).transpose();
    match spec {
        AlgoSpec::Bary1 { alpha } | AlgoSpec::Renato2 { alpha } => {
            if let Some(a) = num("alpha")? {
                *alpha = a;
            }
        }
        AlgoSpec::Bary2 { weights } | AlgoSpec::PlanarBones { weights } | AlgoSpec::Renato3 { weights } => {
            *weights = parse_weights(algorithm, *weights, pairs, false)?;
        }
        AlgoSpec::Geometric { weights } => {
            *weights = parse_weights(algorithm, *weights, pairs, true)?;
        }
        AlgoSpec::PointDistance {
            k,
            local,
            interpolate,
        } => {
            if let Some(v) = get("k") {
                *k = if v.eq_ignore_ascii_case("all") {
                    None
                } else {
                    let n = number(algorithm, "k", v, true)?;
                    if n.fract() != 0.0 {
                        return Err(SpecError::BadValue {
                            algorithm,
                            key: "k".into(),
                            value: v.into(),
                            problem: "must be a whole number or \"all\"".into(),
                        });
                    }
                    Some(n as u32)
                };
            }
            if let Some(l) = num("local")? {
                *local = l;
            }
            if let Some(v) = get("interpolate") {
                *interpolate = match v.to_ascii_lowercase().as_str() {
                    "true" => true,
                    "false" => false,
                    _ => {
                        return Err(SpecError::BadValue {
                            algorithm,
                            key: "interpolate".into(),
                            value: v.into(),
                            problem: "valid: true, false".into(),
                        })
                    }
                };
            }
        }
        AlgoSpec::Rbf(params) => {
            if let Some(v) = get("kernel") {
                params.kernel =
                    match v.to_ascii_lowercase().as_str() {
                        "gaussian" => Kernel::Gaussian,
                        "multiquadric" => Kernel::Multiquadric,
                        "inverse_multiquadric" => Kernel::InverseMultiquadric,
                        "thin_plate" => Kernel::ThinPlate,
                        "wendland" => Kernel::Wendland,
                        _ => return Err(SpecError::BadValue {
                            algorithm,
                            key: "kernel".into(),
                            value: v.into(),
                            problem:
                                "valid: gaussian, multiquadric, inverse_multiquadric, thin_plate, wendland"
                                    .into(),
                        }),
                    };
            }
            if let Some(v) = get("distance") {
                params.metric = match v.to_ascii_lowercase().as_str() {
                    "euclidean" => Metric::Euclidean,
                    "surface" => Metric::Surface,
                    _ => {
                        return Err(SpecError::BadValue {
                            algorithm,
                            key: "distance".into(),
                            value: v.into(),
                            problem: "valid: euclidean, surface".into(),
                        })
                    }
                };
            }
            if let Some(r) = num("r_mm")? {
                params.r_mm = r;
            }
            if let Some(v) = get("poly") {
                params.polynomial = match v.to_ascii_lowercase().as_str() {
                    "linear" => true,
                    "none" => false,
                    _ => {
                        return Err(SpecError::BadValue {
                            algorithm,
                            key: "poly".into(),
                            value: v.into(),
                            problem: "valid: linear, none".into(),
                        })
                    }
                };
            }
        }
        AlgoSpec::Biharmonic {
            hold_mm,
            eyes_hold_mm,
            k,
        } => {
            if let Some(h) = num("hold_mm")? {
                *hold_mm = h;
            }
            if let Some(h) = num("eyes_hold_mm")? {
                *eyes_hold_mm = h;
            }
            if let Some(v) = get("k") {
                let n = number(algorithm, "k", v, true)?;
                if n.fract() != 0.0 || n > MAX_BIHARMONIC_K as f32 {
                    return Err(SpecError::BadValue {
                        algorithm,
                        key: "k".into(),
                        value: v.into(),
                        problem: format!("must be a whole number from 1 to {MAX_BIHARMONIC_K}"),
                    });
                }
                *k = n as u32;
            }
        }
        AlgoSpec::Renato1 | AlgoSpec::Kshirsagar => {}
    }
    Ok(())
}

fn parse_weights(
    algorithm: &'static str,
    default: Weights,
    pairs: &[(String, String)],
    feature_points: bool,
) -> Result<Weights, SpecError> {
    let get = |key: &str| pairs.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str());
    let num = |key: &str| get(key).map(|v| number(algorithm, key, v, true)).transpose();
    let system = match get("weights") {
        Some(s) => s.to_ascii_lowercase(),
        None if get("r_mm").is_some() => {
            if feature_points {
                "kshirsagar".into()
            } else {
                "distance".into()
            }
        }
        None if get("r_pct").is_some() => "planar_bones".into(),
        None => match default {
            Weights::None => "none".into(),
            Weights::Distance { .. } => "distance".into(),
            Weights::PlanarBones { .. } => "planar_bones".into(),
            Weights::Kshirsagar { .. } => "kshirsagar".into(),
        },
    };
    let stray = |keys: &[&str], system: &str| -> Result<(), SpecError> {
        match keys.iter().find(|k| get(k).is_some()) {
            Some(k) => Err(SpecError::Inconsistent {
                algorithm,
                problem: format!("parameter {k} does not apply to weights={system}"),
            }),
            None => Ok(()),
        }
    };
    let valid = if feature_points {
        "none, distance, kshirsagar"
    } else {
        "none, distance, planar_bones"
    };
    match system.as_str() {
        "none" => {
            stray(&["r_mm", "local", "r_pct", "n"], "none")?;
            Ok(Weights::None)
        }
        "distance" => {
            stray(&["r_pct", "n"], "distance")?;
            Ok(Weights::Distance {
                r_mm: num("r_mm")?.unwrap_or(10.0),
                local: num("local")?.unwrap_or(2.0),
            })
        }
        "planar_bones" if !feature_points => {
            stray(&["r_mm", "local"], "planar_bones")?;
            Ok(Weights::PlanarBones {
                r_pct: num("r_pct")?.unwrap_or(10.0),
                n: num("n")?.unwrap_or(1.0),
            })
        }
        "kshirsagar" if feature_points => {
            stray(&["local"], "kshirsagar")?;
            Ok(Weights::Kshirsagar {
                r_mm: num("r_mm")?.unwrap_or(10.0),
            })
        }
        other => Err(SpecError::BadValue {
            algorithm,
            key: "weights".into(),
            value: other.into(),
            problem: format!("valid: {valid}"),
        }),
    }
}

impl fmt::Display for Weights {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Weights::None => write!(f, "weights=none"),
            Weights::Distance { r_mm, local } => write!(f, "weights=distance,r_mm={r_mm},local={local}"),
            Weights::PlanarBones { r_pct, n } => write!(f, "weights=planar_bones,r_pct={r_pct},n={n}"),
            Weights::Kshirsagar { r_mm } => write!(f, "weights=kshirsagar,r_mm={r_mm}"),
        }
    }
}

impl fmt::Display for AlgoSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = self.name();
        match self {
            AlgoSpec::Bary1 { alpha } | AlgoSpec::Renato2 { alpha } => write!(f, "{name}:alpha={alpha}"),
            AlgoSpec::Bary2 { weights }
            | AlgoSpec::PlanarBones { weights }
            | AlgoSpec::Renato3 { weights }
            | AlgoSpec::Geometric { weights } => write!(f, "{name}:{weights}"),
            AlgoSpec::PointDistance {
                k,
                local,
                interpolate,
            } => match k {
                Some(k) => write!(f, "{name}:k={k},local={local},interpolate={interpolate}"),
                None => write!(f, "{name}:k=all,local={local},interpolate={interpolate}"),
            },
            AlgoSpec::Renato1 | AlgoSpec::Kshirsagar => write!(f, "{name}"),
            AlgoSpec::Rbf(p) => {
                let kernel = match p.kernel {
                    Kernel::Gaussian => "gaussian",
                    Kernel::Multiquadric => "multiquadric",
                    Kernel::InverseMultiquadric => "inverse_multiquadric",
                    Kernel::ThinPlate => "thin_plate",
                    Kernel::Wendland => "wendland",
                };
                let metric = match p.metric {
                    Metric::Euclidean => "euclidean",
                    Metric::Surface => "surface",
                };
                let poly = if p.polynomial { "linear" } else { "none" };
                write!(
                    f,
                    "{name}:kernel={kernel},distance={metric},r_mm={},poly={poly}",
                    p.r_mm
                )
            }
            AlgoSpec::Biharmonic {
                hold_mm,
                eyes_hold_mm,
                k,
            } => write!(f, "{name}:hold_mm={hold_mm},eyes_hold_mm={eyes_hold_mm},k={k}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn letters_and_names_parse() {
        assert_eq!("O".parse::<AlgoSpec>(), Ok(AlgoSpec::Renato2 { alpha: 0.4 }));
        assert_eq!(
            "bary2:weights=distance,r_mm=10".parse::<AlgoSpec>(),
            Ok(AlgoSpec::Bary2 {
                weights: Weights::Distance {
                    r_mm: 10.0,
                    local: 2.0
                }
            })
        );
        assert_eq!("c".parse::<AlgoSpec>(), "bary2:r_mm=10".parse::<AlgoSpec>());
        assert_eq!(
            "planar_bones:r_pct=30".parse::<AlgoSpec>(),
            Ok(AlgoSpec::PlanarBones {
                weights: Weights::PlanarBones { r_pct: 30.0, n: 1.0 }
            })
        );
        assert_eq!(
            "point_distance:k=all".parse::<AlgoSpec>(),
            Ok(AlgoSpec::PointDistance {
                k: None,
                local: 2.0,
                interpolate: true
            })
        );
        assert_eq!(
            "G".parse::<AlgoSpec>().unwrap().to_string(),
            "point_distance:k=3,local=2,interpolate=false"
        );
        let rbf: AlgoSpec = "rbf:kernel=gaussian,distance=euclidean,r_mm=25".parse().unwrap();
        assert_eq!(
            rbf,
            AlgoSpec::Rbf(RbfParams {
                kernel: Kernel::Gaussian,
                metric: Metric::Euclidean,
                r_mm: 25.0,
                polynomial: true
            })
        );
    }

    #[test]
    fn canonical_form_round_trips_and_presets_have_letters() {
        for (letter, spec, _) in AlgoSpec::presets() {
            let text = spec.to_string();
            assert_eq!(text.parse::<AlgoSpec>(), Ok(spec), "{text}");
            assert_eq!(spec.letter(), Some(letter), "{text}");
        }
        assert!(!AlgoSpec::presets()
            .iter()
            .any(|(_, s, _)| matches!(s, AlgoSpec::Bary2 { .. }) && s.is_linear()));
    }

    #[test]
    fn bad_specs_list_what_is_valid() {
        let err = "smooth".parse::<AlgoSpec>().unwrap_err();
        assert!(
            err.to_string().contains("renato2") && err.to_string().contains("rbf"),
            "{err}"
        );
        let err = "bary2:radius=3".parse::<AlgoSpec>().unwrap_err();
        assert_eq!(
            err.to_string(),
            "bary2: unknown parameter \"radius\"; valid: weights, r_mm, local, r_pct, n"
        );
        let err = "renato1:alpha=1".parse::<AlgoSpec>().unwrap_err();
        assert!(err.to_string().contains("valid: none"), "{err}");
        let err = "bary2:weights=distance,r_pct=4".parse::<AlgoSpec>().unwrap_err();
        assert!(matches!(err, SpecError::Inconsistent { .. }), "{err}");
        let err = "point_distance:interpolate=yes".parse::<AlgoSpec>().unwrap_err();
        assert_eq!(
            err.to_string(),
            "point_distance: parameter interpolate=\"yes\": valid: true, false"
        );
        let err = "rbf:kernel=cubic".parse::<AlgoSpec>().unwrap_err();
        assert!(err.to_string().contains("wendland"), "{err}");
        let err = "bary2:r_mm=-3".parse::<AlgoSpec>().unwrap_err();
        assert!(err.to_string().contains("positive"), "{err}");
        let err = "geometric:weights=planar_bones".parse::<AlgoSpec>().unwrap_err();
        assert!(err.to_string().contains("none, distance, kshirsagar"), "{err}");
        assert!("point_distance:k=2.5".parse::<AlgoSpec>().is_err());
        for (text, problem) in [
            ("biharmonic:k=0", "positive"),
            ("biharmonic:k=2.5", "whole number from 1 to 128"),
            ("biharmonic:k=129", "whole number from 1 to 128"),
            ("biharmonic:hold_mm=0", "positive"),
            ("biharmonic:hold_mm=inf", "positive"),
            ("biharmonic:eyes_hold_mm=-1", "positive"),
        ] {
            let err = text.parse::<AlgoSpec>().unwrap_err().to_string();
            assert!(err.contains(problem), "{text}: {err}");
        }
    }

    #[test]
    fn biharmonic_defaults_and_round_trip() {
        let spec: AlgoSpec = "biharmonic".parse().unwrap();
        let recommended = AlgoSpec::Biharmonic {
            hold_mm: 50.0,
            eyes_hold_mm: 20.0,
            k: 32,
        };
        assert_eq!(spec, recommended);
        assert_eq!(spec.to_string(), "biharmonic:hold_mm=50,eyes_hold_mm=20,k=32");
        let spec: AlgoSpec = "biharmonic:hold_mm=40".parse().unwrap();
        assert_eq!(spec.to_string(), "biharmonic:hold_mm=40,eyes_hold_mm=20,k=32");
        let spec: AlgoSpec = "Biharmonic: k=4, eyes_hold_mm=12, hold_mm=30.5".parse().unwrap();
        assert_eq!(spec.to_string().parse::<AlgoSpec>(), Ok(spec));
        assert!(spec.is_linear() && spec.letter().is_none());
    }
}
