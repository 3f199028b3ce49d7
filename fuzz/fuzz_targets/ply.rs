#![no_main]
//! PLY meshes, as model files and with the mesh attributes a Mitsuba scene asks for.
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = glint_fuzz::file("f.ply", data);
    if let Err(e) = glint_formats::load(&path) {
        glint_fuzz::check_error(&path, &e);
    }
    if let Err(e) = glint_formats::ply::load_with_attributes(&path) {
        glint_fuzz::check_error(&path, &e);
    }
});
