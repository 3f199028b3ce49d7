#![no_main]
//! Sky images: one file read as a cross, a strip or a lat-long map by its aspect.
use glint_formats::{SkyLoadOptions, SkySource, load_sky};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let name = if data.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        "sky.exr"
    } else if data.starts_with(b"#?") {
        "sky.hdr"
    } else {
        "sky.png"
    };
    let path = glint_fuzz::file(name, data);
    if let Err(e) = load_sky(&SkySource::Path(path.clone()), &SkyLoadOptions::default()) {
        glint_fuzz::check_error(&path, &e);
    }
});
