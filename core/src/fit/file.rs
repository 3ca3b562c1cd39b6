//! The `.fit.toml` file: a small, hand-editable record of one fit, stored next to its head.
//!
//! ```toml
//! head = "makehuman_head.obj"   # the head this fit belongs to (informational)
//! mm_per_unit = 100.0           # millimetres per head unit; derived from 63 mm pupils if absent
//! rotation_deg = [0.0, 0.0, 0.0] # rx ry rz, R = Rz Ry Rx
//! scale = 0.55                  # head units per mask unit
//! translation = [0.0, 7.2, 1.0] # head units
//!
//! [shape_units]                 # weights by unit key (see `facewire inspect candide3.wfm`)
//! head_height = 0.12
//!
//! [[nudge]]                     # optional per-vertex offsets, mask units, before the pose
//! vertex = 31
//! offset = [0.0, 0.01, 0.0]
//! ```

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::limits::{finite3, in_range, RangeError, MM_PER_UNIT_RANGE, SCALE_RANGE};
use super::Fit;
use crate::input::{read_file, toml_error, utf8, ReadError, MAX_TEXT_BYTES};
use crate::mask::{Mask, MaskPose};
use crate::quote::clip;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitFile {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub head: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mm_per_unit: Option<f32>,
    pub rotation_deg: [f32; 3],
    pub scale: f32,
    pub translation: [f32; 3],
    /// What the fit's maker asks a person to check (the automatic fit's warnings,
    /// [`crate::fit::AutomaticFitWarning`]); the fit report repeats them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    #[serde(default)]
    pub shape_units: BTreeMap<String, f32>,
    #[serde(default, rename = "nudge", skip_serializing_if = "Vec::is_empty")]
    pub nudges: Vec<Nudge>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Nudge {
    pub vertex: u32,
    /// Mask units.
    pub offset: [f32; 3],
}

#[derive(Debug, thiserror::Error)]
pub enum FitFileError {
    #[error(transparent)]
    Read(#[from] ReadError),
    #[error("{path}: {message}")]
    Toml { path: String, message: String },
    #[error("{path}: field {field}: {message}")]
    Invalid {
        path: String,
        field: String,
        message: String,
    },
}

impl FitFile {
    /// Reads a `.fit.toml`: a regular file of at most [`MAX_TEXT_BYTES`], UTF-8.
    pub fn load(path: &Path) -> Result<FitFile, FitFileError> {
        let origin = path.display().to_string();
        let bytes = read_file(path, MAX_TEXT_BYTES)?;
        FitFile::parse(&origin, utf8(&origin, &bytes)?)
    }

    /// Parses TOML text; `origin` names the source in errors, which give the line and
    /// column and quote at most a few dozen characters of the input.
    pub fn parse(origin: &str, text: &str) -> Result<FitFile, FitFileError> {
        toml::from_str(text).map_err(|e| FitFileError::Toml {
            path: origin.to_string(),
            message: toml_error(text, &e),
        })
    }

    /// The file's text: a header, then one line per field with arrays inline and numbers
    /// rounded to what a fit can resolve (1e-4 degrees, 1e-6 head units).
    pub fn to_toml(&self) -> String {
        use std::fmt::Write;
        let mut out = String::from(
            "# facewire fit: lays the CANDIDE-3 mask on a head.\n\
             # g = R(rotation_deg; R = Rz Ry Rx) * scale * (g0 + SU sigma + nudge) + translation\n\
             # rotation in degrees, scale in head units per mask unit, translation in head units,\n\
             # mm_per_unit in millimetres per head unit.\n",
        );
        let vec3 = |v: [f32; 3], digits: usize| {
            let parts: Vec<String> = v.iter().map(|x| trim_float(*x, digits)).collect();
            format!("[{}]", parts.join(", "))
        };
        if let Some(head) = &self.head {
            let _ = writeln!(out, "head = {}", toml::Value::String(head.clone()));
        }
        if let Some(mm) = self.mm_per_unit {
            let _ = writeln!(out, "mm_per_unit = {}", trim_float(mm, 4));
        }
        let _ = writeln!(out, "rotation_deg = {}", vec3(self.rotation_deg, 4));
        let _ = writeln!(out, "scale = {}", trim_float(self.scale, 6));
        let _ = writeln!(out, "translation = {}", vec3(self.translation, 6));
        if !self.warnings.is_empty() {
            let quoted: Vec<String> = self
                .warnings
                .iter()
                .map(|w| toml::Value::String(w.clone()).to_string())
                .collect();
            let _ = writeln!(out, "# what the fit's maker asks a person to check");
            let _ = writeln!(out, "warnings = [{}]", quoted.join(", "));
        }
        let _ = writeln!(out, "\n[shape_units]");
        for (name, value) in &self.shape_units {
            let _ = writeln!(out, "{name} = {}", trim_float(*value, 4));
        }
        for n in &self.nudges {
            let _ = writeln!(
                out,
                "\n[[nudge]]\nvertex = {}\noffset = {}",
                n.vertex,
                vec3(n.offset, 6)
            );
        }
        out
    }

    /// Resolves unit names against `mask` and checks every value: scale and
    /// `mm_per_unit` within [`SCALE_RANGE`] and [`MM_PER_UNIT_RANGE`], the rest finite.
    /// `origin` names the file in errors.
    pub fn resolve(&self, origin: &str, mask: &Mask) -> Result<Fit, FitFileError> {
        let invalid = |field: &str, message: String| FitFileError::Invalid {
            path: origin.to_string(),
            field: field.to_string(),
            message,
        };
        let out_of_range = |e: RangeError| invalid(&e.field, e.reason);
        let rotation = finite3("rotation_deg", self.rotation_deg).map_err(out_of_range)?;
        let translation = finite3("translation", self.translation).map_err(out_of_range)?;
        let scale = in_range("scale", self.scale, SCALE_RANGE).map_err(out_of_range)?;
        let mut shape = vec![0.0; mask.shape_units.len()];
        for (name, &value) in &self.shape_units {
            let field = format!("shape_units.{}", clip(name));
            let index = mask
                .shape_unit(name)
                .map_err(|e| invalid(&field, e.to_string()))?;
            if !value.is_finite() {
                return Err(invalid(&field, format!("{value} is not finite")));
            }
            shape[index] = value;
        }
        let mut nudges = Vec::with_capacity(self.nudges.len());
        for (i, n) in self.nudges.iter().enumerate() {
            if n.vertex as usize >= mask.vertices.len() {
                return Err(invalid(
                    &format!("nudge[{i}].vertex"),
                    format!(
                        "{} is out of range (the mask has {} vertices)",
                        n.vertex,
                        mask.vertices.len()
                    ),
                ));
            }
            let offset = finite3(&format!("nudge[{i}].offset"), n.offset).map_err(out_of_range)?;
            nudges.push((n.vertex, offset));
        }
        let pose = MaskPose::similarity(rotation * (std::f32::consts::PI / 180.0), scale, translation);
        let mm_per_unit = match self.mm_per_unit {
            Some(mm) => in_range("mm_per_unit", mm, MM_PER_UNIT_RANGE),
            None => in_range(
                "mm_per_unit (from 63 mm pupils)",
                Fit::mm_per_unit_from_pupils(mask, &shape, &pose),
                MM_PER_UNIT_RANGE,
            ),
        }
        .map_err(out_of_range)?;
        Ok(Fit {
            pose,
            shape,
            nudges,
            mm_per_unit,
        })
    }

    /// The file form of a resolved fit; shape units at zero are left out.
    pub fn from_fit(fit: &Fit, mask: &Mask, head: Option<String>) -> FitFile {
        let degrees = fit.pose.rotation_rad * (180.0 / std::f32::consts::PI);
        FitFile {
            head,
            mm_per_unit: Some(fit.mm_per_unit),
            rotation_deg: degrees.to_array(),
            scale: fit.pose.scale.x,
            translation: fit.pose.translation.to_array(),
            shape_units: mask
                .shape_units
                .iter()
                .zip(&fit.shape)
                .filter(|(_, &w)| w.abs() >= 5e-5)
                .map(|(u, &w)| (u.key.clone(), w))
                .collect(),
            nudges: fit
                .nudges
                .iter()
                .map(|&(vertex, offset)| Nudge {
                    vertex,
                    offset: offset.to_array(),
                })
                .collect(),
            warnings: Vec::new(),
        }
    }
}

/// `x` with at most `digits` decimals and no trailing zeros, always with a decimal point
/// (so TOML reads it as a float); `-0` prints as `0.0`.
fn trim_float(x: f32, digits: usize) -> String {
    let text = format!("{x:.digits$}");
    let text = text.trim_end_matches('0');
    let text = if text.ends_with('.') {
        format!("{text}0")
    } else {
        text.to_string()
    };
    if text.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
        "0.0".to_string()
    } else {
        text
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    const SAMPLE: &str = r#"
head = "h.obj"
mm_per_unit = 100.0
rotation_deg = [10.0, 0.0, 0.0]
scale = 0.5
translation = [0.0, 7.0, 1.0]
[shape_units]
head_height = 0.25
[[nudge]]
vertex = 31
offset = [0.0, 0.01, 0.0]
"#;

    #[test]
    fn round_trips_through_toml() {
        let mask = Mask::candide3();
        let file = FitFile::parse("sample", SAMPLE).unwrap();
        let fit = file.resolve("sample", &mask).unwrap();
        assert_eq!(fit.shape[0], 0.25);
        assert!((fit.pose.rotation_rad.x - 10f32.to_radians()).abs() < 1e-7);
        assert_eq!(fit.nudges, vec![(31, Vec3::new(0.0, 0.01, 0.0))]);
        let again = FitFile::parse(
            "again",
            &FitFile::from_fit(&fit, &mask, file.head.clone()).to_toml(),
        )
        .unwrap();
        let fit_again = again.resolve("again", &mask).unwrap();
        assert_eq!(fit_again.shape, fit.shape);
        assert_eq!(fit_again.nudges, fit.nudges);
        assert!(fit_again
            .pose
            .rotation_rad
            .abs_diff_eq(fit.pose.rotation_rad, 1e-6));
    }

    /// The automatic fit's warnings travel in the file, before its tables, and back.
    #[test]
    fn warnings_round_trip_through_toml() {
        let file = FitFile {
            warnings: vec!["check the \"chin\"".into(), "and the eyes".into()],
            ..FitFile::parse("sample", SAMPLE).unwrap()
        };
        let text = file.to_toml();
        assert!(
            text.find("warnings").unwrap() < text.find("[shape_units]").unwrap(),
            "{text}"
        );
        assert_eq!(FitFile::parse("again", &text).unwrap(), file);
        assert!(!FitFile::parse("sample", SAMPLE)
            .unwrap()
            .to_toml()
            .contains("warnings"));
    }

    #[test]
    fn floats_are_written_short_and_as_floats() {
        assert_eq!(trim_float(1.5, 4), "1.5");
        assert_eq!(trim_float(2.0, 4), "2.0");
        assert_eq!(trim_float(-3.4e-15, 4), "0.0");
        assert_eq!(trim_float(0.1234567, 6), "0.123457");
    }

    #[test]
    fn errors_name_the_field() {
        let mask = Mask::candide3();
        let bad = SAMPLE.replace("head_height", "head_hieght");
        let err = FitFile::parse("f.fit.toml", &bad)
            .unwrap()
            .resolve("f.fit.toml", &mask)
            .unwrap_err();
        assert!(
            err.to_string()
                .starts_with("f.fit.toml: field shape_units.head_hieght: unknown shape unit"),
            "{err}"
        );
        let bad = SAMPLE.replace("vertex = 31", "vertex = 500");
        let err = FitFile::parse("f", &bad)
            .unwrap()
            .resolve("f", &mask)
            .unwrap_err();
        assert!(err.to_string().contains("nudge[0].vertex"), "{err}");
        let bad = SAMPLE.replace("scale = 0.5", "scale = -1.0");
        let err = FitFile::parse("f", &bad)
            .unwrap()
            .resolve("f", &mask)
            .unwrap_err();
        assert!(err.to_string().contains("field scale"), "{err}");
        let err = FitFile::parse("f", "scale = 1\nrotation = 3").unwrap_err();
        assert!(err.to_string().starts_with("f: "), "{err}");
    }

    #[test]
    fn extreme_scales_are_refused() {
        let mask = Mask::candide3();
        for (from, to, field) in [
            ("scale = 0.5", "scale = 1e30", "scale"),
            ("scale = 0.5", "scale = 1e-30", "scale"),
            ("scale = 0.5", "scale = nan", "scale"),
            ("mm_per_unit = 100.0", "mm_per_unit = 1e-30", "mm_per_unit"),
            ("mm_per_unit = 100.0", "mm_per_unit = 0.0", "mm_per_unit"),
            ("mm_per_unit = 100.0", "mm_per_unit = inf", "mm_per_unit"),
        ] {
            let err = FitFile::parse("f", &SAMPLE.replace(from, to))
                .unwrap()
                .resolve("f", &mask)
                .unwrap_err()
                .to_string();
            assert!(err.starts_with(&format!("f: field {field}: ")), "{to}: {err}");
            assert!(err.ends_with("is not a number in [1e-6, 1e6]"), "{to}: {err}");
        }
    }

    #[test]
    fn toml_errors_give_the_line_and_cut_long_values() {
        let token = "x".repeat(6_000_000);
        let err = FitFile::parse("f", &format!("scale = 0.5\nhead = {token}\n"))
            .unwrap_err()
            .to_string();
        assert!(err.len() < 200, "{} bytes", err.len());
        assert!(err.starts_with("f: line 2, column 8: "), "{err}");
        let err = FitFile::parse("f", &format!("scale = 0.5\n{token} = 1\n"))
            .unwrap_err()
            .to_string();
        assert!(err.len() < 500, "{} bytes", err.len());
        let mask = Mask::candide3();
        let long_unit = SAMPLE.replace(
            "head_height = 0.25",
            &format!("head_height = 0.25\n{token} = 0.1"),
        );
        let err = FitFile::parse("f", &long_unit)
            .unwrap()
            .resolve("f", &mask)
            .unwrap_err()
            .to_string();
        assert!(err.len() < 2_000, "{} bytes", err.len());
        assert!(err.contains("(6000000 bytes)"), "{err}");
    }

    #[test]
    fn bad_utf8_names_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("h.fit.toml");
        std::fs::write(&path, b"scale = 0.5\n# caf\xe9\n").unwrap();
        let err = FitFile::load(&path).unwrap_err().to_string();
        assert!(
            err.ends_with("h.fit.toml: line 2, column 6: not valid UTF-8 (byte 17)"),
            "{err}"
        );
        let err = FitFile::load(Path::new("/dev/zero")).unwrap_err().to_string();
        assert!(err.ends_with("not a regular file"), "{err}");
    }
}
