//! `glint merge`: put the chunk files of a frame together (`glint render --chunk I/N` or
//! `--tile I/N`) and finish the frame as the single-process render does (glint-render's
//! `chunk` module checks them, adds shares and places tiles, and ends with the single run's
//! own last step), then write it like `render` does.

use super::render::{output_kind, png_options_from, write_film};
use crate::cli::MergeArgs;
use anyhow::{Result, bail};
use glint_render::chunk::{self, Chunk};
use std::time::Instant;

pub fn run(args: &MergeArgs) -> Result<()> {
    let start = Instant::now();
    let kind = output_kind(&args.output)?;
    // Never overwrite an input: the output must not be (a link to) one of them.
    if let Ok(out) = std::fs::canonicalize(&args.output) {
        for input in &args.inputs {
            if std::fs::canonicalize(input).is_ok_and(|i| i == out) {
                bail!("-o {} is one of the chunk files being merged: choose another output", args.output.display());
            }
        }
    }
    // Read one after another as the merge takes them in: about one chunk in memory at a time.
    let merged = chunk::merge(args.inputs.iter().map(|p| Chunk::read(p).map(|c| (p.clone(), c))))?;
    let options = png_options_from(&merged.settings, &args.inputs[0])?;
    let summary = format!("merged {} in {:.3} s", merged.description, start.elapsed().as_secs_f64());
    write_film(&args.output, kind, &merged.film, &options, &summary, args.quiet)?;
    Ok(())
}
