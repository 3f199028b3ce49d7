#![no_main]
//! XYZ and PTS text point clouds (the first byte picks the extension).
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let name = if data.first().is_some_and(|b| b & 1 == 1) { "f.pts" } else { "f.xyz" };
    let path = glint_fuzz::file(name, data);
    if let Err(e) = glint_formats::load(&path) {
        glint_fuzz::check_error(&path, &e);
    }
});
