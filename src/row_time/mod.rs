//! A rolling shutter's row time, measured from the bands a flickering light draws across the
//! frames (`glint row-time`).
//!
//! Lamps on the mains flicker at twice its frequency (100 Hz on 50 Hz mains, 120 Hz on 60 Hz),
//! and a rolling shutter exposes row `y` `y τ` after row 0, so each row sees the light at
//! another point of its cycle: the picture carries bands `2π f τ` radians a row apart in phase
//! ([`bands`]). The bands' spacing is the row time: `τ = k / 2π f` for the spatial frequency
//! `k` that best explains the differences between consecutive frames' row profiles
//! ([`profiles`]). A global shutter draws no bands (every row sees the same moment), nor does
//! an exposure of a whole number of flicker periods (a camera's power-line filter).
//!
//! What makes it the light and not the scene: from one frame to the next the bands move on by
//! the light's phase over the frame interval, `2π f Δt`. Each pair's band is
//! `A (e^{iψₙ} − e^{iψₙ₋₁})`, so the ratio of consecutive pairs' bands is known from the frame
//! times alone for each candidate frequency, and the measured ratios must agree with it (a
//! moving LED, a robot's shadow or a camera's gain hunting draw nothing that keeps that
//! clock). That also tells 100 Hz from 120 Hz, except at frame rates where both move the bands
//! alike, and it tells which way the rows are read: bands read bottom to top move the other
//! way. Bands that stand still from frame to frame (120 Hz at exactly 30 fps) cancel between
//! frames and cannot be told from the scene: nothing is measured.
//!
//! The row time's uncertainty is the spread of the row times measured on four quarters of the
//! frame pairs.

pub mod bands;
pub mod profiles;

use core::f64::consts::TAU;

use nalgebra::Complex;

use crate::golden;
use crate::track::frame_interval_us;
use bands::{fit_pair, Basis, PairFit};
use profiles::RowProfiles;

/// Frames a measurement needs: eight pairs, two in each of the four quarters its uncertainty
/// is read from.
pub const MIN_FRAMES: usize = 9;

/// The flicker frequencies tried when none is given: twice 50 Hz and twice 60 Hz mains.
pub const MAINS_FLICKER_HZ: [f64; 2] = [100.0, 120.0];

/// The fewest band cycles over the picture's height measured: bands wider than twice the
/// picture cannot be told from a slow change of brightness down it.
const MIN_CYCLES: f64 = 0.5;

/// The search grid's step in cycles over the height: a fifth of the width of the fit's peak
/// (about one cycle).
const GRID_CYCLES: f64 = 0.05;

/// Golden-section steps refining the grid's best frequency: its bracket of two grid steps
/// shrinks to 0.618^40 of that.
const REFINE_STEPS: usize = 40;

/// A row whose residual is beyond this many robust standard deviations of its pair's is left
/// out of the second fit (the rows a moving LED or its glow crossed).
const OUTLIER_SIGMAS: f64 = 5.0;

/// Evidence for bands: what the sinusoid explains per parameter over the residual per degree
/// of freedom (an F ratio). Noise alone gives about 1, and the best of the grid's frequencies
/// a few times that.
const MIN_F_RATIO: f64 = 25.0;

/// Consecutive pairs whose bands' ratio is compared with a frequency's clock, at least.
const MIN_RATIOS: usize = 4;

/// How closely the bands' ratios must keep a frequency's clock: the length of their weighted
/// mean on the unit circle (1 when every ratio has the same phase) ...
const MIN_COHERENCE: f64 = 0.8;

/// ... and how far that mean's phase may be from the clock's (0.7 ms a frame at 100 Hz; a
/// camera at 29.97 fps replayed as 30 misses by 0.02 rad).
const MAX_CLOCK_MISS_RAD: f64 = 0.44;

/// A light whose phase moves less than this over a frame interval leaves bands that stand
/// nearly still: their difference is too small to compare with the clock.
const MIN_PHASE_STEP_RAD: f64 = 0.3;

/// Quarters of the pairs whose row times give the uncertainty.
const PARTS: usize = 4;

/// A row time measured from flicker bands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowTime {
    /// The time from one row's exposure to the next, µs.
    pub row_time_us: f64,
    /// Its standard error, µs (from the spread over four quarters of the frame pairs).
    pub standard_error_us: f64,
    /// The light's flicker frequency, Hz.
    pub flicker_hz: f64,
    /// The bands' amplitude, as a fraction of the rows' luma (median over the pairs).
    pub band_depth: f64,
    /// Frame pairs fitted.
    pub pairs: usize,
    /// The median frame interval, µs.
    pub frame_interval_us: u64,
}

/// Why no row time was measured.
#[derive(Debug, Clone, PartialEq)]
pub enum NoRowTime {
    /// Fewer than [`MIN_FRAMES`] frames, or fewer than eight pairs a frame interval apart.
    TooFewFrames { pairs: usize },
    /// Nothing down the rows changes like bands from frame to frame.
    NoBands { f_ratio: f64 },
    /// Bands were fitted, but they do not move from frame to frame as any of the flicker
    /// frequencies tried would move them.
    NotAFlicker { tried_hz: Vec<f64> },
    /// Two frequencies, or both directions down the rows, move the bands alike at this frame
    /// rate: each candidate's frequency (Hz), whether it reads the rows upward, and its row
    /// time (µs).
    Ambiguous { candidates: Vec<(f64, bool, f64)> },
    /// The bands move as bands read from the bottom row up do (a picture flipped upside
    /// down): `glint`'s row time counts rows from the top.
    ReadUpward { row_time_us: f64 },
    /// The bands' spacing would need a readout longer than the frame interval.
    TooSlow { row_time_us: f64 },
}

impl core::fmt::Display for NoRowTime {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            NoRowTime::TooFewFrames { pairs } => write!(
                f,
                "{pairs} pairs of consecutive frames a frame interval apart; at least {} are needed",
                MIN_FRAMES - 1
            ),
            NoRowTime::NoBands { f_ratio } => write!(
                f,
                "no flicker bands in these frames (evidence {f_ratio:.1}, {MIN_F_RATIO} needed): \
                 a global shutter, steady light, or an exposure of whole flicker periods \
                 (turn the camera's power-line filter off and set a short exposure, 1-5 ms)"
            ),
            NoRowTime::NotAFlicker { tried_hz } => write!(
                f,
                "the frames change down their rows, but not as a light flickering at {} Hz \
                 moves bands from frame to frame (check --fps or the sidecar's times, or give \
                 --flicker-hz)",
                join(tried_hz, " or ")
            ),
            NoRowTime::Ambiguous { candidates } => {
                let shown: Vec<String> = candidates
                    .iter()
                    .map(|&(hz, upward, us)| {
                        let from = if upward { "bottom" } else { "top" };
                        format!("a {hz} Hz light read from the {from} ({us:.2} µs a row)")
                    })
                    .collect();
                write!(
                    f,
                    "at this frame rate the bands move alike for {}: give --flicker-hz (twice \
                     the mains frequency), or record at another frame rate",
                    shown.join(" and ")
                )
            }
            NoRowTime::ReadUpward { row_time_us } => write!(
                f,
                "the rows are read from the bottom up ({row_time_us:.2} µs a row): the picture \
                 is flipped upside down, and glint counts row times from the top row"
            ),
            NoRowTime::TooSlow { row_time_us } => write!(
                f,
                "the bands' spacing needs {row_time_us:.2} µs a row, a readout longer than the \
                 frame interval"
            ),
        }
    }
}

impl std::error::Error for NoRowTime {}

/// `e^{i phase}`.
fn unit(phase_rad: f64) -> Complex<f64> {
    let (sin, cos) = phase_rad.sin_cos();
    Complex::new(cos, sin)
}

/// `|c|`.
fn size(c: Complex<f64>) -> f64 {
    c.re.hypot(c.im)
}

/// `arg c`, rad.
fn phase(c: Complex<f64>) -> f64 {
    c.im.atan2(c.re)
}

/// `values` joined by `separator`.
fn join(values: &[f64], separator: &str) -> String {
    let shown: Vec<String> = values.iter().map(f64::to_string).collect();
    shown.join(separator)
}

/// Consecutive frames `n − 1` and `n` a frame interval apart, and their rows' weights.
struct Pairs<'a> {
    profiles: &'a RowProfiles,
    /// The later frame of each pair.
    later: Vec<usize>,
    /// Each pair's rows' weights, pair after pair.
    weights: Vec<f32>,
}

impl Pairs<'_> {
    fn height(&self) -> usize {
        self.profiles.height_px()
    }

    fn fit(&self, p: usize, basis: &Basis) -> Option<PairFit> {
        let n = self.later[p];
        let h = self.height();
        fit_pair(
            self.profiles.profile(n - 1),
            self.profiles.profile(n),
            &self.weights[p * h..(p + 1) * h],
            basis,
        )
    }

    /// What the sinusoid explains over `pairs`.
    fn score(&self, pairs: core::ops::Range<usize>, basis: &Basis) -> f64 {
        pairs
            .filter_map(|p| self.fit(p, basis))
            .map(|fit| fit.explained)
            .sum()
    }

    /// Leaves out each pair's rows whose residual at `basis` is an outlier.
    fn drop_outliers(&mut self, basis: &Basis) {
        let h = self.height();
        let mut residuals = Vec::with_capacity(h);
        for p in 0..self.later.len() {
            let Some(fit) = self.fit(p, basis) else {
                continue;
            };
            let n = self.later[p];
            let (a, b) = (self.profiles.profile(n - 1), self.profiles.profile(n));
            let weights = &mut self.weights[p * h..(p + 1) * h];
            residuals.clear();
            residuals.extend((0..h).filter(|&y| weights[y] > 0.0).filter_map(|y| {
                let r = fit.residual_at(basis, y, f64::from(b[y] - a[y]));
                r.is_finite().then_some(r.abs())
            }));
            let Some(mad) = median(&mut residuals) else {
                continue;
            };
            let limit = OUTLIER_SIGMAS * 1.4826 * mad;
            for (y, w) in weights.iter_mut().enumerate() {
                let r = fit.residual_at(basis, y, f64::from(b[y] - a[y]));
                if *w > 0.0 && limit > 0.0 && r.abs() > limit {
                    *w = 0.0;
                }
            }
        }
    }
}

fn median(values: &mut [f64]) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    Some(values[values.len() / 2])
}

/// The spatial frequency (rad a row) within `bracket` at which the sinusoid explains most of
/// `pairs`, by golden-section search.
fn refine(
    pairs: &Pairs<'_>,
    range: core::ops::Range<usize>,
    basis: &mut Basis,
    bracket: (f64, f64),
) -> f64 {
    let unexplained = |k: f64| {
        basis.set(k);
        -pairs.score(range.clone(), basis)
    };
    let (lo, hi) = golden::minimise(unexplained, bracket, REFINE_STEPS);
    0.5 * (lo + hi)
}

/// The best spatial frequency (rad a row) on the grid from `lo_rad` by `step_rad` up to
/// `hi_rad`, refined, and whether the grid's best is at either end of it (then the bands'
/// spacing, if any, lies outside the range searched, and it is not refined).
fn search(
    pairs: &Pairs<'_>,
    basis: &mut Basis,
    lo_rad: f64,
    hi_rad: f64,
    step_rad: f64,
) -> (f64, bool) {
    let all = 0..pairs.later.len();
    let count = ((hi_rad - lo_rad) / step_rad).floor() as usize + 1;
    let (mut best, mut best_score) = (0, f64::NEG_INFINITY);
    for j in 0..count {
        basis.set(lo_rad + j as f64 * step_rad);
        let explained = pairs.score(all.clone(), basis);
        if explained > best_score {
            (best, best_score) = (j, explained);
        }
    }
    let k_rad = lo_rad + best as f64 * step_rad;
    if best == 0 || best + 1 >= count {
        return (k_rad, true);
    }
    (
        refine(pairs, all, basis, (k_rad - step_rad, k_rad + step_rad)),
        false,
    )
}

/// How the bands' ratios from pair to pair keep the clock of a light flickering at
/// `omega_rad_s`, read top to bottom (`upward` false) or bottom to top, where pair `p` ends
/// at frame `later[p]`, `steps_s[p]` after the frame before it: the length of their weighted
/// mean phase miss on the unit circle, and that mean miss (rad). `None` with fewer than
/// [`MIN_RATIOS`] ratios to compare.
fn clock_miss(
    later: &[usize],
    steps_s: &[f64],
    bands: &[Option<Complex<f64>>],
    omega_rad_s: f64,
    upward: bool,
) -> Option<(f64, f64)> {
    let (mut sum, mut weight, mut count) = (Complex::new(0.0, 0.0), 0.0, 0);
    for p in 1..later.len() {
        let (Some(before), Some(after)) = (bands[p - 1], bands[p]) else {
            continue;
        };
        if later[p] != later[p - 1] + 1 {
            continue;
        }
        // ζ_after / ζ_before = e^{iωΔt₁} (e^{iωΔt₂} − 1) / (e^{iωΔt₁} − 1).
        let (first, second) = (
            unit(omega_rad_s * steps_s[p - 1]),
            unit(omega_rad_s * steps_s[p]),
        );
        if size(first - 1.0) < MIN_PHASE_STEP_RAD || size(second - 1.0) < MIN_PHASE_STEP_RAD {
            continue;
        }
        let mut clock = first * (second - 1.0) / (first - 1.0);
        if upward {
            clock = clock.conj();
        }
        let measured = after * before.conj();
        let w = size(measured);
        if w <= 0.0 {
            continue;
        }
        // The measured ratio turned back by the clock's phase: its weight is its size.
        sum += measured * clock.conj() / size(clock);
        weight += w;
        count += 1;
    }
    (count >= MIN_RATIOS && weight > 0.0).then(|| (size(sum) / weight, phase(sum)))
}

/// Each pair's time step on the camera's own clock (s), from the stamps' steps `stamped_us`
/// and their median: the frames it spans (its step over the median step, rounded: a dropped
/// frame spans two) times the mean frame interval over the whole run. A camera's frames follow
/// its crystal, while the stamps a host gives them jitter by a millisecond or more (USB),
/// which at 100 Hz turns the light's phase by 0.6 rad a millisecond; the run's mean interval
/// carries that jitter divided by the run's length.
fn camera_steps_s(stamped_us: &[f64], median_us: f64) -> Vec<f64> {
    let frames = |step_us: f64| (step_us / median_us).round().max(1.0);
    let elapsed_us: f64 = stamped_us.iter().sum();
    let spanned: f64 = stamped_us.iter().map(|&s| frames(s)).sum();
    let interval_s = elapsed_us / spanned * 1e-6;
    stamped_us.iter().map(|&s| frames(s) * interval_s).collect()
}

/// Measures the row time from `profiles`, trying the flicker frequencies `flicker_hz`.
pub fn measure(profiles: &RowProfiles, flicker_hz: &[f64]) -> Result<RowTime, NoRowTime> {
    let height = profiles.height_px();
    let later: Vec<usize> = (1..profiles.frames())
        .filter(|&n| frame_interval_us(profiles.time_us(n - 1), profiles.time_us(n)).is_some())
        .collect();
    if profiles.frames() < MIN_FRAMES || later.len() < MIN_FRAMES - 1 || height < 2 {
        return Err(NoRowTime::TooFewFrames { pairs: later.len() });
    }
    let stamped_us: Vec<f64> = later
        .iter()
        .map(|&n| (profiles.time_us(n) - profiles.time_us(n - 1)) as f64)
        .collect();
    let frame_interval_us = median(&mut stamped_us.clone()).unwrap_or(0.0);
    let mut pairs = Pairs {
        profiles,
        weights: vec![1.0; later.len() * height],
        later,
    };
    // From bands wider than twice the picture to a readout of the whole frame interval at the
    // highest frequency tried.
    let highest_hz = flicker_hz.iter().copied().fold(0.0, f64::max);
    let rad_per_cycle = TAU / height as f64;
    let (lo_rad, hi_rad) = (
        MIN_CYCLES * rad_per_cycle,
        highest_hz * frame_interval_us * 1e-6 * rad_per_cycle,
    );
    let step_rad = GRID_CYCLES * rad_per_cycle;
    let mut basis = Basis::new(height, lo_rad);
    let (first_rad, _) = search(&pairs, &mut basis, lo_rad, hi_rad, step_rad);
    basis.set(first_rad);
    pairs.drop_outliers(&basis);
    let (k_rad, at_edge) = search(&pairs, &mut basis, lo_rad, hi_rad, step_rad);
    basis.set(k_rad);
    // Each pair's fit at the bands' frequency: the evidence, and each pair's band.
    let fits: Vec<Option<PairFit>> = (0..pairs.later.len())
        .map(|p| pairs.fit(p, &basis))
        .collect();
    let (mut explained, mut residual, mut dof, mut fitted) = (0.0, 0.0, 0.0, 0usize);
    for fit in fits.iter().flatten() {
        explained += fit.explained;
        residual += fit.residual;
        dof += fit.rows as f64 - 4.0;
        fitted += 1;
    }
    let f_ratio = if residual > 0.0 && dof > 0.0 && fitted > 0 {
        (explained / (2.0 * fitted as f64)) / (residual / dof)
    } else {
        0.0
    };
    if at_edge || f_ratio < MIN_F_RATIO {
        return Err(NoRowTime::NoBands { f_ratio });
    }
    let bands: Vec<Option<Complex<f64>>> = fits.iter().map(|f| f.map(|f| f.band())).collect();
    // Which light, read which way, moves the bands as they moved.
    let steps_s = camera_steps_s(&stamped_us, frame_interval_us);
    let mut kept = Vec::new();
    for &hz in flicker_hz {
        for upward in [false, true] {
            let Some((coherence, miss)) =
                clock_miss(&pairs.later, &steps_s, &bands, TAU * hz, upward)
            else {
                continue;
            };
            if coherence >= MIN_COHERENCE && miss.abs() <= MAX_CLOCK_MISS_RAD {
                kept.push((hz, upward));
            }
        }
    }
    let row_time_us = |hz: f64| k_rad / (TAU * hz) * 1e6;
    let (hz, upward) = match kept.as_slice() {
        [] => {
            return Err(NoRowTime::NotAFlicker {
                tried_hz: flicker_hz.to_vec(),
            })
        }
        [one] => *one,
        several => {
            return Err(NoRowTime::Ambiguous {
                candidates: several
                    .iter()
                    .map(|&(hz, upward)| (hz, upward, row_time_us(hz)))
                    .collect(),
            })
        }
    };
    let row_time = row_time_us(hz);
    if upward {
        return Err(NoRowTime::ReadUpward {
            row_time_us: row_time,
        });
    }
    if row_time * (height - 1) as f64 > frame_interval_us {
        return Err(NoRowTime::TooSlow {
            row_time_us: row_time,
        });
    }
    // The spread over the quarters of the pairs.
    let count = pairs.later.len();
    let parts: Vec<f64> = (0..PARTS)
        .map(|i| {
            let range = i * count / PARTS..(i + 1) * count / PARTS;
            refine(
                &pairs,
                range,
                &mut basis,
                (k_rad - step_rad, k_rad + step_rad),
            )
        })
        .collect();
    let mean = parts.iter().sum::<f64>() / PARTS as f64;
    let variance = parts.iter().map(|p| (p - mean).powi(2)).sum::<f64>() / (PARTS - 1) as f64;
    let standard_error_us = (variance / PARTS as f64).sqrt() / (TAU * hz) * 1e6;
    // A pair's band is A (e^{iψₙ} − e^{iψₙ₋₁}): its amplitude over |e^{iωΔt} − 1|.
    let mut depths: Vec<f64> = steps_s
        .iter()
        .zip(&bands)
        .filter_map(|(&dt_s, band)| {
            let chord = size(unit(TAU * hz * dt_s) - 1.0);
            (chord >= MIN_PHASE_STEP_RAD).then(|| band.map(|b| size(b) / chord))?
        })
        .collect();
    Ok(RowTime {
        row_time_us: row_time,
        standard_error_us,
        flicker_hz: hz,
        band_depth: median(&mut depths).unwrap_or(0.0),
        pairs: fitted,
        frame_interval_us: frame_interval_us.round() as u64,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{Frame, FrameSize, PixelFormat};
    use proptest::prelude::*;

    const WIDTH: usize = 64;
    const HEIGHT: usize = 120;

    /// A small xorshift stream, for textures and noise.
    fn next(state: &mut u64) -> u64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        *state
    }

    /// GREY frames of a textured floor lit by a light flickering at `hz`, `depth` deep, each
    /// row `row_time_us` after the one above, taken at `times_us`; rows bottom to top with
    /// `upward`.
    fn banded(
        times_us: &[u64],
        hz: f64,
        depth: f64,
        row_time_us: f64,
        upward: bool,
    ) -> RowProfiles {
        let mut state = 0x9e37_79b9_7f4a_7c15;
        let floor: Vec<f64> = (0..WIDTH * HEIGHT)
            .map(|_| 40.0 + (next(&mut state) % 80) as f64)
            .collect();
        let size = FrameSize::new(WIDTH as u32, HEIGHT as u32).unwrap();
        let mut profiles = RowProfiles::new(HEIGHT, times_us.len());
        let mut bytes = vec![0u8; WIDTH * HEIGHT];
        for &t_us in times_us {
            for (i, b) in bytes.iter_mut().enumerate() {
                let row = i / WIDTH;
                let read = if upward { HEIGHT - 1 - row } else { row };
                let t_s = (t_us as f64 + read as f64 * row_time_us) * 1e-6;
                let light = 1.0 + depth * (TAU * hz * t_s + 0.4).sin();
                let noise = (next(&mut state) % 5) as f64 - 2.0;
                *b = (floor[i] * light + noise).round().clamp(0.0, 255.0) as u8;
            }
            let frame = Frame::new_checked_as(&bytes, size, WIDTH, PixelFormat::Grey).unwrap();
            assert!(profiles.push(&frame, t_us));
        }
        profiles
    }

    /// 30 frames at 30 fps, frame 12 dropped.
    fn times_us() -> Vec<u64> {
        (0..31u64)
            .filter(|&n| n != 12)
            .map(|n| n * 33_333)
            .collect()
    }

    #[test]
    fn a_flickering_light_s_bands_give_the_row_time_and_its_frequency() {
        for (hz, row_time_us) in [(100.0, 120.0), (100.0, 200.0)] {
            let profiles = banded(&times_us(), hz, 0.05, row_time_us, false);
            let measured = measure(&profiles, &MAINS_FLICKER_HZ).expect("measured");
            assert_eq!(measured.flicker_hz, hz);
            assert!(
                (measured.row_time_us / row_time_us - 1.0).abs() < 0.005,
                "{measured:?}"
            );
            assert!(
                (measured.band_depth / 0.05 - 1.0).abs() < 0.2,
                "{measured:?}"
            );
        }
    }

    #[test]
    fn bands_read_upward_or_standing_still_give_no_row_time() {
        let upward = banded(&times_us(), 100.0, 0.05, 150.0, true);
        assert!(matches!(
            measure(&upward, &MAINS_FLICKER_HZ),
            Err(NoRowTime::ReadUpward { .. })
        ));
        // 120 Hz at exactly 30 fps: the same bands in every frame.
        let still = banded(&times_us(), 120.0, 0.05, 150.0, false);
        let result = measure(&still, &MAINS_FLICKER_HZ);
        assert!(result.is_err(), "{result:?}");
        let steady = banded(&times_us(), 100.0, 0.0, 150.0, false);
        let result = measure(&steady, &MAINS_FLICKER_HZ);
        assert!(
            matches!(result, Err(NoRowTime::NoBands { .. })),
            "{result:?}"
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Any frames at any times (repeated, backwards, far apart), any flicker frequencies:
        /// a row time is finite, positive and read out within the frame interval, or there is
        /// none; never a panic.
        #[test]
        fn any_frames_at_any_times_give_a_sane_row_time_or_none(
            width in 1usize..40,
            height in 1usize..60,
            frames in 0usize..24,
            seed in any::<u64>(),
            pattern in 0usize..4,
            steps_us in proptest::collection::vec(0u64..100_000, 24),
            backwards in any::<bool>(),
            hz in proptest::collection::vec(0.5f64..300.0, 0..3),
        ) {
            let size = FrameSize::new(2 * width as u32, height as u32).unwrap();
            let mut state = seed | 1;
            let mut profiles = RowProfiles::new(height, frames);
            let mut bytes = vec![0u8; size.pixels()];
            let mut t_us = 5_000_000u64;
            for (n, &step_us) in steps_us.iter().enumerate().take(frames) {
                for (i, b) in bytes.iter_mut().enumerate() {
                    *b = match pattern {
                        0 => 0,
                        1 => 255,
                        2 => (next(&mut state) >> 56) as u8,
                        _ => ((i / size.width()) as u64 * 37 + n as u64 * 11) as u8,
                    };
                }
                t_us = if backwards && n % 3 == 2 {
                    t_us.saturating_sub(step_us)
                } else {
                    t_us + step_us
                };
                let frame =
                    Frame::new_checked_as(&bytes, size, size.width(), PixelFormat::Grey).unwrap();
                prop_assert!(profiles.push(&frame, t_us));
            }
            if let Ok(r) = measure(&profiles, &hz) {
                prop_assert!(r.row_time_us.is_finite() && r.row_time_us > 0.0, "{:?}", r);
                prop_assert!(r.standard_error_us.is_finite(), "{:?}", r);
                prop_assert!(r.band_depth.is_finite(), "{:?}", r);
                prop_assert!(
                    r.row_time_us * (height - 1) as f64 <= r.frame_interval_us as f64 + 1.0,
                    "{:?}",
                    r
                );
            }
        }
    }
}
