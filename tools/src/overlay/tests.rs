//! Overlays of small hand-made frames: markers land where the layout's pixel convention says,
//! and the detector's mask and skeleton show on the full frame.

use glint::detect::bitimage::BitImage;
use glint::frame::{Frame, FrameSize};
use glint::pipeline::{Pipeline, PipelineConfig};
use glint::source::FrameMeta;

use super::canvas::mix;
use super::caption::Caption;
use super::*;
use crate::scene::{Truth, Visibility};

const WIDTH_PX: usize = 64;
const HEIGHT_PX: usize = 48;
const FLOOR_LUMA: u8 = 100;
const FLOOR_RGB: Rgb = [100, 100, 100];

/// A full-range grey frame with a saturated disk of `radius` px around `centre`, if any.
fn frame_bytes(disk: Option<((f64, f64), f64)>) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(WIDTH_PX * HEIGHT_PX * 2);
    for y in 0..HEIGHT_PX {
        for x in 0..WIDTH_PX {
            let lit = disk.is_some_and(|((cx, cy), r)| (x as f64 - cx).hypot(y as f64 - cy) <= r);
            bytes.push(if lit { 255 } else { FLOOR_LUMA });
            bytes.push(128);
        }
    }
    bytes
}

fn frame(bytes: &[u8]) -> Frame<'_> {
    let size = FrameSize::new(WIDTH_PX as u32, HEIGHT_PX as u32).unwrap();
    Frame::new_checked(bytes, size, WIDTH_PX * 2).unwrap()
}

fn truth(mid: (f64, f64), position: (f64, f64)) -> Truth {
    Truth {
        frame: 0,
        t_s: 0.0,
        visible: Visibility::Visible,
        x_px: Some(position.0),
        y_px: Some(position.1),
        mid_x_px: Some(mid.0),
        mid_y_px: Some(mid.1),
        vx_px_s: Some(0.0),
        vy_px_s: Some(0.0),
        streak_px: Some(0.0),
        path_mid_x_px: Some(mid.0),
        path_mid_y_px: Some(mid.1),
    }
}

/// The canvas pixel that shows frame point `(x, y)` in the inset, computed from the layout's
/// crop and zoom alone: pixel `i` covers `[i - ½, i + ½)` and is drawn `zoom` times larger.
fn inset_pixel(layout: &Layout, (x, y): (f64, f64)) -> (i64, i64) {
    let zoom = layout.zoom as f64;
    let px = layout.inset_left_px as f64 + ((x + 0.5 - layout.crop_x0_px as f64) * zoom).floor();
    let py = layout.inset_top_px as f64 + ((y + 0.5 - layout.crop_y0_px as f64) * zoom).floor();
    (px as i64, py as i64)
}

fn inset_pixels(image: &OverlayImage) -> impl Iterator<Item = Rgb> + '_ {
    let l = image.layout;
    let (x0, y0) = (l.inset_left_px as i64, l.inset_top_px as i64);
    let (w, h) = (
        (l.crop_width_px * l.zoom) as i64,
        (l.crop_height_px * l.zoom) as i64,
    );
    (y0..y0 + h).flat_map(move |y| (x0..x0 + w).filter_map(move |x| image.canvas.get(x, y)))
}

#[test]
fn the_truth_markers_sit_on_their_sub_pixel_positions_in_the_inset() {
    let bytes = frame_bytes(None);
    let mid = (20.3, 15.7);
    let position = (26.0, 18.25);
    let t = truth(mid, position);
    let image = Overlay::new(frame(&bytes), 0, YuvRange::Full)
        .with_truth(&t)
        .render();
    let layout = image.layout;
    assert!(layout.zoom >= 4, "{layout:?}");

    let truth_colour = style::TRUTH_MID.colour;
    let (mx, my) = inset_pixel(&layout, mid);
    assert_eq!(
        image.canvas.get(mx, my),
        Some(truth_colour),
        "diamond centre"
    );
    let r = style::TRUTH_MID.radius_px;
    for (vx, vy) in [(mx - r, my), (mx + r, my), (mx, my - r), (mx, my + r)] {
        assert_eq!(
            image.canvas.get(vx, vy),
            Some(truth_colour),
            "diamond corner"
        );
    }
    // Inside the diamond, between centre and corner, the floor shows.
    assert_ne!(image.canvas.get(mx + r / 2, my), Some(truth_colour));

    let (px, py) = inset_pixel(&layout, position);
    let r = style::TRUTH_POSITION.radius_px;
    assert_eq!(
        image.canvas.get(px, py),
        Some(truth_colour),
        "square centre"
    );
    assert_eq!(
        image.canvas.get(px - r, py - r),
        Some(truth_colour),
        "square corner"
    );
    assert_eq!(
        image.canvas.get(px + r, py),
        Some(truth_colour),
        "square side"
    );

    // No detection was given: none of glint's colours appear.
    let glint_colours = [
        style::MID.colour,
        style::CENTROID.colour,
        style::ENDS.colour,
    ];
    assert!(inset_pixels(&image).all(|p| !glint_colours.contains(&p)));
}

#[test]
fn half_a_pixel_of_truth_moves_the_marker_half_a_block() {
    let bytes = frame_bytes(None);
    // Only the middle is known; both values keep the same crop (its origin is the floor of
    // the middle + ½ - 10 px: 10.4 and 10.9).
    let mid_only = |x: f64| Truth {
        x_px: None,
        y_px: None,
        ..truth((x, 15.0), (0.0, 0.0))
    };
    let (a, b) = (mid_only(19.9), mid_only(20.4));
    let render = |t| {
        Overlay::new(frame(&bytes), 0, YuvRange::Full)
            .with_truth(t)
            .render()
    };
    let (ia, ib) = (render(&a), render(&b));
    assert_eq!(ia.layout, ib.layout);
    // The marker is symmetric, so the mean of its pixels is its centre.
    let centre_x = |image: &OverlayImage| {
        let l = image.layout;
        let (x0, w) = (l.inset_left_px as i64, (l.crop_width_px * l.zoom) as i64);
        let (y0, h) = (l.inset_top_px as i64, (l.crop_height_px * l.zoom) as i64);
        let xs: Vec<f64> = (y0..y0 + h)
            .flat_map(|y| (x0..x0 + w).map(move |x| (x, y)))
            .filter(|&(x, y)| image.canvas.get(x, y) == Some(style::TRUTH_MID.colour))
            .map(|(x, _)| x as f64)
            .collect();
        assert!(xs.len() > 20, "the marker is drawn");
        xs.iter().sum::<f64>() / xs.len() as f64
    };
    let (ca, cb) = (centre_x(&ia), centre_x(&ib));
    assert_eq!(ca, inset_pixel(&ia.layout, (19.9, 15.0)).0 as f64);
    assert_eq!(cb - ca, (ia.layout.zoom / 2) as f64);
}

/// A frame interval at 30 fps.
const FRAME_US: u64 = 33_333;

/// A pipeline that has seen the disk 8 px to the left of (30, 20) in the frame before: a light
/// that has stood still since it appeared is never taken as the LED, so the disk must move
/// before the frame under test finds it.
fn moved_into_view(size: FrameSize) -> Pipeline {
    let mut pipeline = Pipeline::new(size, PipelineConfig::default()).unwrap();
    let before = frame_bytes(Some(((22.0, 20.0), 3.2)));
    let meta = FrameMeta {
        index: 0,
        sequence: 0,
        dropped: 0,
        timestamp_us: 0,
        monotonic_us: 0,
    };
    pipeline.process(&frame(&before), meta);
    pipeline
}

#[test]
fn the_detector_s_mask_skeleton_and_answers_are_drawn() {
    let centre = (30.0, 20.0);
    let bytes = frame_bytes(Some((centre, 3.2)));
    let size = FrameSize::new(WIDTH_PX as u32, HEIGHT_PX as u32).unwrap();
    let mut pipeline = moved_into_view(size);
    let meta = FrameMeta {
        index: 7,
        sequence: 7,
        dropped: 0,
        timestamp_us: FRAME_US,
        monotonic_us: FRAME_US,
    };
    let report = pipeline.process(&frame(&bytes), meta);
    let position = report.position.expect("the disk is found");
    let image = Overlay::from_report(frame(&bytes), &pipeline, &report, YuvRange::Full).render();
    let canvas = &image.canvas;

    // Full frame at 1×: a saturated pixel is tinted, the floor is plain grey.
    let tinted = mix([255, 255, 255], style::MASK_TINT, style::MASK_ALPHA);
    assert_eq!(canvas.get(28, 20), Some(tinted));
    assert_eq!(canvas.get(5, 5), Some(FLOOR_RGB));
    // The skeleton of a disk lies inside it.
    let skeleton: Vec<(i64, i64)> = (0..HEIGHT_PX as i64)
        .flat_map(|y| (0..WIDTH_PX as i64).map(move |x| (x, y)))
        .filter(|&(x, y)| canvas.get(x, y) == Some(style::SKELETON))
        .collect();
    assert!(!skeleton.is_empty());
    assert!(skeleton
        .iter()
        .all(|&(x, y)| (x as f64 - 30.0).hypot(y as f64 - 20.0) <= 3.2));
    // The blob box frames the disk two pixels out: x 27..=33 → columns 25 and 35.
    assert_eq!(canvas.get(25, 20), Some(style::BLOB_BOX));
    assert_eq!(canvas.get(35, 20), Some(style::BLOB_BOX));

    // Inset: glint's middle is drawn where it says.
    let mid = (f64::from(position.mid_px.0), f64::from(position.mid_px.1));
    assert!((mid.0 - centre.0).abs() < 0.1 && (mid.1 - centre.1).abs() < 0.1);
    let (mx, my) = inset_pixel(&image.layout, mid);
    assert_eq!(canvas.get(mx, my), Some(style::MID.colour));
    assert_eq!(
        canvas.get(mx + style::MID.radius_px, my),
        Some(style::MID.colour)
    );
}

#[test]
fn caption_reports_the_errors_against_the_truth() {
    let bytes = frame_bytes(Some(((30.0, 20.0), 3.2)));
    let size = FrameSize::new(WIDTH_PX as u32, HEIGHT_PX as u32).unwrap();
    let mut pipeline = moved_into_view(size);
    let meta = FrameMeta {
        index: 1,
        sequence: 1,
        dropped: 0,
        timestamp_us: FRAME_US,
        monotonic_us: FRAME_US,
    };
    let report = pipeline.process(&frame(&bytes), meta);
    // A truth 3 px to the right of the disk's centre.
    let t = truth((33.0, 20.0), (33.0, 24.0));
    let overlay =
        Overlay::from_report(frame(&bytes), &pipeline, &report, YuvRange::Full).with_truth(&t);
    let image = overlay.render();
    let caption = Caption::new(&overlay, &image.layout);
    let error_line = caption
        .lines()
        .iter()
        .find(|l| l.starts_with("error"))
        .expect("an error line");
    let numbers: Vec<f64> = error_line
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .collect();
    assert_eq!(numbers.len(), 2, "{error_line}");
    assert!((numbers[0] - 3.0).abs() < 0.1, "{error_line}");
    assert!((numbers[1] - 5.0).abs() < 0.1, "{error_line}");
}

#[test]
fn a_mask_of_another_size_is_ignored_and_a_hidden_truth_draws_nothing() {
    let bytes = frame_bytes(Some(((30.0, 20.0), 3.2)));
    let mut wrong = BitImage::with_dimensions(10, 10);
    wrong.set(3, 3);
    let hidden = Truth {
        visible: Visibility::Hidden,
        x_px: None,
        y_px: None,
        mid_x_px: None,
        mid_y_px: None,
        ..truth((0.0, 0.0), (0.0, 0.0))
    };
    let mut overlay = Overlay::new(frame(&bytes), 0, YuvRange::Full).with_truth(&hidden);
    overlay.mask = Some(&wrong);
    let image = overlay.render();
    assert_eq!(image.canvas.get(3, 3), Some(FLOOR_RGB));
    assert_eq!(image.canvas.get(30, 20), Some([255, 255, 255]));
    assert!(inset_pixels(&image).all(|p| p != style::TRUTH_MID.colour));
}
