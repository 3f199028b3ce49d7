//! What the window shows of a film: the beauty or one AOV, as 0RGB words of 8-bit sRGB (the
//! format softbuffer presents), scaled up to the window when the frame was drawn smaller.

use glint_core::Rgb;
use glint_core::colour::linear_to_srgb;
use glint_render::points::PointFrame;
use glint_render::{Film, PathAovs};
use rayon::prelude::*;

/// The channel on screen; the display key cycles through them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Display {
    #[default]
    Beauty,
    /// Shading normal, (n + 1) / 2 as RGB.
    Normal,
    /// Eye depth, near white to far black over the frame's range.
    Depth,
    Albedo,
    /// Path mode: direct light.
    Direct,
    /// Path mode: diffuse indirect light (demodulated, filtered as it went into the beauty).
    Indirect,
}

impl Display {
    pub const ALL: [Display; 6] =
        [Display::Beauty, Display::Normal, Display::Depth, Display::Albedo, Display::Direct, Display::Indirect];

    pub fn name(self) -> &'static str {
        match self {
            Display::Beauty => "beauty",
            Display::Normal => "normal",
            Display::Depth => "depth",
            Display::Albedo => "albedo",
            Display::Direct => "direct",
            Display::Indirect => "indirect",
        }
    }

    /// The next channel that `film`-like pictures of the path mode (`path_aovs`) or not have.
    pub fn next(self, path_aovs: bool) -> Display {
        let i = Display::ALL.iter().position(|d| *d == self).unwrap_or(0);
        let mut next = Display::ALL[(i + 1) % Display::ALL.len()];
        if !path_aovs && matches!(next, Display::Direct | Display::Indirect) {
            next = Display::Beauty;
        }
        next
    }
}

/// Entries of the linear → 8-bit sRGB table (12 bits of linear input: even the darkest step is
/// under one 8-bit level).
const SRGB_TABLE_SIZE: usize = 4096;

fn srgb_table() -> &'static [u8; SRGB_TABLE_SIZE] {
    static TABLE: std::sync::OnceLock<[u8; SRGB_TABLE_SIZE]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        std::array::from_fn(|i| (linear_to_srgb(i as f32 / (SRGB_TABLE_SIZE - 1) as f32) * 255.0 + 0.5) as u8)
    })
}

/// A linear colour as a 0RGB word of 8-bit sRGB (clamped; NaN → 0), by table: a lookup per
/// channel, not a power.
#[inline]
fn srgb_word(table: &[u8; SRGB_TABLE_SIZE], c: Rgb) -> u32 {
    let scale = (SRGB_TABLE_SIZE - 1) as f32;
    // NaN clamps to 0 through the saturating cast.
    let q = |v: f32| u32::from(table[((v.clamp(0.0, 1.0) * scale + 0.5) as usize).min(SRGB_TABLE_SIZE - 1)]);
    (q(c.x) << 16) | (q(c.y) << 8) | q(c.z)
}

/// Linear colours → 0RGB words of 8-bit sRGB.
pub fn to_pixels(colours: &[Rgb], pixels: &mut Vec<u32>) {
    pixels.resize(colours.len(), 0);
    let table = srgb_table();
    pixels.par_chunks_mut(4096).zip(colours.par_chunks(4096)).for_each(|(out, c)| {
        for (o, c) in out.iter_mut().zip(c) {
            *o = srgb_word(table, *c);
        }
    });
}

/// What the display reads of one pixel.
#[derive(Clone, Copy)]
struct Aovs {
    colour: Rgb,
    normal: glint_core::Vec3,
    albedo: Rgb,
    depth: f32,
    direct: Rgb,
    indirect: Rgb,
}

/// `film`'s channel `what` as 0RGB words (film size).
pub fn display(film: &Film, what: Display, pixels: &mut Vec<u32>) {
    display_with(film.pixels.len(), what, pixels, |i| {
        let p = film.record(i);
        // Only path frames have direct and indirect light: black elsewhere.
        let path = if film.path_aovs { film.path[i] } else { PathAovs::default() };
        Aovs {
            colour: p.colour,
            normal: p.normal,
            albedo: p.albedo,
            depth: p.depth,
            direct: path.direct,
            indirect: path.indirect,
        }
    });
}

/// A points-mode frame's channel `what` as 0RGB words, read from its own buffers (no film is
/// built: at 1024×768 that would cost more than the shading). It has no direct and indirect
/// light: those channels are black.
pub fn display_points(frame: &PointFrame, what: Display, pixels: &mut Vec<u32>) {
    display_with(frame.depth.len(), what, pixels, |i| Aovs {
        colour: frame.colour[i],
        normal: frame.normal[i],
        albedo: frame.albedo[i],
        depth: frame.depth[i],
        direct: Rgb::ZERO,
        indirect: Rgb::ZERO,
    });
}

fn display_with(n: usize, what: Display, pixels: &mut Vec<u32>, at: impl Fn(usize) -> Aovs + Sync) {
    pixels.resize(n, 0);
    let table = srgb_table();
    let (near, far) = match what {
        Display::Depth => (0..n)
            .into_par_iter()
            .map(|i| at(i).depth)
            .filter(|d| d.is_finite())
            .fold(|| (f32::INFINITY, f32::NEG_INFINITY), |(a, b), d| (a.min(d), b.max(d)))
            .reduce(|| (f32::INFINITY, f32::NEG_INFINITY), |(a, b), (c, d)| (a.min(c), b.max(d))),
        _ => (0.0, 1.0),
    };
    let range = (far - near).max(1e-12);
    pixels.par_chunks_mut(4096).enumerate().for_each(|(chunk, out)| {
        for (k, o) in out.iter_mut().enumerate() {
            let p = at(chunk * 4096 + k);
            *o = match what {
                Display::Beauty => srgb_word(table, p.colour),
                Display::Albedo => srgb_word(table, p.albedo),
                Display::Direct => srgb_word(table, p.direct),
                Display::Indirect => srgb_word(table, p.indirect),
                Display::Normal => {
                    let byte = |v: f32| ((v * 0.5 + 0.5).clamp(0.0, 1.0) * 255.0 + 0.5) as u32;
                    if p.normal == glint_core::Vec3::ZERO {
                        0
                    } else {
                        (byte(p.normal.x) << 16) | (byte(p.normal.y) << 8) | byte(p.normal.z)
                    }
                }
                Display::Depth => {
                    if p.depth.is_finite() {
                        let g = ((1.0 - (p.depth - near) / range).clamp(0.0, 1.0) * 235.0 + 20.5) as u32;
                        (g << 16) | (g << 8) | g
                    } else {
                        0
                    }
                }
            };
        }
    });
}

/// Blow `src` (sw × sh) up to `dst` (dw × dh) by nearest neighbour (the frame drawn at a
/// reduced resolution while the camera moves).
pub fn upscale(src: &[u32], sw: usize, sh: usize, dst: &mut [u32], dw: usize, dh: usize) {
    if sw == 0 || sh == 0 || dw == 0 {
        return;
    }
    let columns: Vec<usize> = (0..dw).map(|x| (x * sw / dw).min(sw - 1)).collect();
    dst.par_chunks_mut(dw).take(dh).enumerate().for_each(|(y, row)| {
        let sy = (y * sh / dh).min(sh - 1);
        let src_row = &src[sy * sw..(sy + 1) * sw];
        for (o, &sx) in row.iter_mut().zip(&columns) {
            *o = src_row[sx];
        }
    });
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use glint_core::Vec3;
    use glint_render::{FilmPixel, SurfacePixel};

    #[test]
    fn pixels_are_srgb_words() {
        let mut p = Vec::new();
        to_pixels(&[Rgb::new(1.0, 0.0, 0.0), Rgb::new(0.0, 2.0, -1.0), Rgb::splat(0.5), Rgb::splat(f32::NAN)], &mut p);
        assert_eq!(p[0], 0x00ff_0000);
        assert_eq!(p[1], 0x0000_ff00);
        assert_eq!(p[2], 0x00bc_bcbc);
        assert_eq!(p[3], 0);
        // The table is within one level of the exact conversion everywhere.
        for i in 0..=1000 {
            let v = i as f32 / 1000.0;
            let exact = (linear_to_srgb(v) * 255.0 + 0.5) as i32;
            to_pixels(&[Rgb::splat(v)], &mut p);
            assert!(((p[0] & 0xff) as i32 - exact).abs() <= 1, "{v}");
        }
    }

    #[test]
    fn every_channel_shows_its_aov() {
        let mut film = Film::new(3, 1);
        film.pixels[0] = FilmPixel { colour: Rgb::ONE, ..FilmPixel::default() };
        film.surface[0] = SurfacePixel { normal: Vec3::X, albedo: Rgb::new(1.0, 0.0, 0.0), depth: 1.0 };
        film.pixels[1] = film.pixels[0];
        film.surface[1] = SurfacePixel { normal: Vec3::NEG_Y, depth: 3.0, ..film.surface[0] };
        let mut p = Vec::new();
        display(&film, Display::Direct, &mut p);
        assert_eq!(p, [0, 0, 0], "no path AOVs: black");
        let direct =
            PathAovs { direct: Rgb::new(0.0, 1.0, 0.0), indirect: Rgb::new(0.0, 0.0, 1.0), ..PathAovs::default() };
        film.path_aovs_mut().expect("small").1[0] = direct;
        display(&film, Display::Beauty, &mut p);
        assert_eq!(p, [0xffffff, 0xffffff, 0]);
        display(&film, Display::Albedo, &mut p);
        assert_eq!(p[0], 0xff0000);
        display(&film, Display::Direct, &mut p);
        assert_eq!(p[0], 0x00ff00);
        display(&film, Display::Indirect, &mut p);
        assert_eq!(p[0], 0x0000ff);
        display(&film, Display::Normal, &mut p);
        assert_eq!(p, [0xff8080, 0x800080, 0]);
        // Depth: nearest white, farthest dark grey, nothing black.
        display(&film, Display::Depth, &mut p);
        assert_eq!(p, [0xffffff, 0x141414, 0]);
    }

    #[test]
    fn the_display_key_skips_path_channels_elsewhere() {
        let mut d = Display::Beauty;
        let mut seen = vec![d];
        for _ in 0..5 {
            d = d.next(true);
            seen.push(d);
        }
        assert_eq!(seen, Display::ALL);
        assert_eq!(d.next(true), Display::Beauty);
        assert_eq!(Display::Albedo.next(false), Display::Beauty);
    }

    #[test]
    fn upscaling_repeats_pixels() {
        let src = [1, 2, 3, 4];
        let mut dst = vec![0; 16];
        upscale(&src, 2, 2, &mut dst, 4, 4);
        assert_eq!(dst, [1, 1, 2, 2, 1, 1, 2, 2, 3, 3, 4, 4, 3, 3, 4, 4]);
        let mut dst = vec![0; 9];
        upscale(&src, 2, 2, &mut dst, 3, 3);
        assert_eq!(dst, [1, 1, 2, 1, 1, 2, 3, 3, 4]);
    }

    /// A points frame of clouds alone is displayed straight from the points buffers; the film
    /// made from it on demand (screenshots) shows the same picture in every channel.
    #[test]
    fn a_points_frame_displays_as_its_film() {
        use glint_render::{Hooks, ImageSettings, ModeSettings, Picture, Renderer};
        let mut clouds = glint_testkit::scenes::cloud_and_sphere();
        clouds.objects.clear();
        let camera = clouds.camera;
        let mode = ModeSettings::from_defaults(&clouds.render).mode(glint_scene::RenderMode::Points);
        let mut r = Renderer::new(clouds).unwrap();
        r.render(&camera, &ImageSettings::new(48, 32), &mode, &Hooks::default()).unwrap();
        let (mut shown, mut from_film) = (Vec::new(), Vec::new());
        for what in Display::ALL {
            match r.picture() {
                Picture::Points(frame) => display_points(frame, what, &mut shown),
                Picture::Film(_) => panic!("clouds alone are held as a points frame"),
            }
            display(r.film(), what, &mut from_film);
            assert_eq!(shown, from_film, "{what:?}");
            if what == Display::Beauty {
                assert!(shown.iter().collect::<std::collections::HashSet<_>>().len() > 3, "lit points and sky");
            }
        }
        assert_eq!(r.size(), (48, 32));
    }
}
