//! How several control elements (triangles, or feature points for `geometric`) are
//! blended: the `weights=` parameter and the keys that go with each system, shared by the
//! algorithms that blend (`bary2`, `planar_bones`, `renato3`, `geometric`).

use std::fmt;

use super::given::Given;
use super::SpecError;

/// How several control elements are blended. Distances are surface distances in mm.
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

/// The keys of the weights, for an algorithm's list of keys.
pub const TRIANGLE_KEYS: &[&str] = &["weights", "r_mm", "local", "r_pct", "n"];
/// ... and for `geometric`'s feature points.
pub const FEATURE_POINT_KEYS: &[&str] = &["weights", "r_mm", "local"];

impl Weights {
    /// The system's name in `weights=`.
    fn system(self) -> &'static str {
        match self {
            Weights::None => "none",
            Weights::Distance { .. } => "distance",
            Weights::PlanarBones { .. } => "planar_bones",
            Weights::Kshirsagar { .. } => "kshirsagar",
        }
    }

    /// The weights `given` asks for, `self` when it asks for none; `feature_points` for
    /// `geometric` (kshirsagar instead of planar_bones). A radius alone picks its system.
    pub fn with(self, given: &Given, feature_points: bool) -> Result<Weights, SpecError> {
        let system = match given.get("weights") {
            Some(s) => s.to_ascii_lowercase(),
            None if given.get("r_mm").is_some() => match feature_points {
                true => "kshirsagar".into(),
                false => "distance".into(),
            },
            None if given.get("r_pct").is_some() => "planar_bones".into(),
            None => self.system().into(),
        };
        let stray = |keys: &[&str], system: &str| -> Result<(), SpecError> {
            match keys.iter().find(|k| given.get(k).is_some()) {
                Some(k) => Err(SpecError::Inconsistent {
                    algorithm: given.algorithm,
                    problem: format!("parameter {k} does not apply to weights={system}"),
                }),
                None => Ok(()),
            }
        };
        match system.as_str() {
            "none" => {
                stray(&["r_mm", "local", "r_pct", "n"], "none")?;
                Ok(Weights::None)
            }
            "distance" => {
                stray(&["r_pct", "n"], "distance")?;
                Ok(Weights::Distance {
                    r_mm: given.positive("r_mm")?.unwrap_or(10.0),
                    local: given.positive("local")?.unwrap_or(2.0),
                })
            }
            "planar_bones" if !feature_points => {
                stray(&["r_mm", "local"], "planar_bones")?;
                Ok(Weights::PlanarBones {
                    r_pct: given.positive("r_pct")?.unwrap_or(10.0),
                    n: given.positive("n")?.unwrap_or(1.0),
                })
            }
            "kshirsagar" if feature_points => {
                stray(&["local"], "kshirsagar")?;
                Ok(Weights::Kshirsagar {
                    r_mm: given.positive("r_mm")?.unwrap_or(10.0),
                })
            }
            other => Err(given.bad(
                "weights",
                other,
                match feature_points {
                    true => "valid: none, distance, kshirsagar",
                    false => "valid: none, distance, planar_bones",
                },
            )),
        }
    }
}

impl fmt::Display for Weights {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "weights={}", self.system())?;
        match self {
            Weights::None => Ok(()),
            Weights::Distance { r_mm, local } => write!(f, ",r_mm={r_mm},local={local}"),
            Weights::PlanarBones { r_pct, n } => write!(f, ",r_pct={r_pct},n={n}"),
            Weights::Kshirsagar { r_mm } => write!(f, ",r_mm={r_mm}"),
        }
    }
}
