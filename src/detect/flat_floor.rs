//! The luma a pixel would have on a flat floor, where the floor under it has been learned.
//!
//! The floor's texture (tiles, grout lines) under a glow's shallow flank moves where the
//! light falls through a level, and a rim pixel's weight, by tenths of a pixel to a pixel;
//! what lies under the two caps of a streak is the same only by chance, so the light's mirror
//! symmetry (`mirror_middle`) and the centroid read it as light. The floor under a moving
//! streak was in view, unlit, in earlier frames ([`FloorBackground`]): taking the learned
//! floor's light off a pixel and a flat floor's light on leaves the LED's light on a floor
//! without texture. Light adds before the camera's tone curve, so the exchange is done in
//! linear light, through a square-law tone curve (the webcams' 1.8–2.4 about it; the error
//! left is the curve's mismatch times the texture, a small share of it).

use super::floor_bg::FloorBackground;

/// A clip level below this is a studio-range camera's white (235), whose black is 16.
const STUDIO_WHITE_ABOVE: u8 = 245;
/// A studio-range camera's black.
const STUDIO_BLACK_LUMA: f32 = 16.0;

/// The learned floor exchanged for a flat one of a given luma.
#[derive(Clone, Copy)]
pub struct FlatFloor<'f> {
    learned: &'f FloorBackground,
    black_luma: f32,
    clip_luma: f32,
    /// The flat floor's light (linear, arbitrary scale).
    flat_light: f32,
}

impl<'f> FlatFloor<'f> {
    /// The floor `learned` exchanged for a flat floor of `flat_luma`, on a camera that clips
    /// at `clip_luma`.
    pub fn new(learned: &'f FloorBackground, flat_luma: f32, clip_luma: u8) -> Self {
        let black_luma = if clip_luma < STUDIO_WHITE_ABOVE {
            STUDIO_BLACK_LUMA
        } else {
            0.0
        };
        FlatFloor {
            learned,
            black_luma,
            clip_luma: f32::from(clip_luma),
            flat_light: linear(flat_luma, black_luma),
        }
    }

    /// The light (linear, arbitrary scale) of luma `luma`.
    #[inline]
    pub fn light(&self, luma: f32) -> f32 {
        linear(luma, self.black_luma)
    }

    /// How fast the light rises with the luma at light `light`.
    #[inline]
    pub fn light_per_luma(&self, light: f32) -> f32 {
        2.0 * light.max(0.0).sqrt().max(1.0)
    }

    /// The light of pixel `(x, y)`, of luma `luma`, on the flat floor; a clipped pixel, or one
    /// whose floor is unknown, as it is.
    #[inline]
    pub fn light_at(&self, x: usize, y: usize, luma: f32) -> f32 {
        let light = self.light(luma);
        match self.learned.luma(x, y) {
            Some(floor) if luma < self.clip_luma => light - self.light(floor) + self.flat_light,
            _ => light,
        }
    }

    /// The luma of pixel `(x, y)`, of luma `luma`, on the flat floor.
    #[inline]
    pub fn luma_at(&self, x: usize, y: usize, luma: f32) -> f32 {
        self.black_luma + self.light_at(x, y, luma).max(0.0).sqrt()
    }
}

/// Light through a square-law tone curve above black `black_luma`.
#[inline]
fn linear(luma: f32, black_luma: f32) -> f32 {
    let v = (luma - black_luma).max(0.0);
    v * v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{Frame, FrameSize, PixelFormat};

    #[test]
    fn light_on_a_textured_floor_reads_as_on_a_flat_one() {
        let size = FrameSize::new(64, 4).unwrap();
        // A floor of tiles 60 and 100 luma, full range (black 0).
        let tile = |i: usize| {
            if ((i % 64) / 8).is_multiple_of(2) {
                60.0f32
            } else {
                100.0
            }
        };
        let floor_bytes: Vec<u8> = (0..64 * 4).map(|i| tile(i) as u8).collect();
        let mut learned = FloorBackground::new(size);
        let floor = Frame::new_checked_as(&floor_bytes, size, 64, PixelFormat::Grey).unwrap();
        learned.update(&floor, core::iter::empty(), |_| 0);
        // The same light added to every pixel, in linear light, under the square law.
        let light = 120.0f32 * 120.0;
        let lit_luma = |i: usize| (tile(i) * tile(i) + light).sqrt();
        let lit_bytes: Vec<u8> = (0..64 * 4).map(|i| lit_luma(i).round() as u8).collect();
        let flat = FlatFloor::new(&learned, 80.0, 255);
        let expected = (80.0f32 * 80.0 + light).sqrt();
        for (x, &luma) in lit_bytes.iter().enumerate().take(64) {
            let read = flat.luma_at(x, 0, f32::from(luma));
            assert!(
                (read - expected).abs() < 0.6,
                "x {x}: {read} for {expected}"
            );
            // Without the exchange the tiles differ by 12 luma.
            assert!((f32::from(luma) - expected).abs() > 4.0, "x {x}: {luma}");
        }
    }

    #[test]
    fn an_unknown_floor_and_a_clipped_pixel_read_as_they_are() {
        let size = FrameSize::new(8, 2).unwrap();
        let learned = FloorBackground::new(size);
        let flat = FlatFloor::new(&learned, 80.0, 255);
        assert_eq!(flat.luma_at(3, 1, 150.0), 150.0);
        let bytes = vec![40u8; 16];
        let mut learned = FloorBackground::new(size);
        let floor = Frame::new_checked_as(&bytes, size, 8, PixelFormat::Grey).unwrap();
        learned.update(&floor, core::iter::empty(), |_| 0);
        let flat = FlatFloor::new(&learned, 80.0, 250);
        assert_eq!(flat.luma_at(3, 1, 250.0), 250.0, "clipped");
        assert!(
            flat.luma_at(3, 1, 150.0) > 150.0,
            "a dark floor under it lifts it"
        );
    }
}
