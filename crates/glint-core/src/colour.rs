//! Linear RGB colour and the sRGB transfer function.

use glam::Vec3;

/// Linear-light RGB (Rec. 709 primaries). A plain `Vec3` so colour arithmetic is SIMD glam code.
pub type Rgb = Vec3;

/// Rec. 709 luminance of a linear colour.
#[inline]
pub fn luminance(c: Rgb) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// sRGB electro-optical transfer: encoded value in [0,1] → linear.
#[inline]
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 { v / 12.92 } else { ((v + 0.055) / 1.055).powf(2.4) }
}

/// Linear → sRGB-encoded value (input clamped to [0,1]).
#[inline]
pub fn linear_to_srgb(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 { v * 12.92 } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trips() {
        for i in 0..=255 {
            let e = i as f32 / 255.0;
            let back = linear_to_srgb(srgb_to_linear(e));
            assert!((back - e).abs() < 1e-5, "{e} -> {back}");
        }
    }

    #[test]
    fn luminance_of_white_is_one() {
        assert!((luminance(Rgb::ONE) - 1.0).abs() < 1e-6);
    }
}
