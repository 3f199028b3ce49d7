//! One module per subcommand.

mod bench;
mod render;
mod sky;

use crate::cli::{Cli, Command, RenderArgs};
use anyhow::Result;

pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        None => render::run(&RenderArgs { output: "glint.png".into(), tonemap: "clamp".into(), ..Default::default() }),
        Some(Command::Render(args)) => render::run(&args),
        Some(Command::Bench(b)) => bench::run(b),
        Some(Command::Sky(s)) => sky::run(s),
    }
}
