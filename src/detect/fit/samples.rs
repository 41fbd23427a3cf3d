//! The pixels the streak fit reads around a rough streak: every pixel of both end caps and an
//! even subsample of the body, each with the floor learned under it where it was seen unlit.

use super::{Local, Rough, BODY_PX, CAP_PX, MAX_FIT_PX, MIN_CLIPPED_PX, PARAMS, REACH_PX};
use crate::detect::clip_spread::ClipSpread;
use crate::detect::floor_bg::FloorBackground;
use crate::detect::luma_histogram::LumaHistogram;
use crate::detect::moments::Moments;
use crate::frame::{Frame, FrameSize};

/// The pixels the fit uses: position, luma, and where known the floor's luma there as
/// `ln(floor / clip)` (the floor in the model's linear light is then `exp(that / k)`).
pub(super) struct Samples {
    pub(super) xy: [(f32, f32); MAX_FIT_PX],
    pub(super) luma: [f32; MAX_FIT_PX],
    pub(super) floor_ln: [Option<f32>; MAX_FIT_PX],
    pub(super) len: usize,
    /// The floor seen around the streak (luma), where no sample's own floor was learned:
    /// where the flat floor starts.
    pub(super) around_luma: Option<f32>,
    /// What the LED's frames before say of the tone exponent (see
    /// [`crate::detect::tone_memory`]), weighed as a pseudo-pixel: the exponent, and the weight
    /// in luma² a unit of it costs (the last fit's residual variance per pixel over the prior's
    /// variance).
    pub(super) tone_prior: Option<(f32, f32)>,
    /// The light laid along the path changes along it by this, relative to its mean
    /// ([`super::swept::Path::gradient`]): zero, or what the LED's change of speed since its
    /// last frame says ([`super::gradient_of`]). It is not fitted: left free, it traded against
    /// the ends of streaks at one speed.
    pub(super) gradient: f32,
}

impl Samples {
    /// No pixels yet, nothing known around them, no prior, the light laid evenly.
    pub(super) fn empty() -> Samples {
        Samples {
            xy: [(0.0, 0.0); MAX_FIT_PX],
            luma: [0.0; MAX_FIT_PX],
            floor_ln: [None; MAX_FIT_PX],
            len: 0,
            around_luma: None,
            tone_prior: None,
            gradient: 0.0,
        }
    }
}

/// Squared distance from `(x, y)` to the polyline `a → mid → b` (squared, so that the
/// collection's two passes over the streak's box take no square root per pixel).
pub(in crate::detect) fn distance2_to_rough(rough: &Rough, x: f32, y: f32) -> f32 {
    let [a, b] = rough.ends_px;
    segment_distance2(a, rough.mid_px, x, y).min(segment_distance2(rough.mid_px, b, x, y))
}

/// The columns of row `y` that can lie within `reach` of the rough polyline `a → mid → b`,
/// as a span `(left, right)` that holds them all (`None` when none can): a pixel within
/// `reach` of a segment lies within `reach` across of the segment's part within `reach` of
/// its row, so its column lies within `reach` of that part's columns.
pub(in crate::detect) fn row_span(rough: &Rough, y: f32, reach: f32) -> Option<(f32, f32)> {
    let [a, b] = rough.ends_px;
    let mut span: Option<(f32, f32)> = None;
    for (p, q) in [(a, rough.mid_px), (rough.mid_px, b)] {
        let dy = q.1 - p.1;
        let (t0, t1) = if dy.abs() < 1e-6 {
            if (p.1 - y).abs() > reach {
                continue;
            }
            (0.0, 1.0)
        } else {
            let (ta, tb) = ((y - reach - p.1) / dy, (y + reach - p.1) / dy);
            (ta.min(tb).max(0.0), ta.max(tb).min(1.0))
        };
        if t0 > t1 {
            continue;
        }
        let (xa, xb) = (p.0 + t0 * (q.0 - p.0), p.0 + t1 * (q.0 - p.0));
        let (left, right) = (xa.min(xb) - reach, xa.max(xb) + reach);
        span = Some(span.map_or((left, right), |(l, r)| (l.min(left), r.max(right))));
    }
    span
}

fn segment_distance2(a: (f32, f32), b: (f32, f32), x: f32, y: f32) -> f32 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let l2 = dx * dx + dy * dy;
    let t = if l2 > 0.0 {
        (((x - a.0) * dx + (y - a.1) * dy) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    distance2((a.0 + t * dx, a.1 + t * dy), (x, y))
}

fn distance2(a: (f32, f32), b: (f32, f32)) -> f32 {
    (a.0 - b.0) * (a.0 - b.0) + (a.1 - b.1) * (a.1 - b.1)
}

/// Whether the pixel at `(x, y)` is clipped inside the clipped region, not on its border
/// (its four neighbours are clipped too). A clipped pixel says only "at least the clip
/// level", and for a spot whose light falls off away from its path the border says that of
/// every pixel inside it: the inside carries nothing more. On a wide saturated streak (a
/// bloom whose glow clips) the inside was most of the pixels the caps and body were
/// subsampled from, and the unclipped flanks, which carry the spot's width, tone and the
/// path's ends, got few of the fitted pixels. A pixel the clip's spread put below its level
/// among four clipped neighbours is inside too (see [`ClipSpread::holds_hole`]).
fn clipped_inside(frame: &Frame<'_>, x: usize, y: usize, spread: &ClipSpread) -> bool {
    let clip = spread.level_luma;
    let clipped = |x: Option<usize>, y: Option<usize>| match (x, y) {
        (Some(x), Some(y)) => frame.luma(x, y).is_some_and(|l| f32::from(l) >= clip),
        _ => false,
    };
    frame
        .luma(x, y)
        .is_some_and(|l| f32::from(l) >= clip || spread.holds_hole(f32::from(l)))
        && clipped(x.checked_sub(1), Some(y))
        && clipped(x.checked_add(1), Some(y))
        && clipped(Some(x), y.checked_sub(1))
        && clipped(Some(x), y.checked_add(1))
}

/// The pixels around the rough streak: every pixel of both end caps, and an even subsample
/// of the body, [`MAX_FIT_PX`] at most, each placed in `local`'s ideal pixels. Clipped pixels
/// inside the clipped region are left out (see [`clipped_inside`]).
pub(super) fn collect(
    frame: &Frame<'_>,
    rough: &Rough,
    background: Option<&FloorBackground>,
    spread: &ClipSpread,
    local: &Local,
) -> Option<Samples> {
    let clip = spread.level_luma;
    let half = 0.5 * rough.thickness_px;
    let cap = half + CAP_PX;
    let [a, b] = rough.ends_px;
    let within = Reach::of(rough, frame.size());
    let near = |x: usize, y: usize| within.holds(x, y) && !clipped_inside(frame, x, y, spread);
    let in_cap =
        |x: f32, y: f32| distance2((x, y), a) <= cap * cap || distance2((x, y), b) <= cap * cap;
    let (x0, x1, y0, y1) = (within.x0, within.x1, within.y0, within.y1);
    // First pass: count both kinds of pixel, to subsample each evenly.
    let (mut caps, mut body) = (0usize, 0usize);
    for y in y0..=y1 {
        for x in within.columns(y) {
            if near(x, y) {
                if in_cap(x as f32, y as f32) {
                    caps += 1;
                } else {
                    body += 1;
                }
            }
        }
    }
    let cap_stride = caps.div_ceil(MAX_FIT_PX - BODY_PX).max(1);
    let body_stride = body.div_ceil(BODY_PX).max(1);
    let mut s = Samples::empty();
    let (mut caps_seen, mut body_seen) = (0usize, 0usize);
    for y in y0..=y1 {
        for x in within.columns(y) {
            if !near(x, y) {
                continue;
            }
            let (fx, fy) = (x as f32, y as f32);
            let (seen, stride) = if in_cap(fx, fy) {
                (&mut caps_seen, cap_stride)
            } else {
                (&mut body_seen, body_stride)
            };
            *seen += 1;
            if !(*seen - 1).is_multiple_of(stride) {
                continue;
            }
            let Some(luma) = frame.luma(x, y) else {
                continue;
            };
            let (Some(xy), Some(l), Some(f)) = (
                s.xy.get_mut(s.len),
                s.luma.get_mut(s.len),
                s.floor_ln.get_mut(s.len),
            ) else {
                continue;
            };
            *xy = local.to_ideal((fx, fy));
            *l = f32::from(luma);
            // A floor at or above the clip level says nothing the clip does not.
            *f = background
                .and_then(|b| b.luma(x, y))
                .filter(|&floor| floor < clip - 0.5)
                .map(|floor| (floor.max(0.5) / clip).ln());
            s.len += 1;
        }
    }
    // Where no pixel's floor was seen unlit (under the glow of a track's first frame), the
    // flat floor starts at the floor seen around the streak (see [`Start::floor_luma`]). Where
    // some pixel's floor was, starting there too set back an LED arriving where it stops:
    // its streak, fitted 11 px for 4.7, carried its first heads at rest 2.5-3.5 px ahead.
    if s.floor_ln.iter().take(s.len).all(Option::is_none) {
        s.around_luma = background
            .and_then(|b| b.floor_around((x0, y0), (x1, y1)))
            .filter(|&floor| floor < clip - 0.5);
    }
    (s.len > 2 * PARAMS).then_some(s)
}

/// The radius of the caps of the stadium with the moments of the pixels at or above `clip`
/// within the fit's reach of `rough` (see [`Moments::stadium`]), where there are at least
/// [`MIN_CLIPPED_PX`]: how far from the path the spot's light reaches the clip (image pixels).
pub(super) fn clip_radius_px(frame: &Frame<'_>, rough: &Rough, clip: f32) -> Option<f32> {
    let within = Reach::of(rough, frame.size());
    // Each clipped pixel is a run of one.
    let clipped = (within.y0..=within.y1).flat_map(|y| {
        within.columns(y).filter_map(move |x| {
            let clipped = frame.luma(x, y).is_some_and(|l| f32::from(l) >= clip);
            (clipped && within.holds(x, y)).then_some((y as u16, x as u16, x as u16))
        })
    });
    Moments::of_runs(clipped)
        .filter(|m| m.area_px() >= MIN_CLIPPED_PX)
        .map(|m| 0.5 * m.stadium().width_px)
}

/// The pixels the fit reads around a rough streak: those within half its thickness and
/// [`REACH_PX`] of its polyline, and the box (clamped to the frame) and row spans that hold
/// them, so that a walk over them tests few pixels beyond.
#[derive(Clone, Copy)]
struct Reach<'a> {
    rough: &'a Rough,
    reach_px: f32,
    x0: usize,
    x1: usize,
    y0: usize,
    y1: usize,
}

impl<'a> Reach<'a> {
    fn of(rough: &'a Rough, size: FrameSize) -> Reach<'a> {
        let reach_px = 0.5 * rough.thickness_px + REACH_PX;
        let [a, b] = rough.ends_px;
        let m = rough.mid_px;
        let lo = |v: f32| (v - reach_px - 1.0).floor().max(0.0) as usize;
        let hi = |v: f32, n: usize| {
            ((v + reach_px + 1.0).ceil().max(0.0) as usize).min(n.saturating_sub(1))
        };
        Reach {
            rough,
            reach_px,
            x0: lo(a.0.min(b.0).min(m.0)),
            x1: hi(a.0.max(b.0).max(m.0), size.width()),
            y0: lo(a.1.min(b.1).min(m.1)),
            y1: hi(a.1.max(b.1).max(m.1), size.height()),
        }
    }

    /// The columns of row `y` worth testing: every pixel [`Reach::holds`] accepts, and fewer
    /// than the box's (the box of a diagonal streak is mostly beyond its reach).
    fn columns(&self, y: usize) -> impl Iterator<Item = usize> + use<> {
        let (x0, x1) = (self.x0, self.x1);
        let span = row_span(self.rough, y as f32, self.reach_px + 1.0).map(|(left, right)| {
            (left.floor().max(0.0) as usize).max(x0)..=(right.ceil().max(0.0) as usize).min(x1)
        });
        span.into_iter().flatten()
    }

    /// Whether the pixel at `(x, y)` lies within reach of the rough polyline.
    fn holds(&self, x: usize, y: usize) -> bool {
        distance2_to_rough(self.rough, x as f32, y as f32) <= self.reach_px * self.reach_px
    }
}

/// How far beyond a blob's bounding box the fit may read pixels, for a blob whose shorter
/// side is `min_side_px`: the floor must not learn them from the frame being fitted. The
/// fit's thickness is at most the blob's shorter side, and it reads up to half a thickness
/// and the caps' reach beyond the path, which lies inside the box; a pixel more for rounding.
pub fn sample_margin_px(min_side_px: usize) -> usize {
    CAP_PX as usize + 2 + min_side_px
}

/// The 20th percentile of the samples' luma: the floor around the streak.
pub(super) fn low_percentile(s: &Samples) -> f32 {
    let mut histogram = LumaHistogram::new();
    s.luma
        .iter()
        .take(s.len)
        .for_each(|&luma| histogram.add(luma));
    histogram.level_above(s.len / 5).unwrap_or(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::fit::dist;

    /// Every pixel within reach of a rough streak lies in its row's span (what the pixel
    /// collection tests), for straight and bent streaks at every angle, and some rows' spans
    /// are narrower than the streak's box (else the span saves nothing).
    #[test]
    fn a_row_s_span_holds_every_pixel_within_reach() {
        let mut narrower = 0;
        for (k, sagitta) in (0..24).flat_map(|k| [(k, 0.0), (k, 6.0), (k, -3.0)]) {
            let angle = k as f32 * 0.27;
            let (a, b) = (
                (40.0, 40.0),
                (40.0 + 30.0 * angle.cos(), 40.0 + 30.0 * angle.sin()),
            );
            let (dx, dy, length) = (b.0 - a.0, b.1 - a.1, dist(a, b));
            let mid = (
                0.5 * (a.0 + b.0) - sagitta * dy / length,
                0.5 * (a.1 + b.1) + sagitta * dx / length,
            );
            let rough = Rough {
                ends_px: [a, b],
                mid_px: mid,
                thickness_px: 4.0,
            };
            let reach = 5.0f32;
            for y in 0..90usize {
                let span = row_span(&rough, y as f32, reach + 1.0);
                let xs = (0..90usize)
                    .filter(|&x| distance2_to_rough(&rough, x as f32, y as f32) <= reach * reach);
                for x in xs {
                    let (left, right) = span.expect("a row with a pixel in reach has a span");
                    assert!(
                        (left..=right).contains(&(x as f32)),
                        "({x}, {y}) outside {left}..{right}, angle {angle}, sagitta {sagitta}"
                    );
                }
                let box_width = a.0.max(b.0).max(mid.0) - a.0.min(b.0).min(mid.0) + 2.0 * reach;
                narrower += usize::from(span.is_some_and(|(l, r)| r - l < 0.5 * box_width));
            }
        }
        assert!(narrower > 100, "{narrower} rows narrower than half the box");
    }
}
