#![no_main]
//! The TOML scene format, from memory (files it names resolve in the scratch folder).
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let path = std::path::Path::new("fuzz.toml");
    if let Err(e) = glint_formats::load_scene_str(text, glint_fuzz::scratch(), "fuzz.toml") {
        glint_fuzz::check_error(path, &e);
    }
});
