//! Service configuration: defaults, then a TOML file, then `FACEWIRE_*` environment
//! variables, then command-line flags, each overriding the one before. Every field is
//! documented in `deploy/facewire.example.toml`.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};

use serde::Deserialize;

/// The algorithm facewire recommends (preset U, the thesis's G made exact at the anchors):
/// smooth lips, almost no new creases, every control reproduced, about 31 µs per frame on
/// the scan. See the README's "Which algorithm" and docs/reports/.
pub const DEFAULT_ALGORITHM: &str = "point_distance";

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Config {
    /// Address to listen on.
    pub addr: SocketAddr,
    /// Where registered heads are stored; `None` keeps them in memory only (the demo).
    pub data_dir: Option<PathBuf>,
    /// Algorithm viewers get when they name none ([`DEFAULT_ALGORITHM`]).
    pub default_algorithm: String,
    pub limits: Limits,
    pub auth: Auth,
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Limits {
    /// Largest HTTP body (head uploads, batches), bytes.
    pub max_upload_bytes: usize,
    /// Largest head a registration accepts, vertices.
    pub max_vertices: usize,
    /// Largest producer WebSocket message, bytes.
    pub max_message_bytes: usize,
    /// Most frames per second a producer may send.
    pub max_fps: f64,
    /// A producer that sends nothing for this long is closed, seconds.
    pub producer_idle_s: f64,
    /// Most viewers at once over all streams.
    pub max_viewers: usize,
    /// Most frames one HTTP batch may hold.
    pub max_batch_frames: usize,
}

#[derive(Debug, Clone, PartialEq, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Auth {
    /// Token every producer must present (`?token=` or `Authorization: Bearer`), unless
    /// the head was registered with its own.
    pub producer_token: Option<String>,
    /// Token every viewer must present.
    pub viewer_token: Option<String>,
    /// Token needed to register and delete heads.
    pub admin_token: Option<String>,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            addr: SocketAddr::from(([127, 0, 0, 1], 8480)),
            data_dir: Some(PathBuf::from("facewire-data")),
            default_algorithm: DEFAULT_ALGORITHM.into(),
            limits: Limits::default(),
            auth: Auth::default(),
        }
    }
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_upload_bytes: 64 << 20,
            max_vertices: 500_000,
            max_message_bytes: 64 << 10,
            max_fps: 240.0,
            producer_idle_s: 30.0,
            max_viewers: 2_000,
            max_batch_frames: 200_000,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("cannot read {path}: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("{path}: {message}")]
    Toml { path: String, message: String },
    #[error("environment variable {name}={value:?}: {message}")]
    Env {
        name: &'static str,
        value: String,
        message: String,
    },
    #[error("default_algorithm {value:?}: {message}")]
    Algorithm { value: String, message: String },
}

impl Config {
    /// Reads a TOML file over the defaults.
    pub fn load(path: &Path) -> Result<Config, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
            path: path.display().to_string(),
            source,
        })?;
        toml::from_str(&text).map_err(|e| ConfigError::Toml {
            path: path.display().to_string(),
            message: e.to_string(),
        })
    }

    /// Applies `FACEWIRE_ADDR`, `FACEWIRE_DATA_DIR`, `FACEWIRE_DEFAULT_ALGORITHM`,
    /// `FACEWIRE_PRODUCER_TOKEN`, `FACEWIRE_VIEWER_TOKEN`, `FACEWIRE_ADMIN_TOKEN` from `env`.
    pub fn apply_env(&mut self, env: impl Fn(&str) -> Option<String>) -> Result<(), ConfigError> {
        if let Some(value) = env("FACEWIRE_ADDR") {
            self.addr = value
                .parse()
                .map_err(|e: std::net::AddrParseError| ConfigError::Env {
                    name: "FACEWIRE_ADDR",
                    value: value.clone(),
                    message: e.to_string(),
                })?;
        }
        if let Some(value) = env("FACEWIRE_DATA_DIR") {
            self.data_dir = Some(PathBuf::from(value));
        }
        if let Some(value) = env("FACEWIRE_DEFAULT_ALGORITHM") {
            self.default_algorithm = value;
        }
        for (name, slot) in [
            ("FACEWIRE_PRODUCER_TOKEN", &mut self.auth.producer_token),
            ("FACEWIRE_VIEWER_TOKEN", &mut self.auth.viewer_token),
            ("FACEWIRE_ADMIN_TOKEN", &mut self.auth.admin_token),
        ] {
            if let Some(value) = env(name) {
                *slot = Some(value).filter(|v| !v.is_empty());
            }
        }
        Ok(())
    }

    /// Checks what parsing alone cannot.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.default_algorithm
            .parse::<crate::deform::AlgoSpec>()
            .map_err(|e| ConfigError::Algorithm {
                value: self.default_algorithm.clone(),
                message: e.to_string(),
            })?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_example_config_is_valid() {
        let config: Config = toml::from_str(include_str!("../../deploy/facewire.example.toml")).unwrap();
        config.validate().unwrap();
        assert_eq!(config.addr.port(), 8480);
        assert_eq!(config.limits, Limits::default());
        assert_eq!(config.auth, Auth::default());
    }

    #[test]
    fn file_then_environment() {
        let mut config: Config = toml::from_str(
            "addr = \"0.0.0.0:9000\"\n[limits]\nmax_fps = 60.0\n[auth]\nviewer_token = \"v\"\n",
        )
        .unwrap();
        assert_eq!(config.addr.port(), 9000);
        assert_eq!(config.limits.max_fps, 60.0);
        assert_eq!(config.limits.max_vertices, Limits::default().max_vertices);
        config
            .apply_env(|name| (name == "FACEWIRE_PRODUCER_TOKEN").then(|| "p".to_string()))
            .unwrap();
        assert_eq!(config.auth.producer_token.as_deref(), Some("p"));
        assert_eq!(config.auth.viewer_token.as_deref(), Some("v"));
        let err = config
            .apply_env(|name| (name == "FACEWIRE_ADDR").then(|| "nowhere".to_string()))
            .unwrap_err();
        assert!(
            err.to_string().starts_with("environment variable FACEWIRE_ADDR"),
            "{err}"
        );
        assert!(toml::from_str::<Config>("adress = 1").is_err());
        config.default_algorithm = "smooth".into();
        assert!(config.validate().is_err());
    }
}
