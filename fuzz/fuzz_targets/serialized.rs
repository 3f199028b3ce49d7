#![no_main]
//! Mitsuba's .serialized meshes (zlib-compressed), first and second shape.
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = glint_fuzz::file("f.serialized", data);
    for index in [0, 1] {
        if let Err(e) = glint_formats::mitsuba::read_serialized(&path, index) {
            glint_fuzz::check_error(&path, &e);
        }
    }
});
