//! `facewire demo`: the service with the three shipped heads registered and a built-in
//! producer looping the syllable stream, in memory, printing the URL to open. Everything
//! it needs is embedded in the binary.

use std::net::SocketAddr;

use super::serve::{init_logging, runtime, ABANDON_AFTER};
use super::CliResult;
use crate::server::demo::{loop_syllables, register_heads, DEMO_HEADS};
use crate::server::{serve, AppState, Config};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Address to listen on (port 0 picks a free one).
    #[arg(long, default_value = "127.0.0.1:8480")]
    addr: SocketAddr,
    /// Algorithm viewers get when they name none.
    #[arg(long, default_value = crate::server::config::DEFAULT_ALGORITHM)]
    default_algorithm: String,
}

pub fn run(args: Args) -> CliResult {
    init_logging(false);
    let config = Config {
        addr: args.addr,
        data_dir: None,
        default_algorithm: args.default_algorithm,
        ..Config::default()
    };
    let rt = runtime(&config.limits)?;
    let state = AppState::new(config)?;
    let served = rt.block_on(async {
        register_heads(&state).await?;
        tokio::spawn(loop_syllables(
            state.clone(),
            DEMO_HEADS.iter().map(|h| h.id.to_string()).collect(),
            "main".to_string(),
        ));
        serve(state, |addr| {
            println!("facewire demo: open http://{addr}/ in a browser (Ctrl-C to stop)");
            println!("heads: scan, makehuman, ict; stream: main (the syllable stream, looping)");
        })
        .await?;
        Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
    });
    rt.shutdown_timeout(ABANDON_AFTER);
    served
}
