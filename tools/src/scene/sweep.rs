//! A sweep of physical parameters, so that accuracy is asserted over the range a real camera
//! can show rather than at one setting the tracker was tuned on.
//!
//! Each [`SweepPoint`] is one short scene: a spot profile (disk, Gaussian, Gaussian core with a
//! wide glow) 0.8–3 px wide, an LED from barely to strongly saturating, a tone curve of gamma
//! 1.8–2.4, read noise up to σ 4 luma, in half the points noise of 0.5–3 luma after the clip
//! (saturated pixels not all exactly white), full or studio range, and a path that is still or
//! barely moving (after moving into place: a light that never moved cannot be told from a
//! lamp), a straight line (3–60 px streaks) or an arc; and where in a wide-angle lens's picture
//! it is seen, which squeezes the round spot into an ellipse (a third of the points at the
//! picture's centre, unsqueezed; the rest down to two thirds along an axis at any angle).
//! Points are drawn from a seed, so a test can take a reproducible random subset and a
//! benchmark the whole sweep.

use std::f64::consts::{PI, TAU};

use super::camera::Range;
use super::optics::{Led, Spot};
use super::presets;
use super::rng::{mix64, unit_from_bits, SplitMix64};
use super::squeeze::Squeeze;
use super::trajectory::{Point, Trajectory};
use super::SceneConfig;

/// Frame rate of every sweep scene: high enough that a 60 px streak (6000 px/s) stays in view
/// for several frames.
const FPS: f64 = 90.0;
/// Exposure of every sweep scene.
const EXPOSURE_US: u32 = 10_000;
/// Frames per sweep scene, unless a fast LED would leave the view sooner.
const MAX_FRAMES: usize = 10;
/// Frames a settling LED takes to move into place, before its [`MAX_FRAMES`] at rest.
pub const APPROACH_FRAMES: usize = 3;
/// How far a settling LED moves into place: its streaks are then 12, 19 and 5 px long
/// (a raised-cosine move, peak speed twice the mean), clearly moving.
const APPROACH_PX: f64 = 40.0;
/// The path stays this far inside the frame.
const MARGIN_PX: f64 = 40.0;
/// Spot widths (disk radius, Gaussian σ).
const WIDTH_RANGE_PX: (f64, f64) = (0.8, 3.0);
/// Level of the streak's unclipped core in multiples of the clip level.
const SATURATION_RANGE: (f64, f64) = (1.3, 30.0);
const GAMMA_RANGE: (f64, f64) = (1.8, 2.4);
const NOISE_MAX_LUMA: f64 = 4.0;
/// The glow of a blooming spot: this many times wider than the core...
const GLOW_WIDTH_RANGE: (f64, f64) = (3.0, 6.0);
/// ... and this bright at its centre relative to the core's.
const GLOW_RATIO_RANGE: (f64, f64) = (0.02, 0.08);
/// A wide webcam lens images a round spot in its corners down to this fraction of its round
/// extent, radially.
const SQUEEZE_RANGE: (f64, f64) = (0.67, 1.0);
/// One point in this many is at the picture's centre, where the lens leaves the spot round.
const ROUND_ONE_IN: u64 = 3;
/// Separates the lens's random stream from the other parameters', so that adding the lens left
/// every other parameter of every point as it was.
const LENS_SALT: u64 = 0x1E45_1E45_1E45_1E45;
/// Noise after the clip (`Camera::post_noise_luma`), in luma levels: in one point in
/// [`POST_NOISE_ONE_IN`], none in the others (a camera whose saturated pixels read exactly
/// white).
const POST_NOISE_RANGE_LUMA: (f64, f64) = (0.5, 3.0);
const POST_NOISE_ONE_IN: u64 = 2;
/// Separates the noise after the clip's random stream from the others', as [`LENS_SALT`].
const POST_NOISE_SALT: u64 = 0xC11F_C11F_C11F_C11F;

/// The shape of the LED's spot in a sweep point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpotKind {
    /// A uniform disk.
    Disk,
    /// A Gaussian.
    Gaussian,
    /// A Gaussian core inside a wide glow.
    Bloom,
}

/// How the LED moves in a sweep point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SweepPath {
    /// A straight line at constant speed, `length_px` per exposure (0: standing still).
    Line {
        /// Streak length.
        length_px: f64,
        /// Direction of travel.
        angle_rad: f64,
    },
    /// Moves into place over `APPROACH_FRAMES` frames (a robot arriving where it rests),
    /// then on along `angle_rad` at `length_px` per exposure (0: standing still).
    Settle {
        /// Streak length once in place.
        length_px: f64,
        /// Direction of the move into place and of travel after it.
        angle_rad: f64,
    },
    /// A circle of `radius_px`, `length_px` of arc per exposure.
    Arc {
        /// The circle's radius.
        radius_px: f64,
        /// Arc length per exposure.
        length_px: f64,
    },
}

impl SweepPath {
    /// The streak's length (once in place, for [`SweepPath::Settle`]).
    pub fn length_px(self) -> f64 {
        match self {
            SweepPath::Line { length_px, .. }
            | SweepPath::Settle { length_px, .. }
            | SweepPath::Arc { length_px, .. } => length_px,
        }
    }

    /// The first frame whose whole exposure comes after the LED arrived in place (0 unless
    /// it settles).
    pub fn settled_frame(self) -> usize {
        match self {
            SweepPath::Settle { .. } => APPROACH_FRAMES,
            _ => 0,
        }
    }
}

/// One point of the sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepPoint {
    /// Index in the sweep.
    pub index: usize,
    /// Spot profile.
    pub spot: SpotKind,
    /// Disk radius or Gaussian σ of the core.
    pub width_px: f64,
    /// Glow σ over core σ, and glow centre over core centre (bloom only).
    pub glow: (f64, f64),
    /// Level of the streak's core, in multiples of the clip level (for an LED that moves
    /// into place, of its longest streak on the way in: brighter at rest), for the round
    /// spot. The lens gathers the same light into its squeezed spot: a streak along the
    /// squeezed axis is as bright, one across it (and a still spot) up to `1 / ratio` brighter.
    pub saturation: f64,
    /// The camera's tone-curve exponent.
    pub gamma: f64,
    /// Read noise, in luma levels of a linear camera.
    pub noise_luma: f64,
    /// Noise after the clip, in luma levels.
    pub post_noise_luma: f64,
    /// Output range.
    pub range: Range,
    /// The LED's path.
    pub path: SweepPath,
    /// How the lens squeezes the LED's spot where it is seen.
    pub lens: Squeeze,
    /// Seed of the floor texture and the noise.
    pub seed: u64,
}

/// When a settling LED arrives, and how long its move into place takes: it arrives in the
/// gap between the last approach frame's exposure and the first standing one's, and the move
/// started half a frame before frame 0's exposure, so frame 0 already shows it moving.
fn approach_timing() -> (f64, f64) {
    let period_s = 1.0 / FPS;
    let exposure_s = f64::from(EXPOSURE_US) * 1e-6;
    let arrive_s = (APPROACH_FRAMES - 1) as f64 * period_s + 0.5 * (period_s - exposure_s);
    (arrive_s, arrive_s + exposure_s + 0.5 * period_s)
}

/// The longest streak a settling LED can leave on its way in: an exposure at the move's peak
/// speed (twice its mean).
fn approach_peak_streak_px() -> f64 {
    let (_, move_s) = approach_timing();
    2.0 * APPROACH_PX / move_s * f64::from(EXPOSURE_US) * 1e-6
}

/// The lens's squeeze at point `index` of the sweep from `seed`: none for one point in
/// [`ROUND_ONE_IN`] (the picture's centre), else a ratio uniform in [`SQUEEZE_RANGE`] along an
/// axis at any angle.
fn lens_squeeze(seed: u64, index: usize) -> Squeeze {
    let mut rng = SplitMix64::new(mix64(seed ^ mix64(index as u64 ^ LENS_SALT)));
    if rng.next_u64().is_multiple_of(ROUND_ONE_IN) {
        return Squeeze::NONE;
    }
    Squeeze {
        ratio: uniform(&mut rng, SQUEEZE_RANGE),
        axis_rad: uniform(&mut rng, (0.0, PI)),
    }
}

/// The noise after the clip at point `index` of the sweep from `seed`: none for all but one
/// point in [`POST_NOISE_ONE_IN`], else uniform in [`POST_NOISE_RANGE_LUMA`].
fn post_clip_noise(seed: u64, index: usize) -> f64 {
    let mut rng = SplitMix64::new(mix64(seed ^ mix64(index as u64 ^ POST_NOISE_SALT)));
    if rng.next_u64().is_multiple_of(POST_NOISE_ONE_IN) {
        uniform(&mut rng, POST_NOISE_RANGE_LUMA)
    } else {
        0.0
    }
}

/// Uniform in `[lo, hi)`.
fn uniform(rng: &mut SplitMix64, (lo, hi): (f64, f64)) -> f64 {
    lo + (hi - lo) * unit_from_bits(rng.next_u64())
}

/// Log-uniform in `[lo, hi)`.
fn log_uniform(rng: &mut SplitMix64, (lo, hi): (f64, f64)) -> f64 {
    uniform(rng, (lo.ln(), hi.ln())).exp()
}

impl SweepPoint {
    /// Point `index` of the sweep drawn from `seed`. Indices cycle through four kinds of path
    /// so that any run of four points covers them all: an LED that moves into place and then
    /// stands still or barely moves (streaks up to 2 px), a line of 3–20 px, a 60 px line, an
    /// arc of 8–40 px on a circle of 15–80 px. The lens is drawn from its own stream.
    pub fn new(seed: u64, index: usize) -> SweepPoint {
        let mut rng = SplitMix64::new(mix64(seed ^ mix64(index as u64)));
        let spot = match rng.next_u64() % 3 {
            0 => SpotKind::Disk,
            1 => SpotKind::Gaussian,
            _ => SpotKind::Bloom,
        };
        let width_px = uniform(&mut rng, WIDTH_RANGE_PX);
        let glow = (
            uniform(&mut rng, GLOW_WIDTH_RANGE),
            uniform(&mut rng, GLOW_RATIO_RANGE),
        );
        let saturation = log_uniform(&mut rng, SATURATION_RANGE);
        let gamma = uniform(&mut rng, GAMMA_RANGE);
        let noise_luma = uniform(&mut rng, (0.0, NOISE_MAX_LUMA));
        let range = if rng.next_u64().is_multiple_of(2) {
            Range::Full
        } else {
            Range::Studio
        };
        let angle_rad = uniform(&mut rng, (0.0, TAU));
        let path = match index % 4 {
            0 => SweepPath::Settle {
                length_px: uniform(&mut rng, (0.0, 2.0)),
                angle_rad,
            },
            1 => SweepPath::Line {
                length_px: uniform(&mut rng, (3.0, 20.0)),
                angle_rad,
            },
            2 => SweepPath::Line {
                length_px: 60.0,
                angle_rad,
            },
            _ => {
                let radius_px = uniform(&mut rng, (15.0, 80.0));
                // At most a quarter turn per exposure.
                let longest = (0.5 * PI * radius_px).min(40.0);
                SweepPath::Arc {
                    radius_px,
                    length_px: uniform(&mut rng, (8.0, longest)),
                }
            }
        };
        SweepPoint {
            index,
            spot,
            width_px,
            glow,
            saturation,
            gamma,
            noise_luma,
            post_noise_luma: post_clip_noise(seed, index),
            range,
            path,
            lens: lens_squeeze(seed, index),
            seed: rng.next_u64(),
        }
    }

    /// The first `count` points of the sweep drawn from `seed`.
    pub fn sweep(seed: u64, count: usize) -> Vec<SweepPoint> {
        (0..count).map(|i| SweepPoint::new(seed, i)).collect()
    }

    /// The LED's spot.
    fn led(&self) -> Led {
        let spot = match self.spot {
            SpotKind::Disk => Spot::Disk,
            SpotKind::Gaussian => Spot::Gaussian {
                sigma_px: self.width_px,
            },
            SpotKind::Bloom => Spot::Bloom {
                sigma_px: self.width_px,
                glow_sigma_px: self.glow.0 * self.width_px,
                glow_ratio: self.glow.1,
            },
        };
        // The centre of a long streak is lit for the time the spot's core takes to pass:
        // its level is the spot's peak times (core's line integral / streak length).
        let core_span_px = match self.spot {
            SpotKind::Disk => 2.0 * self.width_px,
            _ => (TAU).sqrt() * self.width_px,
        };
        // A settling LED's longest streak is on its way in: that one is the point's level
        // (brighter at rest), so that the move that shows it is the LED is seen at all.
        let longest_px = match self.path {
            SweepPath::Settle { length_px, .. } => length_px.max(approach_peak_streak_px()),
            _ => self.path.length_px(),
        };
        let smear = (longest_px / core_span_px).max(1.0);
        Led {
            radius_px: match self.spot {
                SpotKind::Disk => self.width_px,
                _ => 2.0 * self.width_px,
            },
            spot,
            squeeze: self.lens,
            peak: self.saturation * smear,
            glow_peak: 0.0,
            glow_radius_px: 0.0,
        }
    }

    /// The scene of this point: 640×480 at 90 fps, 10 ms exposure, the presets' floor.
    pub fn config(&self) -> SceneConfig {
        let mut config = presets::base(
            &format!("sweep-{}", self.index),
            &self.to_string(),
            EXPOSURE_US,
            MAX_FRAMES,
            Trajectory::Line {
                start_px: Point::default(),
                velocity_px_s: Point::default(),
            },
        );
        config.fps = FPS;
        config.seed = self.seed;
        config.led = self.led();
        config.camera.range = self.range;
        config.camera.gamma = self.gamma;
        config.camera.noise_sigma = self.noise_luma / 255.0;
        config.camera.post_noise_luma = self.post_noise_luma;
        let exposure_s = f64::from(EXPOSURE_US) * 1e-6;
        let centre = Point::new(
            0.5 * f64::from(config.width_px),
            0.5 * f64::from(config.height_px),
        );
        let (trajectory, frames) = match self.path {
            SweepPath::Line {
                length_px,
                angle_rad,
            } => {
                let speed = length_px / exposure_s;
                let per_frame_px = speed / FPS;
                let room_px = f64::from(config.height_px) - 2.0 * MARGIN_PX;
                let frames = if per_frame_px > 0.0 {
                    ((room_px / per_frame_px) as usize).clamp(2, MAX_FRAMES)
                } else {
                    MAX_FRAMES
                };
                let (dx, dy) = (angle_rad.cos(), angle_rad.sin());
                let half_s = 0.5 * frames as f64 / FPS;
                (
                    Trajectory::Line {
                        start_px: Point::new(
                            centre.x - speed * half_s * dx,
                            centre.y - speed * half_s * dy,
                        ),
                        velocity_px_s: Point::new(speed * dx, speed * dy),
                    },
                    frames,
                )
            }
            SweepPath::Settle {
                length_px,
                angle_rad,
            } => {
                let (dx, dy) = (angle_rad.cos(), angle_rad.sin());
                let (arrive_s, move_s) = approach_timing();
                let speed = length_px / exposure_s;
                (
                    Trajectory::Arrive {
                        from_px: Point::new(
                            centre.x - APPROACH_PX * dx,
                            centre.y - APPROACH_PX * dy,
                        ),
                        to_px: centre,
                        move_s,
                        arrive_s,
                        then_velocity_px_s: Point::new(speed * dx, speed * dy),
                    },
                    APPROACH_FRAMES + MAX_FRAMES,
                )
            }
            SweepPath::Arc {
                radius_px,
                length_px,
            } => (
                Trajectory::Circle {
                    centre_px: centre,
                    radius_px,
                    rev_per_s: length_px / exposure_s / (TAU * radius_px),
                    phase_rad: 0.0,
                },
                MAX_FRAMES,
            ),
        };
        config.trajectory = trajectory;
        config.frame_count = frames;
        config
    }
}

impl std::fmt::Display for SweepPoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let path = match self.path {
            SweepPath::Line { length_px, .. } => format!("line {length_px:.1} px"),
            SweepPath::Settle { length_px, .. } => {
                format!("moves into place, then line {length_px:.1} px")
            }
            SweepPath::Arc {
                radius_px,
                length_px,
            } => format!("arc {length_px:.1} px on r {radius_px:.0} px"),
        };
        let lens = if self.lens.is_none() {
            "round (picture centre)".to_string()
        } else {
            format!(
                "squeezed to {:.2} at {:.0}°",
                self.lens.ratio,
                self.lens.axis_rad.to_degrees()
            )
        };
        write!(
            f,
            "{:?} {:.2} px{}, core {:.1}× clip, gamma {:.2}, noise {:.1} luma{}, {:?} range, {path}, {lens}",
            self.spot,
            self.width_px,
            if self.spot == SpotKind::Bloom {
                format!(
                    " (glow {:.1}× wide, {:.3} bright)",
                    self.glow.0, self.glow.1
                )
            } else {
                String::new()
            },
            self.saturation,
            self.gamma,
            self.noise_luma,
            if self.post_noise_luma > 0.0 {
                format!(" and {:.1} after the clip", self.post_noise_luma)
            } else {
                String::new()
            },
            self.range,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;

    #[test]
    fn every_point_builds_and_four_in_a_row_cover_every_path() {
        let points = SweepPoint::sweep(7, 40);
        for p in &points {
            let scene = Scene::new(p.config()).unwrap_or_else(|e| panic!("{p}: {e}"));
            let settled = p.path.settled_frame();
            assert!(scene.frame_count() >= settled + 2);
            let t = scene.truth(settled + 1);
            let length = t.streak_px.unwrap();
            assert!((length - p.path.length_px()).abs() < 1e-3, "{p}: {length}");
            if settled > 0 {
                // Clearly moving on the way in (streaks of 4.8 px or more), in place after.
                for frame in 0..settled {
                    assert!(
                        scene.truth(frame).streak_px.unwrap() > 4.5,
                        "{p}: frame {frame}"
                    );
                }
                // In place by then: at most a frame's creep from where it arrived.
                let arrived = scene.truth(settled);
                let (x, y) = (arrived.x_px.unwrap(), arrived.y_px.unwrap());
                let period_per_exposure = 1.0 / (FPS * f64::from(EXPOSURE_US) * 1e-6);
                let creep_px = p.path.length_px() * period_per_exposure;
                let from_place_px = (x - 320.0).hypot(y - 240.0);
                assert!(from_place_px <= creep_px + 1e-6, "{p}: {from_place_px} px");
            }
        }
        assert!(
            matches!(points[0].path, SweepPath::Settle { .. }),
            "the still kind moves into place"
        );
        let widths: Vec<f64> = points.iter().map(|p| p.width_px).collect();
        assert!(widths.iter().any(|&w| w < 1.2) && widths.iter().any(|&w| w > 2.6));
        assert_eq!(
            SweepPoint::new(7, 5),
            points[5],
            "a point is its seed and index"
        );
    }

    /// The lens: about a third of the points at the picture's centre (round), the rest
    /// squeezed across the whole range along axes all round; drawn apart from the rest.
    #[test]
    fn the_lens_squeezes_two_thirds_of_the_points_over_its_range() {
        let points = SweepPoint::sweep(11, 300);
        let round = points.iter().filter(|p| p.lens.is_none()).count();
        assert!((70..=130).contains(&round), "{round} of 300 round");
        let squeezed: Vec<Squeeze> = points
            .iter()
            .map(|p| p.lens)
            .filter(|l| !l.is_none())
            .collect();
        assert!(squeezed.iter().all(|l| l.ratio >= SQUEEZE_RANGE.0
            && l.ratio < 1.0
            && (0.0..PI).contains(&l.axis_rad)));
        assert!(squeezed.iter().any(|l| l.ratio < 0.7) && squeezed.iter().any(|l| l.ratio > 0.95));
        assert!(
            squeezed.iter().any(|l| l.axis_rad < 0.3) && squeezed.iter().any(|l| l.axis_rad > 2.8)
        );
        assert!(points.iter().any(|p| p.to_string().contains("squeezed to")));
    }

    /// Noise after the clip: in about half the points, across its range, drawn apart.
    #[test]
    fn half_the_points_have_noise_after_the_clip_over_its_range() {
        let points = SweepPoint::sweep(11, 300);
        let post: Vec<f64> = points
            .iter()
            .map(|p| p.post_noise_luma)
            .filter(|&n| n > 0.0)
            .collect();
        assert!((110..=190).contains(&post.len()), "{} of 300", post.len());
        assert!(post
            .iter()
            .all(|n| (POST_NOISE_RANGE_LUMA.0..POST_NOISE_RANGE_LUMA.1).contains(n)));
        assert!(post.iter().any(|&n| n < 0.8) && post.iter().any(|&n| n > 2.7));
        assert!(points
            .iter()
            .any(|p| p.to_string().contains("after the clip")));
    }

    #[test]
    fn a_barely_saturating_streak_clips_only_in_its_core() {
        let mut p = SweepPoint::new(3, 2);
        p.saturation = 1.3;
        p.noise_luma = 0.0;
        p.post_noise_luma = 0.0;
        p.spot = SpotKind::Gaussian;
        let scene = Scene::new(p.config()).unwrap();
        let mut frame = vec![0u8; scene.frame_len_bytes()];
        scene.render(1, &mut frame).unwrap();
        let white = scene.white_luma();
        let clipped = frame.iter().step_by(2).filter(|&&y| y == white).count();
        // A 60 px streak clipped only where the core is above 1/1.3 of its peak: a band
        // about 1.4 σ wide (2 σ sqrt(2 ln 1.3) ≈ 1.45 σ).
        let band = clipped as f64 / 60.0;
        assert!(
            band > 0.5 * p.width_px && band < 3.0 * p.width_px,
            "{band} px wide"
        );
    }
}
