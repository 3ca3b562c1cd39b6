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
//! Each algorithm's parameters are a type of their own ([`params`]: keys, defaults, how
//! given values apply, how they print), listed once in the table that makes [`AlgoSpec`];
//! the blends are [`weights`]'; [`given`] reads a spec's pairs.

mod given;
mod params;
mod weights;

use std::fmt;
use std::str::FromStr;

use given::Given;
pub use params::{
    AlgoParams, Bary1Params, Bary2Params, BiharmonicParams, GeometricParams, Kernel, KshirsagarParams,
    Metric, PlanarBonesParams, PointDistanceParams, RbfParams, Renato1Params, Renato2Params, Renato3Params,
    MAX_BIHARMONIC_K,
};
pub use weights::Weights;

/// Makes [`AlgoSpec`] from the table of algorithms: one variant per algorithm holding its
/// parameters, and every lookup by name, keys, application and printing from that table.
macro_rules! algorithms {
    ($($variant:ident($params:ident)),* $(,)?) => {
        /// One interpolation variant with all its parameters.
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub enum AlgoSpec {
            $($variant($params)),*
        }

        /// Names of every algorithm, in catalogue order.
        pub const ALGORITHM_NAMES: &[&str] = &[$($params::NAME),*];

        impl AlgoSpec {
            pub fn name(&self) -> &'static str {
                match self {
                    $(AlgoSpec::$variant(_) => $params::NAME),*
                }
            }

            /// The algorithm called `name`, with its default parameters.
            fn defaults(name: &str) -> Option<AlgoSpec> {
                $(if name == $params::NAME {
                    return Some(AlgoSpec::$variant($params::DEFAULT));
                })*
                None
            }

            /// Parameter keys the algorithm accepts.
            fn valid_keys(&self) -> &'static [&'static str] {
                match self {
                    $(AlgoSpec::$variant(_) => $params::KEYS),*
                }
            }

            fn apply(&mut self, given: &Given) -> Result<(), SpecError> {
                match self {
                    $(AlgoSpec::$variant(p) => p.apply(given)),*
                }
            }

            fn write_params(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                match self {
                    $(AlgoSpec::$variant(p) => p.write(f)),*
                }
            }
        }
    };
}

algorithms! {
    Bary1(Bary1Params),
    Bary2(Bary2Params),
    Geometric(GeometricParams),
    PointDistance(PointDistanceParams),
    PlanarBones(PlanarBonesParams),
    Renato1(Renato1Params),
    Renato2(Renato2Params),
    Renato3(Renato3Params),
    Kshirsagar(KshirsagarParams),
    Rbf(RbfParams),
    Biharmonic(BiharmonicParams),
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
/// short, smoothed over the lips): every control reproduced (the lips' within 0.15 mm), the
/// artists' expression targets followed closest of every preset (mean RMS 0.54 mm on
/// MakeHuman, 0.52 mm on ICT), no lip triangle turned over 60 degrees on the syllable
/// stream of any shipped head, and smoother lips than the thesis's smoothest method. See
/// the README's "Which algorithm" and docs/reports/.
pub const DEFAULT_ALGORITHM: &str = "biharmonic";

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
        "the smoothest field through every control (least bi-Laplacian energy), the head held still beyond its nearest anchor's reach: 50 mm, 20 mm for the eyes; averaged over the lips within an eighth of the mouth's width (recommended)",
    ),
];

impl AlgoSpec {
    /// Whether deforming is one sparse matrix-vector product over control displacements.
    pub fn is_linear(&self) -> bool {
        !matches!(
            self,
            AlgoSpec::Bary1(_) | AlgoSpec::Bary2(_) | AlgoSpec::PlanarBones(_)
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
        spec.apply(&Given {
            algorithm: spec.name(),
            pairs: &pairs,
        })?;
        Ok(spec)
    }
}

impl fmt::Display for AlgoSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())?;
        if !self.valid_keys().is_empty() {
            f.write_str(":")?;
            self.write_params(f)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn letters_and_names_parse() {
        assert_eq!(
            "O".parse::<AlgoSpec>(),
            Ok(AlgoSpec::Renato2(Renato2Params { alpha: 0.4 }))
        );
        assert_eq!(
            "bary2:weights=distance,r_mm=10".parse::<AlgoSpec>(),
            Ok(AlgoSpec::Bary2(Bary2Params {
                weights: Weights::Distance {
                    r_mm: 10.0,
                    local: 2.0
                }
            }))
        );
        assert_eq!("c".parse::<AlgoSpec>(), "bary2:r_mm=10".parse::<AlgoSpec>());
        assert_eq!(
            "planar_bones:r_pct=30".parse::<AlgoSpec>(),
            Ok(AlgoSpec::PlanarBones(PlanarBonesParams {
                weights: Weights::PlanarBones { r_pct: 30.0, n: 1.0 }
            }))
        );
        assert_eq!(
            "point_distance:k=all".parse::<AlgoSpec>(),
            Ok(AlgoSpec::PointDistance(PointDistanceParams {
                k: None,
                local: 2.0,
                interpolate: true
            }))
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
            .any(|(_, s, _)| matches!(s, AlgoSpec::Bary2(_)) && s.is_linear()));
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
            ("biharmonic:smooth_lips=-0.1", "from 0 to 0.25"),
            ("biharmonic:smooth_lips=0.3", "from 0 to 0.25"),
            ("biharmonic:smooth_lips=NaN", "from 0 to 0.25"),
            ("biharmonic:smooth_lips=wide", "not a number"),
        ] {
            let err = text.parse::<AlgoSpec>().unwrap_err().to_string();
            assert!(err.contains(problem), "{text}: {err}");
        }
    }

    #[test]
    fn biharmonic_defaults_and_round_trip() {
        let spec: AlgoSpec = "biharmonic".parse().unwrap();
        let recommended = AlgoSpec::Biharmonic(BiharmonicParams {
            hold_mm: 50.0,
            eyes_hold_mm: 20.0,
            k: 32,
            smooth_lips: 0.125,
        });
        assert_eq!(spec, recommended);
        assert_eq!(
            spec.to_string(),
            "biharmonic:hold_mm=50,eyes_hold_mm=20,k=32,smooth_lips=0.125"
        );
        let spec: AlgoSpec = "biharmonic:hold_mm=40,smooth_lips=0".parse().unwrap();
        assert_eq!(
            spec.to_string(),
            "biharmonic:hold_mm=40,eyes_hold_mm=20,k=32,smooth_lips=0"
        );
        let spec: AlgoSpec = "Biharmonic: k=4, eyes_hold_mm=12, hold_mm=30.5".parse().unwrap();
        assert_eq!(spec.to_string().parse::<AlgoSpec>(), Ok(spec));
        assert!(spec.is_linear() && spec.letter().is_none());
    }
}
