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
    match commands::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // Messages quote names and lines from the input files: no escape sequence of
            // theirs reaches the terminal.
            eprintln!("glint: error: {}", glint_formats::printable(&format!("{e:#}")));
            ExitCode::FAILURE
        }
    }
}
