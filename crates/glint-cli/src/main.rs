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
            // Messages quote names and lines from the input files: no escape sequence of
            // theirs reaches the terminal.
            eprintln!("glint: error: {}", glint_formats::printable(&report(&e)));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes, joined by ": ", each cause left out when the text before it
/// already says it (library errors often quote their source in their own message, and
/// anyhow's chain would print an OS error twice).
fn report(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if text.is_empty() || out.contains(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::report;
    use anyhow::Context;

    #[derive(Debug)]
    struct Quoting(std::io::Error);

    impl std::fmt::Display for Quoting {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(f, "out.png: {}", self.0)
        }
    }

    impl std::error::Error for Quoting {
        fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
            Some(&self.0)
        }
    }

    #[test]
    fn an_os_error_is_printed_once() {
        let io = std::io::Error::from_raw_os_error(2);
        let text = io.to_string();
        let e = Err::<(), _>(Quoting(io)).context("cannot write out.png").unwrap_err();
        let message = report(&e);
        assert_eq!(message.matches(&text).count(), 1, "{message}");
        assert!(message.starts_with("cannot write out.png: out.png: "), "{message}");
    }
}
