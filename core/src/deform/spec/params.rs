//! Each algorithm's parameters as a type of its own: its name in a spec, the keys it
//! takes, its defaults, how given values change them, and how it writes them back in the
//! canonical form (every parameter, in a fixed order, which parses to the same value).

use std::fmt;

use super::given::{name_of, Given, Names};
use super::weights::{Weights, FEATURE_POINT_KEYS, TRIANGLE_KEYS};
use super::SpecError;

/// One algorithm's parameters.
pub trait AlgoParams: Copy {
    /// The algorithm's name in a spec.
    const NAME: &'static str;
    /// The keys it takes, in the order it writes them.
    const KEYS: &'static [&'static str];
    /// Its parameters when a spec gives none.
    const DEFAULT: Self;
    /// Changes the parameters `given` names (its keys are among [`AlgoParams::KEYS`]).
    fn apply(&mut self, given: &Given) -> Result<(), SpecError>;
    /// Writes `key=value,...` for every key (nothing for an algorithm without any).
    fn write(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result;
}

/// Parameters that are a falloff `alpha` outside the mask and nothing else.
macro_rules! falloff {
    ($(#[$doc:meta])* $params:ident, $name:literal) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub struct $params {
            /// The exponential falloff of the nearest controls (or corners) outside the mask.
            pub alpha: f32,
        }

        impl AlgoParams for $params {
            const NAME: &'static str = $name;
            const KEYS: &'static [&'static str] = &["alpha"];
            const DEFAULT: Self = $params { alpha: 0.4 };
            fn apply(&mut self, given: &Given) -> Result<(), SpecError> {
                self.alpha = given.positive("alpha")?.unwrap_or(self.alpha);
                Ok(())
            }
            fn write(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "alpha={}", self.alpha)
            }
        }
    };
}

falloff!(
    /// `bary1`: a vertex rides on its mask triangle's local frame inside the mask; outside,
    /// the 3 nearest controls with an exponential falloff.
    Bary1Params,
    "bary1"
);
falloff!(
    /// `renato2`: barycentric weights inside the mask triangle; outside, the nearest
    /// corners with an exponential falloff.
    Renato2Params,
    "renato2"
);

/// Parameters that are a blend of control elements and nothing else: triangles, or the
/// controls themselves (`feature_points`, `geometric`).
macro_rules! blended {
    ($(#[$doc:meta])* $params:ident, $name:literal, $default:expr, $feature_points:literal) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub struct $params {
            pub weights: Weights,
        }

        impl AlgoParams for $params {
            const NAME: &'static str = $name;
            const KEYS: &'static [&'static str] = match $feature_points {
                true => FEATURE_POINT_KEYS,
                false => TRIANGLE_KEYS,
            };
            const DEFAULT: Self = $params { weights: $default };
            fn apply(&mut self, given: &Given) -> Result<(), SpecError> {
                self.weights = self.weights.with(given, $feature_points)?;
                Ok(())
            }
            fn write(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "{}", self.weights)
            }
        }
    };
}

blended!(
    /// `bary2`: the local frames of the nearest mask triangles (surface-oriented FFD).
    Bary2Params,
    "bary2",
    Weights::None,
    false
);
blended!(
    /// `renato3`: barycentric weights of the nearest mask triangles.
    Renato3Params,
    "renato3",
    Weights::None,
    false
);
blended!(
    /// `planar_bones`: each mask triangle carries nearby vertices like a bone.
    PlanarBonesParams,
    "planar_bones",
    Weights::PlanarBones { r_pct: 10.0, n: 1.0 },
    false
);
blended!(
    /// `geometric`: a blend of the controls (feature points) themselves.
    GeometricParams,
    "geometric",
    Weights::None,
    true
);

/// `true` and `false`, as `interpolate=` takes them.
const BOOLEANS: &Names<bool> = &[("true", true), ("false", false)];

/// `point_distance`: the nearest controls along the surface, weights `1/(1+d^local)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointDistanceParams {
    /// Controls blended per vertex; `None` for every reachable one (`k=all`).
    pub k: Option<u32>,
    pub local: f32,
    /// Blend corrected values so the controls are reproduced at their anchors.
    pub interpolate: bool,
}

impl AlgoParams for PointDistanceParams {
    const NAME: &'static str = "point_distance";
    const KEYS: &'static [&'static str] = &["k", "local", "interpolate"];
    const DEFAULT: Self = PointDistanceParams {
        k: Some(3),
        local: 2.0,
        interpolate: true,
    };
    fn apply(&mut self, given: &Given) -> Result<(), SpecError> {
        if let Some(v) = given.get("k") {
            self.k = if v.eq_ignore_ascii_case("all") {
                None
            } else {
                let n = given.number("k", v)?;
                if n.fract() != 0.0 {
                    return Err(given.bad("k", v, "must be a whole number or \"all\""));
                }
                Some(n as u32)
            };
        }
        self.local = given.positive("local")?.unwrap_or(self.local);
        self.interpolate = given.choice("interpolate", BOOLEANS)?.unwrap_or(self.interpolate);
        Ok(())
    }
    fn write(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.k {
            Some(k) => write!(f, "k={k}")?,
            None => write!(f, "k=all")?,
        }
        write!(
            f,
            ",local={},interpolate={}",
            self.local,
            name_of(BOOLEANS, self.interpolate)
        )
    }
}

/// Parameters of an algorithm that takes none.
macro_rules! no_parameters {
    ($(#[$doc:meta])* $params:ident, $name:literal) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub struct $params;

        impl AlgoParams for $params {
            const NAME: &'static str = $name;
            const KEYS: &'static [&'static str] = &[];
            const DEFAULT: Self = $params;
            fn apply(&mut self, _: &Given) -> Result<(), SpecError> {
                Ok(())
            }
            fn write(&self, _: &mut fmt::Formatter<'_>) -> fmt::Result {
                Ok(())
            }
        }
    };
}

no_parameters!(
    /// `renato1`: barycentric weights inside, their absolute values outside.
    Renato1Params,
    "renato1"
);
no_parameters!(
    /// `kshirsagar`: the published feature-point method.
    KshirsagarParams,
    "kshirsagar"
);

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kernel {
    Gaussian,
    Multiquadric,
    InverseMultiquadric,
    ThinPlate,
    Wendland,
}

const KERNELS: &Names<Kernel> = &[
    ("gaussian", Kernel::Gaussian),
    ("multiquadric", Kernel::Multiquadric),
    ("inverse_multiquadric", Kernel::InverseMultiquadric),
    ("thin_plate", Kernel::ThinPlate),
    ("wendland", Kernel::Wendland),
];

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Metric {
    Euclidean,
    Surface,
}

const METRICS: &Names<Metric> = &[("euclidean", Metric::Euclidean), ("surface", Metric::Surface)];

/// `poly=`: with the linear polynomial term or without.
const POLYNOMIALS: &Names<bool> = &[("linear", true), ("none", false)];

/// `rbf`: radial basis functions through every control.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RbfParams {
    pub kernel: Kernel,
    pub metric: Metric,
    /// Kernel scale (Gaussian, multiquadrics) or support radius (Wendland), mm.
    pub r_mm: f32,
    /// Add the linear polynomial term (reproduces affine motions exactly).
    pub polynomial: bool,
}

impl AlgoParams for RbfParams {
    const NAME: &'static str = "rbf";
    const KEYS: &'static [&'static str] = &["kernel", "distance", "r_mm", "poly"];
    const DEFAULT: Self = RbfParams {
        kernel: Kernel::Wendland,
        metric: Metric::Surface,
        r_mm: 30.0,
        polynomial: true,
    };
    fn apply(&mut self, given: &Given) -> Result<(), SpecError> {
        self.kernel = given.choice("kernel", KERNELS)?.unwrap_or(self.kernel);
        self.metric = given.choice("distance", METRICS)?.unwrap_or(self.metric);
        self.r_mm = given.positive("r_mm")?.unwrap_or(self.r_mm);
        self.polynomial = given.choice("poly", POLYNOMIALS)?.unwrap_or(self.polynomial);
        Ok(())
    }
    fn write(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "kernel={},distance={},r_mm={},poly={}",
            name_of(KERNELS, self.kernel),
            name_of(METRICS, self.metric),
            self.r_mm,
            name_of(POLYNOMIALS, self.polynomial)
        )
    }
}

/// Most weights a `biharmonic` vertex may keep.
pub const MAX_BIHARMONIC_K: u32 = 128;

/// `biharmonic`: the smoothest field through every control.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BiharmonicParams {
    /// How far along the surface an anchor reaches, mm: a vertex beyond its nearest
    /// anchor's reach is held still. This one is for every anchor but the eyes'.
    pub hold_mm: f32,
    /// The reach of the eye controls' anchors ([`FaceRegion::Eyes`](crate::mask::FaceRegion)),
    /// mm: the fold of the upper eyelid overshoots when they reach far.
    pub eyes_hold_mm: f32,
    /// Weights kept per vertex (the largest), rescaled to their full sum.
    pub k: u32,
    /// The radius the field is smoothed over near the lips, as a share of the mouth's
    /// width at rest (0: not smoothed; see `deform::lip_smoothing`).
    pub smooth_lips: f32,
}

/// Largest `smooth_lips`: a quarter of the mouth's width already averages the lip
/// contours with the cheeks.
pub const MAX_SMOOTH_LIPS: f32 = 0.25;

impl AlgoParams for BiharmonicParams {
    const NAME: &'static str = "biharmonic";
    const KEYS: &'static [&'static str] = &["hold_mm", "eyes_hold_mm", "k", "smooth_lips"];
    const DEFAULT: Self = BiharmonicParams {
        hold_mm: 50.0,
        eyes_hold_mm: 20.0,
        k: 32,
        smooth_lips: 0.125,
    };
    fn apply(&mut self, given: &Given) -> Result<(), SpecError> {
        self.hold_mm = given.positive("hold_mm")?.unwrap_or(self.hold_mm);
        self.eyes_hold_mm = given.positive("eyes_hold_mm")?.unwrap_or(self.eyes_hold_mm);
        if let Some(v) = given.get("k") {
            let n = given.number("k", v)?;
            if n.fract() != 0.0 || n > MAX_BIHARMONIC_K as f32 {
                return Err(given.bad(
                    "k",
                    v,
                    format!("must be a whole number from 1 to {MAX_BIHARMONIC_K}"),
                ));
            }
            self.k = n as u32;
        }
        if let Some(v) = given.get("smooth_lips") {
            let share: f32 = v
                .parse()
                .map_err(|_| given.bad("smooth_lips", v, "not a number"))?;
            if !(0.0..=MAX_SMOOTH_LIPS).contains(&share) {
                return Err(given.bad(
                    "smooth_lips",
                    v,
                    format!("must be a share of the mouth's width from 0 to {MAX_SMOOTH_LIPS}"),
                ));
            }
            self.smooth_lips = share;
        }
        Ok(())
    }
    fn write(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "hold_mm={},eyes_hold_mm={},k={},smooth_lips={}",
            self.hold_mm, self.eyes_hold_mm, self.k, self.smooth_lips
        )
    }
}
