#![no_main]
//! Mitsuba 3 XML scenes, strict and lenient.
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let lenient = data.first().is_some_and(|b| b & 1 == 1);
    let path = glint_fuzz::file("f.xml", data);
    if let Err(e) = glint_formats::mitsuba::load(&path, &[], lenient) {
        glint_fuzz::check_error(&path, &e);
    }
});
