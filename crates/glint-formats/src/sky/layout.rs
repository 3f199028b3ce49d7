//! Single-image layouts: which layout an image's aspect means, where each face sits in it,
//! cutting faces out of an image and putting them back together.
//!
//! ```text
//! horizontal cross (4:3)     vertical cross (3:4)     strips (6:1, 1:6)      lat-long (2:1)
//!     ┌──┐                       ┌──┐                 px nx py ny pz nz      u = 0.5 + atan2(x, −z)/2π
//!     │+Y│                       │+Y│                 (CubeFace::ALL order)  v = acos(y)/π
//! ┌──┬──┬──┬──┐              ┌──┬──┬──┐
//! │−X│+Z│+X│−Z│              │−X│+Z│+X│
//! └──┼──┼──┴──┘              └──┼──┼──┘
//!    │−Y│                       │−Y│
//!    └──┘                       ├──┤
//!                               │−Z│ turned 180°
//!                               └──┘
//! ```
//! Faces sit in a cross exactly as a six-file set stores them (t = 0 at the top), so a cross is
//! the cube unfolded and seen from inside; the vertical cross's −Z hangs below −Y and is
//! therefore upside down and mirrored (turned 180°).

use crate::sky::SkyLayout;
use glint_core::Rgb;
use glint_image::Image;
use glint_scene::{CubeFace, TextureImage};

impl SkyLayout {
    /// The grid of square cells of a single-image cube layout (columns, rows); `None` for
    /// [`SkyLayout::Faces`] and [`SkyLayout::LatLong`].
    pub fn grid(self) -> Option<(u32, u32)> {
        match self {
            SkyLayout::HorizontalCross => Some((4, 3)),
            SkyLayout::VerticalCross => Some((3, 4)),
            SkyLayout::HorizontalStrip => Some((6, 1)),
            SkyLayout::VerticalStrip => Some((1, 6)),
            SkyLayout::Faces | SkyLayout::LatLong => None,
        }
    }

    /// For each face in [`CubeFace::ALL`] order: its cell (column, row) and whether it is
    /// stored turned by 180°.
    pub(crate) fn cells(self) -> Option<[(u32, u32, bool); 6]> {
        match self {
            // px, nx, py, ny, pz, nz
            SkyLayout::HorizontalCross => {
                Some([(2, 1, false), (0, 1, false), (1, 0, false), (1, 2, false), (1, 1, false), (3, 1, false)])
            }
            SkyLayout::VerticalCross => {
                Some([(2, 1, false), (0, 1, false), (1, 0, false), (1, 2, false), (1, 1, false), (1, 3, true)])
            }
            SkyLayout::HorizontalStrip => Some(std::array::from_fn(|i| (i as u32, 0, false))),
            SkyLayout::VerticalStrip => Some(std::array::from_fn(|i| (0, i as u32, false))),
            SkyLayout::Faces | SkyLayout::LatLong => None,
        }
    }

    /// A name for messages: "horizontal cross (4:3)".
    pub fn describe(self) -> &'static str {
        match self {
            SkyLayout::Faces => "six face images",
            SkyLayout::HorizontalCross => "horizontal cross (4:3)",
            SkyLayout::VerticalCross => "vertical cross (3:4)",
            SkyLayout::HorizontalStrip => "horizontal strip (6:1)",
            SkyLayout::VerticalStrip => "vertical strip (1:6)",
            SkyLayout::LatLong => "lat-long (2:1)",
        }
    }

    /// The single-image layout a `width × height` image has, with its face edge (cube
    /// layouts) or height (lat-long). The aspects are exact, so the cells are whole.
    pub fn from_image_size(width: u32, height: u32) -> Option<(SkyLayout, u32)> {
        let (w, h) = (u64::from(width), u64::from(height));
        if w == 0 || h == 0 {
            return None;
        }
        let layouts = [
            SkyLayout::HorizontalCross,
            SkyLayout::VerticalCross,
            SkyLayout::HorizontalStrip,
            SkyLayout::VerticalStrip,
        ];
        for layout in layouts {
            let (cols, rows) = layout.grid()?;
            if w * u64::from(rows) == h * u64::from(cols) {
                return Some((layout, width / cols));
            }
        }
        (w == 2 * h).then_some((SkyLayout::LatLong, height))
    }

    /// The accepted aspects, for messages.
    pub(crate) const ACCEPTED: &'static str = "4:3 horizontal cross, 3:4 vertical cross, 6:1 or 1:6 strip \
         (faces in px nx py ny pz nz order), 2:1 lat-long";

    /// The layout whose aspect is within 3 % of `width × height`, if any, for a hint.
    pub(crate) fn nearest(width: u32, height: u32) -> Option<SkyLayout> {
        let aspect = f64::from(width) / f64::from(height.max(1));
        let candidates = [
            (SkyLayout::HorizontalCross, 4.0 / 3.0),
            (SkyLayout::VerticalCross, 3.0 / 4.0),
            (SkyLayout::HorizontalStrip, 6.0),
            (SkyLayout::VerticalStrip, 1.0 / 6.0),
            (SkyLayout::LatLong, 2.0),
        ];
        candidates.into_iter().find(|(_, a)| (aspect / a - 1.0).abs() < 0.03).map(|(l, _)| l)
    }
}

/// Cuts the six faces (edge `n`) of a cube layout out of the `R`, `G`, `B` planes of `image`,
/// undoing the vertical cross's turn, so each comes out as a six-file set stores it.
/// The caller checked the layout and size.
pub(crate) fn slice_faces(image: &Image, layout: SkyLayout, n: u32) -> Option<[TextureImage; 6]> {
    let (r, g, b) = image.rgb_planes()?;
    let cells = layout.cells()?;
    let width = image.width as usize;
    let n = n as usize;
    Some(cells.map(|(col, row, turned)| {
        let (x0, y0) = (col as usize * n, row as usize * n);
        let mut texels = Vec::with_capacity(n * n);
        for y in 0..n {
            let start = (y0 + y) * width + x0;
            let row = r[start..start + n].iter().zip(&g[start..start + n]).zip(&b[start..start + n]);
            texels.extend(row.map(|((&r, &g), &b)| Rgb::new(r, g, b)));
        }
        if turned {
            texels.reverse();
        }
        TextureImage { width: n as u32, height: n as u32, texels }
    }))
}

/// The six faces (equal and square, [`CubeFace::ALL`] order) laid out in one image; unused
/// cells are black. `None` for a layout that is not a single-image cube layout.
pub(crate) fn assemble_faces(faces: &[TextureImage; 6], layout: SkyLayout) -> Option<Image> {
    let (cols, rows) = layout.grid()?;
    let cells = layout.cells()?;
    let n = faces[0].width as usize;
    let (width, height) = (cols as usize * n, rows as usize * n);
    let mut planes = [vec![0.0f32; width * height], vec![0.0f32; width * height], vec![0.0f32; width * height]];
    for (face, (col, row, turned)) in CubeFace::ALL.iter().zip(cells) {
        let texels = &faces[face.index()].texels;
        let (x0, y0) = (col as usize * n, row as usize * n);
        for y in 0..n {
            for x in 0..n {
                let (sx, sy) = if turned { (n - 1 - x, n - 1 - y) } else { (x, y) };
                let c = texels[sy * n + sx];
                let i = (y0 + y) * width + x0 + x;
                planes[0][i] = c.x;
                planes[1][i] = c.y;
                planes[2][i] = c.z;
            }
        }
    }
    Some(planar_rgb(width as u32, height as u32, planes))
}

/// An `R`, `G`, `B` image from its planes.
pub(crate) fn planar_rgb(width: u32, height: u32, planes: [Vec<f32>; 3]) -> Image {
    let mut image = Image::new(width, height);
    for (name, data) in ["R", "G", "B"].into_iter().zip(planes) {
        image.channels.push(glint_image::Channel { name: name.to_string(), data });
    }
    image
}

/// A texture image as an `R`, `G`, `B` image.
pub(crate) fn texture_to_image(texture: &TextureImage) -> Image {
    let planes = [0, 1, 2].map(|k| texture.texels.iter().map(|c| c[k]).collect());
    planar_rgb(texture.width, texture.height, planes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sky::test_util::painted_faces;

    #[test]
    fn aspects_pick_layouts_with_whole_cells() {
        assert_eq!(SkyLayout::from_image_size(8192, 6144), Some((SkyLayout::HorizontalCross, 2048)));
        assert_eq!(SkyLayout::from_image_size(768, 1024), Some((SkyLayout::VerticalCross, 256)));
        assert_eq!(SkyLayout::from_image_size(3072, 512), Some((SkyLayout::HorizontalStrip, 512)));
        assert_eq!(SkyLayout::from_image_size(64, 384), Some((SkyLayout::VerticalStrip, 64)));
        assert_eq!(SkyLayout::from_image_size(1024, 512), Some((SkyLayout::LatLong, 512)));
        assert_eq!(SkyLayout::from_image_size(4, 3), Some((SkyLayout::HorizontalCross, 1)));
        for (w, h) in [(1025, 768), (512, 512), (1000, 501), (0, 0), (7, 3)] {
            assert_eq!(SkyLayout::from_image_size(w, h), None, "{w}x{h}");
        }
        assert_eq!(SkyLayout::nearest(1025, 768), Some(SkyLayout::HorizontalCross));
        assert_eq!(SkyLayout::nearest(1000, 501), Some(SkyLayout::LatLong));
        assert_eq!(SkyLayout::nearest(512, 512), None);
    }

    #[test]
    fn every_layout_round_trips_and_places_faces_where_documented() {
        let n = 3;
        let faces = painted_faces(n);
        for layout in
            [SkyLayout::HorizontalCross, SkyLayout::VerticalCross, SkyLayout::HorizontalStrip, SkyLayout::VerticalStrip]
        {
            let image = assemble_faces(&faces, layout).expect("cube layout");
            let (cols, rows) = layout.grid().expect("grid");
            assert_eq!((image.width, image.height), (cols * n, rows * n));
            assert_eq!(SkyLayout::from_image_size(image.width, image.height), Some((layout, n)));
            let back = slice_faces(&image, layout, n).expect("slice");
            assert_eq!(back, faces, "{layout:?}");
        }
        // Spot checks against the diagrams, reading the assembled image directly: the colour
        // at the centre of a cell names the face in it.
        let at = |image: &Image, col: u32, row: u32| {
            let i = ((row * n + 1) * image.width + col * n + 1) as usize;
            let r = image.channel("R").expect("R")[i];
            (r * 8.0).round() as usize
        };
        let cross = assemble_faces(&faces, SkyLayout::HorizontalCross).expect("cross");
        let expect = [((1, 0), 2), ((0, 1), 1), ((1, 1), 4), ((2, 1), 0), ((3, 1), 5), ((1, 2), 3)];
        for ((col, row), face) in expect {
            assert_eq!(at(&cross, col, row), face, "cell {col},{row}");
        }
        assert_eq!(cross.channel("G").expect("G")[0], 0.0, "unused cells are black");
        let vertical = assemble_faces(&faces, SkyLayout::VerticalCross).expect("vertical");
        assert_eq!(at(&vertical, 1, 3), 5);
        // −Z is turned 180°: its marker sits in the cell's bottom-right texel.
        let i = ((4 * n - 1) * vertical.width + 2 * n - 1) as usize;
        assert_eq!(vertical.channel("B").expect("B")[i], 0.0);
        assert_eq!(vertical.channel("R").expect("R")[i], 1.0);
    }

    #[test]
    fn texture_to_image_keeps_texels() {
        let faces = painted_faces(2);
        let image = texture_to_image(&faces[3]);
        assert_eq!(image.rgb().expect("rgb")[1], [0.0, 1.0, 1.0]);
    }
}
