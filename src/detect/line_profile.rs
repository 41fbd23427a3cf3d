//! Where a streak's path ends, placed by the spot's line profile read across the streak's body.
//!
//! The streak is the LED's spot swept along its path. Across the body of the streak (far from
//! its ends, where every point was passed over by the whole spot) the light is the spot's line
//! profile `P · g(t)`, and along the axis past an end, at distance `u` beyond it, it is
//! `P · G(−u)`, the spot's cumulative profile: half the body's light at the end itself, for
//! any symmetric spot. A brightness level cuts both profiles where they hold the same light,
//! whatever the camera's tone curve, its black level and how far the LED saturates (neither
//! enters: equal luma is equal light), so each level `k` pairs the half-width `t_k` across the
//! body with the distance `s_k` at which the axis falls through it past the end:
//! `g(t_k) = G(L − s_k)`, with `L` the end. For a Gaussian spot of σ, `g(t) = exp(−t²/2σ²)`
//! and `G(x) = Φ(x/σ)`, so `s_k = L + σ · β(t_k / σ)` with `β(a) = −Φ⁻¹(exp(−a²/2))`.
//!
//! That σ is the light's, not the luma's, and the gamma is unknown. Through a power-law tone
//! curve the luma across is a Gaussian of σ√γ, read from the widths at the levels (the light
//! above the floor taken off through a nominal curve, a small correction): σ lies within that
//! over √γ for the tone curves webcams use. Within that range the pairing picks it: `β` is
//! not a straight line, so σ is the width whose `β` makes the ends' offsets agree across the
//! levels best (alone, the pairing does not fix σ under the sweep's noise: far down a
//! strongly saturated spot's flank `β(a)` is nearly `a`).
//!
//! The pairing is a Gaussian's. A sharp-edged spot (a disk) has no long foot: across, its
//! light stops at its rim, where a Gaussian's goes on falling. So the foot of the profile
//! across is read at a low level too: when it stops well short of where the Gaussian through
//! the upper levels says, the spot is not Gaussian-like, and the ramps' rule (`tips`, a disk's
//! ends) keeps the ends.
//!
//! A short streak has no uniform body: its middle holds `P · g(t) · (2Φ(ℓ/2σ) − 1)` for a path
//! of `ℓ`, and past an end the light lost off the far end is `P · Φ(−(u + ℓ)/σ)`; both are in
//! the pairing, with `ℓ` from the ends found without them.

use super::level_falls::{first_falls, Armed};
use super::normal::{normal_cdf, quantile_of_ln};
use super::ray_floor;
use crate::frame::Frame;
use crate::golden;

/// The brightness levels the profiles are cut at, as fractions of the way from the floor to
/// the clip level. They stay clear of the floor (its texture and the LED's glow bend the foot
/// of the profile) and of the clip (a bilinear sample beside a clipped pixel understates it).
const LEVELS: [f32; 7] = [FOOT_LEVEL, 0.35, 0.45, 0.55, 0.65, 0.75, 0.85];

/// The level the foot of the profile across is read at (index 0 of [`LEVELS`]), to tell a
/// Gaussian-like spot from a sharp-edged one; the others place the ends.
const FOOT_LEVEL: f32 = 0.15;

/// A Gaussian's foot reaches as far below the upper levels as the Gaussian through them
/// says (a ratio of 1; 0.75–1 measured over the sweep's Gaussians, where the floor's texture
/// and the pixels' sampling take their share); a sharp-edged spot's stops about halfway
/// (0.5–0.8 over the sweep's disks). Below this ratio the spot is no Gaussian, and its ends
/// are left to the ramps' rule.
const FOOT_MIN_RATIO: f32 = 0.75;

/// The widths the fit searches at most, in pixels: a spot narrower than a pixel's sampling to
/// a glow wider than the profile's reach.
const SIGMA_RANGE_PX: (f32, f32) = (0.3, 8.0);

/// Golden-section steps on ln σ: the gamma range's bracket (ln √(2.6/1.6) ≈ 0.24 wide)
/// shrinks to 0.618^12 of that, σ to within 0.1 %.
const SEARCH_STEPS: usize = 12;

/// Body cross-sections read: at the middle and this far to either side along the chord.
const BODY_OFFSETS_PX: [f32; 3] = [-1.0, 0.0, 1.0];

/// A ray's crossings of the levels: the distance at which it first falls through each.
type Crossings = [Option<f32>; LEVELS.len()];

/// Where a ray first falls through each level (a level it reaches beyond its start counts:
/// an end's ray may start on the streak's flank), read no farther than the floor is sought.
fn crossings(
    frame: &Frame<'_>,
    start: (f32, f32),
    d: (f32, f32),
    levels: &[f32; LEVELS.len()],
    reach_px: f32,
) -> Crossings {
    let reach_px = reach_px.min(ray_floor::MAX_REACH_PX);
    first_falls(frame, start, d, levels, reach_px, Armed::OnceReached).map(|f| f.map(|f| f.at_px))
}

/// Places the two path ends. `mid` is the streak's middle and `across` the unit normal to its
/// chord there; `origins` are points on the axis near the two ends and `outward` the unit
/// directions out along it; `path_px` is the path's length as first read; `clip_luma` the
/// frame's top level. Returns the distance from each origin, along its outward direction, to
/// the path's end; `None` when the spot is not Gaussian-like (its foot stops short) or fewer
/// than two levels cut both the body and each end.
pub fn place_ends(
    frame: &Frame<'_>,
    mid: (f32, f32),
    across: (f32, f32),
    origins: [(f32, f32); 2],
    outward: [(f32, f32); 2],
    path_px: f32,
    clip_luma: u8,
) -> Option<[f32; 2]> {
    let clip = f32::from(clip_luma);
    let along = (across.1, -across.0);
    // The floor: the brighter of the floors the body's rays reach on its two sides, so that
    // every level stands clear of the floor on both sides; the profiles are read as far out
    // as any of the rays, the ends' included, found the light still falling.
    let mut floor = f32::NEG_INFINITY;
    let mut reach_px = 0.0f32;
    for side in [across, (-across.0, -across.1)] {
        let f = ray_floor::along(frame, mid, side)?;
        floor = floor.max(f.luma);
        reach_px = reach_px.max(f.reach_px);
    }
    for (&o, &d) in origins.iter().zip(&outward) {
        if let Some(f) = ray_floor::along(frame, o, d) {
            reach_px = reach_px.max(f.reach_px);
        }
    }
    let span = clip - floor;
    if span < 1.0 {
        return None;
    }
    let levels = LEVELS.map(|f| floor + f * span);
    // The half-width across at each level, averaged over both sides and the body's sections.
    let mut width_sum = [0.0f32; LEVELS.len()];
    let mut width_count = [0u32; LEVELS.len()];
    for offset in BODY_OFFSETS_PX {
        let centre = (mid.0 + offset * along.0, mid.1 + offset * along.1);
        let a = crossings(frame, centre, across, &levels, reach_px);
        let b = crossings(frame, centre, (-across.0, -across.1), &levels, reach_px);
        for k in 0..LEVELS.len() {
            if let (Some(a), Some(b)) = (a[k], b[k]) {
                width_sum[k] += 0.5 * (a + b);
                width_count[k] += 1;
            }
        }
    }
    let mut widths: Crossings = [None; LEVELS.len()];
    for k in 0..LEVELS.len() {
        if width_count[k] > 0 {
            widths[k] = Some(width_sum[k] / width_count[k] as f32);
        }
    }
    let ends = [
        crossings(frame, origins[0], outward[0], &levels, reach_px),
        crossings(frame, origins[1], outward[1], &levels, reach_px),
    ];
    for end in &ends {
        let paired = widths
            .iter()
            .zip(end)
            .skip(1)
            .filter(|(w, s)| w.is_some() && s.is_some())
            .count();
        if paired < 2 {
            return None;
        }
    }
    let fit = |sigma: f32| fit_ends(&widths, &ends, sigma, path_px);
    // The luma across is a Gaussian of σ√γ: the light's σ lies within the tone curves'
    // range of that.
    let black = if clip_luma < STUDIO_WHITE_ABOVE {
        STUDIO_BLACK_LUMA
    } else {
        0.0
    };
    let luma_sigma = luma_sigma(&widths, &levels, floor, black)?;
    if foot_ratio(&widths, &levels, floor, black, luma_sigma)? < FOOT_MIN_RATIO {
        return None;
    }
    let (lo, hi) = (
        (luma_sigma / GAMMA_RANGE.1.sqrt())
            .max(SIGMA_RANGE_PX.0)
            .ln(),
        (luma_sigma / GAMMA_RANGE.0.sqrt())
            .min(SIGMA_RANGE_PX.1)
            .ln(),
    );
    if lo >= hi {
        return None;
    }
    let (lo, hi) = golden::minimise(|x: f32| fit(x.exp()).1, (lo, hi), SEARCH_STEPS);
    let sigma_px = (0.5 * (lo + hi)).exp();
    let (end_px, _) = fit(sigma_px);
    end_px.iter().all(|e| e.is_finite()).then_some(end_px)
}

/// Tone curves' exponents, generously around the 1.8–2.4 of webcams.
const GAMMA_RANGE: (f32, f32) = (1.6, 2.6);

/// The exponent the floor's share of a level is taken off with (a small correction).
const NOMINAL_GAMMA: f32 = 2.1;

/// A clip level below this is a studio-range camera's white (235), whose black is 16.
const STUDIO_WHITE_ABOVE: u8 = 245;
const STUDIO_BLACK_LUMA: f32 = 16.0;

/// The width of the luma's Gaussian across the body: `t_k² = c − 2 σ_l² ln(light at k)`, with
/// the light above the floor read through the nominal tone curve; `None` with fewer than three
/// levels or no fall.
fn luma_sigma(
    widths: &Crossings,
    levels: &[f32; LEVELS.len()],
    floor: f32,
    black: f32,
) -> Option<f32> {
    let f = (floor - black).max(0.0);
    let (mut n, mut sx, mut sy, mut sxx, mut sxy) = (0.0f32, 0.0f32, 0.0f32, 0.0f32, 0.0f32);
    for (w, &v) in widths.iter().zip(levels).skip(1) {
        let (Some(t), Some(x)) = (w, light_log(v, f, black)) else {
            continue;
        };
        let y = t * t;
        n += 1.0;
        sx += x;
        sy += y;
        sxx += x * x;
        sxy += x * y;
    }
    if n < 3.0 {
        return None;
    }
    let var = sxx - sx * sx / n;
    let slope = (sxy - sx * sy / n) / var;
    (var > 0.0 && slope < 0.0).then(|| (-0.5 * slope).sqrt())
}

/// `ln` of the light above the floor at luma `v` (floor `f` above `black`), through the
/// nominal tone curve; `None` at or below the floor.
fn light_log(v: f32, f: f32, black: f32) -> Option<f32> {
    let v = v - black;
    (v > f).then(|| v.ln() + (1.0 - (f / v).powf(NOMINAL_GAMMA)).ln() / NOMINAL_GAMMA)
}

/// How far the foot of the profile across reaches below the lowest placing level, over how
/// far the Gaussian of `luma_sigma` through the placing levels says it would.
fn foot_ratio(
    widths: &Crossings,
    levels: &[f32; LEVELS.len()],
    floor: f32,
    black: f32,
    luma_sigma: f32,
) -> Option<f32> {
    let f = (floor - black).max(0.0);
    let (foot, upper) = (widths[0]?, widths[1]?);
    let drop = light_log(levels[1], f, black)? - light_log(levels[0], f, black)?;
    let predicted = (upper * upper + 2.0 * luma_sigma * luma_sigma * drop).sqrt();
    let reach = predicted - upper;
    (reach > 0.0).then(|| (foot - upper) / reach)
}

/// For a spot of `sigma`, the two ends (least squares over the levels) and the levels'
/// root-mean-square disagreement about them.
fn fit_ends(
    widths: &Crossings,
    ends: &[Crossings; 2],
    sigma: f32,
    path_px: f32,
) -> ([f32; 2], f32) {
    // The body's light on a path of `path_px`, as a fraction of a long streak's.
    let body = (2.0 * normal_cdf(0.5 * path_px / sigma) - 1.0).max(f32::EPSILON);
    let mut offsets = [[f32::NAN; LEVELS.len()]; 2];
    let mut end_px = [0.0f32; 2];
    let (mut sq, mut n) = (0.0f32, 0u32);
    for (i, end) in ends.iter().enumerate() {
        let (mut sum, mut count) = (0.0f32, 0u32);
        for k in 1..LEVELS.len() {
            let (Some(t), Some(s)) = (widths[k], end[k]) else {
                continue;
            };
            let ln_light = body.ln() - 0.5 * (t / sigma) * (t / sigma);
            let beyond = end_offset(ln_light, sigma, path_px);
            offsets[i][k] = s - beyond;
            sum += s - beyond;
            count += 1;
        }
        end_px[i] = sum / count.max(1) as f32;
        for o in offsets[i].iter().filter(|o| o.is_finite()) {
            sq += (o - end_px[i]) * (o - end_px[i]);
            n += 1;
        }
    }
    (end_px, (sq / n.max(1) as f32).sqrt())
}

/// How far past the end of a path of `path_px` the axis holds the light `exp(ln_light)` (a
/// fraction of the long streak's body): `Φ(−u/σ) − Φ(−(u + ℓ)/σ) = light`, solved by
/// substitution from the long streak's `u = −σ Φ⁻¹(light)` (the far end's share is small and
/// changes slowly). The light is carried as its logarithm: a level far down a narrow spot's
/// flank holds a fraction of the peak that no `f32` holds.
fn end_offset(ln_light: f32, sigma: f32, path_px: f32) -> f32 {
    let mut u = -sigma * quantile_of_ln(ln_light);
    for _ in 0..2 {
        let lost = normal_cdf(-(u + path_px) / sigma);
        // A long streak's far end is out of reach: nothing to add.
        if lost <= 0.0 {
            break;
        }
        // ln(light + lost), without forming a light too small to hold.
        let ln_total = ln_light + (lost * (-ln_light).min(MAX_LN_RATIO).exp()).ln_1p();
        u = -sigma * quantile_of_ln(ln_total);
    }
    u
}

/// The largest `ln(lost / light)` formed: beyond it the far end's share is all there is.
const MAX_LN_RATIO: f32 = 80.0;
