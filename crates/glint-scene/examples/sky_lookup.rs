//! Instruction-count probe for sky lookups (load-independent, for before/after comparisons):
//! `valgrind --tool=callgrind target/release/examples/sky_lookup KIND` with KIND one of cube,
//! cube_mip, latlong, latlong_mip (anything else: no lookup, the baseline to subtract); it performs
//! 640×360 coherent lookups on 256² faces / a 128×64 map, then prints a sum.

use glint_core::{Rgb, Vec2, Vec3};
use glint_scene::{Camera, CubeMap, Fov, LatLongMap};

fn main() {
    let kind = std::env::args().nth(1).unwrap_or_else(|| "cube".into());
    let pattern = |d: Vec3| Rgb::new(d.x.abs(), d.y.abs(), d.z.abs());
    let cube = CubeMap::from_fn(256, pattern);
    let latlong = LatLongMap::from_fn(64, pattern);
    let cam = Camera {
        position: Vec3::ZERO,
        forward: Vec3::new(0.3, 0.1, -1.0),
        up: Vec3::Y,
        fov: Fov::Vertical(60.0),
        lens: glint_scene::Lens::Pinhole,
    };
    let rays = cam.rays(640, 360);
    let dirs: Vec<Vec3> =
        (0..640 * 360).map(|i| rays.ray(Vec2::new((i % 640) as f32 + 0.5, (i / 640) as f32 + 0.5)).dir).collect();
    let cone = 60f32.to_radians() / 360.0 * 20.0; // 64² faces: about a texel and a half
    let mut sum = Rgb::ZERO;
    for d in &dirs {
        sum += match kind.as_str() {
            "cube" => probe_cube(&cube, *d),
            "cube_mip" => probe_cube_mip(&cube, *d, cone),
            "latlong" => latlong.lookup(*d),
            "latlong_mip" => latlong.lookup_filtered(*d, cone),
            _ => *d,
        };
    }
    println!("{kind}: {sum}");
}

#[inline(never)]
pub fn probe_cube(m: &CubeMap, d: Vec3) -> Rgb {
    m.lookup(d)
}

#[inline(never)]
pub fn probe_cube_mip(m: &CubeMap, d: Vec3, cone: f32) -> Rgb {
    m.lookup_filtered(d, cone)
}
