//! `glint`: the command-line front end. Parses arguments (clap), loads inputs through
//! glint-formats, renders through glint-render, writes through glint-image. Errors are reported
//! once, with their context chain, and give a non-zero exit status.
#![forbid(unsafe_code)]

mod cli;
mod commands;
mod input;
mod progress;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    glint_core::memory::install(glint_image::memory::system_budget(args.max_memory));
    match commands::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("glint: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
