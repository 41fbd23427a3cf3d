//! Drawing a track: the trajectory (equal scale on both axes) above, speed over time below.

use super::axes::{Range, Scale};
use super::track::{Track, Units};
use crate::overlay::{Canvas, Marker, Rgb};

/// Colours of the plot.
pub mod style {
    use crate::overlay::Rgb;

    pub const BACKGROUND: Rgb = [255, 255, 255];
    pub const AXES: Rgb = [40, 40, 40];
    pub const GRID: Rgb = [225, 225, 225];
    pub const TEXT: Rgb = [20, 20, 20];
    /// The trajectory line.
    pub const TRAJECTORY: Rgb = [20, 90, 200];
    /// The speed curve.
    pub const SPEED: Rgb = [200, 60, 20];
    /// The first and the last position of the track.
    pub const START: Rgb = [0, 150, 60];
    pub const END: Rgb = [210, 0, 0];
}

/// Smallest and largest image the plot is drawn at, per side.
pub const MIN_SIDE_PX: usize = 240;
pub const MAX_SIDE_PX: usize = 8192;

/// Height of a line of text (the 8×8 font) plus spacing.
const LINE_PX: i64 = 12;
/// Room left of a panel for the y tick labels and the axis name.
const LEFT_MARGIN_PX: i64 = 84;
/// Room right of a panel.
const RIGHT_MARGIN_PX: i64 = 16;
/// Room under a panel for the x tick labels and the axis name.
const BOTTOM_MARGIN_PX: i64 = 2 * LINE_PX + 8;
/// Space between the title and the panels, and between the panels.
const GAP_PX: i64 = 16;
/// Share of the panels' height given to the trajectory.
const TRAJECTORY_SHARE: f64 = 0.62;
/// Radius of the start and end markers.
const END_MARKER_RADIUS_PX: i64 = 5;
/// Length of a tick mark.
const TICK_PX: i64 = 4;

/// A plot area on the canvas, in pixels (inclusive edges).
#[derive(Debug, Clone, Copy)]
struct Area {
    left: i64,
    top: i64,
    right: i64,
    bottom: i64,
}

impl Area {
    fn width(&self) -> f64 {
        (self.right - self.left) as f64
    }
    fn height(&self) -> f64 {
        (self.bottom - self.top) as f64
    }
}

/// Draws `track` on a `width_px × height_px` canvas (sides clamped to
/// [`MIN_SIDE_PX`]..=[`MAX_SIDE_PX`]) under `title`.
pub fn render(track: &Track, width_px: usize, height_px: usize, title: &str) -> Canvas {
    let width_px = width_px.clamp(MIN_SIDE_PX, MAX_SIDE_PX);
    let height_px = height_px.clamp(MIN_SIDE_PX, MAX_SIDE_PX);
    let mut canvas = Canvas::new(width_px, height_px, style::BACKGROUND);
    canvas.text(8, 8, title, 1, style::TEXT);

    let panels_top = 8 + 2 * LINE_PX;
    let panels_height = height_px as i64 - panels_top - 2 * (BOTTOM_MARGIN_PX + GAP_PX);
    let trajectory_height = (panels_height as f64 * TRAJECTORY_SHARE) as i64;
    let trajectory = Area {
        left: LEFT_MARGIN_PX,
        top: panels_top,
        right: width_px as i64 - RIGHT_MARGIN_PX,
        bottom: panels_top + trajectory_height,
    };
    let speed_top = trajectory.bottom + BOTTOM_MARGIN_PX + GAP_PX;
    let speed = Area {
        top: speed_top,
        bottom: height_px as i64 - BOTTOM_MARGIN_PX - GAP_PX,
        ..trajectory
    };
    draw_trajectory(&mut canvas, track, trajectory);
    draw_speed(&mut canvas, track, speed);
    canvas
}

fn draw_trajectory(canvas: &mut Canvas, track: &Track, area: Area) {
    let points = || track.samples.iter().filter_map(|s| s.position);
    let (Some(xs), Some(ys)) = (
        Range::of(points().map(|p| p.0)),
        Range::of(points().map(|p| p.1)),
    ) else {
        return;
    };
    // One scale for both axes, so a circle stays round: each range is widened until both
    // have the panel's aspect ratio.
    let units_per_px = (xs.span() / area.width()).max(ys.span() / area.height());
    let xs = xs.widened_to(units_per_px * area.width()).rounded_out();
    let ys = ys.widened_to(units_per_px * area.height()).rounded_out();
    let units_per_px = (xs.span() / area.width()).max(ys.span() / area.height());
    let xs = xs.widened_to(units_per_px * area.width());
    let ys = ys.widened_to(units_per_px * area.height());
    let x = Scale {
        range: xs,
        start_px: area.left as f64,
        end_px: area.right as f64,
        flip: false,
    };
    // Image rows grow downwards like the canvas; a floor map has y upwards.
    let y = Scale {
        range: ys,
        start_px: area.top as f64,
        end_px: area.bottom as f64,
        flip: track.units == Units::Floor,
    };
    let unit = track.length_name();
    draw_axes(
        canvas,
        area,
        &x,
        &y,
        &format!("x ({unit})"),
        &format!("y ({unit})"),
    );
    for run in track.runs() {
        polyline(canvas, &run, &x, &y, style::TRAJECTORY);
    }
    let mut all = points();
    if let Some(first) = all.next() {
        let last = all.next_back().unwrap_or(first);
        let r = END_MARKER_RADIUS_PX;
        canvas.marker(
            Marker::Square,
            x.px(first.0),
            y.px(first.1),
            r,
            style::START,
        );
        canvas.marker(Marker::Cross, x.px(last.0), y.px(last.1), r, style::END);
    }
}

fn draw_speed(canvas: &mut Canvas, track: &Track, area: Area) {
    let runs = track.speed_runs();
    let times = Range::of(track.samples.iter().map(|s| s.t_s));
    let speeds = Range::of(runs.iter().flatten().map(|p| p.1).chain([0.0]));
    let (Some(ts), Some(vs)) = (times, speeds) else {
        return;
    };
    let x = Scale {
        range: ts,
        start_px: area.left as f64,
        end_px: area.right as f64,
        flip: false,
    };
    let y = Scale {
        range: Range { min: 0.0, ..vs }.rounded_out(),
        start_px: area.top as f64,
        end_px: area.bottom as f64,
        flip: true,
    };
    let unit = track.length_name();
    draw_axes(canvas, area, &x, &y, "t (s)", &format!("speed ({unit}/s)"));
    for run in &runs {
        polyline(canvas, run, &x, &y, style::SPEED);
    }
    if runs.is_empty() {
        let note = "no speed: no two consecutive frames with a position";
        canvas.text(area.left + 8, area.top + 8, note, 1, style::TEXT);
    }
}

/// Frame, grid, tick labels and axis names of one panel.
fn draw_axes(canvas: &mut Canvas, area: Area, x: &Scale, y: &Scale, x_name: &str, y_name: &str) {
    for t in x.range.ticks() {
        let px = x.px(t);
        canvas.line(px, area.top, px, area.bottom, style::GRID);
        canvas.line(px, area.bottom, px, area.bottom + TICK_PX, style::AXES);
        let label = format!("{t:.*}", x.range.tick_decimals());
        let half_width = (label.len() as i64 * 8) / 2;
        canvas.text(px - half_width, area.bottom + 6, &label, 1, style::TEXT);
    }
    for t in y.range.ticks() {
        let py = y.px(t);
        canvas.line(area.left, py, area.right, py, style::GRID);
        canvas.line(area.left - TICK_PX, py, area.left, py, style::AXES);
        let label = format!("{t:.*}", y.range.tick_decimals());
        let width = label.len() as i64 * 8;
        canvas.text(
            area.left - TICK_PX - 2 - width,
            py - 3,
            &label,
            1,
            style::TEXT,
        );
    }
    canvas.rect_outline(area.left, area.top, area.right, area.bottom, style::AXES);
    let name_width = x_name.len() as i64 * 8;
    let name_x = (area.left + area.right) / 2 - name_width / 2;
    canvas.text(name_x, area.bottom + 6 + LINE_PX, x_name, 1, style::TEXT);
    canvas.text(8, area.top - LINE_PX, y_name, 1, style::TEXT);
}

fn polyline(canvas: &mut Canvas, points: &[(f64, f64)], x: &Scale, y: &Scale, colour: Rgb) {
    match points {
        [single] => canvas.disk(x.px(single.0), y.px(single.1), 1, colour),
        _ => {
            for pair in points.windows(2) {
                if let [a, b] = pair {
                    canvas.line(x.px(a.0), y.px(a.1), x.px(b.0), y.px(b.1), colour);
                }
            }
        }
    }
}
