//! `glint filter`: filter the indirect light of a stored path-mode AOV image (docs/aovs.md).

use crate::cli::FilterArgs;
use crate::commands::render::filter_from_args;
use crate::input;
use anyhow::{Context, Result, bail};
use glint_filter::Filter;
use glint_image::PngOptions;
use std::time::Instant;

pub fn run(args: &FilterArgs) -> Result<()> {
    let ext = args.output.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    if !matches!(ext.as_deref(), Some("exr" | "png")) {
        bail!("output {}: unsupported image type (use .exr or .png)", args.output.display());
    }
    if args.output == args.input {
        bail!("output {}: would overwrite the input; choose another file", args.output.display());
    }
    let pool = input::thread_pool(args.threads)?;
    let image =
        glint_image::read_image(&args.input).with_context(|| format!("cannot read {}", args.input.display()))?;
    let filter = filter_from_args(args.filter, &args.filter_options, image.width)?;
    if filter == Filter::None {
        bail!("--filter none: nothing to do (choose guided, bilateral or atrous)");
    }
    let start = Instant::now();
    let filtered = pool
        .install(|| glint_filter::aov::filter_image(&image, &filter))
        .with_context(|| format!("cannot filter {}", args.input.display()))?;
    let ms = start.elapsed().as_secs_f64() * 1e3;
    let out = if ext.as_deref() == Some("png") {
        let mut beauty = glint_image::Image::new(filtered.width, filtered.height);
        for name in ["R", "G", "B"] {
            let data = filtered.channel(name).map(<[f32]>::to_vec).unwrap_or_default();
            beauty.add_channel(name, data)?;
        }
        beauty
    } else {
        filtered
    };
    glint_image::write_image(&args.output, &out, &PngOptions::default())
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    if !args.quiet {
        eprintln!(
            "glint: filtered {} ({}x{}, {}) in {ms:.1} ms -> {}",
            args.input.display(),
            image.width,
            image.height,
            filter,
            args.output.display()
        );
    }
    Ok(())
}
