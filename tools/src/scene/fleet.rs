//! Several robots in one scene, each carrying one LED on its own trajectory, with the glare,
//! static lights and occluders of a base scene: what `glint track --robots N` is tested on.
//!
//! Every robot is a [`Scene`] that differs from the base only in its trajectory, so its
//! [`Truth`] (visibility, positions, velocity) is the single-robot truth, computed from its
//! formulas. A frame adds every robot's LED light into the base's static picture before the
//! sensor's noise and quantisation, exactly as one LED is rendered; the picture is the ideal
//! camera's (a scene with a view is refused).

use super::presets::base;
use super::{
    hide, patch_row, Glare, Occluder, Patch, Point, Scene, SceneConfig, SceneError, Trajectory,
    Truth, NOISE_SALT,
};
use super::{mix64, SplitMix64};

/// The robots' LEDs and what they share.
#[derive(Clone, Debug)]
pub struct Fleet {
    /// One scene per robot; the first holds the static picture all share.
    robots: Vec<Scene>,
}

impl Fleet {
    /// Robots on `trajectories` (at least one) in the scene `base` (whose own trajectory is
    /// replaced).
    pub fn new(base: &SceneConfig, trajectories: &[Trajectory]) -> Result<Fleet, SceneError> {
        if base.view.is_some() {
            return Err(super::invalid(
                "view",
                "a fleet is rendered through the ideal camera",
            ));
        }
        if trajectories.is_empty() {
            return Err(super::invalid(
                "trajectory",
                "a fleet has at least one robot",
            ));
        }
        let robots = trajectories
            .iter()
            .map(|trajectory| {
                Scene::new(SceneConfig {
                    trajectory: trajectory.clone(),
                    ..base.clone()
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Fleet { robots })
    }

    /// A fleet preset by name (see [`Fleet::names`]).
    pub fn preset(name: &str) -> Option<Fleet> {
        let (config, trajectories) = preset(name)?;
        Fleet::new(&config, &trajectories).ok()
    }

    /// A fleet preset's shared configuration and its robots' trajectories, to change (frames,
    /// seed...) before [`Fleet::new`].
    pub fn preset_config(name: &str) -> Option<(SceneConfig, Vec<Trajectory>)> {
        preset(name)
    }

    /// The fleet preset names.
    pub fn names() -> &'static [&'static str] {
        NAMES
    }

    /// The number of robots.
    pub fn robots(&self) -> usize {
        self.robots.len()
    }

    /// The scene of robot `k` (its truth, and the settings all robots share).
    pub fn robot(&self, k: usize) -> Option<&Scene> {
        self.robots.get(k)
    }

    fn shared(&self) -> &Scene {
        // `new` refuses an empty fleet.
        &self.robots[0]
    }

    /// Every robot's truth in frame `frame`, in robot order.
    pub fn truths(&self, frame: usize) -> Vec<Truth> {
        self.robots.iter().map(|r| r.truth(frame)).collect()
    }

    /// Renders frame `frame` as packed YUYV into `out` and returns every robot's truth.
    pub fn render(&self, frame: usize, out: &mut [u8]) -> Result<Vec<Truth>, SceneError> {
        let shared = self.shared();
        let expected = shared.frame_len_bytes();
        if out.len() != expected {
            return Err(SceneError::BufferLength {
                expected,
                actual: out.len(),
            });
        }
        let config = shared.config();
        let width = config.width_px as usize;
        let mut patches: Vec<Patch> = self.robots.iter().map(|r| r.led_radiance(frame)).collect();
        for patch in &mut patches {
            for occluder in &config.occluders {
                hide(patch, occluder);
            }
        }
        let mut rng = config
            .camera
            .is_noisy()
            .then(|| SplitMix64::new(mix64(config.seed ^ mix64(frame as u64 ^ NOISE_SALT))));
        let mut row = vec![0.0f32; width];
        for (y, (out_row, static_row)) in out
            .chunks_exact_mut(2 * width)
            .zip(shared.static_radiance.chunks_exact(width))
            .enumerate()
        {
            row.copy_from_slice(static_row);
            for patch in &patches {
                if let Some(led_row) = patch_row(patch, y) {
                    if let Some(dst) = row.get_mut(patch.left..patch.left + led_row.len()) {
                        for (d, s) in dst.iter_mut().zip(led_row) {
                            *d += s;
                        }
                    }
                }
            }
            config.camera.expose_row(&row, &mut rng, out_row);
        }
        Ok(self.truths(frame))
    }
}

/// The fleet presets, each with glare in view.
const NAMES: &[&str] = &["fleet-crossing", "fleet-meeting", "fleet-leave-return"];

/// Two glare spots away from every preset's paths.
fn glare() -> Vec<Glare> {
    vec![
        Glare {
            centre_px: Point::new(90.0, 420.0),
            radius_px: 6.0,
            peak: 6.0,
        },
        Glare {
            centre_px: Point::new(560.0, 60.0),
            radius_px: 9.0,
            peak: 4.0,
        },
    ]
}

fn preset(name: &str) -> Option<(SceneConfig, Vec<Trajectory>)> {
    let line = |x: f64, y: f64, vx: f64, vy: f64| Trajectory::Line {
        start_px: Point::new(x, y),
        velocity_px_s: Point::new(vx, vy),
    };
    let (summary, frames, trajectories, occluders) = match name {
        // A and B cross diagonally, A passing 20 px above where B is (inside each other's
        // gate) at t = 2.1 s; C circles beside them.
        "fleet-crossing" => (
            "three robots: two crossing paths 20 px apart, one circling, two glare spots",
            150,
            vec![
                line(120.0, 120.0, 100.0, 75.0),
                line(540.0, 140.0, -100.0, 75.0),
                Trajectory::Circle {
                    centre_px: Point::new(200.0, 380.0),
                    radius_px: 50.0,
                    rev_per_s: 0.3,
                    phase_rad: 0.0,
                },
            ],
            Vec::new(),
        ),
        // A and B meet head-on on one line: their LEDs pass through each other (one blob
        // for a few frames, `merged`). C and D drive to within 16 px of each other, stand
        // there 1 s, and drive back the way they came.
        "fleet-meeting" => (
            "four robots: two passing through each other head-on, two meeting, standing side by side and parting; two glare spots",
            150,
            vec![
                line(100.0, 150.0, 110.0, 0.0),
                line(540.0, 150.0, -110.0, 0.0),
                Trajectory::StopGo {
                    waypoints_px: vec![Point::new(180.0, 320.0), Point::new(312.0, 320.0)],
                    move_s: 1.2,
                    hold_s: 1.0,
                    start_s: 0.1,
                },
                Trajectory::StopGo {
                    waypoints_px: vec![Point::new(460.0, 320.0), Point::new(328.0, 320.0)],
                    move_s: 1.2,
                    hold_s: 1.0,
                    start_s: 0.1,
                },
            ],
            Vec::new(),
        ),
        // A drives out of the right edge and back (1.2 s out of view, longer than a track
        // coasts); B circles and passes behind an occluder.
        "fleet-leave-return" => (
            "two robots: one leaving the view and coming back, one passing behind an occluder; two glare spots",
            150,
            vec![
                Trajectory::PingPong {
                    a_px: Point::new(330.0, 200.0),
                    b_px: Point::new(800.0, 200.0),
                    speed_px_s: 280.0,
                    at_a_s: 0.0,
                },
                Trajectory::Circle {
                    centre_px: Point::new(200.0, 300.0),
                    radius_px: 80.0,
                    rev_per_s: 0.4,
                    phase_rad: 0.0,
                },
            ],
            vec![Occluder {
                left: 100,
                top: 280,
                width: 30,
                height: 40,
                radiance: 0.05,
            }],
        ),
        _ => return None,
    };
    let mut config = base(name, summary, 8_000, frames, trajectories[0].clone());
    config.glare = glare();
    config.occluders = occluders;
    Some((config, trajectories))
}
