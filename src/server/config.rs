//! Service configuration: defaults, then a TOML file, then `FACEWIRE_*` environment
//! variables, then command-line flags, each overriding the one before. Every field is
//! documented in `deploy/facewire.example.toml`.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};

use std::time::Duration;

use serde::Deserialize;

use crate::deform::AlgoSpec;
use crate::input::{read_text, ReadError, MAX_TEXT_BYTES};

/// The algorithm viewers get by default: the core's recommendation
/// ([`crate::deform::spec::DEFAULT_ALGORITHM`]).
pub const DEFAULT_ALGORITHM: &str = crate::deform::spec::DEFAULT_ALGORITHM;

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Config {
    /// Address to listen on.
    pub addr: SocketAddr,
    /// Where registered heads are stored; `None` keeps them in memory only (the demo).
    pub data_dir: Option<PathBuf>,
    /// Algorithm viewers get when they name none ([`DEFAULT_ALGORITHM`]).
    pub default_algorithm: String,
    /// When set, the only algorithms viewers may ask for (specs or preset letters); the
    /// default algorithm is always allowed.
    pub algorithms: Option<Vec<String>>,
    /// `"local"` (one node, no server needed) or a NATS URL (`nats://host:4222`, with
    /// JetStream; the servers of a NATS cluster comma-separated): the nodes sharing it share heads and streams (`src/server/cluster/`).
    pub bus: String,
    /// Copies JetStream keeps of each bucket the cluster makes (1-5; 3 on a
    /// three-server NATS cluster, so that one server lost loses nothing). Buckets that
    /// exist are used as they are.
    pub bus_replicas: usize,
    /// This node's name on the bus; a random `node-...` when absent.
    pub node_name: Option<String>,
    pub limits: Limits,
    pub auth: Auth,
    /// How this node authenticates to the NATS bus.
    pub bus_auth: BusAuth,
}

/// A secret from the configuration: read like a string, never printed (`Debug` shows
/// `***`).
#[derive(Clone, PartialEq, Eq, Deserialize)]
#[serde(transparent)]
pub struct Secret(String);

impl Secret {
    pub fn expose(&self) -> &str {
        &self.0
    }
}

impl From<&str> for Secret {
    fn from(text: &str) -> Secret {
        Secret(text.to_string())
    }
}

impl std::fmt::Debug for Secret {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("***")
    }
}

/// `[bus_auth]`: credentials and TLS for the NATS bus. At most one way to authenticate
/// (user and password, token, nkey seed, `.creds` file, or credentials in the bus URL).
#[derive(Debug, Clone, PartialEq, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BusAuth {
    pub user: Option<String>,
    pub password: Option<Secret>,
    pub token: Option<Secret>,
    /// An nkey user seed (`SU...`), or a file holding one.
    pub nkey_seed: Option<Secret>,
    pub nkey_seed_file: Option<PathBuf>,
    /// A NATS `.creds` file (user JWT and its seed).
    pub creds_file: Option<PathBuf>,
    /// The CA that signed the server's certificate (PEM); implies TLS.
    pub tls_ca: Option<PathBuf>,
    /// A client certificate and its key (PEM), for mutual TLS.
    pub tls_cert: Option<PathBuf>,
    pub tls_key: Option<PathBuf>,
    /// Refuse a server that does not speak TLS (also implied by `tls://` URLs).
    pub tls_required: bool,
    /// The key every node of the cluster shares (16 bytes or more): each bus message
    /// carries its HMAC, and messages without a valid one are dropped.
    pub cluster_key: Option<Secret>,
}

/// The bus `Config::bus` names.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Bus {
    Local,
    Nats(String),
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Limits {
    /// Largest HTTP body (head uploads, batches), bytes.
    pub max_upload_bytes: usize,
    /// Most vertices of a head and its parts together.
    pub max_vertices: usize,
    /// Most triangles of a head and its parts together.
    pub max_triangles: usize,
    /// Most heads the server holds (ready, registering or failed).
    pub max_heads: usize,
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
    /// Longest HTTP batch, seconds from its first frame's `t` to its last.
    pub max_batch_duration_s: f64,
    /// Most live streams per head.
    pub max_streams_per_head: usize,
    /// Most recorded streams a head keeps for replay (`record=` on a producer).
    pub max_recordings_per_head: usize,
    /// Most frames a recording keeps; a producer that sends more goes on unrecorded.
    pub max_recording_frames: usize,
    /// Most memory all recordings of the server take together, bytes; a recording that
    /// would go past it is cut there.
    pub max_recording_bytes: usize,
    /// A stream with no producer and no viewer is dropped this long after its last
    /// frame, seconds.
    pub stream_linger_s: f64,
    /// Most algorithms bound at once per head; bindings no viewer uses are evicted first.
    pub max_bindings_per_head: usize,
    /// Most deform pipelines (one per algorithm, heat map and frame format watched) per
    /// stream.
    pub max_pipelines_per_stream: usize,
    /// Most head registrations (upload, parse, fit, surface distances) and fit pictures
    /// at once.
    pub max_registrations: usize,
    /// Most threads for blocking work (registrations, slow frame jobs, pictures).
    pub max_blocking_threads: usize,
    /// Most open connections; more wait in the kernel's accept queue.
    pub max_connections: usize,
    /// A connection must send its request headers within this, seconds.
    pub header_timeout_s: f64,
    /// An HTTP request (body included) must be answered within this, seconds.
    pub request_timeout_s: f64,
    /// On SIGTERM, sockets get this long to close with a reason before the process
    /// exits, seconds.
    pub shutdown_grace_s: f64,
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
            algorithms: None,
            bus: "local".into(),
            bus_replicas: 1,
            node_name: None,
            limits: Limits::default(),
            auth: Auth::default(),
            bus_auth: BusAuth::default(),
        }
    }
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_upload_bytes: 64 << 20,
            max_vertices: 250_000,
            max_triangles: 500_000,
            max_heads: 100,
            max_message_bytes: 64 << 10,
            max_fps: 240.0,
            producer_idle_s: 30.0,
            max_viewers: 2_000,
            max_batch_frames: 200_000,
            max_batch_duration_s: 3600.0,
            max_streams_per_head: 16,
            max_recordings_per_head: 8,
            max_recording_frames: 18_000,
            max_recording_bytes: 256 << 20,
            stream_linger_s: 30.0,
            max_bindings_per_head: 8,
            max_pipelines_per_stream: 8,
            max_registrations: 2,
            max_blocking_threads: 64,
            max_connections: 1000,
            header_timeout_s: 10.0,
            request_timeout_s: 120.0,
            shutdown_grace_s: 5.0,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error(transparent)]
    Read(#[from] ReadError),
    #[error("{path}: {message}")]
    Toml { path: String, message: String },
    #[error("environment variable {name}={value:?}: {message}")]
    Env {
        name: &'static str,
        value: String,
        message: String,
    },
    #[error("{field} {value:?}: {message}")]
    Algorithm {
        field: &'static str,
        value: String,
        message: String,
    },
    #[error("bus = {0:?}: expected \"local\" or a NATS URL (nats://host:port or tls://host:port)")]
    Bus(String),
    #[error("bus_replicas = {0}: JetStream keeps 1 to 5 copies")]
    BusReplicas(usize),
    #[error("node_name = {0:?}: use 1-64 lowercase letters, digits, '-' or '_'")]
    NodeName(String),
    #[error("limits.{field} = {value}: {expected}")]
    Limit {
        field: &'static str,
        value: f64,
        expected: &'static str,
    },
}

impl Config {
    /// Reads a TOML file over the defaults.
    pub fn load(path: &Path) -> Result<Config, ConfigError> {
        let text = read_text(path, MAX_TEXT_BYTES)?;
        toml::from_str(&text).map_err(|e| ConfigError::Toml {
            path: path.display().to_string(),
            message: e.to_string(),
        })
    }

    /// Applies `FACEWIRE_ADDR`, `FACEWIRE_DATA_DIR`, `FACEWIRE_DEFAULT_ALGORITHM`,
    /// `FACEWIRE_BUS`, `FACEWIRE_NODE_NAME`, `FACEWIRE_PRODUCER_TOKEN`,
    /// `FACEWIRE_VIEWER_TOKEN`, `FACEWIRE_ADMIN_TOKEN` and the `FACEWIRE_BUS_*` of
    /// `[bus_auth]` (`FACEWIRE_BUS_USER`, `_PASSWORD`, `_TOKEN`, `_NKEY_SEED`,
    /// `_NKEY_SEED_FILE`, `_CREDS_FILE`, `_TLS_CA`, `_TLS_CERT`, `_TLS_KEY`) and
    /// `FACEWIRE_CLUSTER_KEY` from `env`.
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
        if let Some(value) = env("FACEWIRE_BUS") {
            self.bus = value;
        }
        if let Some(value) = env("FACEWIRE_NODE_NAME") {
            self.node_name = Some(value).filter(|v| !v.is_empty());
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
        let bus = &mut self.bus_auth;
        if let Some(value) = env("FACEWIRE_BUS_USER") {
            bus.user = Some(value).filter(|v| !v.is_empty());
        }
        for (name, slot) in [
            ("FACEWIRE_BUS_PASSWORD", &mut bus.password),
            ("FACEWIRE_BUS_TOKEN", &mut bus.token),
            ("FACEWIRE_BUS_NKEY_SEED", &mut bus.nkey_seed),
            ("FACEWIRE_CLUSTER_KEY", &mut bus.cluster_key),
        ] {
            if let Some(value) = env(name) {
                *slot = Some(Secret(value)).filter(|v| !v.0.is_empty());
            }
        }
        for (name, slot) in [
            ("FACEWIRE_BUS_NKEY_SEED_FILE", &mut bus.nkey_seed_file),
            ("FACEWIRE_BUS_CREDS_FILE", &mut bus.creds_file),
            ("FACEWIRE_BUS_TLS_CA", &mut bus.tls_ca),
            ("FACEWIRE_BUS_TLS_CERT", &mut bus.tls_cert),
            ("FACEWIRE_BUS_TLS_KEY", &mut bus.tls_key),
        ] {
            if let Some(value) = env(name) {
                *slot = Some(PathBuf::from(value)).filter(|v| !v.as_os_str().is_empty());
            }
        }
        Ok(())
    }

    /// Checks what parsing alone cannot.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.allowed_algorithms()?;
        self.bus()?;
        if !(1..=5).contains(&self.bus_replicas) {
            return Err(ConfigError::BusReplicas(self.bus_replicas));
        }
        if let Some(name) = &self.node_name {
            if !super::ids::valid_id(name) {
                return Err(ConfigError::NodeName(name.clone()));
            }
        }
        self.limits.validate()
    }

    /// The bus, parsed.
    pub fn bus(&self) -> Result<Bus, ConfigError> {
        let bus = self.bus.trim();
        if bus == "local" {
            return Ok(Bus::Local);
        }
        // One server, or several of a NATS cluster, comma-separated.
        let url_ok = bus.split(',').all(|url| {
            ["nats://", "tls://"].iter().any(|scheme| {
                url.trim()
                    .strip_prefix(scheme)
                    .is_some_and(|rest| !rest.is_empty())
            })
        });
        match url_ok {
            true => Ok(Bus::Nats(bus.to_string())),
            false => Err(ConfigError::Bus(super::bus_url::redacted(&self.bus))),
        }
    }

    /// The default algorithm and the allow-list, parsed: `(default, None)` when every
    /// algorithm is allowed.
    pub fn allowed_algorithms(&self) -> Result<(AlgoSpec, Option<Vec<AlgoSpec>>), ConfigError> {
        let parse = |field, text: &String| {
            text.parse::<AlgoSpec>().map_err(|e| ConfigError::Algorithm {
                field,
                value: text.clone(),
                message: e.to_string(),
            })
        };
        let default = parse("default_algorithm", &self.default_algorithm)?;
        let allowed = match &self.algorithms {
            None => None,
            Some(list) => {
                let mut specs = vec![default];
                for text in list {
                    specs.push(parse("algorithms", text)?);
                }
                Some(specs)
            }
        };
        Ok((default, allowed))
    }
}

impl Limits {
    fn validate(&self) -> Result<(), ConfigError> {
        let positive = |field, value: f64| {
            if value.is_finite() && value > 0.0 && value <= 1e9 {
                Ok(())
            } else {
                Err(ConfigError::Limit {
                    field,
                    value,
                    expected: "a positive number of at most 1e9",
                })
            }
        };
        for (field, value) in [
            ("max_fps", self.max_fps),
            ("producer_idle_s", self.producer_idle_s),
            ("max_batch_duration_s", self.max_batch_duration_s),
            ("stream_linger_s", self.stream_linger_s),
            ("header_timeout_s", self.header_timeout_s),
            ("request_timeout_s", self.request_timeout_s),
            ("shutdown_grace_s", self.shutdown_grace_s),
        ] {
            positive(field, value)?;
        }
        for (field, value) in [
            ("max_upload_bytes", self.max_upload_bytes),
            ("max_vertices", self.max_vertices),
            ("max_triangles", self.max_triangles),
            ("max_heads", self.max_heads),
            ("max_pipelines_per_stream", self.max_pipelines_per_stream),
            ("max_blocking_threads", self.max_blocking_threads),
            ("max_message_bytes", self.max_message_bytes),
            ("max_viewers", self.max_viewers),
            ("max_batch_frames", self.max_batch_frames),
            ("max_streams_per_head", self.max_streams_per_head),
            ("max_recordings_per_head", self.max_recordings_per_head),
            ("max_recording_frames", self.max_recording_frames),
            ("max_recording_bytes", self.max_recording_bytes),
            ("max_bindings_per_head", self.max_bindings_per_head),
            ("max_registrations", self.max_registrations),
            ("max_connections", self.max_connections),
        ] {
            positive(field, value as f64)?;
        }
        Ok(())
    }

    pub fn duration(seconds: f64) -> Duration {
        Duration::from_secs_f64(seconds)
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
        config.default_algorithm = "U".into();
        config.algorithms = Some(vec!["E".into(), "nonsense".into()]);
        let err = config.validate().unwrap_err().to_string();
        assert!(err.starts_with("algorithms \"nonsense\""), "{err}");
        config.algorithms = Some(vec!["E".into()]);
        let (default, allowed) = config.allowed_algorithms().unwrap();
        assert_eq!(allowed.unwrap(), vec![default, "E".parse().unwrap()]);
        config.bus = "redis://x".into();
        let err = config.validate().unwrap_err().to_string();
        assert!(err.starts_with("bus = \"redis://x\""), "{err}");
        config.bus = "nats://127.0.0.1:4222".into();
        assert_eq!(config.bus().unwrap(), Bus::Nats("nats://127.0.0.1:4222".into()));
        config.bus = "nats://127.0.0.1:4222,nats://127.0.0.1:4223".into();
        config.validate().unwrap();
        config.bus = "nats://127.0.0.1:4222,".into();
        assert!(config.validate().is_err());
        config.bus = "nats://127.0.0.1:4222".into();
        config.bus_replicas = 0;
        let err = config.validate().unwrap_err().to_string();
        assert!(err.starts_with("bus_replicas = 0"), "{err}");
        config.bus_replicas = 3;
        config.node_name = Some("Node 1".into());
        assert!(config.validate().is_err());
        config.node_name = Some("node-1".into());
        config.validate().unwrap();
        config.limits.max_batch_duration_s = f64::NAN;
        let err = config.validate().unwrap_err().to_string();
        assert!(err.starts_with("limits.max_batch_duration_s = NaN"), "{err}");
    }
}
