//! Flips and quarter turns of a face image, for sets stored in another convention (a set made
//! for a Y-down loader stores every face upside down; some tools rotate the up and down faces).

use glint_core::Rgb;
use glint_scene::TextureImage;

/// A flip and/or a clockwise quarter turn of a face image: the flips first, then the turn.
/// The default does nothing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct FaceTransform {
    /// Mirror left ↔ right.
    pub flip_horizontal: bool,
    /// Mirror top ↔ bottom.
    pub flip_vertical: bool,
    /// 0, 90, 180 or 270 degrees clockwise, applied after the flips.
    pub rotate_degrees: u32,
}

impl FaceTransform {
    pub const IDENTITY: FaceTransform =
        FaceTransform { flip_horizontal: false, flip_vertical: false, rotate_degrees: 0 };

    /// The eight different transforms (the symmetries of a square), simplest first.
    pub const ALL_DISTINCT: [FaceTransform; 8] = [
        FaceTransform::IDENTITY,
        FaceTransform::flip(false, true),
        FaceTransform::flip(true, false),
        FaceTransform::flip(true, true),
        FaceTransform::rotate(90),
        FaceTransform::rotate(270),
        FaceTransform { flip_horizontal: true, flip_vertical: false, rotate_degrees: 90 },
        FaceTransform { flip_horizontal: true, flip_vertical: false, rotate_degrees: 270 },
    ];

    /// Flips only.
    pub const fn flip(horizontal: bool, vertical: bool) -> FaceTransform {
        FaceTransform { flip_horizontal: horizontal, flip_vertical: vertical, rotate_degrees: 0 }
    }

    /// A clockwise turn only.
    pub const fn rotate(degrees: u32) -> FaceTransform {
        FaceTransform { flip_horizontal: false, flip_vertical: false, rotate_degrees: degrees }
    }

    /// The flips a name asks for: `none`, `horizontal`, `vertical` or `both` (case-insensitive),
    /// as the scene file's `flip` key and `glint sky convert --flip` spell them.
    pub fn from_flip_name(name: &str) -> Option<FaceTransform> {
        match name.to_ascii_lowercase().as_str() {
            "none" => Some(FaceTransform::IDENTITY),
            "horizontal" => Some(FaceTransform::flip(true, false)),
            "vertical" => Some(FaceTransform::flip(false, true)),
            "both" => Some(FaceTransform::flip(true, true)),
            _ => None,
        }
    }

    /// The name [`FaceTransform::from_flip_name`] reads for this transform's flips.
    pub fn flip_name(&self) -> &'static str {
        match (self.flip_horizontal, self.flip_vertical) {
            (false, false) => "none",
            (true, false) => "horizontal",
            (false, true) => "vertical",
            (true, true) => "both",
        }
    }

    /// An error message unless `rotate_degrees` is 0, 90, 180 or 270.
    pub fn check(&self) -> Result<(), String> {
        if self.rotate_degrees.is_multiple_of(90) && self.rotate_degrees < 360 {
            Ok(())
        } else {
            Err(format!("rotate = {} is not one of 0, 90, 180, 270 (degrees clockwise)", self.rotate_degrees))
        }
    }

    /// True if the transform leaves every image as it is (flipping both ways and turning by
    /// 180° does too).
    pub fn is_identity(&self) -> bool {
        let n = 2;
        (0..n).all(|y| (0..n).all(|x| self.source_texel(x, y, n, n) == (x, y)))
    }

    /// The size of the transformed image of a `width × height` one.
    pub fn output_size(&self, width: u32, height: u32) -> (u32, u32) {
        if self.rotate_degrees % 180 == 90 { (height, width) } else { (width, height) }
    }

    /// The texel of a `width × height` source image that lands on texel (x, y) of the
    /// transformed image. Undoes the turn, then the flips.
    pub fn source_texel(&self, x: u32, y: u32, width: u32, height: u32) -> (u32, u32) {
        let (w, h) = (width, height);
        let (sx, sy) = match self.rotate_degrees % 360 {
            90 => (y, h - 1 - x),
            180 => (w - 1 - x, h - 1 - y),
            270 => (w - 1 - y, x),
            _ => (x, y),
        };
        (if self.flip_horizontal { w - 1 - sx } else { sx }, if self.flip_vertical { h - 1 - sy } else { sy })
    }

    /// The transformed image (a copy; the identity copies too).
    pub fn apply(&self, image: &TextureImage) -> TextureImage {
        let (w, h) = (image.width, image.height);
        let (ow, oh) = self.output_size(w, h);
        let mut texels: Vec<Rgb> = Vec::with_capacity(image.texels.len());
        for y in 0..oh {
            for x in 0..ow {
                let (sx, sy) = self.source_texel(x, y, w, h);
                texels.push(image.texels[(sy * w + sx) as usize]);
            }
        }
        TextureImage { width: ow, height: oh, texels }
    }

    /// What the transform does, in words: "flipped vertically", "turned 90° clockwise", …
    pub fn describe(&self) -> String {
        let flip = match (self.flip_horizontal, self.flip_vertical) {
            (false, false) => None,
            (true, false) => Some("flipped horizontally"),
            (false, true) => Some("flipped vertically"),
            (true, true) => Some("flipped both ways"),
        };
        let turn =
            (!self.rotate_degrees.is_multiple_of(360)).then(|| format!("turned {}° clockwise", self.rotate_degrees));
        match (flip, turn) {
            (None, None) => "unchanged".to_string(),
            (Some(f), None) => f.to_string(),
            (None, Some(t)) => t,
            (Some(f), Some(t)) => format!("{f} and {t}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3×2 image whose texels are their own index.
    fn numbered(w: u32, h: u32) -> TextureImage {
        TextureImage { width: w, height: h, texels: (0..w * h).map(|i| Rgb::splat(i as f32)).collect() }
    }

    fn values(image: &TextureImage) -> Vec<u32> {
        image.texels.iter().map(|c| c.x as u32).collect()
    }

    #[test]
    fn flips_and_turns_move_texels_as_named() {
        // 0 1 2
        // 3 4 5
        let img = numbered(3, 2);
        assert_eq!(values(&FaceTransform::flip(true, false).apply(&img)), [2, 1, 0, 5, 4, 3]);
        assert_eq!(values(&FaceTransform::flip(false, true).apply(&img)), [3, 4, 5, 0, 1, 2]);
        // Clockwise: the left column, read upwards, becomes the top row.
        let cw = FaceTransform::rotate(90).apply(&img);
        assert_eq!((cw.width, cw.height), (2, 3));
        assert_eq!(values(&cw), [3, 0, 4, 1, 5, 2]);
        assert_eq!(values(&FaceTransform::rotate(180).apply(&img)), [5, 4, 3, 2, 1, 0]);
        assert_eq!(values(&FaceTransform::rotate(270).apply(&img)), [2, 5, 1, 4, 0, 3]);
        // Flips come first: flip horizontally, then turn.
        let t = FaceTransform { flip_horizontal: true, flip_vertical: false, rotate_degrees: 90 };
        assert_eq!(
            values(&t.apply(&img)),
            values(&FaceTransform::rotate(90).apply(&FaceTransform::flip(true, false).apply(&img)))
        );
    }

    #[test]
    fn the_eight_symmetries_are_distinct() {
        let img = numbered(3, 3);
        let mut seen: Vec<Vec<u32>> = FaceTransform::ALL_DISTINCT.iter().map(|t| values(&t.apply(&img))).collect();
        seen.sort();
        seen.dedup();
        assert_eq!(seen.len(), 8);
        assert!(FaceTransform::IDENTITY.is_identity());
        assert!(FaceTransform { flip_horizontal: true, flip_vertical: true, rotate_degrees: 180 }.is_identity());
        assert!(!FaceTransform::rotate(90).is_identity());
    }

    #[test]
    fn names_and_checks() {
        for t in [
            FaceTransform::IDENTITY,
            FaceTransform::flip(true, false),
            FaceTransform::flip(false, true),
            FaceTransform::flip(true, true),
        ] {
            assert_eq!(FaceTransform::from_flip_name(t.flip_name()), Some(t));
        }
        assert_eq!(FaceTransform::from_flip_name("Vertical"), Some(FaceTransform::flip(false, true)));
        assert_eq!(FaceTransform::from_flip_name("upside-down"), None);
        assert!(FaceTransform::rotate(270).check().is_ok());
        assert!(FaceTransform::rotate(45).check().expect_err("45").contains("45"));
        assert!(FaceTransform::rotate(360).check().is_err());
        assert_eq!(FaceTransform::flip(false, true).describe(), "flipped vertically");
        assert_eq!(FaceTransform::rotate(90).describe(), "turned 90° clockwise");
    }
}
