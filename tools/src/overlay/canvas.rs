//! An RGB raster with the few drawing primitives the overlay needs, and its PNG encoding.
//!
//! Every primitive clips to the canvas, so a marker half outside the image, or a coordinate
//! that came from a bad detection, draws what fits and never panics.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

/// An 8-bit RGB colour.
pub type Rgb = [u8; 3];

/// Width and height of a glyph of the 8×8 font, before scaling.
pub const GLYPH_PX: usize = 8;

/// An RGB image, rows top to bottom, three bytes per pixel.
#[derive(Clone, PartialEq, Eq)]
pub struct Canvas {
    width_px: usize,
    height_px: usize,
    rgb: Vec<u8>,
}

impl std::fmt::Debug for Canvas {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Canvas({}x{})", self.width_px, self.height_px)
    }
}

/// A marker shape, centred on a point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Marker {
    /// An upright cross `+` with arms of the given length.
    Plus,
    /// A diagonal cross `×`.
    Cross,
    /// A circle outline.
    Circle,
    /// A filled disk.
    Dot,
    /// A square outline `◇` standing on a corner, with its centre pixel set.
    Diamond,
    /// A square outline `□`, with its centre pixel set.
    Square,
}

impl Canvas {
    /// A canvas filled with `background`.
    pub fn new(width_px: usize, height_px: usize, background: Rgb) -> Self {
        let pixels = width_px.saturating_mul(height_px);
        let mut rgb = Vec::with_capacity(pixels.saturating_mul(3));
        for _ in 0..pixels {
            rgb.extend_from_slice(&background);
        }
        Canvas {
            width_px,
            height_px,
            rgb,
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width_px
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height_px
    }

    /// The packed RGB bytes, rows top to bottom.
    pub fn as_rgb_bytes(&self) -> &[u8] {
        &self.rgb
    }

    /// Byte offset of pixel `(x, y)`, or `None` off the canvas.
    fn offset(&self, x: i64, y: i64) -> Option<usize> {
        let x = usize::try_from(x).ok().filter(|&x| x < self.width_px)?;
        let y = usize::try_from(y).ok().filter(|&y| y < self.height_px)?;
        Some((y * self.width_px + x) * 3)
    }

    /// The colour of pixel `(x, y)`, or `None` off the canvas.
    pub fn get(&self, x: i64, y: i64) -> Option<Rgb> {
        let at = self.offset(x, y)?;
        let px = self.rgb.get(at..at + 3)?;
        Some([px[0], px[1], px[2]])
    }

    /// Sets pixel `(x, y)`; ignored off the canvas.
    pub fn set(&mut self, x: i64, y: i64, colour: Rgb) {
        if let Some(at) = self.offset(x, y) {
            if let Some(px) = self.rgb.get_mut(at..at + 3) {
                px.copy_from_slice(&colour);
            }
        }
    }

    /// Mixes `colour` into pixel `(x, y)` with weight `alpha` (0 keeps the pixel, 1 replaces
    /// it); ignored off the canvas.
    pub fn blend(&mut self, x: i64, y: i64, colour: Rgb, alpha: f32) {
        if let Some(old) = self.get(x, y) {
            self.set(x, y, mix(old, colour, alpha));
        }
    }

    /// Fills the rectangle `[x0, x1) × [y0, y1)`.
    pub fn fill_rect(&mut self, x0: i64, y0: i64, x1: i64, y1: i64, colour: Rgb) {
        for y in y0.max(0)..y1.min(self.height_px as i64) {
            for x in x0.max(0)..x1.min(self.width_px as i64) {
                self.set(x, y, colour);
            }
        }
    }

    /// The outline of the rectangle with corners `(x0, y0)` and `(x1, y1)`, both inclusive.
    pub fn rect_outline(&mut self, x0: i64, y0: i64, x1: i64, y1: i64, colour: Rgb) {
        self.line(x0, y0, x1, y0, colour);
        self.line(x1, y0, x1, y1, colour);
        self.line(x1, y1, x0, y1, colour);
        self.line(x0, y1, x0, y0, colour);
    }

    /// A one-pixel line from `(x0, y0)` to `(x1, y1)`, both ends included (Bresenham). A line
    /// reaching off the canvas is first clipped to it, so far-away ends cost nothing.
    pub fn line(&mut self, x0: i64, y0: i64, x1: i64, y1: i64, colour: Rgb) {
        let Some((x0, y0, x1, y1)) = self.clip_line(x0, y0, x1, y1) else {
            return;
        };
        let (dx, dy) = ((x1 - x0).abs(), -(y1 - y0).abs());
        let (sx, sy) = ((x1 - x0).signum(), (y1 - y0).signum());
        let (mut x, mut y, mut err) = (x0, y0, dx + dy);
        loop {
            self.set(x, y, colour);
            if x == x1 && y == y1 {
                break;
            }
            let e2 = 2 * err;
            if e2 >= dy {
                err += dy;
                x += sx;
            }
            if e2 <= dx {
                err += dx;
                y += sy;
            }
        }
    }

    /// The part of a line inside the canvas (Liang–Barsky), or `None` when it misses it. A
    /// line wholly inside is returned unchanged.
    fn clip_line(&self, x0: i64, y0: i64, x1: i64, y1: i64) -> Option<(i64, i64, i64, i64)> {
        let (w, h) = (self.width_px as i64, self.height_px as i64);
        let inside = |x: i64, y: i64| (0..w).contains(&x) && (0..h).contains(&y);
        if inside(x0, y0) && inside(x1, y1) {
            return Some((x0, y0, x1, y1));
        }
        let (fx0, fy0) = (x0 as f64, y0 as f64);
        let (dx, dy) = (x1 as f64 - fx0, y1 as f64 - fy0);
        let (mut t0, mut t1) = (0.0_f64, 1.0_f64);
        // Each edge as (-d, distance to it): p·t ≤ q keeps the line on the inner side.
        let edges = [
            (-dx, fx0),
            (dx, (w - 1) as f64 - fx0),
            (-dy, fy0),
            (dy, (h - 1) as f64 - fy0),
        ];
        for (p, q) in edges {
            if p == 0.0 {
                if q < 0.0 {
                    return None;
                }
            } else {
                let t = q / p;
                if p < 0.0 {
                    t0 = t0.max(t);
                } else {
                    t1 = t1.min(t);
                }
            }
        }
        if t0 > t1 {
            return None;
        }
        let at = |t: f64| ((fx0 + t * dx).round() as i64, (fy0 + t * dy).round() as i64);
        let ((ax, ay), (bx, by)) = (at(t0), at(t1));
        Some((ax, ay, bx, by))
    }

    /// Pixels whose centre lies within `radius_px` ± ½ of `(cx, cy)`: a one-pixel ring.
    pub fn circle(&mut self, cx: i64, cy: i64, radius_px: i64, colour: Rgb) {
        let r = radius_px.max(0);
        for dy in -r - 1..=r + 1 {
            for dx in -r - 1..=r + 1 {
                let d = ((dx * dx + dy * dy) as f64).sqrt();
                if (d - r as f64).abs() <= 0.5 {
                    self.set(cx + dx, cy + dy, colour);
                }
            }
        }
    }

    /// A filled disk of radius `radius_px`.
    pub fn disk(&mut self, cx: i64, cy: i64, radius_px: i64, colour: Rgb) {
        let r = radius_px.max(0);
        for dy in -r..=r {
            for dx in -r..=r {
                if dx * dx + dy * dy <= r * r {
                    self.set(cx + dx, cy + dy, colour);
                }
            }
        }
    }

    /// `marker` of size `radius_px` centred on `(cx, cy)` in `colour`, drawn three pixels
    /// thick over a dark outline so it stays legible on the white LED and on the floor alike,
    /// and when the image is shown scaled down. The brush is symmetric, so the marker's centre
    /// stays exactly on `(cx, cy)`.
    pub fn marker(&mut self, marker: Marker, cx: i64, cy: i64, radius_px: i64, colour: Rgb) {
        for dy in -OUTLINE_PX..=OUTLINE_PX {
            for dx in -OUTLINE_PX..=OUTLINE_PX {
                self.marker_shape(marker, cx + dx, cy + dy, radius_px, OUTLINE);
            }
        }
        for (dx, dy) in BRUSH {
            self.marker_shape(marker, cx + dx, cy + dy, radius_px, colour);
        }
    }

    fn marker_shape(&mut self, marker: Marker, cx: i64, cy: i64, r: i64, colour: Rgb) {
        match marker {
            Marker::Plus => {
                self.line(cx - r, cy, cx + r, cy, colour);
                self.line(cx, cy - r, cx, cy + r, colour);
            }
            Marker::Cross => {
                self.line(cx - r, cy - r, cx + r, cy + r, colour);
                self.line(cx - r, cy + r, cx + r, cy - r, colour);
            }
            Marker::Circle => self.circle(cx, cy, r, colour),
            Marker::Dot => self.disk(cx, cy, r, colour),
            Marker::Diamond => {
                self.line(cx - r, cy, cx, cy - r, colour);
                self.line(cx, cy - r, cx + r, cy, colour);
                self.line(cx + r, cy, cx, cy + r, colour);
                self.line(cx, cy + r, cx - r, cy, colour);
                self.set(cx, cy, colour);
            }
            Marker::Square => {
                self.rect_outline(cx - r, cy - r, cx + r, cy + r, colour);
                self.set(cx, cy, colour);
            }
        }
    }

    /// Writes `text` with its top-left corner at `(x, y)`, each font pixel `scale` pixels
    /// wide. Characters outside ASCII are drawn as `?`. Returns the x after the last glyph.
    pub fn text(&mut self, x: i64, y: i64, text: &str, scale: usize, colour: Rgb) -> i64 {
        let scale = scale.max(1);
        let advance = (GLYPH_PX * scale) as i64;
        let mut pen_x = x;
        for c in text.chars() {
            let code = if c.is_ascii() {
                c as usize
            } else {
                '?' as usize
            };
            let glyph = font8x8::legacy::BASIC_LEGACY
                .get(code)
                .copied()
                .unwrap_or_default();
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..GLYPH_PX {
                    // Bit 0 is the leftmost pixel of a row.
                    if bits >> col & 1 == 1 {
                        let px = pen_x + (col * scale) as i64;
                        let py = y + (row * scale) as i64;
                        let s = scale as i64;
                        self.fill_rect(px, py, px + s, py + s, colour);
                    }
                }
            }
            pen_x += advance;
        }
        pen_x
    }

    /// Writes the canvas to a PNG file at `path`.
    pub fn save_png(&self, path: &Path) -> Result<(), png::EncodingError> {
        let mut out = BufWriter::new(File::create(path)?);
        self.write_png(&mut out)?;
        out.flush()?;
        Ok(())
    }

    /// Encodes the canvas as an 8-bit RGB PNG.
    pub fn write_png<W: Write>(&self, out: W) -> Result<(), png::EncodingError> {
        let width = u32::try_from(self.width_px).unwrap_or(u32::MAX);
        let height = u32::try_from(self.height_px).unwrap_or(u32::MAX);
        let mut encoder = png::Encoder::new(out, width, height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header()?;
        writer.write_image_data(&self.rgb)?;
        writer.finish()
    }
}

/// The dark outline drawn under every marker.
const OUTLINE: Rgb = [0, 0, 0];

/// How far the outline reaches around each pixel of a marker.
const OUTLINE_PX: i64 = 2;

/// A plus-shaped brush: lines three pixels thick with the centre kept in place.
const BRUSH: [(i64, i64); 5] = [(0, 0), (-1, 0), (1, 0), (0, -1), (0, 1)];

/// `old` moved towards `new` by `alpha`.
pub fn mix(old: Rgb, new: Rgb, alpha: f32) -> Rgb {
    let a = alpha.clamp(0.0, 1.0);
    let channel = |o: u8, n: u8| (f32::from(o) + (f32::from(n) - f32::from(o)) * a).round() as u8;
    [
        channel(old[0], new[0]),
        channel(old[1], new[1]),
        channel(old[2], new[2]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    const BLACK: Rgb = [0, 0, 0];
    const WHITE: Rgb = [255, 255, 255];

    /// The canvas as ASCII rows: `#` where the pixel is `ink`, `.` elsewhere.
    fn picture(canvas: &Canvas, ink: Rgb) -> Vec<String> {
        (0..canvas.height() as i64)
            .map(|y| {
                (0..canvas.width() as i64)
                    .map(|x| {
                        if canvas.get(x, y) == Some(ink) {
                            '#'
                        } else {
                            '.'
                        }
                    })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn a_diamond_is_a_square_on_its_corner_with_its_centre_set() {
        let mut c = Canvas::new(7, 7, BLACK);
        c.marker_shape(Marker::Diamond, 3, 3, 2, WHITE);
        #[rustfmt::skip]
        let want = [
            ".......",
            "...#...",
            "..#.#..",
            ".#.#.#.",
            "..#.#..",
            "...#...",
            ".......",
        ];
        assert_eq!(picture(&c, WHITE), want);
    }

    #[test]
    fn plus_cross_and_circle() {
        let mut c = Canvas::new(5, 5, BLACK);
        c.marker_shape(Marker::Plus, 2, 2, 1, WHITE);
        assert_eq!(
            picture(&c, WHITE),
            [".....", "..#..", ".###.", "..#..", "....."]
        );

        let mut c = Canvas::new(5, 5, BLACK);
        c.marker_shape(Marker::Cross, 2, 2, 2, WHITE);
        assert_eq!(
            picture(&c, WHITE),
            ["#...#", ".#.#.", "..#..", ".#.#.", "#...#"]
        );

        let mut c = Canvas::new(7, 7, BLACK);
        c.circle(3, 3, 2, WHITE);
        #[rustfmt::skip]
        let want = [
            ".......",
            "..###..",
            ".#...#.",
            ".#...#.",
            ".#...#.",
            "..###..",
            ".......",
        ];
        assert_eq!(picture(&c, WHITE), want);
    }

    #[test]
    fn markers_are_thick_outlined_and_clipped_at_the_edges() {
        let grey = [100, 100, 100];
        let mut c = Canvas::new(12, 12, grey);
        c.marker(Marker::Plus, 0, 0, 3, WHITE);
        // The arm: three pixels thick, one past its end by the brush...
        assert_eq!(c.get(0, 0), Some(WHITE));
        assert_eq!(c.get(4, 0), Some(WHITE));
        assert_eq!(c.get(3, 1), Some(WHITE));
        // ...then the outline...
        assert_eq!(c.get(5, 0), Some(OUTLINE));
        assert_eq!(c.get(3, 2), Some(OUTLINE));
        // ...and nothing else changed.
        assert_eq!(c.get(7, 0), Some(grey));
        assert_eq!(c.get(3, 4), Some(grey));
        // Wholly outside: nothing happens, nothing panics.
        c.marker(Marker::Circle, -50, 9_000, 4, WHITE);
        c.line(-1_000_000, 9, 1_000_000, 9, WHITE);
        assert_eq!(picture(&c, WHITE)[9], "############");
    }

    #[test]
    fn text_uses_the_font_with_its_leftmost_pixel_in_bit_0() {
        let mut c = Canvas::new(8, 8, BLACK);
        let end = c.text(0, 0, "L", 1, WHITE);
        assert_eq!(end, 8);
        // An L: the stem on the left, the foot along the bottom.
        let rows = picture(&c, WHITE);
        assert!(rows[2].starts_with(".##."), "{rows:?}");
        assert!(rows[6].starts_with("#######"), "{rows:?}");
        assert_eq!(rows[7], "........");
    }

    #[test]
    fn the_png_decodes_back_to_the_same_pixels() {
        let mut c = Canvas::new(3, 2, [10, 20, 30]);
        c.set(2, 1, [200, 100, 0]);
        let mut bytes = Vec::new();
        c.write_png(&mut bytes).unwrap();
        let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (3, 2));
        assert_eq!(info.color_type, png::ColorType::Rgb);
        assert_eq!(&buf[..info.buffer_size()], c.as_rgb_bytes());
    }

    #[test]
    fn blending_moves_part_of_the_way() {
        assert_eq!(mix([0, 100, 200], [200, 100, 0], 0.5), [100, 100, 100]);
        assert_eq!(mix([0, 0, 0], [255, 255, 255], 2.0), [255, 255, 255]);
    }
}
