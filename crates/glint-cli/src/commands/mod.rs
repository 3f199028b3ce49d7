//! One module per subcommand.

/// Print a line to stdout; a closed pipe (`glint bench ... | head`) ends the command quietly
/// instead of panicking. (Defined before the modules so that each can use it.)
macro_rules! out {
    ($($arg:tt)*) => {
        writeln!(std::io::stdout(), $($arg)*).context("cannot write to standard output")?
    };
}

mod bench;
mod bench_gi;
mod bench_points;
mod bench_view;
mod compare;
mod filter;
mod merge;
mod points;
mod render;
mod sky;
mod stream;
mod view;

use crate::cli::{Cli, Command, RenderArgs, clap_defaults};
use anyhow::Result;

pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        // No subcommand: exactly `glint render` with no scene (the README's first command).
        None => render::run(&clap_defaults::<RenderArgs>()?),
        Some(Command::Render(args)) => render::run(&args),
        Some(Command::Bench(b)) => bench::run(b),
        Some(Command::Sky(s)) => sky::run(s),
        Some(Command::Compare(args)) => compare::run(&args),
        Some(Command::Filter(args)) => filter::run(&args),
        Some(Command::Merge(args)) => merge::run(&args),
        Some(Command::Points(p)) => points::run(p),
        Some(Command::View(args)) => view::run(&args),
    }
}
