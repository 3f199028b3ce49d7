//! `glint sky convert`: any sky glint reads → faces, a cross, a strip or a lat-long map.
//!
//! Loading and writing live in glint-formats (`load_sky`, `write_sky`); this module picks the
//! output format and reports. Faces keep the input's kind of format: PNG for LDR inputs
//! (PNG/JPEG), Radiance .hdr or OpenEXR for HDR inputs, as the input was.

use crate::cli::{FlipArg, SkyCommand, SkyConvertArgs, SkyLayoutArg};
use anyhow::Result;
use glint_formats::{FaceTransform, SkyLayout, SkyLoadOptions, SkyMapRef, SkySource, SkyWriteOptions};
use std::path::Path;
use std::time::Instant;

pub fn run(cmd: SkyCommand) -> Result<()> {
    match cmd {
        SkyCommand::Convert(args) => convert(&args),
    }
}

fn layout(arg: SkyLayoutArg) -> SkyLayout {
    match arg {
        SkyLayoutArg::Faces => SkyLayout::Faces,
        SkyLayoutArg::Cross => SkyLayout::HorizontalCross,
        SkyLayoutArg::VerticalCross => SkyLayout::VerticalCross,
        SkyLayoutArg::Strip => SkyLayout::HorizontalStrip,
        SkyLayoutArg::VerticalStrip => SkyLayout::VerticalStrip,
        SkyLayoutArg::Latlong => SkyLayout::LatLong,
    }
}

fn flip(arg: FlipArg) -> FaceTransform {
    match arg {
        FlipArg::None => FaceTransform::IDENTITY,
        FlipArg::Horizontal => FaceTransform::flip(true, false),
        FlipArg::Vertical => FaceTransform::flip(false, true),
        FlipArg::Both => FaceTransform::flip(true, true),
    }
}

/// The face format for an input file: its own for HDR formats, PNG for 8-bit ones.
fn face_extension(input: &Path) -> &'static str {
    let ext = input.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("hdr") => "hdr",
        Some("exr") => "exr",
        _ => "png",
    }
}

fn convert(args: &SkyConvertArgs) -> Result<()> {
    let start = Instant::now();
    let options = SkyLoadOptions { all_faces: args.flip.map_or(FaceTransform::IDENTITY, flip), ..Default::default() };
    // glint-formats' errors start with the file or folder they are about.
    // The texels as read (not a map's RGB9E5 storage): a change of layout copies them exactly.
    let loaded = glint_formats::sky::load_sky_texels(&SkySource::Path(args.input.clone()), &options)?;
    if !args.quiet {
        for w in &loaded.warnings {
            eprintln!("glint: warning: {}", glint_formats::printable(w));
        }
    }
    let map = SkyMapRef::Texels(&loaded.texels);
    let face_extension = loaded.files.first().map_or("png", |f| face_extension(f)).to_string();
    let write_options = SkyWriteOptions { size: args.size, face_extension };
    let to = layout(args.to);
    let written = glint_formats::write_sky(map, to, &args.output, &write_options)?;
    if !args.quiet {
        for w in &written.warnings {
            eprintln!("glint: warning: {}", glint_formats::printable(w));
        }
        let size = if to == SkyLayout::LatLong {
            format!("{}x{}", 2 * written.size, written.size)
        } else {
            format!("faces of {0}x{0}", written.size)
        };
        eprintln!(
            "glint: {} ({}) → {} ({size}) in {:.2} s",
            args.input.display(),
            loaded.layout.describe(),
            args.output.display(),
            start.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
