//! The floor: a procedural texture the camera looks down on, well below the clip level.
//!
//! Smooth value noise at two scales (stains, lighting falloff) plus darker grout lines of a
//! square tiling, so a detector sees real structure, edges and gradients, never a flat grey.

use super::rng::{hash2, unit_from_bits};

/// Floor appearance, in linear sensor units (1.0 = clip).
#[derive(Clone, Debug, PartialEq)]
pub struct Floor {
    /// Mean radiance, e.g. 0.3–0.45.
    pub mean: f64,
    /// Peak-to-peak variation of the noise around the mean; grout lines are darker by
    /// the same amount. 0 gives a flat floor.
    pub contrast: f64,
    /// Tile pitch; 0 disables the grout lines.
    pub tile_px: u32,
}

/// Lattice spacing of the coarse noise octave.
const COARSE_CELL_PX: f64 = 57.0;
/// Lattice spacing of the fine noise octave.
const FINE_CELL_PX: f64 = 13.0;
/// Share of the fine octave in the noise (the coarse one gets the rest).
const FINE_SHARE: f64 = 0.35;
/// Width of a grout line.
const GROUT_PX: f64 = 2.0;
/// Distinguishes the two octaves' lattices derived from one seed.
const FINE_OCTAVE_SALT: u64 = 0x5EED_F1AE;

impl Floor {
    /// Radiance of every pixel of a `width_px × height_px` frame, row-major.
    pub(crate) fn render(&self, width_px: usize, height_px: usize, seed: u64) -> Vec<f32> {
        let mut map = Vec::with_capacity(width_px * height_px);
        for y in 0..height_px {
            for x in 0..width_px {
                map.push(self.radiance(x as f64, y as f64, seed) as f32);
            }
        }
        map
    }

    pub(crate) fn radiance(&self, x: f64, y: f64, seed: u64) -> f64 {
        let noise = (1.0 - FINE_SHARE) * value_noise(x / COARSE_CELL_PX, y / COARSE_CELL_PX, seed)
            + FINE_SHARE * value_noise(x / FINE_CELL_PX, y / FINE_CELL_PX, seed ^ FINE_OCTAVE_SALT);
        let grout = if self.tile_px > 0 {
            let pitch = f64::from(self.tile_px);
            let on_line = |c: f64| c.rem_euclid(pitch) < GROUT_PX;
            if on_line(x) || on_line(y) {
                1.0
            } else {
                0.0
            }
        } else {
            0.0
        };
        self.mean + self.contrast * (noise - 0.5) - self.contrast * grout
    }
}

/// Smoothly interpolated lattice noise in `[0, 1)`.
fn value_noise(x: f64, y: f64, seed: u64) -> f64 {
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (smoothstep(x - x0), smoothstep(y - y0));
    let (ix, iy) = (x0 as i64, y0 as i64);
    let corner = |dx: i64, dy: i64| unit_from_bits(hash2(seed, ix + dx, iy + dy));
    let top = corner(0, 0) + (corner(1, 0) - corner(0, 0)) * fx;
    let bottom = corner(0, 1) + (corner(1, 1) - corner(0, 1)) * fx;
    top + (bottom - top) * fy
}

fn smoothstep(u: f64) -> f64 {
    u * u * (3.0 - 2.0 * u)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_has_its_mean_and_stays_below_clip() {
        let floor = Floor {
            mean: 0.38,
            contrast: 0.2,
            tile_px: 64,
        };
        let map = floor.render(320, 240, 9);
        let mean = map.iter().map(|&v| f64::from(v)).sum::<f64>() / map.len() as f64;
        let max = map.iter().copied().fold(f32::MIN, f32::max);
        let min = map.iter().copied().fold(f32::MAX, f32::min);
        // Grout lines (2 of every 64 px per axis, ~6 % of pixels) pull the mean down a little.
        assert!((mean - 0.38).abs() < 0.05, "mean {mean}");
        assert!(max < 0.6 && min > 0.05, "range {min}..{max}");
        assert!(max - min > 0.1, "the floor must have texture");
    }

    #[test]
    fn zero_contrast_is_flat_and_seed_changes_texture() {
        let flat = Floor {
            mean: 0.3,
            contrast: 0.0,
            tile_px: 32,
        };
        assert!(flat
            .render(16, 8, 1)
            .iter()
            .all(|&v| (v - 0.3).abs() < 1e-6));
        let textured = Floor {
            mean: 0.3,
            contrast: 0.2,
            tile_px: 0,
        };
        assert_ne!(textured.render(64, 64, 1), textured.render(64, 64, 2));
        assert_eq!(textured.render(64, 64, 1), textured.render(64, 64, 1));
    }
}
