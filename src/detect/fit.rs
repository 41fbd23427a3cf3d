//! Where the LED was at the start, middle and end of the exposure: a model of the streak fitted
//! to the pixels around it.
//!
//! The streak is the LED's blur spot swept along a path during the exposure, then clipped by
//! the sensor and bent by the camera's unknown tone curve. The model says exactly that:
//!
//! - the path is a circular arc from `start` through `mid` to `end` (a straight line when
//!   `mid` lies on the chord), swept at constant speed, as a robot turning steadily moves
//!   (`arc_path::ArcPieces`: drawn by as few straight pieces as keep within 0.1 px of it);
//!   where the LED's last frames say its speed changes, its light along the path falls
//!   evenly toward the fast end instead, by as much as they say (`gradient_of`): an LED
//!   that speeds up lays less light where it is faster, and fitted at one speed both ends
//!   were read toward the slow end;
//! - the spot is a Gaussian core of standard deviation `σ` in a wider, dimmer Gaussian glow,
//!   so the swept light at a pixel is their line integral along the path, in closed form per
//!   straight piece (an error-function difference times a Gaussian across);
//! - the camera maps the floor's light plus that light `q` to luma `clip · (floor + A q)^k`:
//!   the amplitude `A` absorbs the LED's brightness, the exponent `k` the tone curve (a
//!   Gaussian seen through `v^(1/γ)` is a Gaussian `√γ` wider, and `k` lets the flanks and the
//!   ends share one `σ`);
//! - the spot is round where the lens has not squeezed it: the pixels are placed by the lens's
//!   local linear map around the streak ([`SpotShape`]), the model is fitted there, and its
//!   path is mapped back to the image (near a wide lens's corners a round spot is imaged up to
//!   a third shorter radially, and a round model then reads a still LED as a short streak);
//! - the floor is measured: where the floor was seen without the light in earlier frames
//!   ([`FloorBackground`]), its luma seen back through the fitted tone curve, plus one fitted
//!   pedestal (a glow wider than the fitted pixels); elsewhere (the first frame, an LED still
//!   since the start) one fitted flat floor, started at the floor learned around the streak
//!   where there is one. A textured floor under the streak is then not read as light;
//! - a clipped pixel says only "at least the clip level": it costs nothing when the model
//!   reaches the clip there and is pulled up when it does not (a censored residual).
//!
//! So the spot's width, brightness and tone come from the streak's own unclipped flanks, not
//! from constants tuned on one renderer. Where the flanks are nearly all glow (a core clipped
//! far into it), the tone is held near what the same LED's frames before read of it
//! ([`super::tone_memory`]): the camera's tone does not change from frame to frame.
//!
//! The twelve parameters are fitted by Levenberg–Marquardt on a bounded set of pixels (both
//! end caps in full, the body subsampled; of the clipped pixels only the clipped region's
//! border), with fixed-size matrices and no allocation. When the fit does not settle, or lands
//! somewhere the pixels do not support, the caller falls back to the streak's middle. So it
//! does when the fitted model calls a pixel at an end of its path clipped where the frame
//! shows it well below the clip ([`NoFit::EndOffTheClip`]):
//! the model has stretched its path over pixels it does not explain (the light of something
//! bright beside the LED taken for the LED's own).

use nalgebra::{SMatrix, SVector};

use super::arc_path::{ArcPieces, MAX_PIECES, PATH_PARAMS};
use super::clip_spread::{self, ClipSpread};
use super::floor_bg::FloorBackground;
use super::luma_histogram::LumaHistogram;
use super::moments::Moments;
use super::normal::{normal_cdf, normal_cdf_and_density};
use super::spot_shape::SpotShape;
use super::tone_memory::ToneMemory;
use crate::frame::{Frame, FrameSize};

/// A Gaussian's full width at half maximum over its standard deviation.
pub const FWHM_PER_SIGMA: f32 = 2.354_82;
/// Pixels the fit uses at most: both end caps and a subsample of the body.
pub const MAX_FIT_PX: usize = 128;
/// Of those, pixels taken from the body (between the end caps).
const BODY_PX: usize = 32;
/// Levenberg–Marquardt iterations at most, in each stage (the core alone, then everything,
/// at most twice).
pub const MAX_ITERATIONS: usize = 10;
/// A stage has converged when a step lowers the cost by less than this fraction of it.
const CONVERGED_COST: f32 = 1e-4;
/// It has also settled when a step moves no point of the path more than this and lowers the
/// cost by less than [`SETTLED_COST`] of it: what is left to gain is in the spot's shape,
/// whose valley (see [`fitted`]) the steps may follow for long with the path still.
const SETTLED_PATH_PX: f32 = 0.03;
const SETTLED_COST: f32 = 1e-2;
/// The most the path's parameters may move in one step.
const MAX_PATH_STEP_PX: f32 = 2.0;
/// Pixels farther than this from the rough path, beyond the streak's half thickness, are left
/// out: the spot's light has faded into the floor there.
const REACH_PX: f32 = 3.0;
/// End-cap pixels: within this distance of a rough end, beyond half the thickness.
const CAP_PX: f32 = 5.0;

/// The fitted ends may move at most this far from the rough ones (or the thickness, where
/// more) before the pixels are read again around where they went (see [`fit`]).
const MAX_END_SHIFT_PX: f32 = 6.0;
/// Bounds of the fitted spot σ and tone exponent.
const SIGMA_RANGE_PX: (f32, f32) = (0.3, 12.0);
const TONE_RANGE: (f32, f32) = (0.2, 8.0);
/// Parameters: start x, y; end x, y; sagitta; ln σ of the core; ln σ of the glow; ln amplitude;
/// glow ratio; tone exponent; floor; pedestal. The solver moves them in fitted coordinates
/// (see [`fitted`]).
const PARAMS: usize = 12;
/// The glow starts this many times wider than the core, and this bright relative to it.
const GLOW_WIDTH0: f32 = 3.0;
const GLOW_RATIO0: f32 = 0.05;
/// The tone exponent starts at that of a gamma-2.2 camera.
const TONE0: f32 = 0.45;
/// A cold start's spot σ is this fraction of the streak's thickness, at most
/// [`MAX_SIGMA0_PX`].
const THICKNESS_SIGMAS: f32 = 0.3;
const MAX_SIGMA0_PX: f32 = 6.0;
/// The narrow start's core σ is the clipped region's radius over this (see
/// [`Start::by_clip_radius`]).
const CLIP_RADIUS_SIGMAS: f32 = 3.0;
/// Clipped pixels near the streak needed to read the clipped region's radius.
const MIN_CLIPPED_PX: f32 = 3.0;

/// The amplitude's index in the parameters, held as its logarithm: on a clipped streak it
/// runs to hundreds or thousands of times its start, and the fitted coordinates (see
/// [`fitted`]) scale it by the tone exponent.
const LN_AMPLITUDE: usize = 7;
/// The amplitude's start, and the least it may fall to.
const AMPLITUDE0: f32 = 2.0;
const MIN_AMPLITUDE: f32 = 1e-3;
/// The indices of the core's and the glow's `ln σ` in the parameters.
const CORE_WIDTH: usize = 5;
const GLOW_WIDTH: usize = 6;
/// The glow ratio's index in the parameters.
const GLOW_RATIO: usize = 8;
/// The flat floor's index in the parameters.
const FLAT_FLOOR: usize = 10;
/// The pedestal's index: light added evenly to the measured floor over the fitted pixels (a
/// glow wider than they reach, which the spot model need not draw).
const PEDESTAL: usize = 11;
/// The most an LED's speed may change during one exposure, relative to its mean then, for the
/// light laid along its path to be drawn with a gradient ([`gradient_of`]): up to half, the
/// light per pixel (the inverse of the speed) is within 8 % of its mean from a straight
/// gradient along the path (3 % at a change of 0.3, 50 % at 1). More is an LED starting or
/// stopping within the exposure, whose light piles up where it was still and whose
/// acceleration was not the same over the frames before: the fit at one speed stands there.
const MAX_SPEED_CHANGE: f32 = 0.5;

type Params = SVector<f32, PARAMS>;
type Normal = SMatrix<f32, PARAMS, PARAMS>;

/// The rough streak the fit starts from (from the skeleton).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rough {
    /// The skeleton's ends.
    pub ends_px: [(f32, f32); 2],
    /// The streak's middle.
    pub mid_px: (f32, f32),
    /// Mean thickness of the saturated blob.
    pub thickness_px: f32,
}

/// The fitted path: its points and length in image pixels; the spot, the path's length beside
/// it and the uncertainty in ideal pixels, where the lens keeps the spot round (image pixels
/// without a lens), so that a path is compared with the spot in one unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathFit {
    /// The LED at the two ends of the exposure, in the order of the rough ends.
    pub ends_px: [(f32, f32); 2],
    /// The LED halfway through the exposure.
    pub mid_px: (f32, f32),
    /// Length of the path.
    pub path_length_px: f32,
    /// Length of the path in ideal pixels.
    pub ideal_path_length_px: f32,
    /// The spot's fitted standard deviation in ideal pixels, in the model's linear light
    /// (before the fitted tone curve, through which a Gaussian shows `1/√k` times wider).
    pub spot_sigma_px: f32,
    /// One standard deviation of the ends' positions (the larger of the two) in ideal pixels,
    /// from the fit's residual spread evenly over its pixels and its curvature: what the
    /// noise alone would move them by.
    pub noise_px: f32,
    /// One standard deviation of the path's length in ideal pixels from the residual spread
    /// evenly, as `noise_px`: the ends' errors along the path with their correlation (both
    /// move out together when the spot narrows, a trade of length for width that neither
    /// end's own deviation shows). Not calibrated: on a spot outside the model's family the
    /// residual is mostly its misfit, and the lengths of one LED scatter far less.
    pub length_noise_px: f32,
    /// The same with each pixel's own residual (at least `noise_px`): where the model's
    /// profile misses the LED's at the pixels an end is read from, a frame whose model does
    /// not match its pixels shows here.
    pub uncertainty_px: f32,
    /// The fraction of the fitted pixels whose floor was measured (seen without the light in
    /// earlier frames); the others shared one fitted flat floor.
    pub floor_measured: f32,
    /// The fitted spot, to start the next frame's fit of the same LED from.
    pub spot: SpotFit,
}

/// A fitted spot's shape (its core's width, amplitude, tone and pedestal), where its path lay
/// against the rough one, and how well it fitted. The same LED's spot barely changes from one
/// frame to the next, so the next frame's fit starts from it (see `Start::warm`): one stage
/// of everything, where a cold start fits the core alone first and then everything (up to
/// ten iterations each), sometimes twice. Where the warm fit ends more than
/// `WARM_COST_RATIO` times worse per pixel than this one did, the cold fit is run too.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpotFit {
    /// The model's parameters after the path's, as fitted.
    shape: [f32; PARAMS - PATH_PARAMS],
    /// The fit's cost per fitted pixel.
    cost_per_px: f32,
    /// The fitted path against the rough one it started from (see [`PathOffset`]).
    offset: PathOffset,
    /// The tone exponents this LED's fits have read so far, the prior of the next.
    tone: ToneMemory,
    /// Where the fitted path lay and how long it was, for the next frame's change of speed.
    travel: Travel,
}

/// A fitted path's middle (image pixels), and its length and the length's standard
/// deviation (ideal pixels): the larger of the noise's and the model's misfit's (the
/// sandwich, see [`finish`]), since a bloom's lengths wander from frame to frame by more than
/// the noise alone says.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Travel {
    mid_px: (f32, f32),
    length_px: f32,
    length_deviation_px: f32,
    /// Whether the LED's fit in the frame before this one was a path too (longer than this
    /// spot is wide): then this path is a whole exposure's motion, not an LED that started
    /// moving during it, whose short path would read as a speed that grew.
    after_a_path: bool,
}

#[cfg(test)]
impl SpotFit {
    /// A spot that fitted with `cost_per_px`, for tests of what keeps it.
    pub(crate) fn with_cost(cost_per_px: f32) -> SpotFit {
        SpotFit {
            shape: [0.0; PARAMS - PATH_PARAMS],
            cost_per_px,
            offset: PathOffset {
                ends_px: [(0.0, 0.0); 2],
                chord_px: (1.0, 0.0),
                sagitta_px: 0.0,
            },
            tone: ToneMemory::default(),
            travel: Travel::default(),
        }
    }
}

/// Where the fitted path lay against the rough one: the skeleton stops about half the blob's
/// width short of the path's ends and off its line by a fraction of a pixel, the same way
/// from one frame to the next, and the path's trust region took several steps to cover that.
#[derive(Debug, Clone, Copy, PartialEq)]
struct PathOffset {
    /// The fitted ends less the rough ones, in the rough ends' order.
    ends_px: [(f32, f32); 2],
    /// The rough ends' chord, which tells whether the next rough ends come in the same order.
    chord_px: (f32, f32),
    /// The fitted path's sagitta (signed along the rough chord's left normal).
    sagitta_px: f32,
}

impl PathOffset {
    fn of(rough: [(f32, f32); 2], fitted: &Params) -> PathOffset {
        let [a, b] = rough;
        let outwards = |end: (f32, f32), other: (f32, f32), at: (f32, f32)| {
            outward_frame(end, other).map_or((0.0, 0.0), |(u, n)| {
                let d = (at.0 - end.0, at.1 - end.1);
                (d.0 * u.0 + d.1 * u.1, d.0 * n.0 + d.1 * n.1)
            })
        };
        PathOffset {
            ends_px: [
                outwards(a, b, (fitted[0], fitted[1])),
                outwards(b, a, (fitted[2], fitted[3])),
            ],
            chord_px: (b.0 - a.0, b.1 - a.1),
            sagitta_px: fitted[4],
        }
    }

    /// The path's parameters from the rough `path`, offset as this fit's were: the ends
    /// swapped when the rough chord turned round (the skeleton's ends came the other way).
    fn apply(&self, path: [f32; PATH_PARAMS]) -> [f32; PATH_PARAMS] {
        let [ax, ay, bx, by, _] = path;
        let (a, b) = ((ax, ay), (bx, by));
        let same_way = (bx - ax) * self.chord_px.0 + (by - ay) * self.chord_px.1 >= 0.0;
        let ([da, db], sagitta) = if same_way {
            (self.ends_px, self.sagitta_px)
        } else {
            ([self.ends_px[1], self.ends_px[0]], -self.sagitta_px)
        };
        let moved = |end: (f32, f32), other: (f32, f32), (out, left): (f32, f32)| {
            outward_frame(end, other).map_or(end, |(u, n)| {
                (
                    end.0 + out * u.0 + left * n.0,
                    end.1 + out * u.1 + left * n.1,
                )
            })
        };
        let (a1, b1) = (moved(a, b, da), moved(b, a, db));
        [a1.0, a1.1, b1.0, b1.1, sagitta]
    }
}

/// The unit vector from `other` out through `end`, and its left normal; `None` when the two
/// are too close to give a direction.
fn outward_frame(end: (f32, f32), other: (f32, f32)) -> Option<((f32, f32), (f32, f32))> {
    let length_px = dist(end, other);
    (length_px >= MIN_CHORD_PX).then(|| {
        let u = ((end.0 - other.0) / length_px, (end.1 - other.1) / length_px);
        (u, (-u.1, u.0))
    })
}

/// A rough chord shorter than this has no direction to place the ends along.
const MIN_CHORD_PX: f32 = 1.0;

/// The pixels the fit uses: position, luma, and where known the floor's luma there as
/// `ln(floor / clip)` (the floor in the model's linear light is then `exp(that / k)`).
struct Samples {
    xy: [(f32, f32); MAX_FIT_PX],
    luma: [f32; MAX_FIT_PX],
    floor_ln: [Option<f32>; MAX_FIT_PX],
    len: usize,
    /// The floor seen around the streak (luma), where no sample's own floor was learned:
    /// where the flat floor starts.
    around_luma: Option<f32>,
    /// What the LED's frames before say of the tone exponent (see [`super::tone_memory`]),
    /// weighed as a pseudo-pixel: the exponent, and the weight in luma² a unit of it costs
    /// (the last fit's residual variance per pixel over the prior's variance).
    tone_prior: Option<(f32, f32)>,
    /// The light laid along the path changes along it by this, relative to its mean
    /// ([`Path::gradient`]): zero, or what the LED's change of speed since its last frame
    /// says ([`gradient_of`]). It is not fitted: left free, it traded against the ends of
    /// streaks at one speed.
    gradient: f32,
}

/// The lens's local linear map around a point of the image: ideal pixels there are where a
/// round spot is round.
#[derive(Clone, Copy)]
struct Local {
    shape: SpotShape,
    centre_px: (f32, f32),
}

impl Local {
    fn to_ideal(self, p: (f32, f32)) -> (f32, f32) {
        let c = self.centre_px;
        let d = self.shape.to_ideal((p.0 - c.0, p.1 - c.1));
        (c.0 + d.0, c.1 + d.1)
    }

    fn to_image(self, q: (f32, f32)) -> (f32, f32) {
        let c = self.centre_px;
        let d = self.shape.to_image((q.0 - c.0, q.1 - c.1));
        (c.0 + d.0, c.1 + d.1)
    }
}

/// Why a fit gave no path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoFit {
    /// Too few pixels, no convergence, or ends farther from the rough ones than the pixels
    /// support, even when read again around where they went.
    Failed,
    /// The path is longer than the spot is wide, and its ends are uncertain by more than its
    /// length: the fit cannot tell it from a still LED (the caller's rule).
    Uncertain,
    /// The fitted model calls the pixel at an end of its path clipped where the frame shows it
    /// well below the clip: it contradicts the pixels it was meant to explain.
    EndOffTheClip,
}

/// Fits the streak model around `rough` on `frame`, whose clipped pixels read `clip_luma`,
/// on the floor `background` where it has been measured (a flat fitted floor elsewhere), for
/// the spot `shape` the lens makes of a round one there ([`SpotShape::identity`] without a
/// lens), from the spot `warm` fitted to the same LED in a recent frame when there is one
/// (see [`SpotFit`]). Where the fitted ends run past the pixels read around the rough ones,
/// the pixels around where they went are read and fitted once more. [`NoFit`] when the fit
/// fails (too few pixels, no convergence, a result the pixels do not support), and with
/// `check_ends`, when the model contradicts the pixels at an end ([`NoFit::EndOffTheClip`]).
pub fn fit(
    frame: &Frame<'_>,
    rough: &Rough,
    clip_luma: u8,
    background: Option<&FloorBackground>,
    shape: SpotShape,
    warm: Option<&SpotFit>,
    check_ends: bool,
) -> Result<PathFit, NoFit> {
    let seen = Seen {
        frame,
        clip_luma,
        background,
        shape,
        warm,
        check_ends,
    };
    let from = |rough: &Rough| fit_from(&seen, rough);
    match from(rough) {
        Ok(found) => Ok(found),
        Err(Miss::No(why)) => Err(why),
        // The light goes on past the rough ends (a skeleton cut short, on a streak whose
        // clipped core broke up): once more, around the ends the fit moved to, where the
        // pixels beyond them are read too. Only once: the ends may move as far again, and no
        // farther.
        Err(Miss::Beyond(moved)) => from(&moved).map_err(|miss| match miss {
            Miss::No(why) => why,
            Miss::Beyond(_) => NoFit::Failed,
        }),
    }
}

/// Why one fit from one rough streak gave no path.
enum Miss {
    No(NoFit),
    /// The fitted ends moved farther from the rough ones than the pixels read around them
    /// support: the rough streak the fit went to instead.
    Beyond(Rough),
}

/// What [`fit`] fits from: the frame and what is known of it (see [`fit`]).
struct Seen<'a, 'f> {
    frame: &'a Frame<'f>,
    clip_luma: u8,
    background: Option<&'a FloorBackground>,
    shape: SpotShape,
    warm: Option<&'a SpotFit>,
    check_ends: bool,
}

/// [`fit`] from one rough streak.
fn fit_from(seen: &Seen<'_, '_>, rough: &Rough) -> Result<PathFit, Miss> {
    let (frame, background, warm) = (seen.frame, seen.background, seen.warm);
    let spread = clip_spread::measure(frame, rough, seen.clip_luma);
    let clip = spread.level_luma;
    let local = Local {
        shape: seen.shape,
        centre_px: rough.mid_px,
    };
    let mut samples =
        collect(frame, rough, background, &spread, &local).ok_or(Miss::No(NoFit::Failed))?;
    let memory = warm.map_or(ToneMemory::default(), |w| w.tone);
    samples.tone_prior = warm.and_then(|w| {
        let prior = memory.prior()?;
        Some((prior.tone, w.cost_per_px / prior.variance))
    });
    let floor0 = samples
        .around_luma
        .unwrap_or_else(|| low_percentile(&samples));
    // The path in ideal pixels, where the model's spot is round.
    let [a, b] = rough.ends_px.map(|end| local.to_ideal(end));
    let path0 = [a.0, a.1, b.0, b.1, sagitta_of(a, b, rough.mid_px)];
    // The flat floor is fitted only when some pixel's floor was not measured.
    // The pedestal, only when some pixel's floor was.
    let mut all = [true; PARAMS];
    let floors = samples.floor_ln.iter().take(samples.len);
    all[FLAT_FLOOR] = floors.clone().any(Option::is_none);
    all[PEDESTAL] = floors.clone().any(Option::is_some);
    let start = Start {
        samples: &samples,
        path: path0,
        floor_luma: floor0,
        clip,
        all: &all,
    };
    // The fit from one start, bent where the pixels ask, and read out; the rough streak it
    // went to where its ends moved farther than the pixels read support, `None` where it
    // cannot be read.
    let conclude = |samples: &Samples, (p, cost): (Params, f32)| {
        let (p, cost) = bent_if_asked(samples, (p, cost), clip, &all);
        if beyond_the_rough(&p, [a, b], rough.thickness_px) {
            let path = Path::new(&native(&p), true, samples.gradient);
            return Err(Some(Rough {
                ends_px: [(p[0], p[1]), (p[2], p[3])].map(|end| local.to_image(end)),
                mid_px: local.to_image(path.arc.mid),
                thickness_px: rough.thickness_px,
            }));
        }
        // A path left straight was fitted with its sagitta held: so is its uncertainty read.
        let fitted_all = sagitta_held_if_straight(&all, &path_of(&p));
        let found = finish(
            samples,
            (&local, [a, b]),
            (p, cost),
            clip,
            &fitted_all,
            memory,
        );
        found.map(|found| (p, cost, found)).ok_or(None)
    };
    let cold = || start.cold(rough.thickness_px, clip_radius_px(frame, rough, clip));
    let warm_fit = warm.and_then(|w| start.warm(w).map(|found| (found, w.cost_per_px)));
    let (p, cost, found) = match warm_fit {
        Some((found, before)) if found.1 <= WARM_COST_RATIO * before * samples.len as f32 => {
            conclude(&samples, found)
        }
        // The spot changed more than a frame's light and noise explain (another LED, a
        // glow that began to clip): from scratch, keeping the better of the two.
        Some((found, _)) => match cold() {
            Some(cold) if cold.1 < found.1 => conclude(&samples, cold),
            _ => conclude(&samples, found),
        },
        None => cold().ok_or(None).and_then(|cold| conclude(&samples, cold)),
    }
    .map_err(|moved| moved.map_or(Miss::No(NoFit::Failed), Miss::Beyond))?;
    // An LED whose speed changed since its last frame changed it during this exposure too:
    // once more from here, with the light laid along the path as that change says. Where
    // that fit cannot be read, the one at an even speed stands.
    let gradient = warm.and_then(|w| gradient_of(&w.travel, &found));
    let (p, cost, mut found) = match gradient {
        Some(gradient) => {
            samples.gradient = gradient;
            let active = sagitta_held_if_straight(&all, &path_of(&p));
            match levenberg_marquardt(&samples, p, clip, &active)
                .map(|laid| conclude(&samples, laid))
            {
                Some(Ok(laid)) => laid,
                _ => {
                    samples.gradient = 0.0;
                    (p, cost, found)
                }
            }
        }
        None => (p, cost, found),
    };
    found.spot.travel.after_a_path =
        warm.is_some_and(|w| w.travel.length_px > FWHM_PER_SIGMA * found.spot_sigma_px);
    let pixels = Pixels {
        frame,
        background,
        spread,
        residual_sd: (cost / samples.len.saturating_sub(PARAMS).max(1) as f32).sqrt(),
        gradient: samples.gradient,
    };
    if seen.check_ends && end_off_the_clip(&pixels, &local, &native(&p), found.noise_px) {
        return Err(Miss::No(NoFit::EndOffTheClip));
    }
    Ok(found)
}

/// The light's gradient along `found`'s path ([`Path::gradient`]) from the LED's change of
/// speed since its last fitted frame, `before`: `None` where the change is within the two
/// lengths' deviations, where either frame's path is no longer than the spot is wide, where
/// the LED was not moving already in the frame before `before` (it may have started during
/// that exposure: a bloom moving into place read its second frame's head 4.3 px off at p95
/// with the gradient of its first frame's short path), and where the speed changed by more
/// than [`MAX_SPEED_CHANGE`].
///
/// The path's length `L` is the exposure times the mean speed during it, so it grows by
/// `ΔL = a e` a frame at an acceleration `a` (pixels a frame²) and an exposure of `e` of the
/// frame, and the speed changes by `a e` during the exposure: by `ΔL / v` of the speed `v`
/// at this exposure's middle. The middles moved `D`, the mean speed between the two middles,
/// `v − a / 2`; with `a = ΔL v / L`, that is `v = D / (1 − ΔL / 2L)`. Neither the exposure
/// nor the frame rate is needed. The light laid per pixel is the inverse of the speed, so
/// it falls by that fraction from the slow end to the fast one, which is the start of the
/// path when the LED speeds up (the path's start is the end that lies behind the motion).
fn gradient_of(before: &Travel, found: &PathFit) -> Option<f32> {
    let moved = (
        found.mid_px.0 - before.mid_px.0,
        found.mid_px.1 - before.mid_px.1,
    );
    let moved_px = moved.0.hypot(moved.1);
    let length_px = found.ideal_path_length_px;
    let spot_width_px = FWHM_PER_SIGMA * found.spot_sigma_px;
    let grew_px = length_px - before.length_px;
    if !before.after_a_path
        || before.length_px <= spot_width_px
        || length_px <= spot_width_px
        || moved_px <= 0.0
        || grew_px.abs()
            <= 2.0
                * before
                    .length_deviation_px
                    .hypot(found.spot.travel.length_deviation_px)
    {
        return None;
    }
    let change = grew_px * (1.0 - grew_px / (2.0 * length_px)) / moved_px;
    let [a, b] = found.ends_px;
    let forwards = (b.0 - a.0) * moved.0 + (b.1 - a.1) * moved.1 >= 0.0;
    let gradient = if forwards { -change } else { change };
    (change.abs() <= MAX_SPEED_CHANGE).then_some(gradient)
}

/// The frame a fit was read from, as [`end_off_the_clip`] checks it.
struct Pixels<'a, 'f> {
    frame: &'a Frame<'f>,
    background: Option<&'a FloorBackground>,
    spread: ClipSpread,
    /// The fit's residual standard deviation, in luma.
    residual_sd: f32,
    /// The light's gradient along the fitted path ([`Path::gradient`]).
    gradient: f32,
}

/// Whether the fitted model of parameters `p` (native, in `local`'s ideal pixels), whose ends
/// are uncertain by `uncertainty_px`, calls the pixel at an end of its path clipped while the
/// frame shows that pixel below the clip by more than twice the fit's residual deviation (and
/// the clip's own spread).
///
/// On a long enough path the light at an end is half the streak's inside level, so a streak
/// clipped several times over is clipped at its ends, and the LED's centre there lies on the
/// saturated blob. A fitted end out on unclipped pixels then says that the model stretched its
/// path over light it does not explain: a 20x clip disk streak ending against a paper-white
/// square (`tests/bright_beside.rs`) was fitted 3 px long over the square. The model is
/// evaluated with the end drawn in by one of its deviations (the pixel pushed that far out
/// along the path), so that an end the fit could not place is not judged on its exact place,
/// and the verdict is the model's own: a barely clipping spot, whose path ends lie
/// legitimately off its blob (at half its inside level, below the clip), is left alone, where
/// a guard asking every moving end to lie on the blob refused those too.
fn end_off_the_clip(
    pixels: &Pixels<'_, '_>,
    local: &Local,
    p: &Params,
    uncertainty_px: f32,
) -> bool {
    let path = Path::new(p, true, pixels.gradient);
    let ends = [(p[0], p[1]), (p[2], p[3])];
    let clip = pixels.spread.level_luma;
    ends.iter().zip(ends.iter().rev()).any(|(&end, &other)| {
        let (x, y) = local.to_image(end);
        let (x, y) = (x.round(), y.round());
        if x < 0.0 || y < 0.0 {
            return false;
        }
        let (xu, yu) = (x as usize, y as usize);
        let Some(luma) = pixels.frame.luma(xu, yu) else {
            return false;
        };
        let floor_ln = pixels
            .background
            .and_then(|b| b.luma(xu, yu))
            .filter(|&floor| floor < clip - 0.5)
            .map(|floor| (floor.max(0.5) / clip).ln());
        let length_px = dist(end, other).max(MIN_CHORD_PX);
        let outwards = ((end.0 - other.0) / length_px, (end.1 - other.1) / length_px);
        let at = local.to_ideal((x, y));
        let drawn_in = (
            at.0 + uncertainty_px * outwards.0,
            at.1 + uncertainty_px * outwards.1,
        );
        let predicted = model(&path, p, drawn_in, floor_ln, clip).0;
        predicted >= clip
            && f32::from(luma) < clip - pixels.spread.depth_luma - 2.0 * pixels.residual_sd
    })
}

/// The fitted path's ends, middle, length and uncertainty, and its spot, from the fitted `p`
/// of cost `cost`, fitted in `local`'s ideal pixels from the rough ends `[a, b]` (ideal too);
/// `None` when a parameter is not finite or the curvature cannot be inverted.
fn finish(
    samples: &Samples,
    (local, [a, b]): (&Local, [(f32, f32); 2]),
    (p, cost): (Params, f32),
    clip: f32,
    all: &[bool; PARAMS],
    tone_memory: ToneMemory,
) -> Option<PathFit> {
    if !p.iter().all(|v| v.is_finite()) {
        return None;
    }
    let mut spread = Normal::zeros();
    let (mut normal, mut gradient) = normal_equations(samples, &p, clip, all, Some(&mut spread))?;
    hold_inactive(&mut normal, &mut gradient, all);
    let sigma = native(&p)[5].exp();
    let ends = [(p[0], p[1]), (p[2], p[3])];
    let dof = samples.len.saturating_sub(PARAMS).max(1) as f32;
    // The pixels' cost, without the prior's.
    let cost = (cost - prior_cost(samples, &p)).max(0.0);
    let residual_var = cost / dof;
    let covariance = covariance_of(&normal)?;
    // What the pixels alone say of the tone exponent, for the next frame's prior: at a
    // bound they say nothing.
    let tone = p[TONE];
    let tone_memory = if all[TONE] && off_its_bounds(tone, TONE_RANGE) {
        // Without a prior, the curvature is the pixels' alone.
        let variance = match samples.tone_prior {
            Some((_, weight)) => {
                let mut pixels_only = normal;
                pixels_only[(TONE, TONE)] -= weight;
                covariance_of(&pixels_only).map_or(f32::NAN, |c| c[(TONE, TONE)])
            }
            None => covariance[(TONE, TONE)],
        };
        tone_memory.with(tone, variance * residual_var)
    } else {
        tone_memory
    };
    // The residuals are not the noise alone: where the model's profile is not the LED's (a
    // Moffat's wings, a pillbox's edge), they run large and alike exactly where the ends are
    // read. The sandwich (Huber–White) covariance weighs each pixel's slopes by its own
    // squared residual, so an end read off pixels the model misses is reported nearer to as
    // uncertain as it is (not all the way: the misfit is a bias more than a spread, see
    // `a_spot_unlike_the_model_reports_the_ends_as_uncertain_as_they_are`); the residual
    // variance spread evenly is its floor, where few pixels hold an end.
    let robust = covariance * spread * covariance * (samples.len as f32 / dof);
    let end_var_of = |c: &Normal| (c[(0, 0)] + c[(1, 1)]).max(c[(2, 2)] + c[(3, 3)]).max(0.0);
    let noise_var = end_var_of(&covariance) * residual_var;
    let length_slopes = length_slopes(&p);
    let length_var = length_slopes.dot(&(covariance * length_slopes)).max(0.0) * residual_var;
    let robust_length_var = length_slopes.dot(&(robust * length_slopes)).max(0.0);
    let path = Path::new(&native(&p), true, samples.gradient);
    let measured = samples.floor_ln.iter().take(samples.len).flatten().count();
    let corners = path.arc.corners.iter().take(path.arc.count + 1);
    let image_corners = corners.map(|&c| local.to_image(c));
    let path_length_px = image_corners
        .clone()
        .zip(image_corners.skip(1))
        .map(|(s, e)| dist(s, e))
        .sum();
    Some(PathFit {
        ends_px: ends.map(|end| local.to_image(end)),
        mid_px: local.to_image(path.arc.mid),
        path_length_px,
        ideal_path_length_px: path.length(),
        spot_sigma_px: sigma,
        noise_px: noise_var.sqrt(),
        length_noise_px: length_var.sqrt(),
        uncertainty_px: noise_var.max(end_var_of(&robust)).sqrt(),
        floor_measured: measured as f32 / samples.len.max(1) as f32,
        spot: SpotFit {
            shape: core::array::from_fn(|i| native(&p)[PATH_PARAMS + i]),
            cost_per_px: cost / samples.len.max(1) as f32,
            offset: PathOffset::of([a, b], &p),
            tone: tone_memory,
            travel: Travel {
                mid_px: local.to_image(path.arc.mid),
                length_px: path.length(),
                length_deviation_px: length_var.max(robust_length_var).sqrt(),
                // Known to the caller only (see `fit_from`).
                after_a_path: false,
            },
        },
    })
}

/// The path length's slopes in the fitted parameters `p` (only the path's are not zero). An
/// arc of chord `c` and sagitta `s` turns by twice `φ = 2 atan(2s/c)` and is `L = c φ / sin φ`
/// long; the chord's slope lies along its direction at each end.
fn length_slopes(p: &Params) -> Params {
    let (chord_x, chord_y) = (p[2] - p[0], p[3] - p[1]);
    let chord_px = chord_x.hypot(chord_y).max(MIN_CHORD_PX);
    let (ux, uy) = (chord_x / chord_px, chord_y / chord_px);
    let t = 2.0 * p[SAGITTA] / chord_px;
    let phi = 2.0 * t.atan();
    // `φ / sin φ` and its slope, by their series where both vanish together.
    let (g, g_slope) = if phi.abs() < 1e-3 {
        (1.0 + phi * phi / 6.0, phi / 3.0)
    } else {
        let (sin, cos) = phi.sin_cos();
        (phi / sin, (sin - phi * cos) / (sin * sin))
    };
    let phi_per_t = 2.0 / (1.0 + t * t);
    let along = g - t * g_slope * phi_per_t;
    let mut slopes = Params::zeros();
    slopes[0] = -along * ux;
    slopes[1] = -along * uy;
    slopes[2] = along * ux;
    slopes[3] = along * uy;
    slopes[SAGITTA] = 2.0 * g_slope * phi_per_t;
    slopes
}

/// Whether the fitted ends of `p` lie farther from the rough ends `[a, b]` (ideal pixels) of
/// a streak `thickness_px` thick than the pixels read around the rough ones support. The
/// skeleton's ends of a fat blob (a glow that saturates) lie up to its width from the path's:
/// the thinning stops half a width short of each end and may curl sideways.
fn beyond_the_rough(p: &Params, [a, b]: [(f32, f32); 2], thickness_px: f32) -> bool {
    let ends = [(p[0], p[1]), (p[2], p[3])];
    let max_shift_px = MAX_END_SHIFT_PX.max(thickness_px);
    dist(ends[0], a).min(dist(ends[0], b)) > max_shift_px
        || dist(ends[1], b).min(dist(ends[1], a)) > max_shift_px
}

/// A warm start's fit is kept when its cost per pixel is at most this many times the spot's
/// it started from; above, the fit is also run from scratch and the better one kept.
const WARM_COST_RATIO: f32 = 4.0;

/// The sagitta's index in the parameters.
const SAGITTA: usize = 4;
/// A straight fit is bent when the step the pixels ask of its sagitta is more than this many
/// of the sagitta's standard deviations: the usual three, so that a straight streak's noise
/// does not bend it.
const BEND_DEVIATIONS: f32 = 3.0;

/// The path's parameters in `p`: start x, y, end x, y, sagitta.
fn path_of(p: &Params) -> [f32; PATH_PARAMS] {
    [p[0], p[1], p[2], p[3], p[SAGITTA]]
}

/// `all` with the sagitta held where `path` is drawn straight: a straight path is fitted,
/// and its uncertainty read, with its sagitta held, and bends only where the pixels ask
/// ([`bent_if_asked`]).
fn sagitta_held_if_straight(all: &[bool; PARAMS], path: &[f32; PATH_PARAMS]) -> [bool; PARAMS] {
    let mut active = *all;
    active[SAGITTA] = !is_straight(path);
    active
}

/// Whether the path `path` (start x, y, end x, y, sagitta) is drawn straight: within
/// [`ArcPieces`]' tolerance of its chord, one piece.
fn is_straight(path: &[f32; PATH_PARAMS]) -> bool {
    ArcPieces::new(*path, false).count == 1
}

/// The inverse of the normal matrix `normal`, in units of the residual variance: each
/// diagonal raised by a millionth of itself first, so that a parameter the pixels do not
/// constrain (a glow of no light, whose width then moves nothing) reads as uncertain rather
/// than the matrix as singular.
fn covariance_of(normal: &Normal) -> Option<Normal> {
    let mut regularised = *normal;
    for i in 0..PARAMS {
        regularised[(i, i)] += 1e-6 * normal[(i, i)].max(1e-6);
    }
    regularised.try_inverse()
}

/// The fit `(p, cost)`, bent when it is straight and the pixels ask it to bend
/// ([`bend_asked`]): fitted again from there with the parameters in `all` (the sagitta free),
/// and kept when that costs less.
fn bent_if_asked(
    samples: &Samples,
    (p, cost): (Params, f32),
    clip: f32,
    all: &[bool; PARAMS],
) -> (Params, f32) {
    if !is_straight(&path_of(&p)) || !bend_asked(samples, &p, cost, clip, all) {
        return (p, cost);
    }
    match levenberg_marquardt(samples, p, clip, all) {
        Some(bent) if bent.1 < cost => bent,
        _ => (p, cost),
    }
}

/// Whether the pixels ask the fit `p` (of cost `cost`), fitted straight with its sagitta
/// held, to bend: a score test on the sagitta, the Gauss–Newton step it asks of it against its
/// standard deviation, both from the curvature with every parameter in `all` free.
///
/// A path drawn straight is one piece, whose ends do not move with the sagitta, so a fit
/// started straight (the rough middle on the chord, as a stadium's always is) could never
/// bend: a 60 px arc in a 39 px clipped halo (independent scene 28 of seed 3) stayed straight
/// in every frame, its head 2.3–3 px off across the path (median 2.91 px; 0.81 px with the
/// test). Freeing the bend on every straight start let straight streaks bend to their noise
/// instead: on the sweep's seed 11 a 60 px line (point 94) took sagittas of 0.1–0.6 px, each
/// within 1.2 of its deviations, and 4 points went out to none brought in. The test bends
/// only a path the pixels call bent.
fn bend_asked(samples: &Samples, p: &Params, cost: f32, clip: f32, all: &[bool; PARAMS]) -> bool {
    let Some((mut jtj, mut jtr)) = normal_equations(samples, p, clip, all, None) else {
        return false;
    };
    hold_inactive(&mut jtj, &mut jtr, all);
    let Some(covariance) = covariance_of(&jtj) else {
        return false;
    };
    let residual_var = cost / (samples.len.saturating_sub(PARAMS).max(1)) as f32;
    let step = (covariance * jtr)[SAGITTA];
    let deviation = (covariance[(SAGITTA, SAGITTA)] * residual_var)
        .max(0.0)
        .sqrt();
    step.abs() > BEND_DEVIATIONS * deviation
}

/// What a fit starts from: the samples, the rough path, the floor around it.
struct Start<'a> {
    samples: &'a Samples,
    path: [f32; PATH_PARAMS],
    /// The flat floor's start: the floor seen around the streak where no sampled pixel's own
    /// floor was learned (and some around it was), else the samples' low percentile. Inside a
    /// wide glow every sampled pixel is lit, and that percentile is the glow (226 luma on a
    /// floor of 163, sweep seed 13 point 70): started there, the fit settled with the floor
    /// high and the path long in a track's first frame (independent scenes seed 1: 21–33 %
    /// long in scenes 2 and 30, where the floor around the streak was learned and the floor
    /// under it not yet).
    floor_luma: f32,
    clip: f32,
    /// The parameters fitted in the full stage.
    all: &'a [bool; PARAMS],
}

impl Start<'_> {
    /// The model's parameters with the rough path, the spot `shape` and the flat floor at
    /// the samples' low percentile seen through the shape's tone curve.
    fn params(&self, shape: &[f32; PARAMS - PATH_PARAMS]) -> Params {
        let mut p = Params::zeros();
        for (v, &x) in p.iter_mut().zip(self.path.iter().chain(shape)) {
            *v = x;
        }
        p[FLAT_FLOOR] = (self.floor_luma / self.clip)
            .clamp(0.01, 0.95)
            .powf(1.0 / p[TONE]);
        fitted(&p)
    }

    /// From the spot of a recent frame, with the path where the rough one lies against it
    /// as that fit's did: everything at once, one stage. The glow starts afresh at its usual
    /// width and share around the core: carried over, a glow that had collapsed onto the core
    /// (the two then trade light freely) stayed there, and the path's uncertainty, read
    /// through that nearly singular curvature, ran to tens of pixels, which the still rule
    /// then took for a still LED.
    fn warm(&self, spot: &SpotFit) -> Option<(Params, f32)> {
        let start = Start {
            path: spot.offset.apply(self.path),
            ..*self
        };
        let mut shape = spot.shape;
        shape[GLOW_WIDTH - PATH_PARAMS] = shape[CORE_WIDTH - PATH_PARAMS] + GLOW_WIDTH0.ln();
        shape[GLOW_RATIO - PATH_PARAMS] = GLOW_RATIO0;
        let p = clamp_fitted(start.params(&shape));
        levenberg_marquardt(self.samples, p, self.clip, &start.active())
    }

    /// The parameters to fit from this start: all of them, but the sagitta held where the
    /// start is straight (see [`bend_asked`]).
    fn active(&self) -> [bool; PARAMS] {
        sagitta_held_if_straight(self.all, &self.path)
    }

    /// From scratch: from the streak's thickness ([`Start::by_thickness`]) and, where the
    /// spot is clipped, also from the clipped region's radius ([`Start::by_clip_radius`]).
    /// The second is kept only where it ends better than the first by more than fitting the
    /// noise explains: two minima of the same twelve parameters whose costs differ by less
    /// than about twelve residual variances are not told apart by the pixels (on a Moffat
    /// spot, outside the model's family, the narrow core then won by the noise alone and
    /// read the lengths no better).
    fn cold(&self, thickness_px: f32, clip_radius_px: Option<f32>) -> Option<(Params, f32)> {
        let wide = self.by_thickness(thickness_px);
        let narrow = clip_radius_px.and_then(|r| self.by_clip_radius(r, thickness_px));
        let dof = self.samples.len.saturating_sub(PARAMS).max(1) as f32;
        match (wide, narrow) {
            (Some(w), Some(n)) if n.1 * (1.0 + PARAMS as f32 / dof) < w.1 => Some(n),
            (w, n) => w.or(n),
        }
    }

    /// From a core as narrow as the clipped region's caps say (`clip_radius_px`), held while
    /// a glow as wide as the streak's `thickness_px` says, the tone, brightness and path
    /// settle; then everything. A core clipped `A` times clips out to `σ √(2 ln A)`, so the
    /// core starts at a third of the radius (a core clipped about a hundredfold; the fit
    /// finds its width from there). On a bloom clipped far into its glow, nearly every
    /// unclipped pixel is glow, and the start from the thickness fits its core alone first:
    /// that core takes the glow's width, and the fit stays there (a core of 1.31 px clipped
    /// 14× was fitted 4.8–8.5 px wide, and its 8.3 px line read 9.0–17.6 px long). A result
    /// whose core, tone or glow share lies at its bound is a corner this start ran into, not a
    /// fit, and is dropped.
    fn by_clip_radius(&self, clip_radius_px: f32, thickness_px: f32) -> Option<(Params, f32)> {
        let (samples, clip, all) = (self.samples, self.clip, &self.active());
        let sigma0 = (clip_radius_px / CLIP_RADIUS_SIGMAS).clamp(SIGMA_RANGE_PX.0, MAX_SIGMA0_PX);
        let glow0 = (THICKNESS_SIGMAS * thickness_px).max(GLOW_WIDTH0 * sigma0);
        let p = self.params(&[
            sigma0.ln(),
            glow0.ln(),
            AMPLITUDE0.ln(),
            GLOW_RATIO0,
            TONE0,
            0.0,
            0.0,
        ]);
        let mut glow_first = *all;
        glow_first[CORE_WIDTH] = false;
        let (p, _) = levenberg_marquardt(samples, p, clip, &glow_first)?;
        let (p, cost) = levenberg_marquardt(samples, p, clip, all)?;
        let n = native(&p);
        (off_its_bounds(n[CORE_WIDTH].exp(), SIGMA_RANGE_PX)
            && off_its_bounds(n[TONE], TONE_RANGE)
            && n[GLOW_RATIO] < 0.99)
            .then_some((p, cost))
    }

    /// From scratch: the spot's width from the streak's `thickness_px`, its usual glow and
    /// tone.
    fn by_thickness(&self, thickness_px: f32) -> Option<(Params, f32)> {
        let (samples, clip, all) = (self.samples, self.clip, &self.active());
        let sigma0 = (THICKNESS_SIGMAS * thickness_px).clamp(0.7, MAX_SIGMA0_PX);
        let mut p = self.params(&[
            sigma0.ln(),
            (GLOW_WIDTH0 * sigma0).ln(),
            AMPLITUDE0.ln(),
            0.0,
            TONE0,
            0.0,
            0.0,
        ]);
        // First the core alone (no glow), which has one clear minimum near the start; then
        // everything, from there. Started together, a wide core and a glow can settle into a
        // wrong minimum that stretches the path.
        let mut core_only = *all;
        core_only[6] = false;
        core_only[8] = false;
        let (core, core_cost) = levenberg_marquardt(samples, p, clip, &core_only)?;
        p = core;
        p[8] = GLOW_RATIO0;
        let (p, cost) = levenberg_marquardt(samples, p, clip, all)?;
        // The glow, started at its usual share, can upset a spot that has none (its core's
        // amplitude and tone) and end worse than the core alone did: then again from the core
        // alone, with no glow to start with, which can only end better.
        if cost > core_cost {
            return levenberg_marquardt(samples, core, clip, all);
        }
        Some((p, cost))
    }
}

/// Whether the fitted `value` lies clear of both ends of its `(low, high)` range (by 1 %): one
/// held at a bound is where the fit ran into it, not what the pixels say.
fn off_its_bounds(value: f32, (low, high): (f32, f32)) -> bool {
    value > low + 0.01 * low.abs() && value < 0.99 * high
}

/// Keeps the spot's widths, the amplitude, glow ratio, tone exponent and floor where they
/// mean something, so that one wild step cannot carry the fit into a degenerate corner (a
/// vanishing exponent with a huge amplitude fits a flat streak as well as anything).
fn clamp_params(mut p: Params) -> Params {
    // At most a half circle in one exposure.
    let half_chord = 0.5 * (p[2] - p[0]).hypot(p[3] - p[1]);
    p[4] = p[4].clamp(-half_chord, half_chord);
    p[5] = p[5].clamp(SIGMA_RANGE_PX.0.ln(), SIGMA_RANGE_PX.1.ln());
    // The glow is the wider and the dimmer of the two components.
    p[6] = p[6].clamp(p[5], (2.0 * SIGMA_RANGE_PX.1).ln());
    p[LN_AMPLITUDE] = p[LN_AMPLITUDE].max(MIN_AMPLITUDE.ln());
    p[8] = p[8].clamp(0.0, 1.0);
    p[9] = p[9].clamp(TONE_RANGE.0, TONE_RANGE.1);
    p[10] = p[10].clamp(0.0, 1.0);
    p[11] = p[11].clamp(0.0, 1.0);
    p
}

/// The tone index in the parameters.
const TONE: usize = 9;

/// The fitted parameters of the model's `p`: the spot's widths and amplitude as the pixels
/// see them through the tone curve: `ln σ − ½ ln k` for each width (a Gaussian seen through
/// `v^k` is `1/√k` as wide) and `k ln A` for the amplitude (its peak's log luma). The model is
/// nearly unchanged along `σ²/k` and `A^k` constant (exactly so across the path, on a dark
/// floor), a curved valley in `(ln σ, ln A, k)` that Levenberg–Marquardt's straight steps
/// crept along to the iteration cap; in these coordinates the valley runs along `k` alone.
fn fitted(p: &Params) -> Params {
    let mut t = *p;
    let half_ln_k = 0.5 * p[TONE].ln();
    t[5] -= half_ln_k;
    t[6] -= half_ln_k;
    t[LN_AMPLITUDE] *= p[TONE];
    t
}

/// The model's parameters of the fitted `t` (the inverse of [`fitted`]).
fn native(t: &Params) -> Params {
    let mut p = *t;
    let half_ln_k = 0.5 * t[TONE].ln();
    p[5] += half_ln_k;
    p[6] += half_ln_k;
    p[LN_AMPLITUDE] /= t[TONE];
    p
}

/// [`clamp_params`] on fitted parameters.
fn clamp_fitted(mut t: Params) -> Params {
    t[TONE] = t[TONE].clamp(TONE_RANGE.0, TONE_RANGE.1);
    fitted(&clamp_params(native(&t)))
}

/// Holds the parameters not `active` in the normal equations `jtj`, `jtr`: their rows and
/// columns zero, a unit diagonal, so that a step leaves them where they are and the matrix
/// stays invertible.
fn hold_inactive(jtj: &mut Normal, jtr: &mut Params, active: &[bool; PARAMS]) {
    for (i, &on) in active.iter().enumerate() {
        if !on {
            jtj.row_mut(i).fill(0.0);
            jtj.column_mut(i).fill(0.0);
            jtj[(i, i)] = 1.0;
            jtr[i] = 0.0;
        }
    }
}

/// Levenberg–Marquardt from `p` over the parameters marked `active` (the others stay
/// put), at most [`MAX_ITERATIONS`] iterations. Returns the parameters and the cost.
fn levenberg_marquardt(
    samples: &Samples,
    mut p: Params,
    clip: f32,
    active: &[bool; PARAMS],
) -> Option<(Params, f32)> {
    let mut cost = cost_of(samples, &p, clip, active, f32::INFINITY)?;
    let mut lambda = 1e-2f32;
    for _ in 0..MAX_ITERATIONS {
        let (mut jtj, mut jtr) = normal_equations(samples, &p, clip, active, None)?;
        hold_inactive(&mut jtj, &mut jtr, active);
        let mut improved = false;
        for _ in 0..4 {
            let mut damped = jtj;
            for i in 0..PARAMS {
                damped[(i, i)] += lambda * jtj[(i, i)].max(1e-6);
            }
            let Some(mut step) = damped.cholesky().map(|c| c.solve(&jtr)) else {
                lambda *= 10.0;
                continue;
            };
            // A trust region on the path: no point of it moves more than a few pixels a step.
            let reach = step.rows(0, PATH_PARAMS).amax();
            if reach > MAX_PATH_STEP_PX {
                step *= MAX_PATH_STEP_PX / reach;
            }
            let trial = clamp_fitted(p + step);
            match cost_of(samples, &trial, clip, active, cost) {
                Some(c) if c < cost => {
                    let path_moved_px = (trial - p).rows(0, PATH_PARAMS).amax();
                    let converged = (cost - c) < CONVERGED_COST * cost
                        || (path_moved_px < SETTLED_PATH_PX && (cost - c) < SETTLED_COST * cost);
                    p = trial;
                    cost = c;
                    lambda = (lambda * 0.3).max(1e-6);
                    improved = !converged;
                    break;
                }
                _ => lambda *= 10.0,
            }
        }
        if !improved {
            break;
        }
    }
    Some((p, cost))
}

fn dist(a: (f32, f32), b: (f32, f32)) -> f32 {
    (a.0 - b.0).hypot(a.1 - b.1)
}

/// Signed distance of `mid` from the chord `a → b`, along the chord's left normal.
fn sagitta_of(a: (f32, f32), b: (f32, f32), mid: (f32, f32)) -> f32 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len = dx.hypot(dy);
    if len < 1e-3 {
        return 0.0;
    }
    let (mx, my) = (0.5 * (a.0 + b.0), 0.5 * (a.1 + b.1));
    ((mid.0 - mx) * -dy + (mid.1 - my) * dx) / len
}

/// The arc of parameters `p`, drawn as straight pieces ([`ArcPieces`]).
struct Path {
    /// Each piece's start, unit direction and length; the first `arc.count` are drawn.
    pieces: [Piece; MAX_PIECES],
    length: f32,
    /// The corners and their slopes in the path's parameters, for the derivatives.
    arc: ArcPieces,
    /// The core's and the glow's σ as the pixels see them: widened by the pixel's own area
    /// ([`PIXEL_VARIANCE_PX2`]).
    sigmas: [f32; 2],
    /// How the seen σ's logarithm moves with the spot's own (`σ² / σ_seen²`): the lights'
    /// slopes are taken in the seen σ and carried to the fitted one by it.
    ln_sigma_slopes: [f32; 2],
    /// Components whose light is drawn: the core alone while the glow is left out (the
    /// first stage), which halves that stage's cost.
    components: usize,
    /// The light laid along the path per pixel of it, relative to its mean, is
    /// `1 + gradient (s/L − ½)` at `s` of the path's `L` from its start: an LED that speeds
    /// up during the exposure lays less light at its fast end (see [`Samples::gradient`]).
    gradient: f32,
}

#[derive(Clone, Copy, Default)]
struct Piece {
    start: (f32, f32),
    unit: (f32, f32),
    length: f32,
}

impl Path {
    /// The path of `p`, with the glow's light drawn when `glow` (else it reads zero), and
    /// the light laid along it with `gradient` ([`Path::gradient`]).
    fn new(p: &Params, glow: bool, gradient: f32) -> Path {
        Path::drawn(p, glow, ArcPieces::new(path_of(p), false), gradient)
    }

    /// The path of `p` with its corners' slopes in the path's parameters, for
    /// [`Path::lights`]; with `bend`, in at least two pieces, so that a straight path's
    /// sagitta has a slope too ([`ArcPieces::bendable`]).
    fn with_slopes(p: &Params, glow: bool, bend: bool, gradient: f32) -> Path {
        let arc = if bend {
            ArcPieces::bendable(path_of(p))
        } else {
            ArcPieces::new(path_of(p), true)
        };
        Path::drawn(p, glow, arc, gradient)
    }

    fn drawn(p: &Params, glow: bool, arc: ArcPieces, gradient: f32) -> Path {
        let mut pieces = [Piece::default(); MAX_PIECES];
        let mut length = 0.0;
        for (piece, ends) in pieces
            .iter_mut()
            .zip(arc.corners.windows(2))
            .take(arc.count)
        {
            let (s, e) = (ends[0], ends[1]);
            let l = dist(s, e);
            let unit = if l > 1e-6 {
                ((e.0 - s.0) / l, (e.1 - s.1) / l)
            } else {
                (1.0, 0.0)
            };
            *piece = Piece {
                start: s,
                unit,
                length: l,
            };
            length += l;
        }
        // The spot's own variances, which the pixel's area widens.
        let variances = [p[5], p[6]].map(|ln_sigma| ln_sigma.exp().powi(2));
        Path {
            pieces,
            length,
            arc,
            sigmas: variances.map(|v| (v + PIXEL_VARIANCE_PX2).sqrt()),
            ln_sigma_slopes: variances.map(|v| v / (v + PIXEL_VARIANCE_PX2)),
            components: if glow { 2 } else { 1 },
            gradient,
        }
    }

    fn length(&self) -> f32 {
        self.length
    }

    /// The light laid along a piece that starts `piece_start_px` along the path, per pixel
    /// of it, as `c0 + c1 τ` at `τ` along the piece (see [`Path::gradient`]).
    fn density_along(&self, piece_start_px: f32) -> (f32, f32) {
        let c1 = self.gradient / self.length;
        (1.0 + c1 * piece_start_px - 0.5 * self.gradient, c1)
    }

    /// The swept Gaussians' light at `(x, y)` (core, glow), each relative to a still spot's
    /// centre: the spot's line integral along the path over the path's length.
    fn light2(&self, x: f32, y: f32) -> (f32, f32) {
        let mut out = [0.0f32; 2];
        for (light, &sigma) in out.iter_mut().zip(&self.sigmas).take(self.components) {
            let inv = 1.0 / sigma;
            if self.length < STILL_PATH_SIGMAS * sigma {
                let (dx, dy) = (x - self.arc.mid.0, y - self.arc.mid.1);
                *light = (-0.5 * (dx * dx + dy * dy) * inv * inv).exp();
                continue;
            }
            let mut sum = 0.0;
            let mut start_px = 0.0;
            for piece in self.pieces.iter().take(self.arc.count) {
                let piece_start_px = start_px;
                start_px += piece.length;
                if piece.length < MIN_PIECE_PX {
                    continue;
                }
                let (px, py) = (x - piece.start.0, y - piece.start.1);
                let across = (px * -piece.unit.1 + py * piece.unit.0) * inv;
                if across.abs() > ACROSS_REACH_SIGMAS {
                    continue;
                }
                let along = (px * piece.unit.0 + py * piece.unit.1) * inv;
                if beyond_piece(along, piece.length * inv) {
                    continue;
                }
                let length = piece.length * inv;
                if self.gradient == 0.0 {
                    let span = normal_cdf(along) - normal_cdf(along - length);
                    if span > 0.0 {
                        sum += (-0.5 * across * across).exp() * span;
                    }
                    continue;
                }
                let (cdf_s, density_s) = normal_cdf_and_density(along);
                let (cdf_e, density_e) = normal_cdf_and_density(along - length);
                // In units of σ√(2π): the light laid evenly, and its first moment along the
                // piece over σ (see [`Path::swept_light`]).
                let even = cdf_s - cdf_e;
                let moment = along * even - (density_e - density_s);
                let (c0, c1) = self.density_along(piece_start_px);
                sum += (-0.5 * across * across).exp() * (c0 * even + c1 * sigma * moment);
            }
            *light = sum * SQRT_TAU * sigma / self.length;
        }
        (out[0], out[1])
    }

    /// The light of [`Path::light2`] with its derivatives in the path's parameters and in
    /// each component's `ln σ`, in closed form: one evaluation of each piece gives all
    /// of them, where differencing took a model evaluation per parameter.
    fn lights(&self, x: f32, y: f32) -> [Light; 2] {
        let mut out = [Light::default(); 2];
        for ((light, &sigma), &slope) in out
            .iter_mut()
            .zip(&self.sigmas)
            .zip(&self.ln_sigma_slopes)
            .take(self.components)
        {
            *light = if self.length < STILL_PATH_SIGMAS * sigma {
                self.still_light(x, y, sigma)
            } else {
                self.swept_light(x, y, sigma)
            };
            light.d_ln_sigma *= slope;
        }
        out
    }

    /// A still spot at the middle, `exp(−r²/2σ²)`: its slope in the middle is `r/σ² ·` that.
    fn still_light(&self, x: f32, y: f32, sigma: f32) -> Light {
        let inv2 = 1.0 / (sigma * sigma);
        let (dx, dy) = (x - self.arc.mid.0, y - self.arc.mid.1);
        let r2 = (dx * dx + dy * dy) * inv2;
        let value = (-0.5 * r2).exp();
        // The middle is the arc's point at half time.
        let path = self
            .arc
            .mid_gradient((value * dx * inv2, value * dy * inv2));
        Light {
            value,
            d_path: path,
            d_ln_sigma: value * r2,
        }
    }

    /// The swept spot. For one piece from `S` to `E` (length `L`, direction `d`, normal `n`),
    /// at a pixel `t` along it and `c` across it, the light is
    /// `I = e^(−c²/2σ²) σ√(2π) (Φ(t/σ) − Φ((t−L)/σ))`, whose slopes in `t`, `c`, `L` and `σ`
    /// are closed forms in the same normal densities; `t`, `c` and `L` move with the corners
    /// as `∂I/∂E = (I_t c/L − I_c t/L) n + I_L d` and `∂I/∂S = −∂I/∂X − ∂I/∂E`, with
    /// `∂I/∂X = I_t d + I_c n` (moving the pixel is moving the piece the other way).
    fn swept_light(&self, x: f32, y: f32, sigma: f32) -> Light {
        let inv = 1.0 / sigma;
        let (mut sum, mut d_sigma_sum) = (0.0f32, 0.0f32);
        // ∂(Σ I)/∂ corner, and the path's length per corner (∂L/∂E = d, ∂L/∂S = −d).
        let mut at_corners = [(0.0f32, 0.0f32); MAX_PIECES + 1];
        let mut length_at_corners = [(0.0f32, 0.0f32); MAX_PIECES + 1];
        // With a gradient, the light of a piece also moves with the whole length and with
        // where the piece starts along the path: ∂(Σ I)/∂(whole length), and per piece
        // ∂I/∂(its start along the path).
        let mut at_total = 0.0f32;
        let mut at_start = [0.0f32; MAX_PIECES];
        let mut start_px = 0.0f32;
        for (k, piece) in self.pieces.iter().enumerate().take(self.arc.count) {
            let piece_start_px = start_px;
            start_px += piece.length;
            let d = piece.unit;
            if let Some(s) = length_at_corners.get_mut(k) {
                *s = (s.0 - d.0, s.1 - d.1);
            }
            if let Some(e) = length_at_corners.get_mut(k + 1) {
                *e = (e.0 + d.0, e.1 + d.1);
            }
            if piece.length < MIN_PIECE_PX {
                continue;
            }
            let n = (-d.1, d.0);
            let (px, py) = (x - piece.start.0, y - piece.start.1);
            let across = (px * n.0 + py * n.1) * inv;
            if across.abs() > ACROSS_REACH_SIGMAS {
                continue;
            }
            let along = (px * d.0 + py * d.1) * inv;
            let length = piece.length * inv;
            if beyond_piece(along, length) {
                continue;
            }
            let (cdf_s, density_s) = normal_cdf_and_density(along);
            let (cdf_e, density_e) = normal_cdf_and_density(along - length);
            let span = cdf_s - cdf_e;
            if span <= 0.0 {
                continue;
            }
            // e^(−c²/2σ²) √(2π): the densities' constant folded in.
            let across_weight = (-0.5 * across * across).exp() * SQRT_TAU;
            let even = across_weight * sigma * span;
            let even_t = across_weight * (density_s - density_e);
            let even_sigma = even * (across * across + 1.0) * inv
                + across_weight * ((along - length) * density_e - along * density_s);
            let (i, i_t, i_l, i_sigma) = if self.gradient == 0.0 {
                (even, even_t, across_weight * density_e, even_sigma)
            } else {
                // The light laid evenly (B above) and its first moment along the piece,
                // M = ∫ τ e^(−(t−τ)²/2σ²) dτ = t B + σ² (e_0 − e_L), each times e^(−c²/2σ²)
                // (e the densities at the piece's ends, with the constant above): the piece's
                // light is c0 B + c1 M for the density c0 + c1 τ. M's slopes: in t,
                // B − L e_L; in L, L e_L; in σ, t ∂B/∂σ + 2σ (e_0 − e_L) + σ (u_0² e_0 −
                // u_L² e_L) with the across part c²/σ³ (M − t B) = c²/σ (e_0 − e_L) (u = the
                // ends' along / σ).
                let (c0, c1) = self.density_along(piece_start_px);
                let t_px = along * sigma;
                let ends = across_weight * (density_s - density_e);
                let at_end_density = piece.length * across_weight * density_e;
                let moment = t_px * even + sigma * sigma * ends;
                let moment_sigma = t_px * even_sigma
                    + 2.0 * sigma * ends
                    + sigma
                        * across_weight
                        * (along * along * density_s - (along - length).powi(2) * density_e)
                    + across * across * sigma * ends;
                let i = c0 * even + c1 * moment;
                at_total -=
                    self.gradient * (piece_start_px * even + moment) / (self.length * self.length);
                if let Some(a) = at_start.get_mut(k) {
                    *a = c1 * even;
                }
                (
                    i,
                    c0 * even_t + c1 * (even - at_end_density),
                    c0 * across_weight * density_e + c1 * at_end_density,
                    c0 * even_sigma + c1 * moment_sigma,
                )
            };
            let i_c = -across * inv * i;
            sum += i;
            d_sigma_sum += i_sigma;
            let bend = (i_t * across - i_c * along) / length;
            let at_end = (bend * n.0 + i_l * d.0, bend * n.1 + i_l * d.1);
            let at_pixel = (i_t * d.0 + i_c * n.0, i_t * d.1 + i_c * n.1);
            if let Some(s) = at_corners.get_mut(k) {
                *s = (s.0 - at_pixel.0 - at_end.0, s.1 - at_pixel.1 - at_end.1);
            }
            if let Some(e) = at_corners.get_mut(k + 1) {
                *e = (e.0 + at_end.0, e.1 + at_end.1);
            }
        }
        if self.gradient != 0.0 {
            self.gradient_slopes(&mut at_corners, &length_at_corners, &at_start, at_total);
        }
        // The light is Σ I / length: its slope is (∂ΣI − light ∂length) / length.
        let inv_length = 1.0 / self.length;
        let value = sum * inv_length;
        for (g, l) in at_corners.iter_mut().zip(&length_at_corners) {
            *g = (
                (g.0 - value * l.0) * inv_length,
                (g.1 - value * l.1) * inv_length,
            );
        }
        Light {
            value,
            d_path: self.arc.gradient(&at_corners),
            d_ln_sigma: sigma * d_sigma_sum * inv_length,
        }
    }

    /// Adds to `at_corners` (∂(Σ I)/∂ corner) what a gradient along the path adds: the whole
    /// length moves with every corner (`at_total` of light per pixel of it, along
    /// `length_at_corners`), and a piece's start along the path with the pieces before it
    /// (`at_start` per piece: piece j's length moves its end corner along its direction and
    /// its start corner against it).
    fn gradient_slopes(
        &self,
        at_corners: &mut [(f32, f32); MAX_PIECES + 1],
        length_at_corners: &[(f32, f32); MAX_PIECES + 1],
        at_start: &[f32; MAX_PIECES],
        at_total: f32,
    ) {
        let mut later = 0.0f32;
        for (j, piece) in self.pieces.iter().enumerate().take(self.arc.count).rev() {
            let d = piece.unit;
            if let Some(s) = at_corners.get_mut(j) {
                *s = (s.0 - later * d.0, s.1 - later * d.1);
            }
            if let Some(e) = at_corners.get_mut(j + 1) {
                *e = (e.0 + later * d.0, e.1 + later * d.1);
            }
            later += at_start.get(j).copied().unwrap_or(0.0);
        }
        for (c, l) in at_corners.iter_mut().zip(length_at_corners) {
            *c = (c.0 + at_total * l.0, c.1 + at_total * l.1);
        }
    }
}

/// One component's light at a pixel and its slopes.
#[derive(Clone, Copy, Default)]
struct Light {
    value: f32,
    /// In the path's parameters: start x, y, end x, y, sagitta.
    d_path: [f32; PATH_PARAMS],
    /// In the component's `ln σ`.
    d_ln_sigma: f32,
}

/// A pixel reads the mean of the light over its area, a unit square: along each axis, a box
/// of variance 1/12 px². The model's Gaussians are widened by it (a box is near enough a
/// Gaussian of its variance once blurred by the spot), so that a spot narrower than a pixel is
/// drawn as the pixels see it. Drawn at their centres alone, a 0.83 px disk's streak (sweep
/// seed 11, point 111) fitted σ at its lower bound, a residual of 9 luma and ends uncertain
/// by 11 px, so that the moving streak read still and its head came 3.5 px off.
const PIXEL_VARIANCE_PX2: f32 = 1.0 / 12.0;

/// A path shorter than this many σ is drawn as a still spot at its middle.
const STILL_PATH_SIGMAS: f32 = 1e-3;
/// A piece shorter than this draws nothing.
const MIN_PIECE_PX: f32 = 1e-6;
/// Pixels farther than this many σ across a piece, or beyond its ends, get none of its light.
const ACROSS_REACH_SIGMAS: f32 = 5.0;

const SQRT_TAU: f32 = 2.506_628_3;

/// Whether a pixel `along` σ along a piece `length` σ long lies beyond either end by more than
/// [`ACROSS_REACH_SIGMAS`]: the piece's light and slopes there are below 3·10⁻⁷ of a still
/// spot's, and an arc drawn by many pieces would otherwise evaluate every piece at every pixel.
#[inline]
fn beyond_piece(along: f32, length: f32) -> bool {
    along < -ACROSS_REACH_SIGMAS || along - length > ACROSS_REACH_SIGMAS
}

/// The floor in the model's linear light: where known, the measured one seen through the
/// fitted tone curve plus the fitted pedestal, else the fitted flat floor.
#[inline]
fn floor_of(p: &Params, floor_ln: Option<f32>) -> f32 {
    match floor_ln {
        Some(l) => (l / p[9]).exp() + p[PEDESTAL],
        None => p[10],
    }
}

/// The model's luma at a pixel, `clip · (floor + A (core + r glow))^k`, with the light `Q =
/// core + r glow` and the glow's light there.
#[inline]
fn model(
    path: &Path,
    p: &Params,
    (x, y): (f32, f32),
    floor_ln: Option<f32>,
    clip: f32,
) -> (f32, (f32, f32)) {
    let (core, glow) = path.light2(x, y);
    let q = core + p[8].max(0.0) * glow;
    let v = (floor_of(p, floor_ln) + p[LN_AMPLITUDE].exp() * q).max(1e-6);
    (clip * (p[9] * v.ln()).exp(), (q, glow))
}

/// A sample's residual: luma minus model, or for a clipped pixel how far the model falls
/// short of the clip level (zero when it reaches it).
#[inline]
fn residual(luma: f32, model: f32, clip: f32) -> f32 {
    if luma >= clip {
        (clip - model).max(0.0)
    } else {
        luma - model
    }
}

/// The sum of squared residuals at `p` (the glow drawn only when it is `active`), or, once
/// the sum reaches `bound`, the partial sum (itself at least `bound`). A trial step is taken
/// only when its cost is below the current one, and a sum of squares only grows, so the
/// pixels after that point cannot change the verdict: a rejected trial mostly stops early.
fn cost_of(s: &Samples, p: &Params, clip: f32, active: &[bool; PARAMS], bound: f32) -> Option<f32> {
    let mut cost = prior_cost(s, p);
    let p = &native(p);
    let path = Path::new(p, active[GLOW_RATIO], s.gradient);
    for ((&xy, &luma), &floor_ln) in s.xy.iter().zip(&s.luma).zip(&s.floor_ln).take(s.len) {
        let r = residual(luma, model(&path, p, xy, floor_ln, clip).0, clip);
        cost += r * r;
        if cost >= bound {
            break;
        }
    }
    cost.is_finite().then_some(cost)
}

/// `JᵀJ` and `Jᵀr` at `p`, with the model's derivatives in closed form (see
/// [`Path::lights`]), and into `spread`, when given, `Jᵀ diag(r²) J` (see [`finish`]).
/// Derivatives of parameters not `active` are left zero.
fn normal_equations(
    s: &Samples,
    p: &Params,
    clip: f32,
    active: &[bool; PARAMS],
    mut spread: Option<&mut Normal>,
) -> Option<(Normal, Params)> {
    let fit = p;
    let p = &native(fit);
    let path = Path::with_slopes(p, active[GLOW_RATIO], active[SAGITTA], s.gradient);
    let ratio = p[GLOW_RATIO].max(0.0);
    let inv_k = 1.0 / p[TONE];
    let amplitude = p[LN_AMPLITUDE].exp();
    let mut jtj = Normal::zeros();
    let mut jtr = Params::zeros();
    for ((&(x, y), &luma), &floor_ln) in s.xy.iter().zip(&s.luma).zip(&s.floor_ln).take(s.len) {
        let [core, glow] = path.lights(x, y);
        let q = core.value + ratio * glow.value;
        let floor = floor_of(p, floor_ln);
        let v = (floor + amplitude * q).max(1e-6);
        let m = clip * (p[9] * v.ln()).exp();
        // A clipped pixel the model already reaches carries no gradient.
        if luma >= clip && m >= clip {
            continue;
        }
        let r = residual(luma, m, clip);
        let slope = p[9] * m / v;
        let light_slope = slope * amplitude;
        let mut row = Params::zeros();
        for (j, (c, g)) in core.d_path.iter().zip(&glow.d_path).enumerate() {
            row[j] = light_slope * (c + ratio * g);
        }
        row[5] = light_slope * core.d_ln_sigma;
        row[6] = light_slope * ratio * glow.d_ln_sigma;
        row[LN_AMPLITUDE] = light_slope * q;
        row[8] = light_slope * glow.value;
        row[9] = m * v.ln();
        match floor_ln {
            // A measured floor moves with the tone curve: d floor / dk = -floor · l / k².
            Some(l) => {
                row[9] -= slope * (floor - p[PEDESTAL]) * l / (p[9] * p[9]);
                row[PEDESTAL] = slope;
            }
            None => row[10] = slope,
        }
        // To the fitted parameters (see [`fitted`]).
        row[TONE] +=
            0.5 * inv_k * (row[5] + row[6]) - row[LN_AMPLITUDE] * fit[LN_AMPLITUDE] * inv_k * inv_k;
        row[LN_AMPLITUDE] *= inv_k;
        for (value, &on) in row.iter_mut().zip(active) {
            if !on {
                *value = 0.0;
            }
        }
        let outer = row * row.transpose();
        if let Some(spread) = spread.as_deref_mut() {
            *spread += outer * (r * r);
        }
        jtj += outer;
        jtr += row * r;
    }
    // The prior on the tone exponent, a pseudo-pixel whose residual is its distance from the
    // prior (`k` is the same in the fitted coordinates).
    if let Some((tone, weight)) = s.tone_prior.filter(|_| active[TONE]) {
        jtj[(TONE, TONE)] += weight;
        jtr[TONE] += weight * (tone - fit[TONE]);
    }
    (jtr.iter().all(|v| v.is_finite())).then_some((jtj, jtr))
}

/// The cost of the prior on the tone exponent at the fitted `p` (0 without one).
fn prior_cost(s: &Samples, p: &Params) -> f32 {
    s.tone_prior
        .map_or(0.0, |(tone, weight)| weight * (p[TONE] - tone).powi(2))
}

/// Squared distance from `(x, y)` to the polyline `a → mid → b` (squared, so that the
/// collection's two passes over the streak's box take no square root per pixel).
pub(super) fn distance2_to_rough(rough: &Rough, x: f32, y: f32) -> f32 {
    let [a, b] = rough.ends_px;
    segment_distance2(a, rough.mid_px, x, y).min(segment_distance2(rough.mid_px, b, x, y))
}

/// The columns of row `y` that can lie within `reach` of the rough polyline `a → mid → b`,
/// as a span `(left, right)` that holds them all (`None` when none can): a pixel within
/// `reach` of a segment lies within `reach` across of the segment's part within `reach` of
/// its row, so its column lies within `reach` of that part's columns.
pub(super) fn row_span(rough: &Rough, y: f32, reach: f32) -> Option<(f32, f32)> {
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
fn collect(
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
    let mut s = Samples {
        xy: [(0.0, 0.0); MAX_FIT_PX],
        luma: [0.0; MAX_FIT_PX],
        floor_ln: [None; MAX_FIT_PX],
        len: 0,
        around_luma: None,
        tone_prior: None,
        gradient: 0.0,
    };
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
fn clip_radius_px(frame: &Frame<'_>, rough: &Rough, clip: f32) -> Option<f32> {
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
fn low_percentile(s: &Samples) -> f32 {
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
    use crate::frame::PixelFormat;

    /// Parameters of a path from `a` to `b` with sagitta `sagitta`, core σ `sigma`, a glow
    /// three times wider at a tenth of the light, a 2.2 tone and both floors.
    fn params(a: (f32, f32), b: (f32, f32), sagitta: f32, sigma: f32) -> Params {
        Params::from_column_slice(&[
            a.0,
            a.1,
            b.0,
            b.1,
            sagitta,
            sigma.ln(),
            (3.0 * sigma).ln(),
            1.5f32.ln(),
            0.1,
            0.45,
            0.08,
            0.02,
        ])
    }

    /// Straight, bent, short and still paths, and a wide spot on a short bent one.
    fn paths() -> [Params; 5] {
        [
            params((10.0, 12.0), (40.0, 20.0), 0.0, 1.2),
            params((10.0, 12.0), (35.0, 30.0), 6.0, 0.9),
            params((20.0, 20.0), (21.2, 20.5), 0.3, 1.5),
            params((20.0, 20.0), (20.0, 20.0), 0.0, 1.5),
            params((15.0, 25.0), (24.0, 18.0), -3.0, 3.0),
        ]
    }

    /// Pixels on, beside and beyond the ends of the path of `p`.
    fn pixels_around(p: &Params) -> impl Iterator<Item = (f32, f32)> {
        let (a, b) = ((p[0], p[1]), (p[2], p[3]));
        let path = Path::new(p, true, 0.0);
        let mid = path.arc.mid;
        let spread = 2.0 * p[5].exp();
        [a, b, mid, (0.5 * (a.0 + mid.0), 0.5 * (a.1 + mid.1))]
            .into_iter()
            .flat_map(move |(x, y)| {
                [
                    (0.0, 0.0),
                    (0.7, -0.4),
                    (-1.1, 0.9),
                    (1.6, 1.3),
                    (-0.3, -2.1),
                ]
                .into_iter()
                .map(move |(dx, dy)| (x + dx * spread, y + dy * spread))
            })
    }

    #[test]
    fn the_lights_slopes_are_those_of_its_values() {
        // Laid evenly along the path, and unevenly (a fast end, then a slow one), whose
        // light's slopes have their own terms.
        for (gradient, p) in [0.0, 0.3, -0.6]
            .into_iter()
            .flat_map(|g| paths().map(move |p| (g, p)))
        {
            let path = Path::with_slopes(&p, true, false, gradient);
            // A still path stays still under the step: f32 cannot resolve the light of a
            // path a few thousandths of a pixel long, which is why that is drawn as a spot.
            let path_h = if path.length < 0.1 { 5e-4 } else { 2e-3 };
            for (x, y) in pixels_around(&p) {
                let lights = path.lights(x, y);
                let (core, glow) = path.light2(x, y);
                assert!((lights[0].value - core).abs() < 1e-6, "{p:?} at {x}, {y}");
                assert!((lights[1].value - glow).abs() < 1e-6, "{p:?} at {x}, {y}");
                for j in 0..PATH_PARAMS + 2 {
                    let h = if j < PATH_PARAMS { path_h } else { 1e-3 };
                    let light_at = |delta: f32| {
                        let mut q = p;
                        q[j] += delta;
                        Path::new(&q, true, gradient).light2(x, y)
                    };
                    let (plus, minus) = (light_at(h), light_at(-h));
                    let numeric = [
                        (plus.0 - minus.0) / (2.0 * h),
                        (plus.1 - minus.1) / (2.0 * h),
                    ];
                    let analytic = match j {
                        5 => [lights[0].d_ln_sigma, 0.0],
                        6 => [0.0, lights[1].d_ln_sigma],
                        _ => [lights[0].d_path[j], lights[1].d_path[j]],
                    };
                    for (n, a) in numeric.iter().zip(&analytic) {
                        assert!(
                            (n - a).abs() < 2e-3 + 1e-2 * n.abs(),
                            "parameter {j} of {p:?}, gradient {gradient}, at ({x}, {y}): differences \
                             {n}, closed form {a}"
                        );
                    }
                }
            }
        }
    }

    /// No samples yet.
    fn no_samples() -> Samples {
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

    /// Samples around the path of `truth`, its model's luma with a deterministic ripple, a
    /// few clipped; every third pixel's floor unmeasured.
    fn samples_of(truth: &Params, clip: f32) -> Samples {
        let mut s = no_samples();
        let path = Path::new(truth, true, 0.0);
        for (k, xy) in pixels_around(truth).enumerate() {
            let floor_ln = (k % 3 != 0)
                .then_some((40.0 + (k % 7) as f32) / clip)
                .map(f32::ln);
            let ripple = 6.0 * ((k as f32) * 1.7).sin();
            let luma = (model(&path, truth, xy, floor_ln, clip).0 + ripple).min(clip);
            s.xy[s.len] = xy;
            s.luma[s.len] = luma;
            s.floor_ln[s.len] = floor_ln;
            s.len += 1;
        }
        s
    }

    /// A cost bounded below the full one stops at or above the bound, so a trial is judged
    /// as the full sum would judge it, and a low bound stops before the last pixel; a bound
    /// above the full cost changes nothing.
    #[test]
    fn a_bounded_cost_keeps_the_verdict() {
        let clip = 250.0;
        let all = [true; PARAMS];
        for truth in paths() {
            let s = samples_of(&truth, clip);
            let mut p = truth;
            p[0] += 0.7;
            p[LN_AMPLITUDE] += 1.3f32.ln();
            let full = cost_of(&s, &p, clip, &all, f32::INFINITY).expect("finite");
            for bound in [0.1 * full, 0.5 * full, 0.99 * full] {
                let bounded = cost_of(&s, &p, clip, &all, bound).expect("finite");
                assert!(
                    bounded >= bound && bounded <= full,
                    "{truth:?}: bounded at {bound} the cost read {bounded} (full {full})"
                );
            }
            let early = cost_of(&s, &p, clip, &all, 0.1 * full).expect("finite");
            assert!(
                early < full,
                "{truth:?}: a tenth of the cost summed every pixel"
            );
            for bound in [full * 1.01, 2.0 * full] {
                let bounded = cost_of(&s, &p, clip, &all, bound).expect("finite");
                assert_eq!(bounded, full, "{truth:?}: bounded at {bound}");
            }
        }
    }

    /// The fitted coordinates read back as the model's, and a step in the tone alone keeps
    /// the spot as the pixels see it: its width `σ/√k` and its peak `A^k`.
    #[test]
    fn the_fitted_parameters_read_back() {
        for p in paths() {
            let back = native(&fitted(&p));
            for j in 0..PARAMS {
                assert!(
                    (back[j] - p[j]).abs() < 1e-5 * (1.0 + p[j].abs()),
                    "{p:?}: {back:?}"
                );
            }
            let mut steeper = fitted(&p);
            steeper[TONE] *= 1.5;
            let moved = native(&steeper);
            assert!(
                (moved[5] - p[5] - 0.5 * 1.5f32.ln()).abs() < 1e-5,
                "{moved:?}"
            );
            assert!((moved[TONE] * moved[LN_AMPLITUDE] - p[TONE] * p[LN_AMPLITUDE]).abs() < 1e-5);
        }
    }

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

    /// The offset of a fitted path against a rough one puts the same rough path back on the
    /// fitted one; the rough ends in the other order give the same path the other way; and
    /// a streak turned (rough and fitted together) is offset turned with it.
    #[test]
    fn a_path_offset_carries_over() {
        for p in paths() {
            let rough = [(p[0] + 1.3, p[1] - 0.4), (p[2] - 0.9, p[3] + 0.6)];
            let rough_path = [rough[0].0, rough[0].1, rough[1].0, rough[1].1, 0.0];
            let offset = PathOffset::of(rough, &p);
            if dist(rough[0], rough[1]) < MIN_CHORD_PX {
                continue;
            }
            let same = offset.apply(rough_path);
            let swapped = offset.apply([rough[1].0, rough[1].1, rough[0].0, rough[0].1, 0.0]);
            let expected = path_of(&p);
            let expected_swapped = [p[2], p[3], p[0], p[1], -p[4]];
            for j in 0..PATH_PARAMS {
                assert!((same[j] - expected[j]).abs() < 1e-3, "{p:?}: {same:?}");
                assert!(
                    (swapped[j] - expected_swapped[j]).abs() < 1e-3,
                    "{p:?}: {swapped:?}"
                );
            }
            // A quarter turn about the origin: (x, y) -> (-y, x).
            let turn = |(x, y): (f32, f32)| (-y, x);
            let (ta, tb) = (turn(rough[0]), turn(rough[1]));
            let turned = offset.apply([ta.0, ta.1, tb.0, tb.1, 0.0]);
            let (fa, fb) = (turn((p[0], p[1])), turn((p[2], p[3])));
            for (j, v) in [fa.0, fa.1, fb.0, fb.1, p[4]].into_iter().enumerate() {
                assert!((turned[j] - v).abs() < 1e-3, "{p:?} turned: {turned:?}");
            }
        }
    }

    /// A warm start from the spot of a cold fit of the same pixels, at a rough path a pixel
    /// or two off, ends about as well as the cold fit did, with its ends on the cold fit's.
    /// Checked on the paths whose cold fit found the truth's ends (the test's pixels are few
    /// and rippled: on the bent path the cold fit's own ends are 2 px off), at least one.
    #[test]
    fn a_warm_start_finds_the_spot_again() {
        let clip = 250.0;
        let mut checked = 0;
        for truth in paths()
            .into_iter()
            .filter(|p| dist((p[0], p[1]), (p[2], p[3])) > 5.0)
        {
            let s = samples_of(&truth, clip);
            let mut all = [true; PARAMS];
            all[FLAT_FLOOR] = s.floor_ln.iter().take(s.len).any(Option::is_none);
            all[PEDESTAL] = s.floor_ln.iter().take(s.len).any(Option::is_some);
            let rough = [(truth[0] + 1.5, truth[1]), (truth[2] - 1.0, truth[3] + 0.5)];
            let start = Start {
                samples: &s,
                path: [rough[0].0, rough[0].1, rough[1].0, rough[1].1, 0.0],
                floor_luma: low_percentile(&s),
                clip,
                all: &all,
            };
            let (cold, cold_cost) = start.cold(4.0, None).expect("a cold fit");
            if (0..4).any(|j| (cold[j] - truth[j]).abs() > 1.0) {
                continue;
            }
            checked += 1;
            let spot = SpotFit {
                shape: core::array::from_fn(|i| native(&cold)[PATH_PARAMS + i]),
                cost_per_px: cold_cost / s.len as f32,
                offset: PathOffset::of(rough, &native(&cold)),
                tone: ToneMemory::default(),
                travel: Travel::default(),
            };
            let (warm, warm_cost) = start.warm(&spot).expect("a warm fit");
            assert!(
                warm_cost <= WARM_COST_RATIO * cold_cost,
                "{truth:?}: warm cost {warm_cost}, cold {cold_cost}"
            );
            for j in 0..4 {
                assert!(
                    (warm[j] - cold[j]).abs() < 0.3,
                    "{truth:?}: warm {warm:?}, cold {cold:?}"
                );
            }
        }
        assert!(checked > 0, "no cold fit found its path");
    }

    /// A track's first frames: the frame before lit the floor under and around the streak, so
    /// no pixel the fit reads has its floor learned, but the floor farther out was. Streaks
    /// of the model's own family with glows 3-6 times the core and 4-10 % as bright, clipped
    /// 6-20 times over, on a floor textured 30 luma deep: every sampled pixel is in the glow,
    /// and the flat floor started at their low percentile settled high with the path long
    /// (+27, +15, +7, 0 and +55 %). Started at the floor around them, the lengths are within
    /// the issue's bound on the single frame's speed (10 %, p95) on average (they were off by
    /// -10, -9, -4, +2 and +5 %); two of the seven streaks do not fit either way.
    #[test]
    fn a_streak_on_a_floor_never_seen_starts_its_floor_at_the_floor_around_it() {
        let (width, height) = (200usize, 140usize);
        let size = FrameSize::new(width as u32, height as u32).unwrap();
        let clip = 250.0;
        let floor_luma = |x: usize, y: usize| 50.0 + ((x * 7 + y * 13) % 31) as f32;
        let floor_bytes: Vec<u8> = (0..width * height)
            .map(|i| floor_luma(i % width, i / width) as u8)
            .collect();
        let floor_frame =
            Frame::new_checked_as(&floor_bytes, size, width, PixelFormat::Grey).unwrap();
        // The frame before: its light covered x 40..=160, y 30..=110.
        let lit = crate::detect::blobs::Blob::boxed(40, 30, 160, 110);
        let mut background = FloorBackground::new(size);
        background.update(&floor_frame, [lit].iter(), |_| 0);
        // (core σ, glow width over σ, glow ratio, core's peak over the clip, path length).
        let streaks = [
            (1.5f32, 4.0f32, 0.08f32, 10.0f32, 24.0f32),
            (1.5, 6.0, 0.05, 10.0, 24.0),
            (2.0, 5.0, 0.1, 15.0, 12.0),
            (1.0, 5.0, 0.06, 8.0, 40.0),
            (2.5, 4.0, 0.08, 20.0, 20.0),
            (1.2, 4.0, 0.04, 6.0, 30.0),
            (1.8, 3.0, 0.1, 12.0, 16.0),
        ];
        let mut errors = Vec::new();
        for (sigma, glow_width, glow_ratio, peak, length) in streaks {
            let (a, b) = ((100.0 - length / 2.0, 70.0), (100.0 + length / 2.0, 70.0));
            let mut truth = params(a, b, 0.0, sigma);
            truth[GLOW_WIDTH] = (glow_width * sigma).ln();
            truth[GLOW_RATIO] = glow_ratio;
            truth[PEDESTAL] = 0.0;
            let path = Path::new(&truth, true, 0.0);
            let (core, glow) = path.light2(100.0, 70.0);
            truth[LN_AMPLITUDE] = (peak / (core + glow_ratio * glow)).ln();
            let mut state = 5u32;
            let bytes: Vec<u8> = floor_bytes
                .iter()
                .enumerate()
                .map(|(i, &floor)| {
                    let (x, y) = ((i % width) as f32, (i / width) as f32);
                    let floor_ln = Some((f32::from(floor) / clip).ln());
                    let value = model(&path, &truth, (x, y), floor_ln, clip).0;
                    (value + noise(&mut state, 2.0)).clamp(0.0, clip).round() as u8
                })
                .collect();
            let frame = Frame::new_checked_as(&bytes, size, width, PixelFormat::Grey).unwrap();
            let rough = Rough {
                ends_px: [(a.0 + 2.0, 70.0), (b.0 - 2.0, 70.0)],
                mid_px: (100.0, 70.0),
                thickness_px: 8.0,
            };
            let shape = SpotShape::identity();
            if let Ok(f) = fit(&frame, &rough, 250, Some(&background), shape, None, false) {
                assert_eq!(f.floor_measured, 0.0, "no pixel's floor was learned");
                errors.push((f.path_length_px - length) / length);
            }
        }
        assert!(errors.len() >= 5, "{errors:?}");
        let mean = errors.iter().map(|e| e.abs()).sum::<f32>() / errors.len() as f32;
        assert!(mean <= 0.10, "{errors:?}");
    }

    /// [`fit`] on a frame clipped at 250, with no floor learned, no lens and no spot from an
    /// earlier frame.
    fn plain_fit(frame: &Frame<'_>, rough: &Rough) -> Result<PathFit, NoFit> {
        fit(frame, rough, 250, None, SpotShape::identity(), None, false)
    }

    /// A pseudo-random noise of up to `amplitude` either way, from the generator `state`.
    fn noise(state: &mut u32, amplitude: f32) -> f32 {
        *state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        amplitude * ((*state >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0)
    }

    /// [`plain_fit`] on the grey frame `bytes` of `size`, which must give a path.
    fn plain_fit_of(bytes: &[u8], size: FrameSize, rough: &Rough) -> PathFit {
        let frame = Frame::new_checked_as(bytes, size, size.width(), PixelFormat::Grey).unwrap();
        plain_fit(&frame, rough).expect("a path")
    }

    /// An LED at `s(t) = v0 t + a t² / 2` pixels along a line (times in frames), seen by a
    /// camera that exposes `exposure` of each frame around the frame's time: where it was at
    /// the start and end of frame `k`'s exposure.
    struct Speeding {
        v0: f32,
        a: f32,
        exposure: f32,
        origin: (f32, f32),
        unit: (f32, f32),
    }

    impl Speeding {
        fn at(&self, t: f32) -> (f32, f32) {
            let s = self.v0 * t + 0.5 * self.a * t * t;
            (
                self.origin.0 + s * self.unit.0,
                self.origin.1 + s * self.unit.1,
            )
        }

        fn ends(&self, k: f32) -> [(f32, f32); 2] {
            [-0.5, 0.5].map(|h| self.at(k + h * self.exposure))
        }

        /// Frame `k` through `camera` on a floor of 20, a Gaussian spot of `sigma_px` `gain`
        /// times brighter than the clip at 250: the spot's light averaged over 400 instants
        /// of the exposure, each pixel over 3 × 3 points of its area.
        fn render(
            &self,
            k: f32,
            sigma_px: f32,
            gain: f32,
            camera: &Camera,
            size: FrameSize,
        ) -> Vec<u8> {
            let mut noise = camera.noise(k);
            let instants: Vec<(f32, f32)> = (0..400)
                .map(|i| self.at(k + ((i as f32 + 0.5) / 400.0 - 0.5) * self.exposure))
                .collect();
            let width = size.width();
            let [a, b] = self.ends(k);
            let reach_px = 6.0 * sigma_px + 1.0;
            (0..size.pixels())
                .map(|i| {
                    let (px, py) = ((i % width) as f32, (i / width) as f32);
                    // Beyond six σ of the path the light is below a 30th of a luma.
                    let t =
                        ((px - a.0) * (b.0 - a.0) + (py - a.1) * (b.1 - a.1)) / dist(a, b).powi(2);
                    let t = t.clamp(0.0, 1.0);
                    let nearest = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
                    let read_noise = noise();
                    if dist((px, py), nearest) > reach_px {
                        return (20.0 + read_noise).clamp(0.0, 250.0).round() as u8;
                    }
                    let light = (0..9)
                        .map(|j| {
                            let x = px + ((j % 3) as f32 - 1.0) / 3.0;
                            let y = py + ((j / 3) as f32 - 1.0) / 3.0;
                            instants
                                .iter()
                                .map(|&(cx, cy)| {
                                    let r2 = (x - cx).powi(2) + (y - cy).powi(2);
                                    (-0.5 * r2 / (sigma_px * sigma_px)).exp()
                                })
                                .sum::<f32>()
                        })
                        .sum::<f32>()
                        / (9.0 * instants.len() as f32);
                    let linear = 0.003 + gain * light;
                    let tone = 250.0 * linear.powf(1.0 / camera.gamma);
                    (tone.max(20.0) + read_noise).clamp(0.0, 250.0).round() as u8
                })
                .collect()
        }

        /// Frame `k` rendered through `camera` ([`Speeding::render`]) and fitted from rough
        /// ends at the true ones, in the order of time or else `backwards`, warm from `warm`.
        fn fitted(
            &self,
            k: f32,
            (sigma_px, gain): (f32, f32),
            camera: &Camera,
            size: FrameSize,
            backwards: bool,
            warm: Option<&SpotFit>,
        ) -> PathFit {
            let [s, e] = self.ends(k);
            let [s, e] = if backwards { [e, s] } else { [s, e] };
            let rough = Rough {
                ends_px: [s, e],
                mid_px: ((s.0 + e.0) / 2.0, (s.1 + e.1) / 2.0),
                thickness_px: 3.0 * sigma_px,
            };
            let bytes = self.render(k, sigma_px, gain, camera, size);
            let frame =
                Frame::new_checked_as(&bytes, size, size.width(), PixelFormat::Grey).unwrap();
            let shape = SpotShape::identity();
            fit(&frame, &rough, 250, None, shape, warm, false).expect("a path")
        }
    }

    /// The camera a [`Speeding`] LED is rendered through: its tone curve's gamma and its
    /// noise (luma, Gaussian, added after the tone curve and before the clip).
    struct Camera {
        gamma: f32,
        noise_luma: f32,
    }

    impl Camera {
        const CLEAN: Camera = Camera {
            gamma: 2.2,
            noise_luma: 0.0,
        };

        /// Noise for frame `k`: a seeded Box–Muller draw per pixel, the same for the same
        /// frame (so that two fits of one frame see one picture).
        fn noise(&self, k: f32) -> impl FnMut() -> f32 + '_ {
            let mut state = 0x2545_f491u32 ^ (k + 7.0).to_bits().rotate_left(11);
            let mut uniform = move || {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                (state as f32 + 1.0) / (u32::MAX as f32 + 2.0)
            };
            move || {
                let (u, v) = (uniform(), uniform());
                self.noise_luma * (-2.0 * u.ln()).sqrt() * (core::f32::consts::TAU * v).cos()
            }
        }
    }

    /// An LED speeding up by a quarter during the exposure lays less light at its fast end,
    /// so its clipped streak reaches less far beyond that end and farther beyond the slow
    /// one. Fitted at one speed, both ends are read toward the slow end; fitted with the
    /// gradient its last frame's length says (the change of speed worked out from the
    /// lengths and the middles alone, see [`gradient_of`]), they are where the LED was.
    #[test]
    fn an_led_that_speeds_up_is_read_with_its_light_laid_unevenly() {
        // Without noise the ends are within a seventh of a pixel, and the fit at one speed
        // is more than twice as far off.
        read_speeding_through(&Camera::CLEAN, 0.15, 2.0);
    }

    /// The same over the tone curves and noise of other cameras: the noise moves the ends by
    /// a tenth or two of a pixel whichever way the light is laid, so the ends are asked to be
    /// within 0.3 px and nearer than at one speed.
    #[test]
    fn an_led_that_speeds_up_is_read_so_through_other_cameras() {
        for camera in [
            Camera {
                gamma: 1.8,
                noise_luma: 2.0,
            },
            Camera {
                gamma: 2.4,
                noise_luma: 2.0,
            },
            Camera {
                gamma: 2.0,
                noise_luma: 4.0,
            },
        ] {
            read_speeding_through(&camera, 0.3, 1.0);
        }
    }

    /// Fits three frames of an LED speeding up through `camera`, its spot over a grid of
    /// widths and clips, both ways along the rough ends, and asserts the gradient within a
    /// fifth of the change of speed, the ends fitted with it within `bound_px`, and the ends
    /// fitted at one speed more than `worse` times as far off as those.
    fn read_speeding_through(camera: &Camera, bound_px: f32, worse: f32) {
        let size = FrameSize::new(200, 72).unwrap();
        let gamma = camera.gamma;
        // Rough ends in the order of time, and (the other way along) the other order.
        for (unit, forwards) in [((0.98f32, 0.199f32), true), ((-0.98, -0.199), false)] {
            let in_order = |[s, e]: [(f32, f32); 2]| if forwards { [s, e] } else { [e, s] };
            let origin = if forwards {
                (60.0, 26.0)
            } else {
                (140.0, 46.0)
            };
            let led = Speeding {
                v0: 40.0,
                a: 20.0,
                exposure: 0.8,
                origin,
                unit,
            };
            // The speed at frame 1's middle, and its change during the exposure.
            let change = led.a * led.exposure / (led.v0 + led.a);
            for (sigma_px, gain) in [(1.2f32, 30.0f32), (1.2, 120.0), (1.8, 60.0), (2.5, 30.0)] {
                let fit_frame = |k: f32, warm: Option<&SpotFit>| {
                    led.fitted(k, (sigma_px, gain), camera, size, !forwards, warm)
                };
                // Frame 0 after frame −1, so that its path is known to be a whole exposure's.
                let first = fit_frame(-1.0, None);
                let before = fit_frame(0.0, Some(&first.spot));
                let mut even_spot = before.spot;
                even_spot.travel = Travel::default();
                let even = fit_frame(1.0, Some(&even_spot));
                let laid = fit_frame(1.0, Some(&before.spot));
                // Without frame −1, frame 0's short path might be an LED that started moving
                // during its exposure: no gradient.
                let alone = fit_frame(0.0, None);
                assert_eq!(gradient_of(&alone.spot.travel, &even), None);
                // The gradient from the fits' lengths and middles: the light falls toward
                // the fast end, which is the path's start where the rough ends run backwards.
                let gradient = gradient_of(&before.spot.travel, &even).expect("a gradient");
                let truth = if forwards { -change } else { change };
                assert!(
                    (gradient - truth).abs() < 0.2 * change,
                    "γ {gamma}, σ {sigma_px}: gradient {gradient}, the LED's {truth}"
                );
                let truth_ends = in_order(led.ends(1.0));
                let off = |f: &PathFit| -> Vec<f32> {
                    f.ends_px
                        .iter()
                        .zip(truth_ends)
                        .map(|(&e, t)| dist(e, t))
                        .collect()
                };
                let (even_off, laid_off) = (off(&even), off(&laid));
                assert!(
                    laid_off.iter().all(|&e| e < bound_px),
                    "γ {gamma}, σ {sigma_px}: ends {laid_off:?} px off with the gradient \
                     ({even_off:?} without)"
                );
                assert!(
                    even_off.iter().cloned().fold(0.0, f32::max)
                        > worse * laid_off.iter().cloned().fold(0.0, f32::max),
                    "γ {gamma}, σ {sigma_px}: ends {even_off:?} px off at one speed, \
                     {laid_off:?} with the gradient"
                );
            }
        }
    }

    /// At one speed, the lengths of two frames agree to within their noise, or so nearly
    /// that the light laid along the path is even to a hundredth.
    #[test]
    fn an_led_at_one_speed_lays_its_light_evenly() {
        let size = FrameSize::new(176, 72).unwrap();
        let led = Speeding {
            v0: 50.0,
            a: 0.0,
            exposure: 0.7,
            origin: (90.0, 30.0),
            unit: (0.995, 0.0998),
        };
        for (sigma_px, gain) in [(1.2f32, 30.0f32), (2.5, 30.0)] {
            let fitted = |k: f32, warm: Option<&SpotFit>| {
                led.fitted(k, (sigma_px, gain), &Camera::CLEAN, size, false, warm)
            };
            let first = fitted(-1.0, None);
            let before = fitted(0.0, Some(&first.spot));
            let after = fitted(1.0, None);
            let gradient = gradient_of(&before.spot.travel, &after);
            assert!(
                gradient.is_none_or(|g| g.abs() < 0.01),
                "σ {sigma_px}: gradient {gradient:?} at one speed"
            );
        }
    }

    /// Sweep seed 12's point 109 in the model's own family: a bloom whose core (σ 1.31 px) is
    /// clipped 14× and whose glow (3.8× wider, 6 % of the core) peaks just under the clip,
    /// on an 8.3 px line through a 2.23 gamma, in a 96 × 80 picture clipping at 250.
    struct ClippedBloom {
        width: usize,
        size: FrameSize,
        clip: f32,
        ends: [(f32, f32); 2],
        mid: (f32, f32),
        truth: Params,
        path: Path,
    }

    impl ClippedBloom {
        fn new() -> ClippedBloom {
            let (width, height) = (96usize, 80usize);
            let (a, b) = ((44.0f32, 40.3f32), (52.0f32, 42.6f32));
            let mut truth = params(a, b, 0.0, 1.31);
            truth[GLOW_WIDTH] = (3.8f32 * 1.31).ln();
            truth[GLOW_RATIO] = 0.059;
            truth[TONE] = 1.0 / 2.23;
            truth[FLAT_FLOOR] = 0.1;
            let path = Path::new(&truth, true, 0.0);
            let mid = (0.5 * (a.0 + b.0), 0.5 * (a.1 + b.1));
            let (core, glow) = path.light2(mid.0, mid.1);
            truth[LN_AMPLITUDE] = (13.8 / (core + truth[GLOW_RATIO] * glow)).ln();
            ClippedBloom {
                width,
                size: FrameSize::new(width as u32, height as u32).unwrap(),
                clip: 250.0,
                ends: [a, b],
                mid,
                // The amplitude draws nothing of the path: the path drawn above stands.
                path,
                truth,
            }
        }

        /// A grey frame of the bloom, clipped, with noise of up to 6 luma either way from the
        /// generator `state`.
        fn render(&self, state: &mut u32) -> Vec<u8> {
            (0..self.size.pixels())
                .map(|i| {
                    let xy = ((i % self.width) as f32, (i / self.width) as f32);
                    (model(&self.path, &self.truth, xy, None, self.clip).0 + noise(state, 6.0))
                        .clamp(0.0, self.clip)
                        .round() as u8
                })
                .collect()
        }
    }

    /// A bloom whose core is clipped 14× and whose glow (3.8× wider, 6 % of the core) peaks
    /// just under the clip, on an 8.3 px line (sweep seed 12's point 109, in the model's own
    /// family): nearly every unclipped pixel is glow, and the tone exponent trades against the
    /// spot along a valley the pixels hardly tell apart. Twelve frames fitted one after the
    /// other, each from the last one's spot (the first from the true spot): without the
    /// exponents the frames before read, the warm starts walk `k` from 0.45 up to 0.8 and the
    /// lengths read up to 1.8 px long; with them as the prior, `k` stays within 0.1 of the
    /// truth and every length within half a pixel.
    #[test]
    fn a_spot_clipped_into_its_glow_keeps_the_tone_its_frames_before_read() {
        let bloom = ClippedBloom::new();
        let (size, truth) = (bloom.size, bloom.truth);
        let rough = Rough {
            ends_px: [(45.0, 40.5), (51.0, 42.4)],
            mid_px: bloom.mid,
            thickness_px: 12.0,
        };
        // The fits of twelve frames of fresh noise, each from the last one's spot; the LED's
        // tone exponents remembered or each time forgotten.
        let chain = |remembered: bool| {
            let mut state = 5u32;
            let mut memory = ToneMemory::default();
            for k in [0.44, 0.45, 0.46] {
                memory = memory.with(k, 1e-3);
            }
            let mut warm = SpotFit {
                shape: core::array::from_fn(|i| truth[PATH_PARAMS + i]),
                cost_per_px: 12.0,
                offset: PathOffset {
                    ends_px: [(0.0, 0.0); 2],
                    chord_px: (1.0, 0.0),
                    sagitta_px: 0.0,
                },
                tone: memory,
                travel: Travel::default(),
            };
            let mut read = Vec::new();
            for _ in 0..12 {
                let bytes = bloom.render(&mut state);
                let frame =
                    Frame::new_checked_as(&bytes, size, bloom.width, PixelFormat::Grey).unwrap();
                if !remembered {
                    warm.tone = ToneMemory::default();
                }
                let found = fit(
                    &frame,
                    &rough,
                    bloom.clip as u8,
                    None,
                    SpotShape::identity(),
                    Some(&warm),
                    false,
                )
                .expect("a path");
                read.push((found.path_length_px, found.spot.shape[TONE - PATH_PARAMS]));
                warm = found.spot;
            }
            read
        };
        let length_px = dist(bloom.ends[0], bloom.ends[1]);
        let worst = |read: &[(f32, f32)]| {
            read.iter()
                .fold((0.0f32, 0.0f32), |(l, k), &(length, tone)| {
                    (
                        l.max((length - length_px).abs()),
                        k.max((tone - truth[TONE]).abs()),
                    )
                })
        };
        let (forgot, kept) = (chain(false), chain(true));
        let (forgot_length_px, forgot_tone) = worst(&forgot);
        assert!(
            forgot_length_px > 1.0 && forgot_tone > 0.2,
            "forgotten, the tone still holds: {forgot:?}"
        );
        let (kept_length_px, kept_tone) = worst(&kept);
        assert!(
            kept_length_px < 0.5 && kept_tone < 0.1,
            "lengths and tones read with the prior: {kept:?}"
        );
    }

    /// A rough streak whose skeleton stops well short of one end (a streak whose clipped
    /// core broke up, so that the blob holds only part of it): the first fit runs past the
    /// pixels read around the rough ends, and the fit read again around where it went finds
    /// the whole path.
    #[test]
    fn a_rough_streak_cut_short_is_fitted_whole() {
        let (width, height) = (128, 80);
        let size = FrameSize::new(width, height).unwrap();
        let clip = 250.0;
        let mut truth = params((30.0, 40.0), (90.0, 40.0), 0.0, 1.5);
        let path = Path::new(&truth, true, 0.0);
        // Bright enough that the core's light is three times the clip's in linear light.
        let (core, glow) = path.light2(60.0, 40.0);
        truth[LN_AMPLITUDE] = (3.0 / (core + truth[GLOW_RATIO] * glow)).ln();
        let mut state = 11u32;
        let mut bytes = vec![0u8; (width * height) as usize];
        for (i, luma) in bytes.iter_mut().enumerate() {
            let xy = ((i % width as usize) as f32, (i / width as usize) as f32);
            let value = model(&path, &truth, xy, None, clip).0 + noise(&mut state, 2.0);
            *luma = value.clamp(0.0, clip).round() as u8;
        }
        let frame = Frame::new_checked_as(&bytes, size, width as usize, PixelFormat::Grey).unwrap();
        let clipped = bytes.iter().filter(|&&l| f32::from(l) >= clip).count();
        assert!(clipped > 100, "{clipped} clipped pixels");
        // The skeleton of the left part alone: 22 px short of the right end.
        let rough = Rough {
            ends_px: [(32.0, 40.0), (68.0, 40.0)],
            mid_px: (50.0, 40.0),
            thickness_px: 4.0,
        };
        let seen = Seen {
            frame: &frame,
            clip_luma: 250,
            background: None,
            shape: SpotShape::identity(),
            warm: None,
            check_ends: false,
        };
        let once = fit_from(&seen, &rough);
        assert!(
            matches!(once, Err(Miss::Beyond(_))),
            "the first fit stayed within the rough ends' reach"
        );
        let found = plain_fit(&frame, &rough).expect("a path");
        for (end, want) in found.ends_px.iter().zip([(30.0, 40.0), (90.0, 40.0)]) {
            assert!(dist(*end, want) < 0.3, "ends {:?}", found.ends_px);
        }
        assert!((found.path_length_px - 60.0).abs() < 0.5, "{found:?}");
    }

    /// A spot narrower than a pixel (σ 0.3 px), swept along a straight path and rendered as a
    /// camera sees it (each pixel the mean of its area, sampled 8 × 8), from barely to very
    /// saturating, is fitted to its ends: the model widens the spot by the pixel's own area.
    /// Drawn at the pixels' centres alone, the ends came 0.21 px off on the mean (0.11 px with
    /// the pixel's area).
    #[test]
    fn a_spot_narrower_than_a_pixel_is_fitted_to_its_ends() {
        let (width, height) = (96, 64);
        let size = FrameSize::new(width, height).unwrap();
        let (clip, sigma_px) = (250.0f32, 0.3f32);
        let ends = [(20.3f32, 30.6f32), (62.7f32, 36.1f32)];
        let length_px = dist(ends[0], ends[1]);
        let unit = (
            (ends[1].0 - ends[0].0) / length_px,
            (ends[1].1 - ends[0].1) / length_px,
        );
        // The spot's light at (x, y), its mean over the exposure (relative to a still spot's
        // centre): a Gaussian's line integral along the path.
        let light = |x: f32, y: f32| {
            let (px, py) = (x - ends[0].0, y - ends[0].1);
            let along = px * unit.0 + py * unit.1;
            let across = -px * unit.1 + py * unit.0;
            let span = normal_cdf(along / sigma_px) - normal_cdf((along - length_px) / sigma_px);
            (-0.5 * (across / sigma_px).powi(2)).exp() * SQRT_TAU * sigma_px * span / length_px
        };
        let sub = 8;
        let mut errors_px = Vec::new();
        for gain in [40.0f32, 100.0, 400.0, 1500.0] {
            let bytes: Vec<u8> = (0..width * height)
                .map(|i| {
                    let (px, py) = ((i % width) as f32, (i / width) as f32);
                    let area_mean = (0..sub * sub)
                        .map(|j| {
                            let dx = ((j % sub) as f32 + 0.5) / sub as f32 - 0.5;
                            let dy = ((j / sub) as f32 + 0.5) / sub as f32 - 0.5;
                            light(px + dx, py + dy)
                        })
                        .sum::<f32>()
                        / (sub * sub) as f32;
                    // Through a 2.2 gamma, on a floor of 20.
                    let linear = 0.003 + gain * area_mean;
                    (clip * linear.powf(1.0 / 2.2)).clamp(20.0, clip).round() as u8
                })
                .collect();
            let rough = Rough {
                ends_px: [(21.0, 30.7), (62.0, 36.0)],
                mid_px: (41.5, 33.35),
                thickness_px: 2.0,
            };
            let found = plain_fit_of(&bytes, size, &rough);
            errors_px.extend(found.ends_px.iter().zip(ends).map(|(&e, t)| dist(e, t)));
        }
        let mean_px = errors_px.iter().sum::<f32>() / errors_px.len() as f32;
        assert!(mean_px < 0.15, "ends off by {errors_px:?}");
        assert!(
            errors_px.iter().all(|&e| e < 0.5),
            "ends off by {errors_px:?}"
        );
    }

    /// A streak whose spot is not the model's (a Moffat profile, whose wings fall as a power
    /// of the distance where the model's fall as a Gaussian's), swept along a straight path
    /// with noise, from barely to well saturating: the ends come off by more than the noise
    /// alone moves them, and the reported uncertainty says more of it. Over these nine
    /// streaks, an end's error is a median 1.4 and at most 4.4 of `uncertainty_px`; of
    /// `noise_px` (the residual spread evenly), 2.4 and 7.3. Neither is calibrated (the
    /// profile's misfit is a bias, alike from frame to frame, more than a spread), but the
    /// sandwich's is the nearer.
    #[test]
    fn a_spot_unlike_the_model_reports_the_ends_as_uncertain_as_they_are() {
        let (width, height) = (128, 80);
        let size = FrameSize::new(width, height).unwrap();
        let clip = 250.0f32;
        let ends = [(30.4f32, 40.2f32), (88.7f32, 43.9f32)];
        let steps = 240;
        let mut state = 7u32;
        let (mut ratios, mut noise_ratios) = (Vec::new(), Vec::new());
        for (beta, alpha_px) in [(2.5f32, 2.2f32), (4.0, 3.0), (2.0, 1.6)] {
            let light = |x: f32, y: f32| {
                (0..steps)
                    .map(|k| {
                        let f = (k as f32 + 0.5) / steps as f32;
                        let (cx, cy) = (
                            ends[0].0 + f * (ends[1].0 - ends[0].0),
                            ends[0].1 + f * (ends[1].1 - ends[0].1),
                        );
                        let r2 = ((x - cx).powi(2) + (y - cy).powi(2)) / (alpha_px * alpha_px);
                        (1.0 + r2).powf(-beta)
                    })
                    .sum::<f32>()
                    / steps as f32
            };
            let lights: Vec<f32> = (0..width * height)
                .map(|i| light((i % width) as f32, (i / width) as f32))
                .collect();
            let peak = lights.iter().cloned().fold(0.0, f32::max);
            for clipped_times in [1.5f32, 4.0, 12.0] {
                let bytes: Vec<u8> = lights
                    .iter()
                    .map(|&l| {
                        let linear = 0.003 + clipped_times * l / peak;
                        (clip * linear.powf(1.0 / 2.2) + noise(&mut state, 2.0))
                            .clamp(0.0, clip)
                            .round() as u8
                    })
                    .collect();
                let rough = Rough {
                    ends_px: [(32.0, 40.3), (87.0, 43.8)],
                    mid_px: (59.5, 42.05),
                    thickness_px: 4.0,
                };
                let found = plain_fit_of(&bytes, size, &rough);
                for (&end, truth) in found.ends_px.iter().zip(ends) {
                    let error_px = dist(end, truth);
                    ratios.push(error_px / found.uncertainty_px);
                    noise_ratios.push(error_px / found.noise_px);
                }
            }
        }
        ratios.sort_by(f32::total_cmp);
        noise_ratios.sort_by(f32::total_cmp);
        let told = format!("error / uncertainty {ratios:?}; error / noise {noise_ratios:?}");
        assert!(ratios[ratios.len() / 2] < 2.0, "{told}");
        assert!(ratios[ratios.len() - 1] < 6.0, "{told}");
    }

    /// `MAX_FIT_PX` pixels across the whole path of `truth` (out to three of its glow's σ either
    /// side, and up to 3 px past its ends), their luma its model's with a pseudo-random noise of
    /// up to `noise_luma` either way, on a flat floor.
    fn samples_across(truth: &Params, clip: f32, noise_luma: f32) -> Samples {
        let mut s = no_samples();
        let path = Path::new(truth, true, 0.0);
        let corners = &path.arc.corners[..=path.arc.count];
        let reach = 3.0 * truth[GLOW_WIDTH].exp();
        let mut state = 7u32;
        for k in 0..MAX_FIT_PX {
            // Sixteen stations from a little before the start to a little past the end, eight
            // offsets across at each.
            let (station, across) = (k / 8, k % 8);
            let tau = (station as f32 / 15.0) * 1.2 - 0.1;
            let at = tau.clamp(0.0, 1.0) * (corners.len() - 1) as f32;
            let i = (at as usize).min(corners.len() - 2);
            let (c0, c1) = (corners[i], corners[i + 1]);
            let f = at - i as f32;
            let on = (c0.0 + f * (c1.0 - c0.0), c0.1 + f * (c1.1 - c0.1));
            let len = dist(c0, c1).max(1e-6);
            let (ux, uy) = ((c1.0 - c0.0) / len, (c1.1 - c0.1) / len);
            let beyond = (tau - tau.clamp(0.0, 1.0)) * 30.0;
            let off = (across as f32 / 7.0 * 2.0 - 1.0) * reach;
            let xy = (on.0 + beyond * ux - off * uy, on.1 + beyond * uy + off * ux);
            let luma = (model(&path, truth, xy, None, clip).0 + noise(&mut state, noise_luma))
                .clamp(0.0, clip);
            s.xy[s.len] = xy;
            s.luma[s.len] = luma;
            s.len += 1;
        }
        s
    }

    /// The fit of `truth`'s pixels from a straight start between its own ends, bent if asked.
    fn fitted_from_straight(truth: &Params, s: &Samples, clip: f32) -> (Params, f32) {
        let mut all = [true; PARAMS];
        all[PEDESTAL] = false;
        let start = Start {
            samples: s,
            path: [truth[0], truth[1], truth[2], truth[3], 0.0],
            floor_luma: low_percentile(s),
            clip,
            all: &all,
        };
        let straight = start.cold(3.0, None).expect("a straight fit");
        assert!(is_straight(&path_of(&straight.0)));
        bent_if_asked(s, straight, clip, &all)
    }

    /// A fit started straight on a bent streak (its rough middle on the chord, as a stadium's
    /// always is) bends to it: without the bend test its sagitta stays where it started.
    #[test]
    fn a_straight_start_bends_where_the_pixels_ask() {
        let clip = 250.0;
        let truth = params((10.0, 12.0), (35.0, 30.0), 6.0, 0.9);
        let s = samples_across(&truth, clip, 3.0);
        let (p, _) = fitted_from_straight(&truth, &s, clip);
        assert!((p[SAGITTA] - truth[SAGITTA]).abs() < 0.5, "{p:?}");
        for j in 0..4 {
            assert!((p[j] - truth[j]).abs() < 0.5, "{p:?}");
        }
    }

    /// The length's slopes, by which the fit's covariance is carried to the length's
    /// deviation, are those of the drawn path's length, on straight and bent paths: within
    /// 5 % of its central differences (drawn with pieces within 0.1 px of the arc, the drawn
    /// length is 4 % less steep in the sagitta than the arc's on the bend of 2 px).
    #[test]
    fn the_length_s_slopes_are_those_of_the_path_s_length() {
        for (sagitta, sigma) in [(0.0f32, 1.2f32), (2.0, 1.2), (-4.0, 2.0)] {
            let p = params((12.0, 14.0), (40.0, 22.0), sagitta, sigma);
            let slopes = length_slopes(&p);
            for i in 0..PATH_PARAMS {
                let step = 1e-2;
                let (mut ahead, mut behind) = (p, p);
                ahead[i] += step;
                behind[i] -= step;
                let length = |q: &Params| Path::new(q, true, 0.0).length();
                let numeric = (length(&ahead) - length(&behind)) / (2.0 * step);
                assert!(
                    (slopes[i] - numeric).abs() <= 0.05 * numeric.abs().max(0.05),
                    "sagitta {sagitta}, parameter {i}: {} against {numeric}",
                    slopes[i]
                );
            }
        }
    }

    /// Noise does not bend a straight streak: the pixels ask no bend of it, and it stays one
    /// straight piece.
    #[test]
    fn noise_does_not_bend_a_straight_streak() {
        let clip = 250.0;
        for (k, noise_luma) in [2.0, 6.0, 12.0].into_iter().enumerate() {
            let truth = params((10.0, 12.0 + k as f32), (50.0, 20.0), 0.0, 1.2);
            let s = samples_across(&truth, clip, noise_luma);
            let (p, _) = fitted_from_straight(&truth, &s, clip);
            assert!(is_straight(&path_of(&p)), "noise {noise_luma}: {p:?}");
        }
    }

    #[test]
    fn the_normal_equations_descend_the_cost() {
        let clip = 250.0;
        let all = [true; PARAMS];
        for truth in paths() {
            let s = samples_of(&truth, clip);
            // Away from the truth, so that every residual and slope is in play.
            let mut p = truth;
            for (j, shift) in [
                0.4, -0.3, 0.2, 0.5, 0.3, 0.1, -0.1, 0.3, 0.05, 0.04, 0.02, 0.01,
            ]
            .into_iter()
            .enumerate()
            {
                p[j] += shift;
            }
            let (_, jtr) = normal_equations(&s, &p, clip, &all, None).expect("finite");
            let scale = jtr.amax();
            for j in 0..PARAMS {
                let h = 1e-3;
                let cost_at = |delta: f32| {
                    let mut q = p;
                    q[j] += delta;
                    cost_of(&s, &q, clip, &all, f32::INFINITY).expect("finite")
                };
                // The cost is Σ r², so its slope is −2 Jᵀr.
                let numeric = -(cost_at(h) - cost_at(-h)) / (4.0 * h);
                assert!(
                    (numeric - jtr[j]).abs() < 1e-2 * scale,
                    "parameter {j} of {truth:?}: differences {numeric}, closed form {}",
                    jtr[j]
                );
            }
        }
    }

    /// The same bloom as the test above, fitted cold (no spot from an earlier frame), from
    /// rough streaks 6–15 px thick and four frames of fresh noise each: with the start from
    /// the clipped region's radius, most fits find the narrow core (14 of 16 within 1.8 px of
    /// 1.31), and the lengths' median error is about a pixel on 8.3 (single frames, few
    /// pixels at the ends). Started from the thickness alone, every core took the glow's
    /// width (4.8–8.5 px), and the lengths read 9.0–17.6 px.
    #[test]
    fn a_bloom_clipped_into_its_glow_is_fitted_cold_to_its_narrow_core() {
        let bloom = ClippedBloom::new();
        let sigma_px = bloom.truth[CORE_WIDTH].exp();
        let mut state = 11u32;
        let mut read = Vec::new();
        for thickness_px in [6.0f32, 9.0, 12.0, 15.0] {
            let rough = Rough {
                ends_px: [(45.0, 40.5), (51.0, 42.4)],
                mid_px: bloom.mid,
                thickness_px,
            };
            for _ in 0..4 {
                let bytes = bloom.render(&mut state);
                let found = plain_fit_of(&bytes, bloom.size, &rough);
                read.push((thickness_px, found.spot_sigma_px, found.path_length_px));
            }
        }
        let length_px = dist(bloom.ends[0], bloom.ends[1]);
        let narrow = read.iter().filter(|r| r.1 < 2.0 * sigma_px).count();
        let mut errors: Vec<f32> = read.iter().map(|r| (r.2 - length_px).abs()).collect();
        errors.sort_by(f32::total_cmp);
        let median_px = 0.5 * (errors[errors.len() / 2 - 1] + errors[errors.len() / 2]);
        assert!(
            4 * narrow >= 3 * read.len() && median_px < 1.5,
            "{narrow} of {} cores within twice the truth, median length error {median_px} px: \
             (thickness, core, length) {read:?}",
            read.len()
        );
    }
}
