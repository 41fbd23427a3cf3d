//! Where things go on the overlay: the whole frame at 1× on the left, a magnified crop around
//! the LED (the inset) on the right, and the caption below both.
//!
//! The inset is the point of the overlay: glint's answers are sub-pixel, and only a
//! nearest-neighbour blow-up shows whether a marker sits a tenth of a pixel off the truth.

/// The inset is never smaller than this on screen, so small frames still get a usable zoom.
pub const MIN_INSET_SIDE_PX: usize = 320;
/// Frame pixels shown around the region of interest in the inset.
pub const INSET_MARGIN_PX: f64 = 6.0;
/// The inset never shows fewer frame pixels than this across (a static LED is ~8 px wide).
pub const MIN_CROP_SIDE_PX: f64 = 20.0;
/// When detection and truth are farther apart than this, the inset follows the detection alone
/// rather than zooming out to show both.
pub const MAX_ROI_SIDE_PX: f64 = 200.0;
/// Largest magnification.
pub const MAX_ZOOM: usize = 16;
/// Gap between the panels, and around the caption.
pub const GAP_PX: usize = 8;

/// A rectangle in frame pixel coordinates ((0, 0) the centre of the top-left pixel).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Region {
    pub x_min_px: f64,
    pub y_min_px: f64,
    pub x_max_px: f64,
    pub y_max_px: f64,
}

impl Region {
    /// The region around one point.
    pub fn point(x_px: f64, y_px: f64) -> Self {
        Region {
            x_min_px: x_px,
            y_min_px: y_px,
            x_max_px: x_px,
            y_max_px: y_px,
        }
    }

    /// The smallest region holding both.
    pub fn union(self, other: Region) -> Region {
        Region {
            x_min_px: self.x_min_px.min(other.x_min_px),
            y_min_px: self.y_min_px.min(other.y_min_px),
            x_max_px: self.x_max_px.max(other.x_max_px),
            y_max_px: self.y_max_px.max(other.y_max_px),
        }
    }

    /// The larger of width and height.
    fn side_px(&self) -> f64 {
        (self.x_max_px - self.x_min_px).max(self.y_max_px - self.y_min_px)
    }

    /// All four coordinates are finite numbers.
    fn is_finite(&self) -> bool {
        [self.x_min_px, self.y_min_px, self.x_max_px, self.y_max_px]
            .iter()
            .all(|v| v.is_finite())
    }
}

/// The geometry of one overlay image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// The frame's size; the full frame is drawn at 1× with its top-left at (0, 0).
    pub frame_width_px: usize,
    pub frame_height_px: usize,
    /// The first frame column and row shown in the inset.
    pub crop_x0_px: usize,
    pub crop_y0_px: usize,
    /// Frame columns and rows shown in the inset.
    pub crop_width_px: usize,
    pub crop_height_px: usize,
    /// Output pixels per frame pixel in the inset.
    pub zoom: usize,
    /// The inset's top-left corner on the canvas.
    pub inset_left_px: usize,
    pub inset_top_px: usize,
    /// Where the caption starts.
    pub caption_top_px: usize,
    /// Canvas width (the caption's height is added when it is known).
    pub canvas_width_px: usize,
}

impl Layout {
    /// Lays out a `width × height` frame with the inset around `roi` (the detection, the
    /// truth), preferring `fallback` (the detection alone) when `roi` is too large to magnify,
    /// and the frame's centre when neither is known or finite.
    pub fn new(
        frame_width_px: usize,
        frame_height_px: usize,
        roi: Option<Region>,
        fallback: Option<Region>,
    ) -> Layout {
        let (w, h) = (frame_width_px.max(1), frame_height_px.max(1));
        let centre = Region::point((w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
        let roi = [roi, fallback]
            .into_iter()
            .flatten()
            .find(|r| r.is_finite() && r.side_px() <= MAX_ROI_SIDE_PX)
            .or(fallback.filter(Region::is_finite))
            .unwrap_or(centre);

        let inset_side_px = h.max(MIN_INSET_SIDE_PX);
        let wanted_side_px = (roi.side_px() + 2.0 * INSET_MARGIN_PX).max(MIN_CROP_SIDE_PX);
        let zoom = ((inset_side_px as f64 / wanted_side_px) as usize).clamp(1, MAX_ZOOM);
        let crop_side_px = inset_side_px / zoom;
        let (crop_width_px, crop_height_px) = (crop_side_px.min(w), crop_side_px.min(h));
        let crop_x0_px = crop_origin(roi.x_min_px, roi.x_max_px, crop_width_px, w);
        let crop_y0_px = crop_origin(roi.y_min_px, roi.y_max_px, crop_height_px, h);

        let inset_left_px = w + GAP_PX;
        let inset_height_px = crop_height_px * zoom;
        Layout {
            frame_width_px: w,
            frame_height_px: h,
            crop_x0_px,
            crop_y0_px,
            crop_width_px,
            crop_height_px,
            zoom,
            inset_left_px,
            inset_top_px: 0,
            caption_top_px: h.max(inset_height_px) + GAP_PX,
            canvas_width_px: inset_left_px + crop_width_px * zoom,
        }
    }

    /// The inset pixel under frame point `(x, y)`: frame pixel `i` covers `i ± ½`, and is
    /// drawn as the `zoom × zoom` block starting at `(i - crop_x0) · zoom`.
    pub fn inset_point(&self, x_px: f64, y_px: f64) -> (i64, i64) {
        let zoom = self.zoom as f64;
        let to_canvas = |v: f64, crop0: usize, offset: usize| {
            let v = ((v - crop0 as f64 + 0.5) * zoom).floor();
            // Saturating: a wild coordinate lands far off the canvas and is clipped there.
            offset as i64 + v.clamp(-1e9, 1e9) as i64
        };
        (
            to_canvas(x_px, self.crop_x0_px, self.inset_left_px),
            to_canvas(y_px, self.crop_y0_px, self.inset_top_px),
        )
    }

    /// Whether frame pixel `(x, y)` is shown in the inset.
    pub fn crop_contains(&self, x_px: usize, y_px: usize) -> bool {
        (self.crop_x0_px..self.crop_x0_px + self.crop_width_px).contains(&x_px)
            && (self.crop_y0_px..self.crop_y0_px + self.crop_height_px).contains(&y_px)
    }
}

/// The first pixel of a crop `side` pixels long, centred on `min..max` and kept inside
/// `0..frame`.
fn crop_origin(min_px: f64, max_px: f64, side_px: usize, frame_px: usize) -> usize {
    let centre = (min_px + max_px) / 2.0;
    // In edge coordinates pixel `i` spans `[i, i + 1)`, so the centre sits at `centre + ½`.
    let first = (centre + 0.5 - side_px as f64 / 2.0).floor();
    let last_start = frame_px.saturating_sub(side_px) as f64;
    first.clamp(0.0, last_start) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_small_streak_is_magnified_and_centred() {
        // A 10 px streak around (300, 200) in a 640×480 frame.
        let roi = Region {
            x_min_px: 295.0,
            y_min_px: 198.0,
            x_max_px: 305.0,
            y_max_px: 202.0,
        };
        let l = Layout::new(640, 480, Some(roi), None);
        // 10 px + 2·6 px margin = 22 px wanted: 480 / 22 → 21×, capped at 16×, 30 px shown.
        assert_eq!(l.zoom, MAX_ZOOM);
        assert_eq!(l.crop_width_px, 30);
        assert_eq!(l.crop_x0_px, 285);
        assert_eq!(l.crop_y0_px, 185);
        assert!(l.crop_contains(295, 198) && l.crop_contains(305, 202));
        assert_eq!(l.canvas_width_px, 640 + GAP_PX + 480);
    }

    #[test]
    fn the_crop_stays_inside_the_frame() {
        let corner = Region::point(1.0, 478.0);
        let l = Layout::new(640, 480, Some(corner), None);
        assert_eq!(l.crop_x0_px, 0);
        assert_eq!(l.crop_y0_px + l.crop_height_px, 480);
    }

    #[test]
    fn far_apart_truth_and_detection_follow_the_detection() {
        let detection = Region::point(100.0, 100.0);
        let both = detection.union(Region::point(600.0, 400.0));
        let l = Layout::new(640, 480, Some(both), Some(detection));
        assert!(l.zoom > 4);
        assert!(l.crop_contains(100, 100));
        assert!(!l.crop_contains(600, 400));
    }

    #[test]
    fn nothing_known_or_nonsense_shows_the_centre() {
        let nan = Region::point(f64::NAN, 3.0);
        for roi in [None, Some(nan)] {
            let l = Layout::new(640, 480, roi, roi);
            assert!(l.crop_contains(320, 240), "{l:?}");
        }
    }

    #[test]
    fn inset_points_follow_the_pixel_centre_convention() {
        let l = Layout::new(640, 480, Some(Region::point(300.0, 200.0)), None);
        let (x0, y0) = (l.crop_x0_px as f64, l.crop_y0_px as f64);
        let z = l.zoom as i64;
        // The centre of a pixel is the middle of its block; its left edge the block's start.
        let (cx, cy) = l.inset_point(x0, y0);
        assert_eq!((cx, cy), (l.inset_left_px as i64 + z / 2, z / 2));
        let (ex, _) = l.inset_point(x0 - 0.5, y0);
        assert_eq!(ex, l.inset_left_px as i64);
        // A quarter pixel to the right moves a quarter of a block.
        let (qx, _) = l.inset_point(x0 + 0.25, y0);
        assert_eq!(qx - cx, z / 4);
    }
}
