//! The `facewire` command: a thin shell over the library (see `facewire --help`).

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let cli = facewire::cli::Cli::parse();
    match facewire::cli::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            let mut source = std::error::Error::source(&*e);
            while let Some(cause) = source {
                eprintln!("  caused by: {cause}");
                source = cause.source();
            }
            ExitCode::FAILURE
        }
    }
}
