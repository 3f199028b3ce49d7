//! The limits of a render, written once. The scene loader, the render settings, the command
//! line and the viewer all check against these ranges, so a value one of them accepts is never
//! refused by another (docs/scene-format.md states them).

use std::ops::RangeInclusive;

/// Largest image side accepted.
pub const MAX_IMAGE_SIDE: u32 = 32_768;
/// Most pixels accepted in one image (2^27, e.g. 16384 × 8192: a film of about 6 GB; the PNG
/// and EXR writers share the limit).
pub const MAX_IMAGE_PIXELS: u64 = 1 << 27;

/// Whitted: the deepest reflection/refraction chain (0 = primary rays and their shadow rays
/// only). The integrator's explicit stack is bounded by it.
pub const MAX_DEPTH: RangeInclusive<u32> = 0..=64;
/// Whitted: N of N×N stratified samples per pixel.
pub const SAMPLES_PER_SIDE: RangeInclusive<u32> = 1..=64;
/// Path mode: indirect bounces (0 = direct light only).
pub const MAX_BOUNCES: RangeInclusive<u32> = 0..=64;
/// Path mode: a path's total vertex budget (Mitsuba's `max_depth`; its −1, unbounded, reads
/// as the top).
pub const PATH_DEPTH: RangeInclusive<u32> = 1..=1024;
/// Path mode: samples per pixel in one pass.
pub const SPP: RangeInclusive<u32> = 1..=(1 << 16);

/// Whether a `width × height` image is within the limits.
#[must_use]
pub fn image_size_ok(width: u32, height: u32) -> bool {
    width > 0
        && height > 0
        && width <= MAX_IMAGE_SIDE
        && height <= MAX_IMAGE_SIDE
        && width as u64 * height as u64 <= MAX_IMAGE_PIXELS
}

/// `"{what} {value} must be in a..=b"` when `value` is outside `range`: the one wording every
/// layer uses.
///
/// # Errors
/// The message, when `value` is out of range.
pub fn check(what: &str, value: u32, range: &RangeInclusive<u32>) -> Result<(), String> {
    if range.contains(&value) {
        Ok(())
    } else {
        Err(format!("{what} {value} must be in {}..={}", range.start(), range.end()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_and_sizes() {
        assert!(check("max depth", 0, &MAX_DEPTH).is_ok());
        assert_eq!(check("max depth", 65, &MAX_DEPTH).unwrap_err(), "max depth 65 must be in 0..=64");
        assert!(check("spp", 0, &SPP).is_err());
        assert!(image_size_ok(MAX_IMAGE_SIDE, 4096));
        assert!(!image_size_ok(MAX_IMAGE_SIDE, MAX_IMAGE_SIDE));
        assert!(!image_size_ok(0, 1));
    }
}
