#![no_main]
//! glTF: JSON (.gltf) or binary (.glb, when the input starts with `glTF`).
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let name = if data.starts_with(b"glTF") { "f.glb" } else { "f.gltf" };
    let path = glint_fuzz::file(name, data);
    if let Err(e) = glint_formats::load(&path) {
        glint_fuzz::check_error(&path, &e);
    }
});
