//! Text for the HUD, drawn on the CPU into an RGBA image: ASCII with the public-domain 8x8
//! bitmap glyphs of the `font8x8` crate (Daniel Hepper's `font8x8_basic.h`), each glyph pixel
//! drawn as a `scale x scale` square so the text stays legible on large windows.
//!
//! Glyph convention (font8x8's): 8 bytes per glyph, the top row first; in a row, bit 0 is the
//! leftmost pixel. Glyphs are 8 pixels wide with no spacing of their own beyond what the
//! font's own blank columns give (most glyphs leave the rightmost column empty).

/// Width and height of a glyph in pixels at scale 1.
pub const GLYPH_SIZE: u32 = 8;

/// An RGBA image, 8 bits per channel, not premultiplied, row-major with the top row first.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Canvas {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height * 4` bytes.
    pub pixels: Vec<u8>,
}

impl Canvas {
    /// A `width x height` canvas filled with `fill`.
    pub fn new(width: u32, height: u32, fill: [u8; 4]) -> Self {
        let n = width as usize * height as usize;
        Self {
            width,
            height,
            pixels: fill.repeat(n),
        }
    }

    /// The pixel at `(x, y)`; `None` outside the canvas (the tests read the canvas with it).
    #[cfg(test)]
    pub fn pixel(&self, x: u32, y: u32) -> Option<[u8; 4]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = (y as usize * self.width as usize + x as usize) * 4;
        let mut p = [0; 4];
        p.copy_from_slice(&self.pixels[i..i + 4]);
        Some(p)
    }

    /// Sets the pixel at `(x, y)`; outside the canvas nothing happens (text is clipped).
    fn set(&mut self, x: u32, y: u32, colour: [u8; 4]) {
        if x < self.width && y < self.height {
            let i = (y as usize * self.width as usize + x as usize) * 4;
            self.pixels[i..i + 4].copy_from_slice(&colour);
        }
    }

    /// Draws `text` on one line with its top-left corner at `(x, y)`, setting exactly the
    /// glyphs' pixels to `colour` (the pixels between them are left as they are), each glyph
    /// pixel a `scale x scale` square (`scale` 0 counts as 1). Characters outside ASCII are
    /// drawn as `?`; what falls outside the canvas is clipped. Returns the x after the text.
    pub fn draw_text(&mut self, x: u32, y: u32, text: &str, colour: [u8; 4], scale: u32) -> u32 {
        let scale = scale.max(1);
        let advance = GLYPH_SIZE * scale;
        let mut left = x;
        for c in text.chars() {
            for (row, bits) in glyph(c).iter().enumerate() {
                for col in 0..GLYPH_SIZE {
                    if bits & (1 << col) == 0 {
                        continue;
                    }
                    let (px, py) = (left + col * scale, y + row as u32 * scale);
                    for dy in 0..scale {
                        for dx in 0..scale {
                            self.set(px + dx, py + dy, colour);
                        }
                    }
                }
            }
            left = left.saturating_add(advance);
        }
        left
    }
}

/// The 8x8 glyph of `c` (`?` for characters outside ASCII).
pub fn glyph(c: char) -> [u8; 8] {
    let table = &font8x8::legacy::BASIC_LEGACY;
    let code = if c.is_ascii() {
        c as usize
    } else {
        '?' as usize
    };
    table[code]
}

/// Width in pixels of `text` drawn at `scale` (every character is one glyph wide).
pub fn text_width(text: &str, scale: u32) -> u32 {
    text.chars().count() as u32 * GLYPH_SIZE * scale.max(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    const INK: [u8; 4] = [255, 240, 120, 255];
    const PAPER: [u8; 4] = [0, 0, 0, 0];

    /// Whether font8x8's bitmap of `c` sets pixel `(x, y)` of the glyph.
    fn font_bit(c: char, x: u32, y: u32) -> bool {
        font8x8::legacy::BASIC_LEGACY[c as usize][y as usize] & (1 << x) != 0
    }

    #[test]
    fn text_sets_exactly_the_glyph_pixels() {
        let mut canvas = Canvas::new(24, 8, PAPER);
        let end = canvas.draw_text(0, 0, "Hi4", INK, 1);
        assert_eq!(end, 24);
        let mut inked = 0;
        for y in 0..8 {
            for x in 0..24 {
                let c = "Hi4".chars().nth((x / 8) as usize).unwrap();
                let want = if font_bit(c, x % 8, y) { INK } else { PAPER };
                assert_eq!(canvas.pixel(x, y), Some(want), "({x}, {y}) of {c:?}");
                inked += usize::from(want == INK);
            }
        }
        // The glyphs are not empty (the comparison above would pass on blank bitmaps too).
        assert!(inked > 30, "{inked}");
    }

    #[test]
    fn scaled_text_draws_each_glyph_pixel_as_a_square() {
        let mut canvas = Canvas::new(16, 16, PAPER);
        canvas.draw_text(0, 0, "A", INK, 2);
        for y in 0..16 {
            for x in 0..16 {
                let want = if font_bit('A', x / 2, y / 2) {
                    INK
                } else {
                    PAPER
                };
                assert_eq!(canvas.pixel(x, y), Some(want), "({x}, {y})");
            }
        }
    }

    #[test]
    fn text_is_clipped_at_the_canvas_edge() {
        let mut canvas = Canvas::new(12, 5, PAPER);
        canvas.draw_text(4, 1, "MM", INK, 1);
        for y in 0..5 {
            for x in 0..12 {
                let inside_glyph = (1..5).contains(&y) && x >= 4;
                let want = inside_glyph && font_bit('M', (x - 4) % 8, y - 1);
                assert_eq!(canvas.pixel(x, y) == Some(INK), want, "({x}, {y})");
            }
        }
    }

    #[test]
    fn empty_text_draws_nothing() {
        let mut canvas = Canvas::new(8, 8, PAPER);
        assert_eq!(canvas.draw_text(3, 2, "", INK, 1), 3);
        assert_eq!(canvas, Canvas::new(8, 8, PAPER));
        assert_eq!(text_width("", 3), 0);
    }

    #[test]
    fn non_ascii_is_drawn_as_a_question_mark() {
        assert_eq!(glyph('é'), glyph('?'));
        assert_eq!(text_width("né", 2), 32);
    }
}
