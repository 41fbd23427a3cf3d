//! The centre of a still LED's light above the learned floor, for a round blob whose fitted
//! path reads still.
//!
//! An LED at rest in a wide glow that clips (a bloom 30 px across) has no axis: the fit's
//! middle rests on a random few pixels of its rim and jitters by a few tenths of a pixel, and
//! the clip's own outline is no better a guide, for the floor's texture moves the clip's edge
//! where the glow falls slowly (`glint-scene --scene speed-ramp --spot bloom` at rest: the
//! clipped pixels' mass centre 0.4 px off, steady). But the floor under an LED that came to
//! rest was seen without it ([`FloorBackground`]), so the light itself is known pixel by
//! pixel: the frame minus the floor. Where it clips, only a lower bound is known: at least the
//! top minus the floor there. Weighting every pixel by its light above a contour level,
//! capped at the least light any clipped pixel is known to have, gives weights that depend on
//! the light alone, so a round light's centre is where they balance, whatever floor it lies on.

use super::blobs::Blob;
use super::floor_bg::FloorBackground;
use super::satellite::SATELLITE_AREA_RATIO;
use crate::frame::Frame;

/// The contour level, as a fraction of the least clipped light: halfway between the floor
/// and the clip, well above the noise, and close enough to the clipped core that the contour
/// lies within a window half the blob's thickness beyond it (checked, not assumed).
const CONTOUR_FRACTION: f32 = 0.5;

/// The contour must stand this many noise deviations above the floor (as the floor's own
/// gate on light arriving).
const MIN_CONTOUR_DEVIATIONS: f32 = 4.0;

/// The least window reach beyond the blob's box, px.
const MIN_REACH_PX: usize = 3;

/// The centre of the light and its standard deviation per axis from the floor's noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightCentre {
    pub centre_px: (f32, f32),
    pub sigma_px: f32,
}

/// The centre of the light of `blob` (its thickness `thickness_px`) whose clipped pixels read
/// `top_luma`, above `floor`, in a window half its thickness beyond its box, or a whole
/// thickness where the light above the contour reaches that one's edge (a glow that falls
/// slowly). `None` where the floor is not known over the window, another light (of `others`)
/// reaches into it, nothing clips, the contour is within the noise, or the light reaches the
/// wider window's edge too. Specks far smaller than the blob (the tracker's satellites: its
/// rim, or floor its glow lights) are its own light above the floor, and stay in.
pub fn light_centre<'b>(
    frame: &Frame<'_>,
    blob: &Blob,
    thickness_px: f32,
    top_luma: u8,
    floor: &FloorBackground,
    others: impl Iterator<Item = &'b Blob> + Clone,
) -> Option<LightCentre> {
    let reach = ((0.5 * thickness_px).ceil() as usize).max(MIN_REACH_PX);
    for reach in [reach, 2 * reach] {
        match centre_within(frame, blob, reach, top_luma, floor, others.clone())? {
            Within::Centre(centre) => return Some(centre),
            Within::TooNarrow => continue,
        }
    }
    None
}

/// What a window's pixels gave.
enum Within {
    Centre(LightCentre),
    /// The light above the contour reaches the window's edge.
    TooNarrow,
}

/// [`light_centre`] in the window `reach` beyond the blob's box.
fn centre_within<'b>(
    frame: &Frame<'_>,
    blob: &Blob,
    reach: usize,
    top_luma: u8,
    floor: &FloorBackground,
    mut others: impl Iterator<Item = &'b Blob>,
) -> Option<Within> {
    let bbox = &blob.bbox;
    let x0 = bbox.x_min_px.checked_sub(reach)?;
    let y0 = bbox.y_min_px.checked_sub(reach)?;
    let (x1, y1) = (bbox.x_max_px + reach, bbox.y_max_px + reach);
    let inside = |o: &Blob| {
        let b = &o.bbox;
        let piece = o.area_px.saturating_mul(SATELLITE_AREA_RATIO) <= blob.area_px;
        !piece && b.x_max_px >= x0 && b.x_min_px <= x1 && b.y_max_px >= y0 && b.y_min_px <= y1
    };
    if others.any(inside) {
        return None;
    }
    let light = |x: usize, y: usize| -> Option<(f32, bool)> {
        let luma = frame.luma(x, y)?;
        Some((f32::from(luma) - floor.luma(x, y)?, luma >= top_luma))
    };
    // The least light a clipped pixel is known to have (the clip hides the rest).
    let mut cap = f32::INFINITY;
    for y in y0..=y1 {
        for x in x0..=x1 {
            let (light, clipped) = light(x, y)?;
            if clipped {
                cap = cap.min(light);
            }
        }
    }
    let contour = CONTOUR_FRACTION * cap;
    let noise = floor.noise_luma();
    if !cap.is_finite() || contour < MIN_CONTOUR_DEVIATIONS * noise {
        return None;
    }
    let span = cap - contour;
    let (mut sw, mut sx, mut sy) = (0.0f32, 0.0f32, 0.0f32);
    // The pixels between contour and cap carry the noise: their count and moments.
    let (mut n, mut mx, mut my, mut mxx, mut myy) = (0.0f32, 0.0f32, 0.0f32, 0.0f32, 0.0f32);
    for y in y0..=y1 {
        for x in x0..=x1 {
            let (light, _) = light(x, y)?;
            let w = (light - contour).clamp(0.0, span);
            let edge = x == x0 || x == x1 || y == y0 || y == y1;
            if edge && w > 0.0 {
                return Some(Within::TooNarrow);
            }
            let (xf, yf) = (x as f32, y as f32);
            sw += w;
            sx += w * xf;
            sy += w * yf;
            if w > 0.0 && w < span {
                n += 1.0;
                mx += xf;
                my += yf;
                mxx += xf * xf;
                myy += yf * yf;
            }
        }
    }
    if sw <= 0.0 {
        return None;
    }
    let (cx, cy) = (sx / sw, sy / sw);
    // Each ramp pixel's noise moves the centre by its offset over the total weight.
    let spread = (mxx - 2.0 * cx * mx + n * cx * cx) + (myy - 2.0 * cy * my + n * cy * cy);
    Some(Within::Centre(LightCentre {
        centre_px: (cx, cy),
        sigma_px: (0.5 * spread.max(0.0)).sqrt() * noise / sw,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::blobs::BoundingBox;
    use crate::frame::FrameSize;

    const W: usize = 96;
    const H: usize = 64;

    fn yuyv(luma: impl Fn(usize, usize) -> f32) -> Vec<u8> {
        let mut bytes = vec![128u8; 2 * W * H];
        for y in 0..H {
            for x in 0..W {
                bytes[2 * (y * W + x)] = luma(x, y).round().clamp(0.0, 255.0) as u8;
            }
        }
        bytes
    }

    /// A glow clipped 20 px across on a floor that brightens to the right (and a darker
    /// stripe): the clipped pixels' mass centre is pulled off by the floor, the light's centre
    /// is where the glow is.
    #[test]
    fn a_clipped_glow_on_a_sloping_floor_is_centred_on_its_light() {
        let size = FrameSize::new(W as u32, H as u32).unwrap();
        let floor = |x: usize, y: usize| {
            let stripe = if (x / 3).is_multiple_of(5) {
                -25.0
            } else {
                0.0
            };
            120.0 + 1.2 * x as f32 + stripe + ((x * 7 + y * 13) % 5) as f32
        };
        let mut background = FloorBackground::new(size);
        let bare = yuyv(floor);
        let frame = Frame::new_checked(&bare, size, size.row_bytes()).unwrap();
        for _ in 0..4 {
            background.update(&frame, core::iter::empty::<&Blob>(), |_| 0);
        }
        let centre = (47.3f32, 30.6f32);
        let glow = |x: usize, y: usize| {
            let r2 = (x as f32 - centre.0).powi(2) + (y as f32 - centre.1).powi(2);
            220.0 * (-r2 / (2.0 * 9.0 * 9.0)).exp()
        };
        let lit = yuyv(|x, y| floor(x, y) + glow(x, y));
        let frame = Frame::new_checked(&lit, size, size.row_bytes()).unwrap();
        let (mut n, mut sx, mut sy) = (0.0f32, 0.0f32, 0.0f32);
        let (mut x_min, mut x_max, mut y_min, mut y_max) = (W, 0, H, 0);
        for y in 0..H {
            for x in 0..W {
                if frame.luma(x, y) == Some(255) {
                    (n, sx, sy) = (n + 1.0, sx + x as f32, sy + y as f32);
                    (x_min, x_max) = (x_min.min(x), x_max.max(x));
                    (y_min, y_max) = (y_min.min(y), y_max.max(y));
                }
            }
        }
        let clip_error = (sx / n - centre.0).hypot(sy / n - centre.1);
        assert!(clip_error > 0.3, "the floor moves the clip: {clip_error}");
        let bbox = BoundingBox {
            x_min_px: x_min,
            y_min_px: y_min,
            x_max_px: x_max,
            y_max_px: y_max,
        };
        let thickness = (x_max - x_min + 1) as f32;
        let glow_blob = Blob {
            area_px: n as u32,
            bbox,
            mass_centre_px: (sx / n, sy / n),
            elongation: 1.0,
        };
        let b = &glow_blob;
        let alone = || core::iter::empty::<&Blob>();
        let found = light_centre(&frame, b, thickness, 255, &background, alone()).unwrap();
        let (x, y) = found.centre_px;
        let error = (x - centre.0).hypot(y - centre.1);
        assert!(error < 0.05, "{:?}: {error} px", found.centre_px);
        // A window too tight for the contour says so rather than cut it.
        assert_eq!(
            light_centre(&frame, b, 0.0, 255, &background, alone()),
            None
        );
        // Without the floor under it, nothing is claimed.
        let unknown = FloorBackground::new(size);
        assert_eq!(
            light_centre(&frame, b, thickness, 255, &unknown, alone()),
            None
        );
        // Nor with another light beside it in the window; a speck of its rim stays in.
        let beside = |area_px: u32| Blob {
            area_px,
            bbox: BoundingBox {
                x_min_px: x_max + 4,
                y_min_px: y_min,
                x_max_px: x_max + 13,
                y_max_px: y_min + 9,
            },
            mass_centre_px: ((x_max + 8) as f32, (y_min + 4) as f32),
            elongation: 1.0,
        };
        let lamp = [beside(100)];
        assert_eq!(
            light_centre(&frame, b, thickness, 255, &background, lamp.iter()),
            None
        );
        let speck = [beside(n as u32 / 10)];
        let with_speck = light_centre(&frame, b, thickness, 255, &background, speck.iter());
        assert_eq!(with_speck, Some(found));
    }
}
