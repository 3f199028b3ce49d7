#![no_main]
//! LAS, or LAZ when the point format byte (104) has its compression bit.
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let name = if data.get(104).is_some_and(|b| b & 0x80 != 0) { "f.laz" } else { "f.las" };
    let path = glint_fuzz::file(name, data);
    if let Err(e) = glint_formats::load(&path) {
        glint_fuzz::check_error(&path, &e);
    }
});
