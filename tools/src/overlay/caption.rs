//! The caption under the overlay: the numbers behind the markers, and a legend that draws
//! each marker beside its name.

use std::fmt::Write as _;

use super::canvas::{mix, Canvas, GLYPH_PX};
use super::layout::{Layout, GAP_PX};
use super::style::{self, MarkStyle};
use super::{Overlay, YuvRange};
use crate::scene::Visibility;

/// Canvases at least this wide get text at twice the font's size.
const LARGE_TEXT_MIN_WIDTH_PX: usize = 900;
/// Extra space between text lines.
const LINE_SPACING_PX: usize = 4;
/// Width of a legend item's swatch, and the space after each item.
const SWATCH_PX: usize = 30;
const ITEM_SPACING_PX: usize = 20;

/// What a legend item's swatch shows.
#[derive(Debug, Clone, Copy)]
enum Swatch {
    Mask,
    Skeleton,
    BlobBox,
    Mark(MarkStyle),
}

const LEGEND: [(Swatch, &str); 10] = [
    (Swatch::Mask, "mask"),
    (Swatch::Skeleton, "skeleton"),
    (Swatch::BlobBox, "blob box"),
    (Swatch::Mark(style::ENDS), "ends"),
    (Swatch::Mark(style::TIPS), "tips"),
    (Swatch::Mark(style::CENTROID), "centroid"),
    (Swatch::Mark(style::MID), "mid"),
    (Swatch::Mark(style::POSITION), "x,y"),
    (Swatch::Mark(style::TRUTH_MID), "truth mid"),
    (Swatch::Mark(style::TRUTH_POSITION), "truth x,y"),
];

/// The caption's text, ready to be measured and drawn.
pub struct Caption {
    lines: Vec<String>,
}

impl Caption {
    /// The caption of `overlay` laid out by `layout`.
    pub fn new(overlay: &Overlay<'_>, layout: &Layout) -> Self {
        let mut lines = Vec::new();
        let size = overlay.frame.size();
        let range = match overlay.range {
            YuvRange::Full => "full",
            YuvRange::Studio => "studio",
        };
        let mut first = overlay.title.clone().map(|t| t + "  ").unwrap_or_default();
        let _ = write!(
            first,
            "frame {}  {}x{} {range} range",
            overlay.frame_index,
            size.width(),
            size.height()
        );
        lines.push(first);
        lines.extend(detection_lines(overlay));
        lines.extend(truth_lines(overlay));
        lines.push(format!(
            "inset {}x: x {}..{}, y {}..{}",
            layout.zoom,
            layout.crop_x0_px,
            layout.crop_x0_px + layout.crop_width_px - 1,
            layout.crop_y0_px,
            layout.crop_y0_px + layout.crop_height_px - 1
        ));
        Caption { lines }
    }

    /// The caption's text lines (before wrapping).
    #[cfg(test)]
    pub fn lines(&self) -> &[String] {
        &self.lines
    }

    /// Height of the caption drawn `width_px` wide.
    pub fn height_px(&self, width_px: usize) -> usize {
        let line_px = line_height_px(width_px);
        let text_lines: usize = self
            .lines
            .iter()
            .map(|l| wrap(l, chars_per_line(width_px)).len())
            .sum();
        (text_lines + legend_rows(width_px).len()) * line_px + GAP_PX
    }

    /// Draws the caption below the panels.
    pub fn draw(&self, canvas: &mut Canvas, layout: &Layout) {
        let width_px = canvas.width();
        let (scale, line_px) = (text_scale(width_px), line_height_px(width_px));
        let mut y = layout.caption_top_px as i64;
        for line in &self.lines {
            for part in wrap(line, chars_per_line(width_px)) {
                canvas.text(GAP_PX as i64, y, &part, scale, style::TEXT);
                y += line_px as i64;
            }
        }
        for row in legend_rows(width_px) {
            let mut x = GAP_PX as i64;
            for (swatch, label) in row {
                draw_swatch(canvas, swatch, x, y, line_px as i64);
                x = canvas.text(x + SWATCH_PX as i64, y, label, scale, style::TEXT);
                x += ITEM_SPACING_PX as i64;
            }
            y += line_px as i64;
        }
    }
}

/// What detection found, in one or two lines.
fn detection_lines(overlay: &Overlay<'_>) -> Vec<String> {
    let Some(d) = overlay.detection else {
        return vec![];
    };
    let mut lines = vec![match d.levels.threshold_luma {
        Some(t) => format!(
            "threshold {t} (top luma {}): {} px saturated, blobs: {}",
            d.levels.top_luma, d.mask_px, d.blob_count
        ),
        None => format!(
            "nothing saturated (top luma {} is below clip)",
            d.levels.top_luma
        ),
    }];
    if d.blinded {
        lines.push("blinded: too much of the frame is saturated".into());
    }
    if d.overflow.any() {
        lines.push(format!("blob tables overflowed: {}", d.overflow));
    }
    match (overlay.position, d.best) {
        (Some(p), Some((_, streak))) => {
            lines.push(format!(
                "glint  mid {:.2} {:.2}   x,y {:.2} {:.2} ({})",
                p.mid_px.0,
                p.mid_px.1,
                p.position_px.0,
                p.position_px.1,
                p.position_method.name()
            ));
            if let Some(((vx, vy), method)) = p.velocity_px_s {
                lines.push(velocity_line(vx, vy, method.name()));
            }
            lines.push(format!(
                "       centroid {:.2} {:.2}   streak {} px, {:.1} px thick",
                streak.centroid_px.0,
                streak.centroid_px.1,
                streak.skeleton_length_px,
                streak.thickness_px
            ));
        }
        _ if overlay.ambiguous => {
            lines.push("glint  not found: several candidates, none known to be the LED".into())
        }
        _ => lines.push("glint  not found".into()),
    }
    lines
}

/// The truth and glint's errors against it.
/// The velocity as labelled components and the speed, so that the two components never read as
/// one number (`v 185 706 px/s` looked like 185,706).
fn velocity_line(vx_px_s: f32, vy_px_s: f32, method: &str) -> String {
    format!(
        "       vx {vx_px_s:.0} px/s, vy {vy_px_s:.0} px/s, speed {:.0} px/s ({method})",
        vx_px_s.hypot(vy_px_s)
    )
}

fn truth_lines(overlay: &Overlay<'_>) -> Vec<String> {
    let Some(truth) = overlay.truth else {
        return vec![];
    };
    let [mid, position] = overlay.truth_points();
    let mut lines = vec![];
    match (mid, position) {
        (Some((mx, my)), Some((x, y))) => {
            let partial = if truth.visible == Visibility::Partial {
                "   (partly hidden)"
            } else {
                ""
            };
            lines.push(format!(
                "truth  mid {mx:.2} {my:.2}   x,y {x:.2} {y:.2}{partial}"
            ))
        }
        _ => lines.push("truth  hidden".into()),
    }
    if let (Some(p), Some(m), Some(t)) = (overlay.position, mid, position) {
        let err = |(ax, ay): (f32, f32), (bx, by): (f64, f64)| {
            (f64::from(ax) - bx).hypot(f64::from(ay) - by)
        };
        lines.push(format!(
            "error  mid {:.3} px   x,y {:.3} px",
            err(p.mid_px, m),
            err(p.position_px, t)
        ));
    }
    lines
}

fn text_scale(width_px: usize) -> usize {
    if width_px >= LARGE_TEXT_MIN_WIDTH_PX {
        2
    } else {
        1
    }
}

fn line_height_px(width_px: usize) -> usize {
    GLYPH_PX * text_scale(width_px) + LINE_SPACING_PX
}

fn chars_per_line(width_px: usize) -> usize {
    (width_px.saturating_sub(2 * GAP_PX) / (GLYPH_PX * text_scale(width_px))).max(1)
}

/// Breaks `line` at spaces into pieces of at most `max_chars` (longer words are cut). Every
/// piece keeps the line's indentation.
fn wrap(line: &str, max_chars: usize) -> Vec<String> {
    let body = line.trim_start_matches(' ');
    let indent = &line[..line.len() - body.len()];
    let width = max_chars.saturating_sub(indent.len()).max(1);
    let mut pieces = vec![];
    let mut current = String::new();
    for word in body.split(' ') {
        let needed = current.chars().count() + usize::from(!current.is_empty()) + word.len();
        if needed > width && !current.trim().is_empty() {
            pieces.push(std::mem::take(&mut current));
        } else if !current.is_empty() {
            current.push(' ');
        }
        current.push_str(word);
        while current.chars().count() > width {
            let cut: String = current.chars().take(width).collect();
            current = current.chars().skip(width).collect();
            pieces.push(cut);
        }
    }
    if !current.is_empty() || pieces.is_empty() {
        pieces.push(current);
    }
    pieces.into_iter().map(|p| format!("{indent}{p}")).collect()
}

/// The legend's items, flowed into rows that fit `width_px`.
fn legend_rows(width_px: usize) -> Vec<Vec<(Swatch, &'static str)>> {
    let char_px = GLYPH_PX * text_scale(width_px);
    let mut rows: Vec<Vec<(Swatch, &'static str)>> = vec![];
    let mut x = GAP_PX;
    for item in LEGEND {
        let item_px = SWATCH_PX + item.1.len() * char_px + ITEM_SPACING_PX;
        match rows.last_mut() {
            Some(row) if x + item_px <= width_px => row.push(item),
            _ => {
                rows.push(vec![item]);
                x = GAP_PX;
            }
        }
        x += item_px;
    }
    rows
}

/// One swatch in a box `line_px` high whose top-left is `(x, y)`.
fn draw_swatch(canvas: &mut Canvas, swatch: Swatch, x: i64, y: i64, line_px: i64) {
    let (cx, cy) = (x + (SWATCH_PX as i64 - 8) / 2, y + (line_px - 4) / 2);
    let half = (line_px / 2 - 2).max(2);
    match swatch {
        Swatch::Mask => {
            let tinted = mix([255, 255, 255], style::MASK_TINT, style::MASK_ALPHA);
            canvas.fill_rect(cx - half, cy - half, cx + half, cy + half, tinted);
        }
        Swatch::Skeleton => canvas.fill_rect(
            cx - half / 2,
            cy - half,
            cx + half / 2,
            cy + half,
            style::SKELETON,
        ),
        Swatch::BlobBox => {
            canvas.rect_outline(cx - half, cy - half, cx + half, cy + half, style::BLOB_BOX)
        }
        Swatch::Mark(s) => {
            // Legend markers are drawn a little smaller so they fit one line.
            canvas.marker(s.marker, cx, cy, s.radius_px.min(half), s.colour)
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn velocity_components_are_labelled_and_separated() {
        let line = super::velocity_line(185.2, -706.4, "streak");
        assert!(line.contains("vx 185 px/s, vy -706 px/s"), "{line}");
        assert!(line.contains("speed 730 px/s (streak)"), "{line}");
    }

    use super::*;

    #[test]
    fn wrapping_breaks_at_spaces_and_cuts_long_words() {
        assert_eq!(wrap("ab cd ef", 5), ["ab cd", "ef"]);
        assert_eq!(wrap("abcdefgh", 3), ["abc", "def", "gh"]);
        assert_eq!(wrap("", 3), [""]);
        assert_eq!(wrap("short", 80), ["short"]);
        assert_eq!(wrap("  ab cd", 5), ["  ab", "  cd"]);
    }

    #[test]
    fn the_legend_flows_into_more_rows_when_narrow() {
        let wide: usize = legend_rows(4000).len();
        let narrow: usize = legend_rows(300).len();
        assert_eq!(wide, 1);
        assert!(narrow > 2);
        let items: usize = legend_rows(300).iter().map(Vec::len).sum();
        assert_eq!(items, LEGEND.len());
    }
}
