//! Overlays: one YUYV frame as an RGB image with what glint saw drawn on it.
//!
//! The image has three parts. On the left is the whole frame at 1×, with the saturation mask
//! tinted, the skeleton, the chosen blob's box and the inset's outline. On the right is a
//! nearest-neighbour magnification of a crop around the LED (the inset), where the sub-pixel
//! markers can be told apart: the streak's middle, the position, the centroid, the skeleton's
//! two ends, the streak's tips, and the ground truth's middle and position when known. Below both is a caption with the
//! numbers and a legend of the markers.
//!
//! ```no_run
//! # fn demo(frame: glint::frame::Frame<'_>, pipeline: &glint::pipeline::Pipeline,
//! #         report: &glint::report::FrameReport, truth: &glint_tools::scene::Truth)
//! # -> std::io::Result<()> {
//! use glint_tools::overlay::{Overlay, YuvRange};
//! let image = Overlay::from_report(frame, pipeline, report, YuvRange::guess(&frame))
//!     .with_truth(truth)
//!     .render();
//! image.canvas.write_png(std::fs::File::create("overlay.png")?).map_err(std::io::Error::other)?;
//! # Ok(()) }
//! ```

mod canvas;
mod caption;
mod layout;
mod yuv;

pub use canvas::{Canvas, Marker, Rgb};
pub use layout::{Layout, Region};
pub use yuv::{pixel_rgb, YuvRange};

use glint::detect::bitimage::BitImage;
use glint::detect::Detection;
use glint::frame::Frame;
use glint::pipeline::Pipeline;
use glint::report::FrameReport;
use glint::track::Estimate;

use crate::scene::Truth;

/// Colours and sizes of everything drawn. Warm colours are glint's answers, green the truth;
/// within each, the shape says which quantity it is.
pub mod style {
    use super::{Marker, Rgb};

    /// Between and around the panels.
    pub const BACKGROUND: Rgb = [28, 28, 32];
    /// The caption's text.
    pub const TEXT: Rgb = [230, 230, 230];
    /// Mixed into saturated pixels.
    pub const MASK_TINT: Rgb = [255, 0, 200];
    /// How much of the tint goes in.
    pub const MASK_ALPHA: f32 = 0.45;
    /// Skeleton pixels.
    pub const SKELETON: Rgb = [255, 230, 0];
    /// The chosen blob's bounding box.
    pub const BLOB_BOX: Rgb = [80, 160, 255];
    /// The inset's outline on the full frame.
    pub const CROP_BOX: Rgb = [200, 200, 200];
    /// Pixel boundaries in a strongly magnified inset.
    pub const GRID: Rgb = [0, 0, 0];
    /// How dark the grid is.
    pub const GRID_ALPHA: f32 = 0.18;
    /// The grid is drawn from this zoom on.
    pub const GRID_MIN_ZOOM: usize = 6;

    /// A marker's shape, colour and size on the canvas.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub struct MarkStyle {
        pub marker: Marker,
        pub colour: Rgb,
        pub radius_px: i64,
    }

    /// The streak's two ends.
    pub const ENDS: MarkStyle = MarkStyle {
        marker: Marker::Dot,
        colour: [255, 140, 0],
        radius_px: 3,
    };
    /// The streak's tips: where the LED was at the start and the end of the exposure.
    pub const TIPS: MarkStyle = MarkStyle {
        marker: Marker::Circle,
        colour: [255, 200, 0],
        radius_px: 6,
    };
    /// The intensity-weighted centroid.
    pub const CENTROID: MarkStyle = MarkStyle {
        marker: Marker::Cross,
        colour: [0, 230, 230],
        radius_px: 6,
    };
    /// glint's streak middle (`mid_x`, `mid_y`).
    pub const MID: MarkStyle = MarkStyle {
        marker: Marker::Plus,
        colour: [255, 40, 40],
        radius_px: 8,
    };
    /// glint's position (`x`, `y`).
    pub const POSITION: MarkStyle = MarkStyle {
        marker: Marker::Circle,
        colour: [255, 40, 40],
        radius_px: 13,
    };
    /// The truth's streak middle.
    pub const TRUTH_MID: MarkStyle = MarkStyle {
        marker: Marker::Diamond,
        colour: [40, 255, 90],
        radius_px: 22,
    };
    /// The truth's position.
    pub const TRUTH_POSITION: MarkStyle = MarkStyle {
        marker: Marker::Square,
        colour: [40, 255, 90],
        radius_px: 17,
    };
}

/// Everything one overlay shows. Build it with [`Overlay::new`] or [`Overlay::from_report`],
/// add the truth, then [`Overlay::render`].
#[derive(Debug, Clone)]
pub struct Overlay<'a> {
    /// The frame to show.
    pub frame: Frame<'a>,
    /// Its index in the stream.
    pub frame_index: u64,
    /// How to turn its YUV into RGB.
    pub range: YuvRange,
    /// The saturation mask (must have the frame's size to be drawn).
    pub mask: Option<&'a BitImage>,
    /// The chosen blob's skeleton (frame-sized).
    pub skeleton: Option<&'a BitImage>,
    /// What detection found.
    pub detection: Option<Detection>,
    /// The tracker's answer: position (`x, y`) and streak middle.
    pub position: Option<Estimate>,
    /// Several candidates and no way yet to tell the LED among them.
    pub ambiguous: bool,
    /// The ground truth of this frame.
    pub truth: Option<&'a Truth>,
    /// A first caption line: the input's name, say.
    pub title: Option<String>,
}

/// A rendered overlay and where its parts are.
#[derive(Debug, Clone)]
pub struct OverlayImage {
    pub canvas: Canvas,
    pub layout: Layout,
}

impl<'a> Overlay<'a> {
    /// The bare frame, with nothing drawn on it yet.
    pub fn new(frame: Frame<'a>, frame_index: u64, range: YuvRange) -> Self {
        Overlay {
            frame,
            frame_index,
            range,
            mask: None,
            skeleton: None,
            detection: None,
            position: None,
            ambiguous: false,
            truth: None,
            title: None,
        }
    }

    /// The frame as `pipeline` just processed it into `report`. Call it before the pipeline
    /// sees another frame: the mask and skeleton are the detector's, of the last frame.
    pub fn from_report(
        frame: Frame<'a>,
        pipeline: &'a Pipeline,
        report: &FrameReport,
        range: YuvRange,
    ) -> Self {
        let detector = pipeline.detector();
        Overlay {
            mask: detector.map(|d| d.mask()),
            skeleton: detector
                .filter(|_| report.detection.best.is_some())
                .map(|d| d.skeleton()),
            detection: Some(report.detection),
            position: report.position,
            ambiguous: report.ambiguous,
            ..Overlay::new(frame, report.meta.index, range)
        }
    }

    /// Adds the ground truth.
    pub fn with_truth(mut self, truth: &'a Truth) -> Self {
        self.truth = Some(truth);
        self
    }

    /// Adds a title line.
    pub fn with_title(mut self, title: impl Into<String>) -> Self {
        self.title = Some(title.into());
        self
    }

    /// The truth's middle and position, where the truth has them.
    fn truth_points(&self) -> [Option<(f64, f64)>; 2] {
        let pair = |x: Option<f64>, y: Option<f64>| x.zip(y);
        match self.truth {
            Some(t) => [pair(t.mid_x_px, t.mid_y_px), pair(t.x_px, t.y_px)],
            None => [None, None],
        }
    }

    /// The region the inset must show, and the detection's own region to fall back on.
    fn regions(&self) -> (Option<Region>, Option<Region>) {
        let detected = self.detection.and_then(|d| d.best).map(|(blob, _)| {
            let b = blob.bbox;
            Region {
                x_min_px: b.x_min_px as f64 - 0.5,
                y_min_px: b.y_min_px as f64 - 0.5,
                x_max_px: b.x_max_px as f64 + 0.5,
                y_max_px: b.y_max_px as f64 + 0.5,
            }
        });
        let all = self
            .truth_points()
            .into_iter()
            .flatten()
            .map(|(x, y)| Region::point(x, y))
            .chain(detected)
            .reduce(Region::union);
        (all, detected)
    }

    /// Draws the overlay.
    pub fn render(&self) -> OverlayImage {
        let size = self.frame.size();
        let (roi, fallback) = self.regions();
        let layout = Layout::new(size.width(), size.height(), roi, fallback);
        let caption = caption::Caption::new(self, &layout);
        let height_px = layout.caption_top_px + caption.height_px(layout.canvas_width_px);
        let mut canvas = Canvas::new(layout.canvas_width_px, height_px, style::BACKGROUND);

        self.draw_full_frame(&mut canvas, &layout);
        self.draw_inset(&mut canvas, &layout);
        self.draw_markers(&mut canvas, &layout);
        caption.draw(&mut canvas, &layout);
        OverlayImage { canvas, layout }
    }

    /// A bit image is drawn only if it has the frame's size.
    fn fits(&self, image: Option<&'a BitImage>) -> Option<&'a BitImage> {
        let size = self.frame.size();
        image.filter(|i| i.width() == size.width() && i.height() == size.height())
    }

    /// The colour of frame pixel `(x, y)` with the mask and skeleton drawn over it.
    fn pixel(&self, x: usize, y: usize) -> Rgb {
        let rgb = pixel_rgb(&self.frame, self.range, x, y).unwrap_or(style::BACKGROUND);
        if self.fits(self.mask).is_some_and(|m| m.get(x, y)) {
            canvas::mix(rgb, style::MASK_TINT, style::MASK_ALPHA)
        } else {
            rgb
        }
    }

    fn draw_full_frame(&self, canvas: &mut Canvas, layout: &Layout) {
        let skeleton = self.fits(self.skeleton);
        for y in 0..layout.frame_height_px {
            for x in 0..layout.frame_width_px {
                let colour = if skeleton.is_some_and(|s| s.get(x, y)) {
                    style::SKELETON
                } else {
                    self.pixel(x, y)
                };
                canvas.set(x as i64, y as i64, colour);
            }
        }
        if let Some((blob, _)) = self.detection.and_then(|d| d.best) {
            // Two pixels outside the blob, so the box frames it without hiding it.
            let b = blob.bbox;
            canvas.rect_outline(
                b.x_min_px as i64 - 2,
                b.y_min_px as i64 - 2,
                b.x_max_px as i64 + 2,
                b.y_max_px as i64 + 2,
                style::BLOB_BOX,
            );
        }
        canvas.rect_outline(
            layout.crop_x0_px as i64 - 1,
            layout.crop_y0_px as i64 - 1,
            (layout.crop_x0_px + layout.crop_width_px) as i64,
            (layout.crop_y0_px + layout.crop_height_px) as i64,
            style::CROP_BOX,
        );
    }

    fn draw_inset(&self, canvas: &mut Canvas, layout: &Layout) {
        let zoom = layout.zoom as i64;
        let skeleton = self.fits(self.skeleton);
        // A skeleton pixel fills the middle half of its block, so the mask shows around it.
        let (core0, core1) = (zoom / 4, zoom - zoom / 4);
        for cy in 0..layout.crop_height_px {
            for cx in 0..layout.crop_width_px {
                let (x, y) = (layout.crop_x0_px + cx, layout.crop_y0_px + cy);
                let left = layout.inset_left_px as i64 + cx as i64 * zoom;
                let top = layout.inset_top_px as i64 + cy as i64 * zoom;
                canvas.fill_rect(left, top, left + zoom, top + zoom, self.pixel(x, y));
                if skeleton.is_some_and(|s| s.get(x, y)) {
                    let (l, t) = (left + core0, top + core0);
                    canvas.fill_rect(l, t, left + core1, top + core1, style::SKELETON);
                }
                if layout.zoom >= style::GRID_MIN_ZOOM {
                    // The block's top row and left column, each pixel once.
                    for i in 0..zoom {
                        canvas.blend(left + i, top, style::GRID, style::GRID_ALPHA);
                    }
                    for i in 1..zoom {
                        canvas.blend(left, top + i, style::GRID, style::GRID_ALPHA);
                    }
                }
            }
        }
    }

    fn draw_markers(&self, canvas: &mut Canvas, layout: &Layout) {
        let mark = |canvas: &mut Canvas, s: style::MarkStyle, (x, y): (f64, f64)| {
            let (ix, iy) = layout.inset_point(x, y);
            canvas.marker(s.marker, ix, iy, s.radius_px, s.colour);
        };
        if let Some((blob, streak)) = self.detection.and_then(|d| d.best) {
            let b = blob.bbox;
            let (x0, y0) = layout.inset_point(b.x_min_px as f64 - 0.5, b.y_min_px as f64 - 0.5);
            let (x1, y1) = layout.inset_point(b.x_max_px as f64 + 0.5, b.y_max_px as f64 + 0.5);
            // Just outside the blob's outer pixels.
            canvas.rect_outline(x0 - 1, y0 - 1, x1, y1, style::BLOB_BOX);
            for end in streak.ends_px {
                mark(canvas, style::ENDS, f64_pair(end));
            }
            for tip in streak.path.map(|p| p.ends_px).into_iter().flatten() {
                mark(canvas, style::TIPS, f64_pair(tip));
            }
            mark(canvas, style::CENTROID, f64_pair(streak.centroid_px));
        }
        let [truth_mid, truth_position] = self.truth_points();
        // Truth under glint's answers: where they agree, glint's marker is seen inside.
        if let Some(p) = truth_position {
            mark(canvas, style::TRUTH_POSITION, p);
        }
        if let Some(p) = truth_mid {
            mark(canvas, style::TRUTH_MID, p);
        }
        if let Some(p) = self.position {
            mark(canvas, style::POSITION, f64_pair(p.position_px));
            mark(canvas, style::MID, f64_pair(p.mid_px));
        }
    }
}

fn f64_pair((x, y): (f32, f32)) -> (f64, f64) {
    (f64::from(x), f64::from(y))
}

#[cfg(test)]
mod tests;
