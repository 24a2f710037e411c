//! `sinew`: the command line of Sinew's host toolkit (see [`cli`]).

mod cli;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    // Before any thread starts: may re-execute this program once (same arguments).
    sinew_host::training::malloc::keep_freed_memory();
    match cli::run(cli::Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("sinew: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
