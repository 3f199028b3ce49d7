//! Diffuse irradiance from the sky as order-2 spherical harmonics (Ramamoorthi & Hanrahan
//! 2001): nine coefficients per channel, projected once from the sky, then E(n) for any normal
//! in a handful of multiply-adds. The ambient light of the Whitted and point modes.

use glint_core::{Rgb, Vec3};
use std::f32::consts::PI;

/// Irradiance E(n) = ∫ L(ω) max(0, n·ω) dω, band-limited to order 2 (relative error below
/// 10 % for any sky, exact for skies that vary at most quadratically).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IrradianceSh {
    /// Radiance coefficients already multiplied by the cosine lobe's Â_l.
    coefficients: [Rgb; 9],
}

fn basis(d: Vec3) -> [f32; 9] {
    let (x, y, z) = (d.x, d.y, d.z);
    [
        0.282_095,
        0.488_603 * y,
        0.488_603 * z,
        0.488_603 * x,
        1.092_548 * x * y,
        1.092_548 * y * z,
        0.315_392 * (3.0 * z * z - 1.0),
        1.092_548 * x * z,
        0.546_274 * (x * x - y * y),
    ]
}

impl IrradianceSh {
    /// Projects `radiance(direction, footprint)` over the sphere, sampled at the texel centres
    /// of a virtual 32² cube map with each texel's exact solid angle; `footprint` (radians) is
    /// the texel's width, so a mip-mapped sky gives its prefiltered mean.
    pub fn project(radiance: impl Fn(Vec3, f32) -> Rgb) -> IrradianceSh {
        const N: usize = 32;
        let mut sum = [Rgb::ZERO; 9];
        let texel = 2.0 / N as f32;
        for face in 0..6 {
            for j in 0..N {
                for i in 0..N {
                    let (a, b) = (-1.0 + (i as f32 + 0.5) * texel, -1.0 + (j as f32 + 0.5) * texel);
                    let c = match face {
                        0 => Vec3::new(1.0, a, b),
                        1 => Vec3::new(-1.0, a, b),
                        2 => Vec3::new(a, 1.0, b),
                        3 => Vec3::new(a, -1.0, b),
                        4 => Vec3::new(a, b, 1.0),
                        _ => Vec3::new(a, b, -1.0),
                    };
                    let r2 = c.length_squared();
                    let d_omega = texel * texel / (r2 * r2.sqrt());
                    let d = c / r2.sqrt();
                    let l = radiance(d, texel / r2.sqrt()) * d_omega;
                    for (s, y) in sum.iter_mut().zip(basis(d)) {
                        *s += l * y;
                    }
                }
            }
        }
        let band =
            [PI, 2.0 * PI / 3.0, 2.0 * PI / 3.0, 2.0 * PI / 3.0, PI / 4.0, PI / 4.0, PI / 4.0, PI / 4.0, PI / 4.0];
        let mut coefficients = sum;
        for (c, a) in coefficients.iter_mut().zip(band) {
            *c *= a;
        }
        IrradianceSh { coefficients }
    }

    /// Irradiance arriving at a surface with unit normal `n` (never negative).
    #[inline]
    pub fn irradiance(&self, n: Vec3) -> Rgb {
        let y = basis(n);
        let mut e = Rgb::ZERO;
        for (c, b) in self.coefficients.iter().zip(y) {
            e += *c * b;
        }
        e.max(Rgb::ZERO)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_sky_gives_pi_times_radiance() {
        let sh = IrradianceSh::project(|_, _| Rgb::new(1.0, 0.5, 2.0));
        for n in [Vec3::X, -Vec3::Y, Vec3::new(0.6, 0.0, 0.8)] {
            let e = sh.irradiance(n);
            let want = Rgb::new(1.0, 0.5, 2.0) * PI;
            assert!((e - want).abs().max_element() < 1e-3 * want.max_element(), "{n}: {e}");
        }
    }

    #[test]
    fn linear_sky_is_exact() {
        // L = 1 + y: E(n) = π + (2π/3) n_y (the cosine lobe's first band, exactly).
        let sh = IrradianceSh::project(|d, _| Rgb::splat(1.0 + d.y));
        for n in [Vec3::Y, -Vec3::Y, Vec3::X, Vec3::new(0.0, 0.6, 0.8)] {
            let want = PI + 2.0 * PI / 3.0 * n.y;
            assert!((sh.irradiance(n).x - want).abs() < 2e-3, "{n}: {} vs {want}", sh.irradiance(n).x);
        }
    }

    #[test]
    fn upper_hemisphere_sky_is_close() {
        // L = 1 above the horizon, 0 below: E(up) = π, E(down) = 0, E(horizontal) = π/2.
        let sh = IrradianceSh::project(|d, _| if d.y > 0.0 { Rgb::ONE } else { Rgb::ZERO });
        assert!((sh.irradiance(Vec3::Y).x - PI).abs() < 0.1 * PI);
        assert!(sh.irradiance(-Vec3::Y).x < 0.1 * PI);
        assert!((sh.irradiance(Vec3::X).x - PI / 2.0).abs() < 0.02);
    }
}
