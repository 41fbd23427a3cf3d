//! The streak's middle between frames: where its motion puts the head, and how far that can
//! be trusted, measured from how well the same motion predicted the last middles.
//!
//! One frame cannot always tell a still LED from a moving one: where the floor under a
//! saturated glow was never seen without the light, the fitted path reads its texture as
//! light (paths of 6–27 px for an LED at rest, 13–36 px for a true 14–23 px), and a 1.5 px
//! disk streak reads reversed or twice as long. The middle is robust there (a few tenths of a
//! pixel), and its motion over the frame interval, scaled by the exposure, is the path the
//! LED drew: on the accuracy sweep's straight streaks the middles' displacement times exposure
//! over interval is the true length within a few tenths of a pixel, where the fit was off by
//! up to 5 px. This module turns the last middles into a head of its own with a standard
//! deviation; the tracker compares it with the single frame's head (see
//! [`super::Tracker::update`]).
//!
//! The motion is a constant turn (a straight line is a turn of zero): the LED keeps its speed
//! and turns at the rate its last two displacements turned. A tight circle (16–22 px, a
//! quarter turn a frame) needs the turn: the last displacement's direction is the tangent
//! half a frame ago, 30–40° off. Where the turn is noise (a slow or still LED) it would only
//! spread the head, so of the straight and the turning motion the one that predicted the
//! last middles better is taken. A robot starting off or braking changes its speed instead:
//! a third motion gains the acceleration its last two displacements show, and is taken where
//! it predicted the last middles best (at the last displacement's velocity, the head of an LED
//! gaining 4000 px/s² at 30 fps fell a third of a pixel behind; on the independent scenes'
//! accelerating robots up to 0.9 px in the median). The head's deviation is the prediction errors'
//! (innovations') spread, carried to the head: an LED that accelerates or turns against the
//! model makes its own prediction errors large, so its motion head is trusted less at once,
//! in the very frame it changes course.

use super::{dist, frame_interval_s, frame_interval_us};

/// Middles the motion is measured over, the current one included: up to five prediction
/// errors, and for a settling LED only the frames since it stopped after a few frames at rest.
pub const MOTION_MIDDLES: usize = 8;

/// Prediction errors needed before the motion's spread is trusted: one may be small by chance.
pub const MIN_INNOVATIONS: usize = 2;

/// The 99 % quantile of the χ² distribution with two degrees of freedom: a 2-D offset whose
/// squared length exceeds this many known variances (per axis) is beyond the noise.
pub const CHI2_2DOF_99: f32 = 9.21;

/// The same with one degree of freedom, for a length.
pub const CHI2_1DOF_99: f32 = 6.63;

/// A variance measured from a few prediction errors is itself uncertain: an offset measured
/// against it is beyond the noise past `k` times the 99 % quantile of Fisher's F(k, ν), with
/// ν the degrees of freedom of the measurement (two per prediction error); for k = 2 these
/// are that quantile times two, for k = 1 the F quantile itself (Student's t squared), at
/// ν = 4, 6, 8, 10 (two to five prediction errors).
const F_99_TIMES_K: [[f32; 4]; 2] = [[21.20, 13.75, 11.26, 10.04], [36.0, 21.84, 17.30, 15.12]];

/// How the LED is taken to move from one middle to the next.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Model {
    /// At its last velocity.
    Straight,
    /// At its last speed, turning at its last rate.
    Turning,
    /// Gaining its last acceleration (a robot starting or stopping).
    Accelerating,
}

/// A streak's middle at a frame time.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Middle {
    /// Frame time.
    pub t_us: u64,
    /// The streak's middle.
    pub px: (f32, f32),
}

/// What the middles' motion says about the current frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionHead {
    /// The LED at the end of the current exposure.
    pub head_px: (f32, f32),
    /// Its velocity there.
    pub velocity_px_s: (f32, f32),
    /// One standard deviation of `head_px`, per axis.
    pub head_sigma_px: f32,
    /// Whether the last displacement is beyond the middles' noise: the LED moved.
    pub moved: bool,
    /// Whether the turning motion predicted the last middles better than the straight and
    /// the accelerating ones.
    pub turning: bool,
    /// Whether the accelerating motion predicted them best.
    pub accelerating: bool,
    /// The path over the exposure the motion gives (its length).
    pub path_px: f32,
    /// One standard deviation of the path over the exposure the velocity gives, along it.
    pub path_sigma_px: f32,
    /// Prediction errors the deviations were measured from.
    pub innovations: usize,
}

impl MotionHead {
    /// The factor a squared offset in `dimensions` (1 or 2) is compared with, times the
    /// variance measured from the prediction errors, to be beyond their noise (99 %).
    pub fn beyond(&self, dimensions: usize) -> f32 {
        let row = &F_99_TIMES_K[dimensions.clamp(1, 2) - 1];
        row[self.innovations.clamp(MIN_INNOVATIONS, row.len() + 1) - MIN_INNOVATIONS]
    }
}

/// The motion head of the last of `middles` (oldest first, consecutive found frames, the
/// current one last) for an exposure of `exposure_us`, or `None` with too few middles or
/// frame times less than a frame interval apart.
pub fn motion_head(middles: &[Middle], exposure_us: u32) -> Option<MotionHead> {
    // A prediction error of the turning motion needs three middles before it.
    let n = middles.len();
    if !(MIN_INNOVATIONS + 3..=MOTION_MIDDLES).contains(&n) {
        return None;
    }
    // Displacements over each interval, as velocities, and the turn between consecutive ones.
    let mut v = [(0.0f32, 0.0f32); MOTION_MIDDLES];
    let mut dt_s = [0.0f32; MOTION_MIDDLES];
    for j in 1..n {
        dt_s[j] = frame_interval_s(middles[j - 1].t_us, middles[j].t_us)?;
        let (a, b) = (middles[j - 1].px, middles[j].px);
        v[j] = ((b.0 - a.0) / dt_s[j], (b.1 - a.1) / dt_s[j]);
    }
    // The turn rate at middle j (from displacement j to j + 1), per second.
    let turn_rate =
        |j: usize| -> f32 { signed_angle(v[j], v[j + 1]) / (0.5 * (dt_s[j] + dt_s[j + 1])) };
    // The acceleration over middle j (from displacement j to j + 1).
    let acceleration = |j: usize| -> (f32, f32) {
        let dt = 0.5 * (dt_s[j] + dt_s[j + 1]);
        ((v[j + 1].0 - v[j].0) / dt, (v[j + 1].1 - v[j].1) / dt)
    };
    // Each model predicts middle j from the displacement before it: turned by the rate
    // measured one displacement earlier (zero for the straight model), or changed by the
    // acceleration measured there; all are scored on the same middles.
    let innovations = |model: Model| -> f32 {
        let mut sum_sq = 0.0;
        for j in 3..n {
            let (vx, vy) = v[j - 1];
            let step = match model {
                Model::Straight | Model::Turning => {
                    let rate = if model == Model::Turning {
                        turn_rate(j - 2)
                    } else {
                        0.0
                    };
                    let turn = rate * 0.5 * (dt_s[j - 1] + dt_s[j]);
                    let (c, s) = (turn.cos(), turn.sin());
                    ((c * vx - s * vy) * dt_s[j], (s * vx + c * vy) * dt_s[j])
                }
                Model::Accelerating => {
                    let (ax, ay) = acceleration(j - 2);
                    let ahead = 0.5 * (dt_s[j - 1] + dt_s[j]);
                    ((vx + ax * ahead) * dt_s[j], (vy + ay * ahead) * dt_s[j])
                }
            };
            let (m, p) = (middles[j].px, middles[j - 1].px);
            let e = (m.0 - p.0 - step.0, m.1 - p.1 - step.1);
            sum_sq += e.0 * e.0 + e.1 * e.1;
        }
        // Per axis.
        sum_sq / (2 * (n - 3)) as f32
    };
    // The simplest model that predicted the last middles best.
    let (model, innovation_var) = [Model::Straight, Model::Turning, Model::Accelerating]
        .into_iter()
        .map(|model| (model, innovations(model)))
        .fold((Model::Straight, f32::INFINITY), |best, next| {
            if next.1 < best.1 {
                next
            } else {
                best
            }
        });
    let rate = if model == Model::Turning {
        turn_rate(n - 2)
    } else {
        0.0
    };
    let (ax, ay) = if model == Model::Accelerating {
        acceleration(n - 2)
    } else {
        (0.0, 0.0)
    };
    let last_s = dt_s[n - 1];
    let exposure_s = exposure_us as f32 * 1e-6;
    // The last displacement's velocity is the mean over the last interval, half an interval
    // before the current middle: an accelerating LED has gained half an interval's
    // acceleration since.
    let (vx, vy) = (
        v[n - 1].0 + 0.5 * ax * last_s,
        v[n - 1].1 + 0.5 * ay * last_s,
    );
    // The head, by the constant turn (see [`turn`]).
    let half_turn = 0.5 * rate * last_s;
    let Turn {
        to_head_s,
        head_offset_px: (hx, hy),
    } = turn((vx, vy), rate, last_s, exposure_s);
    let m = middles[n - 1].px;
    let speed_per_chord = 1.0 / chord_per_arc(half_turn);
    // The path over the exposure, at the middle's speed (the mean speed over it when the
    // speed changes steadily), and the velocity at its end.
    let path_px = vx.hypot(vy) * speed_per_chord * exposure_s;
    let half_exposure_s = 0.5 * exposure_s;
    let velocity_px_s = rotate(
        (
            vx * speed_per_chord + ax * half_exposure_s,
            vy * speed_per_chord + ay * half_exposure_s,
        ),
        half_turn + 0.5 * rate * exposure_s,
    );
    // With middles of independent noise σ, a prediction error is a second difference
    // (variance 6 σ² per axis; a third difference, 20 σ², for the accelerating model), and
    // the head a weighted sum of the last middles whose variance is the sum of their
    // squared weights times σ²: (1 + r) m_k − r m_{k−1} with r the head's lead over the last
    // interval, plus c (m_k − 2 m_{k−1} + m_{k−2}) for the acceleration's half interval, c =
    // r / 2 at equal intervals. An unmodelled acceleration shows in the prediction errors more
    // than in the head, so the same ratio is an upper bound for it.
    let r = to_head_s / last_s;
    let (middle_var, c) = match model {
        Model::Accelerating => (innovation_var / 20.0, 0.5 * r),
        _ => (innovation_var / 6.0, 0.0),
    };
    let head_weights_sq = (1.0 + r + c).powi(2) + (r + 2.0 * c).powi(2) + c * c;
    let head_var = head_weights_sq * middle_var;
    // The path is the middle's velocity times the exposure: (m_k − m_{k−1}) / Δt, plus half
    // of the second difference for the acceleration.
    let path_weights_sq = match model {
        Model::Accelerating => 1.5f32.powi(2) + 2.0f32.powi(2) + 0.5f32.powi(2),
        _ => 2.0,
    };
    let innovations = n - 3;
    // The last displacement, against its noise (two middles' noise per axis).
    let (dx, dy) = v[n - 1];
    let moved_sq = (dx * dx + dy * dy) * last_s * last_s;
    let mut head = MotionHead {
        head_px: (m.0 + hx, m.1 + hy),
        velocity_px_s,
        head_sigma_px: head_var.sqrt(),
        moved: false,
        turning: model == Model::Turning,
        accelerating: model == Model::Accelerating,
        path_px,
        // The path is the displacement scaled by exposure over interval.
        path_sigma_px: (path_weights_sq * middle_var).sqrt() * exposure_s / last_s,
        innovations,
    };
    head.moved = moved_sq > head.beyond(2) * 2.0 * middle_var;
    Some(head)
}

/// The head the turning motion gives from the first three or four middles of a track (oldest
/// first, the current one last), too few to measure how well any motion predicts them, for an
/// exposure of `exposure_us`; `None` with other counts or frame times less than a frame
/// interval apart.
///
/// For a track whose path reads still in its first frames (a bloom whose fitted spot is the
/// glow), whose head would otherwise be carried straight on from the middle at the last
/// displacement's velocity: on a tight circle that velocity is the tangent half a frame ago,
/// and the head landed 10–14 px off. A turn that is only the middles' noise turns the head's
/// lead of half an exposure's travel by about the middle's error over the displacement, so
/// it moves the head by about half the middle's error.
pub fn early_turning_head(middles: &[Middle], exposure_us: u32) -> Option<(f32, f32)> {
    let s = early_steps(middles)?;
    let Turn { head_offset_px, .. } = turn(s.v1, s.rate, s.dt1, exposure_us as f32 * 1e-6);
    let m = middles.last()?.px;
    Some((m.0 + head_offset_px.0, m.1 + head_offset_px.1))
}

/// The path over an exposure of `exposure_us` that the first three or four middles of a
/// track give (oldest first, the current one last): the speed along the arc at the current
/// middle, from the last two displacements' (each a chord of the turn between them, at the
/// middle of its interval) and their change carried on half an interval; `None` with other
/// counts or frame times less than a frame interval apart.
///
/// The last displacement alone lags an LED that speeds up: on an accelerating halo
/// (independent seed 1, scene 55) it let a fit that read the path 10–15 % short pass for
/// the speed of a path read as still.
pub fn early_path_px(middles: &[Middle], exposure_us: u32) -> Option<f32> {
    let s = early_steps(middles)?;
    let speed = |v: (f32, f32), dt_s: f32| v.0.hypot(v.1) / chord_per_arc(0.5 * s.rate * dt_s);
    let (s0, s1) = (speed(s.v0, s.dt0), speed(s.v1, s.dt1));
    let acceleration = (s1 - s0) / (0.5 * (s.dt0 + s.dt1));
    Some((s1 + 0.5 * s.dt1 * acceleration).max(0.0) * exposure_us as f32 * 1e-6)
}

/// The variance (px²) of [`early_path_px`] from middles each uncertain along the path by
/// `middle_sd_px`, independently: the path is `e (s₁ + a (s₁ − s₀))` for the last two
/// displacements' speeds `sᵢ` over their intervals `dtᵢ` and `a = dt₁ / (dt₀ + dt₁)`, so the
/// last three middles enter it with weights `(1 + a) / dt₁`, `−(1 + a) / dt₁ − a / dt₀` and
/// `a / dt₀` times the exposure `e` (at equal intervals the variance is 6.5 times a
/// middle's, over the interval, times the exposure). The turn's factor on the speeds is taken
/// as 1. `None` where [`early_path_px`] has none.
fn early_path_variance_px2(middles: &[Middle], exposure_us: u32, middle_sd_px: f32) -> Option<f32> {
    let s = early_steps(middles)?;
    let a = s.dt1 / (s.dt0 + s.dt1);
    let weights = [(1.0 + a) / s.dt1, (1.0 + a) / s.dt1 + a / s.dt0, a / s.dt0];
    let exposure_s = exposure_us as f32 * 1e-6;
    let sum_sq: f32 = weights.iter().map(|w| w * w).sum();
    Some(sum_sq * (middle_sd_px * exposure_s).powi(2))
}

/// The path over an exposure of `exposure_us` that a track's first two, three or four middles
/// give (oldest first, the current one last): [`early_path_px`] from three or four; from two,
/// the one displacement scaled from its interval to the exposure, which has no change of speed
/// to measure yet (on an LED speeding up it is the speed half an interval ago), but is the
/// path of a line at a steady speed, where most short tracks' lengths are read steadily long
/// or short (independent seeds 1–5: 21 scenes of 300 out with the offset learned from the
/// third middle, 18 from the second). `None` with other counts or frame times that do not
/// increase.
///
/// On a circle the displacement is a chord of the arc between the middles, shorter by
/// `chord_per_arc` of half the turn between them. Two middles cannot measure that turn, but
/// the current streak's own bend can: its path of `length_px`, whose ends are `ends_chord_px`
/// apart, turned over the exposure by what that chord against that length says
/// (`turn_of_chord_per_arc`), so it lies on a circle of its length over that turn, and the
/// chord `c` between the middles spans the arc `2r · asin(c / 2r)` on it. The radius, not the
/// turn, is taken: a path read short on its circle turns less but has the same radius. (On
/// independent 1280×720 seed 4's scene 33, 120 px arcs turning 61° an exposure, the chord gave
/// 111.2 px, the arc 120.5 px.) Beyond half a turn between the middles (the bend's turn over
/// the interval), or a chord wider than the circle, the chord tells nothing of the arc:
/// `None`. A path read as still is passed as straight (its chord its length).
pub fn first_path_px(
    middles: &[Middle],
    exposure_us: u32,
    (ends_chord_px, length_px): (f32, f32),
) -> Option<f32> {
    match middles {
        [before, last] => {
            let dt_us = frame_interval_us(before.t_us, last.t_us)?;
            let chord_px = (last.px.0 - before.px.0).hypot(last.px.1 - before.px.1);
            let per_exposure = exposure_us as f32 / dt_us as f32;
            let bend_rad = if length_px > 0.0 {
                turn_of_chord_per_arc(ends_chord_px / length_px)
            } else {
                0.0
            };
            if bend_rad / per_exposure >= core::f32::consts::PI {
                return None;
            }
            let arc_px = if bend_rad > 0.0 {
                let radius_px = length_px / bend_rad;
                let half_chord = chord_px / (2.0 * radius_px);
                if half_chord >= 1.0 {
                    return None;
                }
                2.0 * radius_px * half_chord.asin()
            } else {
                chord_px
            };
            Some(arc_px * per_exposure)
        }
        _ => early_path_px(middles, exposure_us),
    }
}

/// The variance (px²) of [`first_path_px`] from middles each uncertain along the path by
/// `middle_sd_px`, independently: from two, the displacement's, `2 σ² (e / dt)²`; from three
/// or four, the early path's, from the weights with which [`early_path_px`] takes its last
/// three middles. `None` where [`first_path_px`] has none.
pub fn first_path_variance_px2(
    middles: &[Middle],
    exposure_us: u32,
    middle_sd_px: f32,
) -> Option<f32> {
    match middles {
        [before, last] => {
            let dt_us = frame_interval_us(before.t_us, last.t_us)?;
            let scaled_sd_px = middle_sd_px * exposure_us as f32 / dt_us as f32;
            Some(2.0 * scaled_sd_px * scaled_sd_px)
        }
        _ => early_path_variance_px2(middles, exposure_us, middle_sd_px),
    }
}

/// The last two displacements of three or four middles, as velocities over their intervals,
/// and the rate of the turn between them.
struct EarlySteps {
    v0: (f32, f32),
    dt0: f32,
    v1: (f32, f32),
    dt1: f32,
    /// rad/s.
    rate: f32,
}

/// [`EarlySteps`] of `middles` (oldest first), `None` with other than three or four of them
/// or frame times less than a frame interval apart.
fn early_steps(middles: &[Middle]) -> Option<EarlySteps> {
    if !(3..MIN_INNOVATIONS + 3).contains(&middles.len()) {
        return None;
    }
    last_steps(middles)
}

/// [`EarlySteps`] of the last three of `middles` (oldest first), `None` with fewer or frame
/// times less than a frame interval apart.
fn last_steps(middles: &[Middle]) -> Option<EarlySteps> {
    let n = middles.len();
    if n < 3 {
        return None;
    }
    let step = |j: usize| -> Option<((f32, f32), f32)> {
        let dt_s = frame_interval_s(middles[j - 1].t_us, middles[j].t_us)?;
        let (a, b) = (middles[j - 1].px, middles[j].px);
        Some((((b.0 - a.0) / dt_s, (b.1 - a.1) / dt_s), dt_s))
    };
    let ((v0, dt0), (v1, dt1)) = (step(n - 2)?, step(n - 1)?);
    let angle = signed_angle(v0, v1);
    Some(EarlySteps {
        v0,
        dt0,
        v1,
        dt1,
        rate: angle / (0.5 * (dt0 + dt1)),
    })
}

/// The most a frame's head may move from a change of speed its run's middles showed, for the
/// run to carry the frame at its speed ([`carried`]): the goal for the head (p95, px).
const CARRIED_HEAD_PX: f32 = 1.5;

/// A run's motion carried on at its last speed and turn, into a frame whose own middle is not
/// its path's (a streak the frame's edge cut): see [`carried`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Carried {
    /// The speed along the arc of the last displacement (px/s).
    pub speed_px_s: f32,
    /// The last displacement's direction (a unit vector): the heading halfway between its
    /// two middles' times, `heading_us`.
    heading: (f32, f32),
    heading_us: u64,
    /// The turn between the last two displacements, per µs.
    rate_rad_per_us: f32,
}

impl Carried {
    /// The heading (a unit vector) at a frame time `t_us`, turned on at the run's rate. A
    /// middle is where the LED was halfway through its exposure, so this is the LED's heading
    /// halfway through the exposure of a frame at `t_us` (the chord's, on a steady turn).
    pub fn heading_at(&self, t_us: u64) -> (f32, f32) {
        // From the heading's own time: a clock's microseconds in an f32 lose whole
        // milliseconds after a day.
        let since_us = (t_us as i64).wrapping_sub(self.heading_us as i64) as f32;
        rotate(self.heading, self.rate_rad_per_us * since_us)
    }
}

/// The motion the last three `middles` of a run (oldest first, the frame's own not among them)
/// carry into a frame exposed for `exposure_us`: the speed along the arc of the last
/// displacement and its heading, turning at the rate it turned from the one before. `None`
/// with fewer middles, times less than a frame interval apart, a turn of more than a right
/// angle (a reversal, no steady turn), or where the run did not keep its speed: the change
/// between the last two displacements, carried on over the interval and a half to the frame's
/// exposure and scaled to it, would move its head by more than the 1.5 px goal
/// (`CARRIED_HEAD_PX`). An LED arriving where it parks with its light at the edge slows in its
/// last frames: carried at its last speed, its head landed 14–18 px past where it stopped.
pub fn carried(middles: &[Middle], exposure_us: u32) -> Option<Carried> {
    let s = last_steps(middles)?;
    let (v0_px, v1_px) = (s.v0.0.hypot(s.v0.1) * s.dt0, s.v1.0.hypot(s.v1.1) * s.dt1);
    let change_px = (v1_px - v0_px).abs();
    let turn_rad = s.rate * 0.5 * (s.dt0 + s.dt1);
    let kept = 1.5 * change_px * exposure_us as f32 * 1e-6 / s.dt1 <= CARRIED_HEAD_PX;
    if !kept
        || !turn_rad.is_finite()
        || turn_rad.abs() > core::f32::consts::FRAC_PI_2
        || v1_px == 0.0
    {
        return None;
    }
    let [.., before, last] = middles else {
        return None;
    };
    Some(Carried {
        speed_px_s: s.v1.0.hypot(s.v1.1) / chord_per_arc(0.5 * s.rate * s.dt1),
        heading: (s.v1.0 * s.dt1 / v1_px, s.v1.1 * s.dt1 / v1_px),
        heading_us: before.t_us + (last.t_us - before.t_us) / 2,
        rate_rad_per_us: s.rate * 1e-6,
    })
}

/// Where a constant turn puts the head from the middle.
struct Turn {
    /// The time ahead of the middle the chord to the head is travelled in at the middle's
    /// speed.
    to_head_s: f32,
    /// The head less the middle.
    head_offset_px: (f32, f32),
}

/// The head of an LED whose last displacement, over `last_s`, was at velocity `v_px_s` and
/// which turns at `rate` (rad/s), for an exposure of `exposure_s`.
///
/// On a circle the last displacement is the chord of the last interval: its direction is the
/// tangent half an interval ago, and the head is a quarter of the exposure's turn further
/// round from the middle's tangent, at a chord of 2 R sin(ω E / 4). The middle is half the
/// path's length from either end: however the speed changes, the head is the middle's
/// velocity times half the exposure ahead of it (at a steady acceleration the path is that
/// velocity times the exposure).
fn turn(v_px_s: (f32, f32), rate: f32, last_s: f32, exposure_s: f32) -> Turn {
    let half_turn = 0.5 * rate * last_s;
    let to_head_s =
        0.5 * exposure_s * chord_per_arc(0.25 * rate * exposure_s) / chord_per_arc(half_turn);
    let head_offset_px = rotate(
        (v_px_s.0 * to_head_s, v_px_s.1 * to_head_s),
        half_turn + 0.25 * rate * exposure_s,
    );
    Turn {
        to_head_s,
        head_offset_px,
    }
}

/// A circular arc's chord over its length, for a turn of `angle` (rad).
fn chord_per_arc(angle: f32) -> f32 {
    if angle.abs() < 1e-4 {
        1.0
    } else {
        angle.sin() / angle
    }
}

/// The turn a frame (rad) beyond which the end of a streak farther from the last middle is
/// not taken as its head without the turn's own measure ([`head_by_turn`]).
const MAX_HEAD_TURN_RAD: f32 = core::f32::consts::FRAC_PI_2;

/// The most the turns read from the streak's bend and from the middles' chord may differ
/// (rad): the bend is read from the arc's chord against its length, and on a 120 px arc
/// turning 181.5° a frame (86° over a 16 ms exposure) a pixel of either is about 8° of turn a
/// frame, so this is about five pixels' worth, where the ends are read to tenths.
const MAX_TURN_DISAGREEMENT_RAD: f32 = core::f32::consts::FRAC_PI_4;

/// Which of a streak's `ends_px` is its head, from how far the LED turned since the last
/// frame, where that turn is more than a right angle; with the turn (rad). `None` (the end
/// farther from where the LED last was is then the head) where it turned less, where the
/// streak's own bend does not say it turned that much or tells of another turn, or where the
/// middles moved no farther than `width_px` (the streak's width, or the middles' noise where
/// that is the less), too little to measure a turn by.
///
/// On a circle, the chord `c` between two middles and the arc `s` the LED went along between
/// them (its speed, the streak's length over the exposure, times the interval) give the turn
/// `φ` with no radius: `c / s = sin(φ/2) / (φ/2)`, which falls from 1 to 0 as `φ` goes from 0
/// to a whole turn. Under half a turn the LED's last middle lies behind it along the streak,
/// and the head is the end away from it; beyond half a turn the LED has gone more than half
/// way round and the last middle lies ahead, so the head is the end toward it. The middles
/// alone cannot tell those apart (an LED turning 181.5° a frame and one turning 178.5° the
/// other way leave the same middles and the same streaks, but for the streaks' length), and
/// the end farther from the last head holds only as long as that head was right: on
/// independent scenes at 1280×720 (seed 5, scene 49, 120 px arcs on a circle of 80 px, 181.5°
/// a frame) the first choice was wrong and every head after it was at the tail, 106 px off.
pub fn head_by_turn(
    ends_px: [(f32, f32); 2],
    (mid_px, length_px, width_px): ((f32, f32), f32, f32),
    (before_px, dt_s, exposure_s): ((f32, f32), f32, f32),
) -> Option<(usize, f32)> {
    let arc_px = length_px / exposure_s * dt_s;
    let chord_px = dist(mid_px, before_px);
    if !(arc_px.is_finite() && arc_px > 0.0 && chord_px > width_px) {
        return None;
    }
    // Most LEDs turn less than a right angle a frame: told by one sine, not a bisection.
    if chord_px / arc_px >= chord_per_arc(0.5 * MAX_HEAD_TURN_RAD) {
        return None;
    }
    let [a, b] = ends_px;
    // The streak's own bend says the same of the exposure: an arc of `θ` over it is
    // `sin(θ/2) / (θ/2)` of its length across. A straight streak whose middles moved less than
    // its speed says is an LED that slowed down, not one that went round.
    let bend_turn_rad = turn_of_chord_per_arc(dist(a, b) / length_px) * dt_s / exposure_s;
    let turn_rad = turn_of_chord_per_arc(chord_px / arc_px);
    if bend_turn_rad <= MAX_HEAD_TURN_RAD || turn_rad <= MAX_HEAD_TURN_RAD {
        return None;
    }
    // The two must tell of one turn: an exposure given wrong scales the bend's turn with it
    // and the chord's another way (given half the true one, a circle turning 60° a frame
    // bends as if turning 120° and its chord reads 229°), and the head is then left to the
    // end farther from the last one, which needs no exposure.
    if (bend_turn_rad - turn_rad).abs() > MAX_TURN_DISAGREEMENT_RAD {
        return None;
    }
    let along = (b.0 - a.0, b.1 - a.1);
    let last_toward_0 =
        (before_px.0 - mid_px.0) * along.0 + (before_px.1 - mid_px.1) * along.1 < 0.0;
    let head_is_1 = last_toward_0 == (turn_rad < core::f32::consts::PI);
    Some((usize::from(head_is_1), turn_rad))
}

/// The streak's length (over `exposure_s`) at which an LED whose middles moved from
/// `before_px` to `mid_px` over `dt_s` turned exactly half a turn a frame: the chord of half a
/// turn is 2/π of its arc.
pub fn half_turn_length_px(
    mid_px: (f32, f32),
    (before_px, dt_s, exposure_s): ((f32, f32), f32, f32),
) -> f32 {
    core::f32::consts::FRAC_PI_2 * dist(mid_px, before_px) * exposure_s / dt_s
}

/// Which of a streak's `ends_px` is its head, from where the LED last was (`last_px`): on a
/// circle of `radius_px` it went `travel_px` along it from there to where this exposure
/// began, its tail, so the tail is the end whose distance from `last_px` is nearer that
/// arc's chord.
pub fn head_by_travel(
    ends_px: [(f32, f32); 2],
    last_px: (f32, f32),
    travel_px: f32,
    radius_px: f32,
) -> usize {
    let chord_px = 2.0 * radius_px * (0.5 * travel_px / radius_px).sin().abs();
    let miss = |tail: (f32, f32)| (dist(last_px, tail) - chord_px).abs();
    usize::from(miss(ends_px[0]) <= miss(ends_px[1]))
}

/// The turn (rad, from none to a whole turn) of a circular arc whose chord is `q` of its
/// length: the inverse of [`chord_per_arc`] of half the turn, which falls monotonically over
/// it (by bisection). No turn for `q` of 1 or more, a whole turn for `q` of 0 or less.
fn turn_of_chord_per_arc(q: f32) -> f32 {
    if q >= 1.0 {
        return 0.0;
    }
    if q.is_nan() || q <= 0.0 {
        return 2.0 * core::f32::consts::PI;
    }
    let (mut lo, mut hi) = (0.0f32, core::f32::consts::PI);
    for _ in 0..24 {
        let half_turn = 0.5 * (lo + hi);
        if chord_per_arc(half_turn) > q {
            lo = half_turn;
        } else {
            hi = half_turn;
        }
    }
    lo + hi
}

/// The angle (rad, in (−π, π]) that turns the direction of `a` onto that of `b`,
/// positive where it turns from the x axis toward the y axis.
pub(crate) fn signed_angle(a: (f32, f32), b: (f32, f32)) -> f32 {
    (a.0 * b.1 - a.1 * b.0).atan2(a.0 * b.0 + a.1 * b.1)
}

/// `(x, y)` turned by `angle` (rad).
pub(crate) fn rotate((x, y): (f32, f32), angle: f32) -> (f32, f32) {
    let (c, s) = (angle.cos(), angle.sin());
    (c * x - s * y, s * x + c * y)
}

#[cfg(test)]
mod tests {
    use super::*;

    const FRAME_US: u64 = 11_111;
    const EXPOSURE_US: u32 = 10_000;

    fn middles(at: impl Fn(f32) -> (f32, f32), n: usize) -> Vec<Middle> {
        (0..n)
            .map(|i| Middle {
                t_us: i as u64 * FRAME_US,
                px: at(i as f32 * FRAME_US as f32 * 1e-6),
            })
            .collect()
    }

    /// The first path's stated variance is its spread over middles that jitter along the
    /// path by the deviation given: 4000 runs of two, three and four middles, the last interval
    /// a third longer than the one before (a dropped frame's worth of difference), on a line
    /// at 1500 px/s.
    #[test]
    fn the_first_path_s_variance_is_its_spread_over_the_middles_jitter() {
        let sd_px = 0.3f32;
        let mut state = 0x2545_f491u32;
        let mut gaussian = || {
            // The sum of twelve uniforms less six: mean 0, variance 1.
            (0..12)
                .map(|_| {
                    state ^= state << 13;
                    state ^= state >> 17;
                    state ^= state << 5;
                    state as f32 / u32::MAX as f32
                })
                .sum::<f32>()
                - 6.0
        };
        for count in [2usize, 3, 4] {
            let times: Vec<u64> = (0..count as u64)
                .map(|i| {
                    i * FRAME_US
                        + if i + 1 == count as u64 {
                            FRAME_US / 3
                        } else {
                            0
                        }
                })
                .collect();
            let clean: Vec<Middle> = times
                .iter()
                .map(|&t_us| Middle {
                    t_us,
                    px: (100.0 + 1500.0 * t_us as f32 * 1e-6, 80.0),
                })
                .collect();
            let stated = first_path_variance_px2(&clean, EXPOSURE_US, sd_px).expect("a variance");
            let paths: Vec<f32> = (0..4000)
                .map(|_| {
                    let noisy: Vec<Middle> = clean
                        .iter()
                        .map(|m| Middle {
                            px: (m.px.0 + sd_px * gaussian(), m.px.1),
                            ..*m
                        })
                        .collect();
                    first_path_px(&noisy, EXPOSURE_US, (0.0, 0.0)).expect("a path")
                })
                .collect();
            let mean = paths.iter().sum::<f32>() / paths.len() as f32;
            let spread =
                paths.iter().map(|p| (p - mean).powi(2)).sum::<f32>() / (paths.len() - 1) as f32;
            assert!(
                (spread / stated - 1.0).abs() < 0.1,
                "{count} middles: spread {spread:.4} px², stated {stated:.4} px²"
            );
        }
    }

    #[test]
    fn a_straight_line_s_head_is_half_an_exposure_ahead() {
        let m = middles(|t| (100.0 + 2000.0 * t, 50.0 - 1000.0 * t), 5);
        let h = motion_head(&m, EXPOSURE_US).unwrap();
        let t = 4.0 * FRAME_US as f32 * 1e-6 + 0.005;
        let truth = (100.0 + 2000.0 * t, 50.0 - 1000.0 * t);
        assert!((h.head_px.0 - truth.0).abs() < 1e-2 && (h.head_px.1 - truth.1).abs() < 1e-2);
        assert!(h.moved);
        assert!(h.head_sigma_px < 1e-2, "{}", h.head_sigma_px);
    }

    #[test]
    fn a_circle_s_head_is_a_quarter_exposure_s_turn_round() {
        // A 16 px circle, 23 px of arc per 10 ms exposure: the sweep's tightest.
        let (r, w) = (16.0f32, 23.0 / 16.0 / 0.01);
        let at = |t: f32| (300.0 + r * (w * t).cos(), 200.0 + r * (w * t).sin());
        let m = middles(at, 5);
        let h = motion_head(&m, EXPOSURE_US).unwrap();
        let truth = at(4.0 * FRAME_US as f32 * 1e-6 + 0.005);
        let error = (h.head_px.0 - truth.0).hypot(h.head_px.1 - truth.1);
        assert!(error < 0.05, "{error} px");
        let speed = h.velocity_px_s.0.hypot(h.velocity_px_s.1);
        assert!((speed - r * w).abs() < 1.0, "{speed} px/s");
    }

    #[test]
    fn a_steadily_accelerating_led_s_head_is_where_it_got_to() {
        // From 500 to 2000 px/s over four frames (a robot starting off), along a diagonal.
        let (v0, a) = (500.0f32, 1500.0 / (4.0 * FRAME_US as f32 * 1e-6));
        let along = |t: f32| v0 * t + 0.5 * a * t * t;
        let at = |t: f32| (100.0 + 0.8 * along(t), 50.0 - 0.6 * along(t));
        let exposure_s = EXPOSURE_US as f32 * 1e-6;
        // A straight path's middle is its chord's.
        let m: Vec<Middle> = (0..5u64)
            .map(|i| {
                let t = i as f32 * FRAME_US as f32 * 1e-6 + exposure_s;
                let (s, e) = (at(t - exposure_s), at(t));
                Middle {
                    t_us: i * FRAME_US,
                    px: (0.5 * (s.0 + e.0), 0.5 * (s.1 + e.1)),
                }
            })
            .collect();
        let h = motion_head(&m, EXPOSURE_US).unwrap();
        let t = 4.0 * FRAME_US as f32 * 1e-6 + exposure_s;
        let truth = at(t);
        let error = (h.head_px.0 - truth.0).hypot(h.head_px.1 - truth.1);
        // At the last displacement's velocity the head fell 0.94 px behind.
        assert!(error < 0.05, "{error} px");
        let speed = h.velocity_px_s.0.hypot(h.velocity_px_s.1);
        let truth_speed = v0 + a * t;
        assert!((speed / truth_speed - 1.0).abs() < 0.01, "{speed} px/s");
        let path = along(t) - along(t - exposure_s);
        assert!((h.path_px - path).abs() < 0.05, "{} px", h.path_px);
    }

    /// The sweep's tightest circle again, from three and from four middles: the turn puts
    /// the head where it is, where the last displacement's velocity carried straight on put
    /// it several pixels off.
    #[test]
    fn the_first_frames_turn_puts_a_circle_s_head_round_it() {
        let (r, w) = (16.0f32, 23.0 / 16.0 / 0.01);
        let at = |t: f32| (300.0 + r * (w * t).cos(), 200.0 + r * (w * t).sin());
        for n in [3, 4] {
            let m = middles(at, n);
            let h = early_turning_head(&m, EXPOSURE_US).unwrap();
            let truth = at((n - 1) as f32 * FRAME_US as f32 * 1e-6 + 0.005);
            let error = (h.0 - truth.0).hypot(h.1 - truth.1);
            assert!(error < 0.05, "{n} middles: {error} px");
            let (a, b) = (m[n - 2].px, m[n - 1].px);
            let lead = 0.005 / (FRAME_US as f32 * 1e-6);
            let straight = (b.0 + lead * (b.0 - a.0), b.1 + lead * (b.1 - a.1));
            let straight_error = (straight.0 - truth.0).hypot(straight.1 - truth.1);
            assert!(straight_error > 5.0, "{n} middles: {straight_error} px");
        }
        assert_eq!(early_turning_head(&middles(at, 2), EXPOSURE_US), None);
        assert_eq!(early_turning_head(&middles(at, 5), EXPOSURE_US), None);
        let mut m = middles(at, 3);
        m[2].t_us = m[1].t_us;
        assert_eq!(early_turning_head(&m, EXPOSURE_US), None);
    }

    /// The path over the exposure from a track's first three or four middles: an LED
    /// speeding up along a line (8000 px/s² from 300 px/s) and one on the sweep's tightest
    /// circle (23 px of arc per exposure on r 16 px). Both are the truth to 0.1 %, where the
    /// last displacement scaled to the exposure falls short by more than 5 %: on the line the
    /// speed half an interval ago, on the circle a chord.
    #[test]
    fn the_first_frames_path_is_the_speed_at_the_middle_round_its_turn() {
        let (frame_s, exposure_s) = (FRAME_US as f32 * 1e-6, EXPOSURE_US as f32 * 1e-6);
        let (v0, a) = (300.0f32, 8000.0f32);
        let line = |t: f32| (100.0 + v0 * t + 0.5 * a * t * t, 50.0);
        let (r, w) = (16.0f32, 23.0 / 16.0 / 0.01);
        let circle = |t: f32| (300.0 + r * (w * t).cos(), 200.0 + r * (w * t).sin());
        for n in [3, 4] {
            let t_last = (n - 1) as f32 * frame_s;
            let truths = [(v0 + a * t_last) * exposure_s, r * w * exposure_s];
            for (m, truth) in [middles(line, n), middles(circle, n)].iter().zip(truths) {
                let path = early_path_px(m, EXPOSURE_US).unwrap();
                assert!(
                    (path - truth).abs() < 1e-3 * truth,
                    "{n}: {path} px, {truth}"
                );
                let (p, q) = (m[n - 2].px, m[n - 1].px);
                let last = (q.0 - p.0).hypot(q.1 - p.1) * exposure_s / frame_s;
                assert!(truth - last > 0.05 * truth, "{n}: {last} px, {truth}");
            }
        }
        assert_eq!(early_path_px(&middles(line, 2), EXPOSURE_US), None);
        assert_eq!(early_path_px(&middles(line, 5), EXPOSURE_US), None);
    }

    /// The path from a track's first two middles: on a line at a steady speed the truth; from
    /// three or four, the turning path's; none from one, from five, or from two at one time.
    #[test]
    fn the_first_two_middles_give_a_steady_line_s_path() {
        let exposure_s = EXPOSURE_US as f32 * 1e-6;
        let (vx, vy) = (700.0f32, -250.0f32);
        let line = |t: f32| (100.0 + vx * t, 300.0 + vy * t);
        let truth = vx.hypot(vy) * exposure_s;
        let path = first_path_px(&middles(line, 2), EXPOSURE_US, (0.0, 0.0)).unwrap();
        assert!((path - truth).abs() < 1e-3 * truth, "{path} px, {truth}");
        let (v0, a) = (300.0f32, 8000.0f32);
        let speeding = |t: f32| (100.0 + v0 * t + 0.5 * a * t * t, 50.0);
        for n in [3, 4] {
            let m = middles(speeding, n);
            assert_eq!(
                first_path_px(&m, EXPOSURE_US, (0.0, 0.0)),
                early_path_px(&m, EXPOSURE_US)
            );
        }
        let mut two = middles(line, 2);
        two[1].t_us = two[0].t_us;
        assert_eq!(first_path_px(&two, EXPOSURE_US, (0.0, 0.0)), None);
        for n in [1, 5] {
            assert_eq!(
                first_path_px(&middles(line, n), EXPOSURE_US, (0.0, 0.0)),
                None
            );
        }
    }

    /// Two middles on a circle of 40 px turning 60° a frame (54° over the exposure): their
    /// chord is 4.5 % shorter than the arc between them, and lengthened by the circle the
    /// path's bend puts it on, the first path is the arc to 0.1 %, whether the path was read
    /// right or 10 % short on its circle (the same radius). Beyond half a turn between the
    /// middles (a bend of 170° over the exposure) or with a chord wider than the bend's circle,
    /// two middles give no path.
    #[test]
    fn the_first_two_middles_chord_is_lengthened_by_the_path_s_bend() {
        let (frame_s, exposure_s) = (FRAME_US as f32 * 1e-6, EXPOSURE_US as f32 * 1e-6);
        let (r, w) = (40.0f32, 60f32.to_radians() / frame_s);
        let circle = |t: f32| (300.0 + r * (w * t).cos(), 200.0 + r * (w * t).sin());
        let m = middles(circle, 2);
        let truth = r * w * exposure_s;
        // A path of `length_px` on the circle: its ends are a chord of it.
        let on_circle = |length_px: f32| (2.0 * r * (0.5 * length_px / r).sin(), length_px);
        for length_px in [truth, 0.9 * truth] {
            let path = first_path_px(&m, EXPOSURE_US, on_circle(length_px)).unwrap();
            assert!((path - truth).abs() < 1e-3 * truth, "{path} px, {truth}");
        }
        let chord = first_path_px(&m, EXPOSURE_US, (truth, truth)).unwrap();
        assert!(truth - chord > 0.04 * truth, "{chord} px, {truth}");
        // A path turning 170° over the exposure on a circle of 100 px.
        let beyond_half_turn = (
            200.0 * (85f32.to_radians()).sin(),
            100.0 * 170f32.to_radians(),
        );
        assert_eq!(first_path_px(&m, EXPOSURE_US, beyond_half_turn), None);
        // A 10 px path turning a radian: a circle of 10 px, on which the middles, 40 px
        // apart, cannot both lie.
        assert_eq!(
            first_path_px(&m, EXPOSURE_US, (20.0 * 0.5f32.sin(), 10.0)),
            None
        );
    }

    #[test]
    fn too_few_middles_or_times_that_do_not_increase_give_nothing() {
        let m = middles(|t| (1000.0 * t, 0.0), 4);
        assert_eq!(motion_head(&m, EXPOSURE_US), None);
        let mut m = middles(|t| (1000.0 * t, 0.0), 5);
        m[3].t_us = m[2].t_us;
        assert_eq!(motion_head(&m, EXPOSURE_US), None);
    }

    /// An LED on a circle of 80 px turning by `turn_deg` a frame (either way), its streak's
    /// ends given in both orders: the turn read from the middles' chord and the streak's
    /// length, and the head chosen, hold from a right angle to near a whole turn, on both
    /// sides of the half turn where the middles alias; under a right angle the choice is left
    /// to the end farther from the LED's last place.
    #[test]
    fn the_turn_a_frame_tells_the_head_of_a_wagon_wheel() {
        let (dt_s, exposure_s, radius_px) = (1.0 / 30.0, 0.016f32, 80.0f32);
        let at = |angle: f32| {
            let (x, y) = rotate((radius_px, 0.0), angle);
            (200.0 + x, 200.0 + y)
        };
        for turn_deg in [60.0f32, 100.0, 170.0, 178.5, 181.5, 190.0, 260.0, 330.0] {
            for sense in [1.0f32, -1.0] {
                let omega = sense * turn_deg.to_radians() / dt_s;
                let angle = |t: f32| 0.3 + omega * t;
                let (head, tail) = (at(angle(dt_s)), at(angle(dt_s - exposure_s)));
                let mid = at(angle(dt_s - 0.5 * exposure_s));
                let before = at(angle(-0.5 * exposure_s));
                let length_px = radius_px * omega.abs() * exposure_s;
                for (ends, head_end) in [([tail, head], 1), ([head, tail], 0)] {
                    let read =
                        head_by_turn(ends, (mid, length_px, 5.0), (before, dt_s, exposure_s));
                    if turn_deg < 90.0 {
                        assert_eq!(read, None, "{turn_deg}° × {sense}");
                        continue;
                    }
                    let (end, turn_rad) = read.expect("a turn beyond a right angle");
                    assert_eq!(end, head_end, "{turn_deg}° × {sense}");
                    assert!(
                        (turn_rad.to_degrees() - turn_deg).abs() < 0.1,
                        "{turn_deg}°: read {}°",
                        turn_rad.to_degrees()
                    );
                }
            }
        }
    }

    /// On circles turning near a half turn a frame (174°–186°, either way round), the end
    /// whose distance from the last head matches the chord of the arc gone since is the
    /// tail, for streaks in either order and exposures of a tenth to nine tenths of the
    /// frame; and from the last middle, half an exposure farther back, except at exactly a
    /// half turn, where the two ends lie equally far from it.
    #[test]
    fn the_tail_is_where_the_last_head_went() {
        let (dt_s, radius_px) = (1.0 / 30.0, 28.0f32);
        let at = |angle: f32| {
            let (x, y) = rotate((radius_px, 0.0), angle);
            (200.0 + x, 200.0 + y)
        };
        for turn_deg in [174.0f32, 180.0, 186.0] {
            for sense in [1.0f32, -1.0] {
                for exposure_s in [0.1 * dt_s, 0.5 * dt_s, 0.9 * dt_s] {
                    let omega = sense * turn_deg.to_radians() / dt_s;
                    let angle = |t: f32| 0.3 + omega * t;
                    let (head, tail) = (at(angle(dt_s)), at(angle(dt_s - exposure_s)));
                    let speed_px_s = radius_px * omega.abs();
                    let gap_px = speed_px_s * (dt_s - exposure_s);
                    let half_px = 0.5 * speed_px_s * exposure_s;
                    let last_head = at(angle(0.0));
                    let last_mid = at(angle(-0.5 * exposure_s));
                    for (ends, head_end) in [([tail, head], 1), ([head, tail], 0)] {
                        let case = format!("{turn_deg}° × {sense}, exposure {exposure_s} s");
                        let read = head_by_travel(ends, last_head, gap_px, radius_px);
                        assert_eq!(read, head_end, "{case}, from the head");
                        if turn_deg != 180.0 {
                            let read = head_by_travel(ends, last_mid, gap_px + half_px, radius_px);
                            assert_eq!(read, head_end, "{case}, from the middle");
                        }
                    }
                }
            }
        }
    }

    /// Middles that moved no farther than the streak is wide measure no turn (a circle of 80 px
    /// turning 181.5° a frame, its middles 160 px apart, read as 170 px wide); nor does a
    /// circle whose exposure was given wrong (turning 60° a frame, its 16 ms given as 8 ms: its
    /// bend tells of 120°, its chord of 229°), nor a straight streak whose middles moved less
    /// than its speed says (an LED slowing down: 10 px in 10 ms, then 20 px in a 33 ms frame).
    #[test]
    fn a_turn_is_read_only_where_the_middles_and_the_streak_show_one() {
        let (dt_s, exposure_s) = (1.0 / 30.0, 0.016f32);
        let at = |deg: f32| {
            let (x, y) = rotate((80.0, 0.0), deg.to_radians());
            (200.0 + x, 200.0 + y)
        };
        // The streak's ends, middle and length, and the last middle, of a turn a frame.
        let circle = |turn_deg: f32| {
            let deg_per_s = turn_deg / dt_s;
            let ends = [at(deg_per_s * (dt_s - exposure_s)), at(deg_per_s * dt_s)];
            let mid = at(deg_per_s * (dt_s - 0.5 * exposure_s));
            let length_px = 80.0 * (deg_per_s * exposure_s).to_radians();
            (ends, mid, length_px, at(-deg_per_s * 0.5 * exposure_s))
        };
        let (ends, mid, length_px, before) = circle(181.5);
        let read = |width_px: f32, exposure_s: f32| {
            head_by_turn(ends, (mid, length_px, width_px), (before, dt_s, exposure_s))
        };
        assert!(
            read(6.0, exposure_s).is_some(),
            "a wagon wheel's turn is read"
        );
        assert_eq!(read(170.0, exposure_s), None, "middles within the width");
        let (ends, mid, length_px, before) = circle(60.0);
        let read =
            |exposure_s: f32| head_by_turn(ends, (mid, length_px, 6.0), (before, dt_s, exposure_s));
        assert_eq!(read(exposure_s), None, "60° a frame is the old rule's");
        assert_eq!(read(0.5 * exposure_s), None, "an exposure given wrong");
        let straight = [(115.0, 100.0), (125.0, 100.0)];
        let slowing = head_by_turn(
            straight,
            ((120.0, 100.0), 10.0, 6.0),
            ((100.0, 100.0), 0.0333, 0.01),
        );
        assert_eq!(slowing, None);
    }
}
