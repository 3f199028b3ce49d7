//! On-screen text: lines of 8×8 bitmap glyphs (the public-domain font8x8 set) drawn over a
//! darkened box in the top-left corner of the frame, scaled ×2 on large windows.

use font8x8::{BASIC_FONTS, UnicodeFonts};

/// Pixels between the box edge and the text, and between lines (at scale 1).
const MARGIN: usize = 6;
const LINE: usize = 11;

/// Glyph scale for a window `width` pixels wide.
pub fn scale_for(width: usize) -> usize {
    if width >= 2200 { 2 } else { 1 }
}

/// Draw `lines` into the 0RGB frame `pixels` (`width` × `height`) at the top left: white
/// glyphs on the frame darkened to a quarter. Lines and glyphs that do not fit are cut.
pub fn draw_text(pixels: &mut [u32], width: usize, height: usize, lines: &[String], scale: usize) {
    if lines.is_empty() || width == 0 || height == 0 {
        return;
    }
    let s = scale.max(1);
    let columns = lines.iter().map(|l| l.chars().count()).max().unwrap_or(0);
    let box_w = ((columns * 8 + 2 * MARGIN) * s).min(width);
    let box_h = ((lines.len() * LINE + 2 * MARGIN - (LINE - 8)) * s).min(height);
    for row in pixels.chunks_mut(width).take(box_h) {
        for p in &mut row[..box_w] {
            // A quarter of each channel: shift each byte right by two, mask the borrow.
            *p = (*p >> 2) & 0x003f_3f3f;
        }
    }
    for (li, line) in lines.iter().enumerate() {
        let y0 = (MARGIN + li * LINE) * s;
        for (ci, ch) in line.chars().enumerate() {
            let x0 = (MARGIN + ci * 8) * s;
            let glyph = BASIC_FONTS.get(ch).or_else(|| BASIC_FONTS.get('?')).unwrap_or([0; 8]);
            for (gy, bits) in glyph.iter().enumerate() {
                for gx in 0..8 {
                    if bits >> gx & 1 == 0 {
                        continue;
                    }
                    for dy in 0..s {
                        let y = y0 + gy * s + dy;
                        if y >= box_h {
                            continue;
                        }
                        for dx in 0..s {
                            let x = x0 + gx * s + dx;
                            if x < box_w {
                                pixels[y * width + x] = 0x00ff_ffff;
                            }
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_white_on_a_darkened_box_and_is_clipped() {
        let (w, h) = (200, 40);
        let mut p = vec![0x00ff_8040u32; w * h];
        draw_text(&mut p, w, h, &["Hi".to_string()], 1);
        // 'H' has set pixels in its first column: at the margin, a few rows down.
        let white = p.iter().filter(|&&c| c == 0x00ff_ffff).count();
        assert!(white > 10, "{white}");
        // The box is darkened, outside it untouched.
        assert_eq!(p[0], 0x003f_2010);
        assert_eq!(p[w - 1], 0x00ff_8040);
        assert_eq!(p[(h - 1) * w], 0x00ff_8040);
        // A long line in a small frame: no panic, clipped.
        let mut small = vec![0u32; 30 * 10];
        draw_text(&mut small, 30, 10, &["a very long line".into(), "two".into()], 2);
        // Scale 2 doubles the lit pixels.
        let mut big = vec![0u32; 400 * 80];
        draw_text(&mut big, 400, 80, &["Hi".to_string()], 2);
        assert_eq!(big.iter().filter(|&&c| c == 0x00ff_ffff).count(), 4 * white);
    }
}
