//! The planar image: one `Vec<f32>` per named channel, rows top to bottom.
//!
//! Planar rather than interleaved so a renderer can add AOV planes (depth, normals, albedo)
//! independently and an EXR writer can store each as its own channel without reshuffling.

use crate::error::ImageError;

/// The `R`, `G`, `B` planes of an image, borrowed.
pub type RgbPlanes<'a> = (&'a [f32], &'a [f32], &'a [f32]);

/// One named plane of an [`Image`]; `data.len() == width * height`, row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    pub name: String,
    pub data: Vec<f32>,
}

/// Planar f32 image with named channels (EXR-style names: `R`, `G`, `B`, `A`, `Z`, `Albedo.R`,
/// `Ns.X`, ...), rows top to bottom. Channel order is insertion order; lookups are by name.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub channels: Vec<Channel>,
}

impl Image {
    /// An image of the given size with no channels yet.
    pub fn new(width: u32, height: u32) -> Image {
        Image { width, height, channels: Vec::new() }
    }

    /// `width * height`, the length every channel must have.
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Adds a channel. Fails with [`ImageError::Mismatch`] if `data` does not hold exactly
    /// `width * height` values or a channel of that name already exists.
    pub fn add_channel(&mut self, name: impl Into<String>, data: Vec<f32>) -> Result<(), ImageError> {
        let name = name.into();
        if data.len() != self.pixel_count() {
            return Err(ImageError::mismatch(format!(
                "channel '{name}' has {} values, but a {}x{} image needs {}",
                data.len(),
                self.width,
                self.height,
                self.pixel_count()
            )));
        }
        if self.channel(&name).is_some() {
            return Err(ImageError::mismatch(format!("the image already has a channel named '{name}'")));
        }
        self.channels.push(Channel { name, data });
        Ok(())
    }

    /// The plane named `name`, if any (exact, case-sensitive match).
    pub fn channel(&self, name: &str) -> Option<&[f32]> {
        self.channels.iter().find(|c| c.name == name).map(|c| c.data.as_slice())
    }

    /// The plane named `name`, mutable.
    pub fn channel_mut(&mut self, name: &str) -> Option<&mut [f32]> {
        self.channels.iter_mut().find(|c| c.name == name).map(|c| c.data.as_mut_slice())
    }

    /// An image with channels `R`, `G`, `B` from interleaved pixels.
    ///
    /// # Panics
    /// If `rgb.len() != width * height` (a programming error, not a user-input one).
    pub fn from_rgb(width: u32, height: u32, rgb: &[[f32; 3]]) -> Image {
        let count = width as usize * height as usize;
        assert_eq!(rgb.len(), count, "Image::from_rgb: {width}x{height} needs {count} pixels, got {}", rgb.len());
        let channels = ["R", "G", "B"]
            .iter()
            .enumerate()
            .map(|(k, name)| Channel { name: (*name).to_string(), data: rgb.iter().map(|p| p[k]).collect() })
            .collect();
        Image { width, height, channels }
    }

    /// The `R`, `G`, `B` planes interleaved, or `None` if any of them is missing.
    pub fn rgb(&self) -> Option<Vec<[f32; 3]>> {
        let (r, g, b) = self.rgb_planes()?;
        Some(r.iter().zip(g).zip(b).map(|((&r, &g), &b)| [r, g, b]).collect())
    }

    /// The `R`, `G`, `B` planes, or `None` if any of them is missing.
    pub fn rgb_planes(&self) -> Option<RgbPlanes<'_>> {
        Some((self.channel("R")?, self.channel("G")?, self.channel("B")?))
    }

    /// Checks that every channel has `width * height` values (the fields are public, so an
    /// image built by hand may be inconsistent).
    pub fn validate(&self) -> Result<(), ImageError> {
        let count = self.pixel_count();
        for c in &self.channels {
            if c.data.len() != count {
                return Err(ImageError::mismatch(format!(
                    "channel '{}' has {} values, but a {}x{} image needs {count}",
                    c.name,
                    c.data.len(),
                    self.width,
                    self.height
                )));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn add_channel_checks_length_and_duplicates() {
        let mut image = Image::new(3, 2);
        image.add_channel("Z", vec![1.0; 6]).expect("fits");
        let err = image.add_channel("Y", vec![0.0; 5]).expect_err("short");
        assert!(matches!(err, ImageError::Mismatch { .. }), "{err}");
        let err = image.add_channel("Z", vec![0.0; 6]).expect_err("duplicate");
        assert!(err.to_string().contains("'Z'"), "{err}");
        assert_eq!(image.channels.len(), 1);
        assert_eq!(image.channel("Z"), Some(&[1.0; 6][..]));
        assert_eq!(image.channel("z"), None);
    }

    #[test]
    fn rgb_round_trips_through_planes() {
        let pixels = [[0.1, 0.2, 0.3], [1.0, 2.0, 3.0]];
        let image = Image::from_rgb(2, 1, &pixels);
        let names: Vec<_> = image.channels.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["R", "G", "B"]);
        assert_eq!(image.channel("G"), Some(&[0.2, 2.0][..]));
        assert_eq!(image.rgb().expect("has rgb"), pixels);
        assert!(Image::new(2, 1).rgb().is_none());
    }

    #[test]
    fn validate_catches_hand_built_inconsistency() {
        let mut image = Image::from_rgb(1, 1, &[[0.0; 3]]);
        assert!(image.validate().is_ok());
        image.channels[1].data.push(1.0);
        assert!(image.validate().is_err());
    }
}
