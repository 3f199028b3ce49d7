#![no_main]
//! PNG, JPEG, Radiance HDR, OpenEXR, TGA, BMP decoding from memory, as textures are read.
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // The format is sniffed from the bytes; the extension only matters for TGA and EXR.
    let name = match data.first().map(|b| b % 3) {
        Some(0) => "f.tga",
        Some(1) => "f.exr",
        _ => "f.png",
    };
    let path = std::path::Path::new(name);
    if let Ok(image) = glint_image::decode_image(path, data) {
        let _ = glint_image::texture_from_image(path, image);
    }
});
