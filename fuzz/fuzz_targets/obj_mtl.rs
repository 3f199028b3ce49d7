#![no_main]
//! An OBJ file and the MTL file it names: the input is split at its first 0xFF byte (OBJ
//! before, MTL after); the OBJ is preceded by `mtllib m.mtl`.
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let (obj, mtl) = match data.iter().position(|&b| b == 0xff) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &b""[..]),
    };
    glint_fuzz::file("m.mtl", mtl);
    let mut text = b"mtllib m.mtl\n".to_vec();
    text.extend_from_slice(obj);
    let path = glint_fuzz::file("f.obj", &text);
    if let Err(e) = glint_formats::load(&path) {
        glint_fuzz::check_error(&path, &e);
    }
});
