//! `facewire serve`: run the service. Settings come from defaults, `--config FILE`,
//! `FACEWIRE_*` environment variables and flags, in that order of precedence.

use std::net::SocketAddr;

use super::{CliResult, FilePath};
use crate::server::config::Limits;
use crate::server::{serve, AppState, Config};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Address to listen on [default: 127.0.0.1:8480; env FACEWIRE_ADDR].
    #[arg(long)]
    addr: Option<SocketAddr>,
    /// Data directory for registered heads [default: ./facewire-data; env FACEWIRE_DATA_DIR].
    #[arg(long)]
    data_dir: Option<FilePath>,
    /// TOML configuration file (see deploy/facewire.example.toml).
    #[arg(long)]
    config: Option<FilePath>,
    /// Algorithm viewers get when they name none [default: biharmonic].
    #[arg(long)]
    default_algorithm: Option<String>,
    /// Log as JSON lines instead of text.
    #[arg(long)]
    log_json: bool,
}

/// Text or JSON logs on stderr, filtered by `RUST_LOG` (default `info`).
pub(super) fn init_logging(json: bool) {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info,tower_http=warn"));
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr);
    if json {
        builder.json().init();
    } else {
        builder.init();
    }
}

/// Once `serve` has returned (every socket closed, or `shutdown_grace_s` passed), work still
/// running on the blocking pool (a registration between its stages) is abandoned after this.
pub(super) const ABANDON_AFTER: std::time::Duration = std::time::Duration::from_millis(500);

/// The runtime a command runs on; a server's blocking pool is held to its configuration's
/// `max_blocking_threads` (a client's to the default).
pub(super) fn runtime(limits: &Limits) -> std::io::Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_multi_thread()
        .max_blocking_threads(limits.max_blocking_threads)
        .enable_all()
        .build()
}

pub fn run(args: Args) -> CliResult {
    let mut config = match &args.config {
        Some(path) => Config::load(path)?,
        None => Config::default(),
    };
    config.apply_env(|name| std::env::var(name).ok())?;
    if let Some(addr) = args.addr {
        config.addr = addr;
    }
    if let Some(dir) = args.data_dir {
        config.data_dir = Some(dir);
    }
    if let Some(algo) = args.default_algorithm {
        config.default_algorithm = algo;
    }
    init_logging(args.log_json);
    let rt = runtime(&config.limits)?;
    let served: CliResult = rt.block_on(async {
        let state = AppState::start(config).await?;
        serve(state, |addr| {
            println!("facewire listening on http://{addr}/");
        })
        .await?;
        Ok(())
    });
    rt.shutdown_timeout(ABANDON_AFTER);
    served
}
