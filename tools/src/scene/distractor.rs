//! Things that are bright but are not the LED: static lights of any shape (an elongated lamp,
//! a window that clips, a hot pixel), and further LEDs fixed to the same rigid body as the
//! tracked one.
//!
//! Static lights are drawn once into the scene's static radiance map. A shape's coverage of a
//! pixel is estimated on a sub-pixel grid: these shapes only have to look like glare, their
//! centroids are never held to any accuracy.

use super::optics::{Led, Patch};
use super::trajectory::Point;

/// Sub-samples per pixel side when estimating a shape's coverage.
const SUBSAMPLES: usize = 4;

/// A static light that never moves.
#[derive(Clone, Debug, PartialEq)]
pub enum StaticLight {
    /// A filled ellipse: with equal radii a disk, with unequal ones a bar-like lamp or a
    /// reflection along an edge.
    Ellipse {
        centre_px: Point,
        /// Half-axes along the ellipse's own x and y.
        radii_px: Point,
        /// Rotation of the ellipse's x axis from the image's, counter-clockwise.
        angle_rad: f64,
        /// Radiance inside, in multiples of the clip level.
        peak: f64,
    },
    /// An axis-aligned rectangle, such as a window; `peak` as for the ellipse.
    Rect {
        left_px: f64,
        top_px: f64,
        width_px: f64,
        height_px: f64,
        peak: f64,
    },
    /// One pixel whose value does not follow the light (a hot pixel): it reads `radiance`
    /// (clip units) whatever lies under it.
    Pixel { x_px: u32, y_px: u32, radiance: f64 },
}

impl StaticLight {
    /// True when every number is finite, sizes positive and radiances not negative.
    pub(crate) fn is_valid(&self) -> bool {
        match *self {
            StaticLight::Ellipse {
                centre_px,
                radii_px,
                angle_rad,
                peak,
            } => {
                centre_px.is_finite()
                    && radii_px.is_finite()
                    && radii_px.x > 0.0
                    && radii_px.y > 0.0
                    && angle_rad.is_finite()
                    && peak.is_finite()
                    && peak >= 0.0
            }
            StaticLight::Rect {
                left_px,
                top_px,
                width_px,
                height_px,
                peak,
            } => {
                [left_px, top_px, width_px, height_px, peak]
                    .iter()
                    .all(|v| v.is_finite())
                    && width_px > 0.0
                    && height_px > 0.0
                    && peak >= 0.0
            }
            StaticLight::Pixel { radiance, .. } => radiance.is_finite() && radiance >= 0.0,
        }
    }

    /// Adds this light into a full-frame radiance map `width` pixels wide.
    pub(crate) fn add_to(&self, map: &mut [f32], width: usize) {
        let height = map.len() / width.max(1);
        match *self {
            StaticLight::Pixel {
                x_px,
                y_px,
                radiance,
            } => {
                let (x, y) = (x_px as usize, y_px as usize);
                if x < width {
                    if let Some(v) = map.get_mut(y * width + x) {
                        *v = radiance as f32;
                    }
                }
            }
            StaticLight::Ellipse {
                centre_px,
                radii_px,
                angle_rad,
                peak,
            } => {
                let reach = radii_px.x.max(radii_px.y) + 1.0;
                let (cos, sin) = (angle_rad.cos(), angle_rad.sin());
                let inside = |x: f64, y: f64| {
                    let (dx, dy) = (x - centre_px.x, y - centre_px.y);
                    let (u, v) = (dx * cos + dy * sin, -dx * sin + dy * cos);
                    (u / radii_px.x).powi(2) + (v / radii_px.y).powi(2) <= 1.0
                };
                let lo = Point::new(centre_px.x - reach, centre_px.y - reach);
                let hi = Point::new(centre_px.x + reach, centre_px.y + reach);
                fill(map, width, height, lo, hi, peak, inside);
            }
            StaticLight::Rect {
                left_px,
                top_px,
                width_px,
                height_px,
                peak,
            } => {
                let (right, bottom) = (left_px + width_px, top_px + height_px);
                let inside =
                    |x: f64, y: f64| x >= left_px && x < right && y >= top_px && y < bottom;
                let lo = Point::new(left_px - 1.0, top_px - 1.0);
                let hi = Point::new(right + 1.0, bottom + 1.0);
                fill(map, width, height, lo, hi, peak, inside);
            }
        }
    }
}

/// Adds `peak` times the covered fraction of each pixel in the box `[lo, hi]`, where a pixel
/// `(i, j)` covers `[i - 0.5, i + 0.5] × [j - 0.5, j + 0.5]`.
fn fill(
    map: &mut [f32],
    width: usize,
    height: usize,
    lo: Point,
    hi: Point,
    peak: f64,
    inside: impl Fn(f64, f64) -> bool,
) {
    let clamp = |v: f64, size: usize| v.round().clamp(0.0, size.saturating_sub(1) as f64) as usize;
    let (x0, x1) = (clamp(lo.x, width), clamp(hi.x, width));
    let (y0, y1) = (clamp(lo.y, height), clamp(hi.y, height));
    let step = 1.0 / SUBSAMPLES as f64;
    let weight = peak / (SUBSAMPLES * SUBSAMPLES) as f64;
    for y in y0..=y1 {
        for x in x0..=x1 {
            let mut hits = 0usize;
            for sy in 0..SUBSAMPLES {
                for sx in 0..SUBSAMPLES {
                    let px = x as f64 - 0.5 + (sx as f64 + 0.5) * step;
                    let py = y as f64 - 0.5 + (sy as f64 + 0.5) * step;
                    hits += usize::from(inside(px, py));
                }
            }
            if let Some(v) = map.get_mut(y * width + x) {
                *v += (weight * hits as f64) as f32;
            }
        }
    }
}

/// Another LED on the tracked LED's rigid body: it follows the same trajectory shifted by
/// `offset_px` (the body translates without turning), with its own size and brightness.
#[derive(Clone, Debug, PartialEq)]
pub struct Companion {
    /// Where it sits relative to the tracked LED.
    pub offset_px: Point,
    /// Its disk and glow.
    pub led: Led,
    /// Frames in which it flickers: it shines at `dim_peak` instead of its own peak (a
    /// failing LED, or one turned away, below the detector's level).
    pub dim_frames: Vec<core::ops::Range<usize>>,
    /// Its radiance (clip units) in `dim_frames`.
    pub dim_peak: f64,
}

impl Companion {
    pub(crate) fn is_valid(&self) -> bool {
        self.offset_px.is_finite()
            && self.led.radius_px.is_finite()
            && self.led.radius_px > 0.0
            && self.led.peak.is_finite()
            && self.led.peak >= 0.0
            && self.led.glow_peak == 0.0
            && self.dim_peak.is_finite()
            && self.dim_peak >= 0.0
    }

    /// Its disk during frame `frame`: dimmed in its `dim_frames`.
    pub(crate) fn led_in(&self, frame: usize) -> Led {
        let dim = self.dim_frames.iter().any(|r| r.contains(&frame));
        Led {
            peak: if dim { self.dim_peak } else { self.led.peak },
            ..self.led.clone()
        }
    }
}

/// Adds one LED's exposure into `patch`: the disk at each of `positions` (shifted by
/// `offset_px`), each sample weighted equally.
pub(crate) fn add_swept_disk(patch: &mut Patch, positions: &[Point], offset_px: Point, led: &Led) {
    let weight = led.peak / positions.len().max(1) as f64;
    for p in positions {
        let centre = Point::new(p.x + offset_px.x, p.y + offset_px.y);
        patch.add_squeezed_disk(centre, led.radius_px, led.squeeze, weight);
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::{Scene, StaticLight, Visibility};

    fn luma(scene: &Scene, frame: usize, x: usize, y: usize) -> u8 {
        let mut out = vec![0u8; scene.frame_len_bytes()];
        scene.render(frame, &mut out).unwrap();
        out[2 * (y * scene.width_px() as usize + x)]
    }

    #[test]
    fn the_hot_pixel_the_window_and_the_bar_are_where_they_are_said_to_be() {
        let hot = Scene::preset("hot-pixel").unwrap();
        // 247 plus the sensor's noise; its neighbours are floor.
        assert!(luma(&hot, 0, 450, 120).abs_diff(247) <= 10);
        assert!(luma(&hot, 0, 451, 120) < 150);
        let window = Scene::preset("window").unwrap();
        assert_eq!(luma(&window, 0, 500, 80), 255, "inside the window");
        assert!(luma(&window, 0, 440, 80) < 200, "left of the window");
        let rest = Scene::preset("rest-glare").unwrap();
        let Some(StaticLight::Ellipse { centre_px, .. }) = rest.config().static_lights.get(1)
        else {
            panic!("the bar is the second light");
        };
        let (x, y) = (centre_px.x as usize, centre_px.y as usize);
        assert_eq!(luma(&rest, 0, x, y), 255, "the bar's centre clips");
        // Along its long axis (0.5 rad) 10 px out it still clips; across it, 10 px out, not.
        let along = (x + 9, y + 5);
        let across = (x - 5, y + 9);
        assert_eq!(luma(&rest, 0, along.0, along.1), 255);
        assert!(luma(&rest, 0, across.0, across.1) < 200);
    }

    #[test]
    fn companions_ride_at_their_offsets() {
        let scene = Scene::preset("three-leds").unwrap();
        let truth = scene.truth(0);
        let (x, y) = (truth.x_px.unwrap(), truth.y_px.unwrap());
        for c in &scene.config().companions {
            let (cx, cy) = (x + c.offset_px.x, y + c.offset_px.y);
            assert_eq!(
                luma(&scene, 0, cx.round() as usize, cy.round() as usize),
                255
            );
        }
        let between = (x + 20.0, y - 20.0);
        assert!(luma(&scene, 0, between.0 as usize, between.1 as usize) < 200);
    }

    #[test]
    fn a_hidden_led_sends_no_light_and_a_dimmed_companion_is_dim() {
        let mut config = Scene::preset_config("three-leds").unwrap();
        let hidden = 3..5;
        config.led_hidden_frames = vec![hidden.clone()];
        config.companions[0].dim_frames = vec![hidden];
        config.companions[0].dim_peak = 0.3;
        let scene = Scene::new(config).unwrap();
        for frame in 2..6 {
            let truth = scene.truth(frame);
            let at = scene.config().trajectory.motion(truth.t_s).position_px;
            let (x, y) = (at.x.round() as usize, at.y.round() as usize);
            let offset = scene.config().companions[0].offset_px;
            let (cx, cy) = ((at.x + offset.x) as usize, (at.y + offset.y) as usize);
            if (3..5).contains(&frame) {
                assert_eq!(truth.visible, Visibility::Hidden, "frame {frame}");
                assert!(
                    luma(&scene, frame, x, y) < 200,
                    "frame {frame}: the LED is dark"
                );
                assert!(luma(&scene, frame, cx, cy) < 200, "frame {frame}: dimmed");
            } else {
                assert_eq!(truth.visible, Visibility::Visible, "frame {frame}");
                assert_eq!(luma(&scene, frame, x, y), 255, "frame {frame}");
                assert_eq!(luma(&scene, frame, cx, cy), 255, "frame {frame}");
            }
        }
    }
}
