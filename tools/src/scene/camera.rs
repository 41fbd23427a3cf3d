//! Camera response: sensor noise, clipping at the sensor's full well, and quantisation to
//! 8-bit luma in full or studio range, packed as YUYV 4:2:2.

use super::rng::SplitMix64;

/// How the camera maps clipped linear signal `v ∈ [0, 1]` to 8-bit luma.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Range {
    /// `Y = round(255 v)`: white is 255.
    Full,
    /// `Y = 16 + round(219 v)`: white clips at 235, as many real webcams deliver.
    Studio,
}

impl Range {
    /// Luma of a clipped (saturated) pixel.
    pub fn white_luma(self) -> u8 {
        self.luma(1.0)
    }

    /// Quantises a linear value; values outside `[0, 1]` are clipped first.
    pub fn luma(self, v: f32) -> u8 {
        let (black, span) = self.black_and_span();
        round_to_u8(black + span * v.clamp(0.0, 1.0))
    }

    /// Luma of black, and the luma span from black to white.
    fn black_and_span(self) -> (f32, f32) {
        match self {
            Range::Full => (0.0, 255.0),
            Range::Studio => (16.0, 219.0),
        }
    }
}

/// Rounds a value in `0.0..=255.0` to the nearest integer, halves up. Adding one half and
/// truncating avoids `f32::round`, which is a library call on baseline x86-64 and would
/// dominate the per-pixel cost.
fn round_to_u8(x: f32) -> u8 {
    (x + 0.5) as u8
}

/// The luma `level` with noise of `post_luma` deviation added after the clip, quantised.
fn after_the_clip(level: f32, post_luma: f32, gaussian: &mut impl FnMut() -> f32) -> u8 {
    let post = if post_luma > 0.0 {
        post_luma * gaussian()
    } else {
        0.0
    };
    round_to_u8((level + post).clamp(0.0, 255.0))
}

/// Neutral chroma.
const CHROMA_NEUTRAL: f32 = 128.0;
/// Chroma offsets of the floor at black, fading to neutral at white: a warm floor under a
/// white LED. glint ignores chroma; this only makes the dump a plausible colour image.
const FLOOR_TINT_U: f32 = -6.0;
const FLOOR_TINT_V: f32 = 9.0;

/// Sensor noise and output range.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Standard deviation of additive Gaussian read noise, in clip units (0.01 ≈ 2.5 luma
    /// levels in full range).
    pub noise_sigma: f64,
    /// Output range.
    pub range: Range,
    /// The tone curve's exponent: the clipped linear signal `v` is written as `v^(1/gamma)`
    /// (1.0 is linear; webcams use about 1.8–2.4, and the tracker is not told which).
    pub gamma: f64,
    /// Standard deviation of Gaussian noise added to the luma after the tone curve, in luma
    /// levels: what processing after the sensor clips (compression, sharpening, denoising)
    /// leaves, so that a saturated pixel reads white give or take this rather than exactly
    /// white, as real recordings' clipped windows and LEDs do.
    pub post_noise_luma: f64,
}

impl Camera {
    /// Adds noise to one row of linear radiance and writes it as YUYV bytes. `out` holds
    /// `2 * radiance.len()` bytes; an odd trailing pixel (never produced by a validated
    /// scene) is left untouched.
    pub(crate) fn expose_row(
        &self,
        radiance: &[f32],
        rng: &mut Option<SplitMix64>,
        out: &mut [u8],
    ) {
        let inverse_gamma = (1.0 / self.gamma) as f32;
        let tone = |v: f32| v.powf(inverse_gamma);
        // Monomorphised loops rather than per-pixel branches on the noise and the tone curve.
        match (rng, self.gamma == 1.0) {
            (Some(rng), true) => self.pack_row(radiance, out, || rng.next_gaussian(), |v| v),
            (None, true) => self.pack_row(radiance, out, || 0.0, |v| v),
            (Some(rng), false) => self.pack_row(radiance, out, || rng.next_gaussian(), tone),
            (None, false) => self.pack_row(radiance, out, || 0.0, tone),
        }
    }

    /// Whether rendering through this camera draws random numbers.
    pub(crate) fn is_noisy(&self) -> bool {
        self.noise_sigma > 0.0 || self.post_noise_luma > 0.0
    }

    /// Read noise is added to the linear signal before the sensor clips it, and the tone
    /// curve follows; the noise after the clip, if any, is added to the luma last. `gaussian`
    /// draws a standard normal deviate (the noise after the clip draws only when there is
    /// some, so that scenes without it render as they always did).
    fn pack_row(
        &self,
        radiance: &[f32],
        out: &mut [u8],
        mut gaussian: impl FnMut() -> f32,
        tone: impl Fn(f32) -> f32,
    ) {
        let sigma = self.noise_sigma as f32;
        let post_luma = self.post_noise_luma as f32;
        let (black, span) = self.range.black_and_span();
        for (pair, quad) in radiance.chunks_exact(2).zip(out.chunks_exact_mut(4)) {
            let [a, b] = *pair else { continue };
            let v0 = tone((a + sigma * gaussian()).clamp(0.0, 1.0));
            let y0 = after_the_clip(black + span * v0, post_luma, &mut gaussian);
            let v1 = tone((b + sigma * gaussian()).clamp(0.0, 1.0));
            let y1 = after_the_clip(black + span * v1, post_luma, &mut gaussian);
            let fade = 1.0 - 0.5 * (v0 + v1);
            quad.copy_from_slice(&[
                y0,
                round_to_u8(CHROMA_NEUTRAL + FLOOR_TINT_U * fade),
                y1,
                round_to_u8(CHROMA_NEUTRAL + FLOOR_TINT_V * fade),
            ]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_and_studio_ranges_map_black_and_white() {
        assert_eq!(Range::Full.luma(-0.3), 0);
        assert_eq!(Range::Full.luma(0.0), 0);
        assert_eq!(Range::Full.luma(1.0), 255);
        assert_eq!(Range::Full.luma(7.0), 255);
        assert_eq!(Range::Full.luma(0.5), 128);
        assert_eq!(Range::Studio.luma(0.0), 16);
        assert_eq!(Range::Studio.luma(1.0), 235);
        assert_eq!(Range::Studio.luma(40.0), 235);
        assert_eq!(Range::Studio.white_luma(), 235);
    }

    #[test]
    fn row_is_packed_as_y0_u_y1_v() {
        let camera = Camera {
            noise_sigma: 0.0,
            range: Range::Full,
            gamma: 1.0,
            post_noise_luma: 0.0,
        };
        let mut out = [0u8; 12];
        camera.expose_row(&[0.0, 1.0, 2.0, 1.5, 0.2, 0.2], &mut None, &mut out);
        assert_eq!(
            [out[0], out[2], out[4], out[6], out[8], out[10]],
            [0, 255, 255, 255, 51, 51]
        );
        // White pairs carry neutral chroma, darker pairs the floor tint.
        assert_eq!((out[5], out[7]), (128, 128));
        assert!(out[1] < 128 && out[3] > 128);
        assert!(out[9] < out[1] && out[11] > out[3]);
    }

    #[test]
    fn gamma_lifts_mid_tones_and_keeps_black_and_white() {
        let camera = Camera {
            noise_sigma: 0.0,
            range: Range::Full,
            gamma: 2.2,
            post_noise_luma: 0.0,
        };
        let mut out = [0u8; 8];
        camera.expose_row(&[0.0, 0.25, 1.0, 3.0], &mut None, &mut out);
        // 0.25^(1/2.2) = 0.5325 → 135.8
        assert_eq!([out[0], out[2], out[4], out[6]], [0, 136, 255, 255]);
    }

    #[test]
    fn noise_has_the_configured_spread() {
        let camera = Camera {
            noise_sigma: 0.04,
            range: Range::Full,
            gamma: 1.0,
            post_noise_luma: 0.0,
        };
        let row = vec![0.5f32; 20_000];
        let mut out = vec![0u8; 40_000];
        camera.expose_row(&row, &mut Some(SplitMix64::new(3)), &mut out);
        let lumas: Vec<f64> = out.iter().step_by(2).map(|&y| f64::from(y)).collect();
        let mean = lumas.iter().sum::<f64>() / lumas.len() as f64;
        let sd =
            (lumas.iter().map(|y| (y - mean).powi(2)).sum::<f64>() / lumas.len() as f64).sqrt();
        assert!((mean - 127.5).abs() < 0.3, "mean {mean}");
        assert!((sd - 0.04 * 255.0).abs() < 0.3, "sd {sd}");
    }

    /// Read noise leaves a saturated pixel exactly white; noise after the clip spreads it.
    #[test]
    fn noise_after_the_clip_spreads_white_and_read_noise_does_not() {
        let saturated = vec![3.0f32; 20_000];
        let mut out = vec![0u8; 40_000];
        let lumas =
            |out: &[u8]| -> Vec<f64> { out.iter().step_by(2).map(|&y| f64::from(y)).collect() };
        let mut camera = Camera {
            noise_sigma: 0.04,
            range: Range::Studio,
            gamma: 2.2,
            post_noise_luma: 0.0,
        };
        camera.expose_row(&saturated, &mut Some(SplitMix64::new(5)), &mut out);
        assert!(lumas(&out).iter().all(|&y| y == 235.0));
        camera.post_noise_luma = 1.5;
        camera.expose_row(&saturated, &mut Some(SplitMix64::new(5)), &mut out);
        let white = lumas(&out);
        let mean = white.iter().sum::<f64>() / white.len() as f64;
        let sd =
            (white.iter().map(|y| (y - mean).powi(2)).sum::<f64>() / white.len() as f64).sqrt();
        assert!((mean - 235.0).abs() < 0.1, "mean {mean}");
        // Quantisation adds 1/12 of a level's square.
        let expected = (1.5f64.powi(2) + 1.0 / 12.0).sqrt();
        assert!((sd - expected).abs() < 0.1, "sd {sd}");
    }
}
