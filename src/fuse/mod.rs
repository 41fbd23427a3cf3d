//! Several cameras, one arena: the reports of cameras calibrated against one shared marker
//! map, merged into one track per robot (`glint fuse`).
//!
//! # Input
//!
//! The fuser takes messages: a camera (an index into the names it was made with), its capture
//! time when the transport carries one, and the camera's report line ([`line`](mod@line)).
//! Where they come from is not its business: [`feed::FileFeed`] reads recorded JSON lines and
//! hands them over in capture-time order; a network subscription hands them over as they
//! arrive.
//!
//! A live feed calls [`line::parse`] with the transport's capture time (or `None`: the line's
//! own `t`) and [`Fuser::push`] for each message as it arrives, or [`Fuser::push_line`] for
//! both; [`Fuser::finish`] at the end.
//!
//! `glint fuse` runs beside the cameras, not on their per-frame path: it allocates per step
//! (a step's tracks, the parsed line), which the cameras' tracking threads never do.
//!
//! # Time steps
//!
//! Capture times are on one clock shared by the cameras (NTP or PTP keeps their clocks
//! together; a recorded dump's sidecar carries them). Reports of different cameras less than
//! [`STEP_TOLERANCE_US`] apart make one fused time step, at the latest of their times; every
//! other report starts a step of its own. So two cameras in step give one step per frame, two
//! out of phase give two, and one camera gives exactly its own frames. A step is written once
//! a report beyond it arrives (or at the end).
//!
//! At a step, each camera's latest sighting of each robot counts if it found the robot with
//! floor numbers (not stale) and is not older than one and a half of that camera's frame
//! intervals (the shortest interval between its reports; before its second report, the other
//! cameras' shortest; until some camera has reported twice, only the step's own sightings
//! count): a camera that has not reported
//! again yet is moved on over its age by its travel over its last frame interval (or, without
//! one, its reported floor velocity). The sightings are averaged
//! with the weights of [`weight`] (its uncertainty, its age, its distance to its picture's
//! edge); the velocity likewise among those that know it. Where a view ends, the spot's weight
//! falls to zero before the spot is cut, so the other camera has taken over by then: the
//! hand-off has no gap, and a robot both cameras see is one track, never two.
//!
//! Robot ids are the cameras' own: ids 1 to `robots` (`--robots`), the single-LED line being
//! robot 1. Cameras must agree on them (issue 14 identifies robots by their LED, which makes
//! an id the same robot in every camera); larger ids are left out and counted.
//!
//! # Clock offsets
//!
//! Where two cameras see the robot moving, their disagreement along its velocity measures the
//! offset between their clocks ([`offset`]); it is reported, with a warning above
//! [`offset::WARN_OFFSET_US`], and not corrected: clocks are assumed synced.

pub mod feed;
pub mod line;
pub mod offset;
pub mod output;
pub mod weight;

use core::fmt;
use std::collections::VecDeque;

use crate::geometry::{FloorUnit, Point};
use line::{Report, Sighting};
use offset::{ClockOffset, OffsetEstimator};

/// Reports of different cameras closer than this are one time step. Below any camera's
/// frame period (glint runs cameras at up to 1000 fps), so one camera's frames never share one.
pub const STEP_TOLERANCE_US: i64 = 1_000;
/// Most robots followed: the cameras' own limit (`glint track --robots`), since the ids fused
/// are the cameras' ids, and the serial link's robot positions carry as many (one constant for
/// the tracker, the reports, the serial link and the fuser).
pub use crate::report::MAX_ROBOTS;
/// A camera's sighting counts until it is this many of its frame intervals old.
const MAX_AGE_INTERVALS: f64 = 1.5;
/// Sightings kept per camera and robot for the clock offset.
const RECENT_SIGHTINGS: usize = 8;
/// The robot must move at least this many pixels between a camera's two reports for the
/// offset to use them: less is the position's noise.
const MIN_OFFSET_TRAVEL_PX: f64 = 2.0;
const MICROS_PER_S: f64 = 1e6;

/// What the fuser needs to know besides the reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FuseConfig {
    /// Robots followed: ids 1 to `robots`.
    pub robots: u32,
    /// Every camera's picture size, px, for the weight near its edges; `None`: unknown.
    pub picture_px: Option<(u32, u32)>,
}

/// One robot at one fused time step.
#[derive(Debug, Clone, PartialEq)]
pub struct FusedTrack {
    /// The robot's id.
    pub id: u32,
    /// Whether any camera saw it.
    pub found: bool,
    /// Floor position, the cameras' floor units.
    pub floor: Option<Point>,
    /// Floor velocity, units/s, when a contributing camera knew it.
    pub velocity: Option<Point>,
    /// Standard deviation of the fused floor position, floor units: the sightings' own
    /// (see [`weight`]) through the weights, `√Σ aᵢ² σᵢ²` for weights `aᵢ` summing to 1 (the
    /// sightings' errors taken as independent). `None` until every contributing camera has
    /// measured its floor length of a pixel: a σ in pixels is no floor distance.
    pub sigma: Option<f64>,
    /// The cameras that contributed and their weights (summing to 1).
    pub cameras: Vec<(usize, f64)>,
    /// Whether every contributing position was a streak's head (not only its middle).
    pub head: bool,
}

/// One fused time step.
#[derive(Debug, Clone, PartialEq)]
pub struct FusedStep {
    /// Capture time on the shared clock, µs.
    pub t_us: i64,
    /// The floor numbers' unit, once a report has named it.
    pub unit: Option<FloorUnit>,
    /// Robots 1 to N, in order.
    pub tracks: Vec<FusedTrack>,
}

/// Why a report was not used.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PushError {
    /// No camera of that index.
    UnknownCamera(usize),
    /// Not later than the camera's previous report.
    BackInTime {
        /// This report's time and the previous one's, µs.
        t_us: i64,
        previous_us: i64,
    },
    /// Floor numbers in another unit than the cameras' so far.
    Unit {
        /// The report's unit and the others'.
        unit: FloorUnit,
        expected: FloorUnit,
    },
    /// Earlier than a step already written.
    Late {
        /// This report's time and the step's, µs.
        t_us: i64,
        step_us: i64,
    },
}

impl fmt::Display for PushError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = |us: i64| us as f64 / MICROS_PER_S;
        match self {
            PushError::UnknownCamera(c) => write!(f, "no camera number {c}"),
            PushError::BackInTime { t_us, previous_us } => write!(
                f,
                "capture time {:.6} s is not after the camera's previous report ({:.6} s): out \
                 of order, left out",
                s(*t_us),
                s(*previous_us)
            ),
            PushError::Unit { unit, expected } => write!(
                f,
                "floor numbers in {}, the other reports' in {}: calibrate every camera in one \
                 unit; left out",
                unit.name(),
                expected.name()
            ),
            PushError::Late { t_us, step_us } => write!(
                f,
                "capture time {:.6} s is before the step already written at {:.6} s: too late, \
                 left out",
                s(*t_us),
                s(*step_us)
            ),
        }
    }
}

impl std::error::Error for PushError {}

/// Why a message (a camera's line) was not used.
#[derive(Debug, Clone, PartialEq)]
pub enum MessageError {
    /// The line is not a report.
    Line(line::LineError),
    /// The report was refused.
    Push(PushError),
}

impl fmt::Display for MessageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MessageError::Line(e) => write!(f, "{e}"),
            MessageError::Push(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for MessageError {}

/// What the fuser did with the reports, for the summary.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FuseCounts {
    /// Reports used.
    pub reports: u64,
    /// Reports left out as out of order or late.
    pub out_of_order: u64,
    /// Found sightings without floor numbers and not beyond the horizon: no calibration.
    pub uncalibrated: u64,
    /// Sightings with stale floor numbers, left out.
    pub stale: u64,
    /// Sightings of ids above `robots`, left out.
    pub other_ids: u64,
    /// Reports left out for floor numbers in another unit.
    pub other_units: u64,
    /// Fused steps written.
    pub steps: u64,
}

/// A camera's latest sighting of one robot.
#[derive(Debug, Clone, Copy)]
struct Latest {
    t_us: i64,
    sighting: Sighting,
}

/// A found floor position kept for the clock offset.
#[derive(Debug, Clone, Copy)]
struct Recent {
    t_us: i64,
    floor: Point,
    /// Far from the picture's edges (full edge weight).
    clean: bool,
}

#[derive(Debug, Clone)]
struct CameraState {
    last_us: Option<i64>,
    /// Shortest interval between its reports, µs.
    interval_us: Option<i64>,
    /// Per robot.
    latest: Vec<Option<Latest>>,
    recent: Vec<VecDeque<Recent>>,
    floor_per_px: Vec<Option<f64>>,
    /// Found sightings without floor numbers seen.
    uncalibrated: bool,
}

impl CameraState {
    /// Robot `r`'s velocity over this camera's last interval, when its sighting at `t_us` and
    /// the one before are consecutive frames: what moves a sighting on by its age. A single
    /// frame's reported velocity can be far off (a short streak read as a long one), and moved
    /// on by half a frame such an outlier would be centimetres; the travel between two frames
    /// cannot be.
    fn travel_velocity(&self, r: usize, t_us: i64, interval_us: Option<i64>) -> Option<Point> {
        let recent = self.recent.get(r)?;
        let mut last_two = recent.iter().rev();
        let (last, before) = (last_two.next()?, last_two.next()?);
        let dt_us = last.t_us - before.t_us;
        let consecutive = last.t_us == t_us
            && dt_us > 0
            && interval_us.is_some_and(|i| dt_us as f64 <= MAX_AGE_INTERVALS * i as f64);
        consecutive
            .then(|| Point::from((last.floor - before.floor) / (dt_us as f64 / MICROS_PER_S)))
    }
}

/// The step being gathered.
#[derive(Debug, Clone)]
struct Pending {
    first_us: i64,
    t_us: i64,
    members: Vec<usize>,
}

/// Merges the cameras' reports into fused steps (see the module documentation).
#[derive(Debug, Clone)]
pub struct Fuser {
    config: FuseConfig,
    cameras: Vec<CameraState>,
    pending: Option<Pending>,
    last_step_us: Option<i64>,
    offsets: OffsetEstimator,
    counts: FuseCounts,
    /// The floor unit, from the first report that named one.
    unit: Option<FloorUnit>,
}

impl Fuser {
    /// A fuser for `cameras` cameras (at least one) and `config.robots` robots (1 to
    /// [`MAX_ROBOTS`]; clamped).
    pub fn new(cameras: usize, config: FuseConfig) -> Fuser {
        let robots = (config.robots as usize).clamp(1, MAX_ROBOTS);
        let camera = CameraState {
            last_us: None,
            interval_us: None,
            latest: vec![None; robots],
            recent: vec![VecDeque::with_capacity(RECENT_SIGHTINGS); robots],
            floor_per_px: vec![None; robots],
            uncalibrated: false,
        };
        Fuser {
            config: FuseConfig {
                robots: robots as u32,
                ..config
            },
            cameras: vec![camera; cameras.max(1)],
            pending: None,
            last_step_us: None,
            offsets: OffsetEstimator::new(cameras.max(1)),
            counts: FuseCounts::default(),
            unit: None,
        }
    }

    /// Takes one camera's report; writes through `emit` the step it closes, if any.
    pub fn push(
        &mut self,
        camera: usize,
        report: &Report,
        emit: &mut dyn FnMut(&FusedStep),
    ) -> Result<(), PushError> {
        let t_us = report.t_us;
        let Some(state) = self.cameras.get(camera) else {
            return Err(PushError::UnknownCamera(camera));
        };
        let refused = if let Some(previous_us) = state.last_us.filter(|&p| t_us <= p) {
            Some(PushError::BackInTime { t_us, previous_us })
        } else {
            self.last_step_us
                .filter(|&s| t_us <= s)
                .map(|step_us| PushError::Late { t_us, step_us })
        };
        if let Some(e) = refused {
            self.counts.out_of_order += 1;
            return Err(e);
        }
        let mut units = report.sightings.iter().filter_map(|s| s.unit);
        if let Some(unit) = units.next() {
            let expected = *self.unit.get_or_insert(unit);
            if let Some(unit) = core::iter::once(unit).chain(units).find(|&u| u != expected) {
                self.counts.other_units += 1;
                return Err(PushError::Unit { unit, expected });
            }
        }
        let closes = self
            .pending
            .as_ref()
            .is_some_and(|p| t_us >= p.first_us + STEP_TOLERANCE_US || p.members.contains(&camera));
        if closes {
            self.close(emit);
        }
        self.counts.reports += 1;
        self.take(camera, report);
        let pending = self.pending.get_or_insert(Pending {
            first_us: t_us,
            t_us,
            members: Vec::new(),
        });
        pending.t_us = pending.t_us.max(t_us);
        pending.members.push(camera);
        Ok(())
    }

    /// Parses one camera's report line (its capture time `capture_us` when the transport gave
    /// one, else the line's `t`) and takes it, as [`Fuser::push`].
    pub fn push_line(
        &mut self,
        camera: usize,
        capture_us: Option<i64>,
        line: &str,
        emit: &mut dyn FnMut(&FusedStep),
    ) -> Result<(), MessageError> {
        let report = line::parse(line, capture_us).map_err(MessageError::Line)?;
        self.push(camera, &report, emit).map_err(MessageError::Push)
    }

    /// Writes the step still being gathered (at the end of the input).
    pub fn finish(&mut self, emit: &mut dyn FnMut(&FusedStep)) {
        self.close(emit);
    }

    /// The clock offsets measured so far.
    pub fn offsets(&self) -> Vec<ClockOffset> {
        self.offsets.offsets()
    }

    /// The counts so far.
    pub fn counts(&self) -> FuseCounts {
        self.counts
    }

    /// The cameras' floor unit, once a report has named it.
    pub fn unit(&self) -> Option<FloorUnit> {
        self.unit
    }

    /// Whether camera `camera` reported found sightings without floor numbers.
    pub fn uncalibrated(&self, camera: usize) -> bool {
        self.cameras.get(camera).is_some_and(|c| c.uncalibrated)
    }

    /// Records a report in its camera's state, and samples the clock offsets.
    fn take(&mut self, camera: usize, report: &Report) {
        let robots = self.config.robots;
        let picture_px = self.config.picture_px;
        let Some(state) = self.cameras.get_mut(camera) else {
            return;
        };
        if let Some(previous) = state.last_us {
            let dt = report.t_us - previous;
            state.interval_us = Some(state.interval_us.map_or(dt, |i| i.min(dt)));
        }
        state.last_us = Some(report.t_us);
        state.latest.iter_mut().for_each(|l| *l = None);
        let mut fresh: Vec<(usize, Recent, Option<f64>)> = Vec::new();
        for s in &report.sightings {
            if s.id > robots {
                self.counts.other_ids += 1;
                continue;
            }
            let r = (s.id - 1) as usize;
            if let Some(l) = state.latest.get_mut(r) {
                *l = Some(Latest {
                    t_us: report.t_us,
                    sighting: *s,
                });
            }
            if !s.found {
                continue;
            }
            if s.floor.is_none() && !s.beyond_horizon {
                self.counts.uncalibrated += 1;
                state.uncalibrated = true;
            }
            if s.floor_stale {
                self.counts.stale += 1;
            }
            if let Some(scale) = weight::floor_per_px(s) {
                if let Some(f) = state.floor_per_px.get_mut(r) {
                    *f = Some(scale);
                }
            }
            if let (Some(floor), false) = (s.floor, s.floor_stale) {
                let clean = weight::edge_weight(s, picture_px) >= 1.0;
                let scale = state.floor_per_px.get(r).copied().flatten();
                fresh.push((
                    r,
                    Recent {
                        t_us: report.t_us,
                        floor,
                        clean,
                    },
                    scale,
                ));
            }
        }
        let interval_us = state.interval_us;
        for (r, now, scale) in fresh {
            self.sample_offsets(camera, r, now, scale, interval_us);
            if let Some(recent) = self
                .cameras
                .get_mut(camera)
                .and_then(|c| c.recent.get_mut(r))
            {
                if recent.len() == RECENT_SIGHTINGS {
                    recent.pop_front();
                }
                recent.push_back(now);
            }
        }
    }

    /// With camera `camera`'s sighting `now` of robot `r` and its previous one, interpolates
    /// where this camera saw the robot at the times other cameras saw it in between.
    fn sample_offsets(
        &mut self,
        camera: usize,
        r: usize,
        now: Recent,
        floor_per_px: Option<f64>,
        interval_us: Option<i64>,
    ) {
        let Some(previous) = self
            .cameras
            .get(camera)
            .and_then(|c| c.recent.get(r))
            .and_then(|q| q.back().copied())
        else {
            return;
        };
        let (Some(interval_us), Some(floor_per_px)) = (interval_us, floor_per_px) else {
            return;
        };
        let dt_us = now.t_us - previous.t_us;
        let travel = now.floor - previous.floor;
        let consecutive = dt_us > 0 && (dt_us as f64) <= MAX_AGE_INTERVALS * interval_us as f64;
        if !(now.clean && previous.clean && consecutive)
            || travel.norm() < MIN_OFFSET_TRAVEL_PX * floor_per_px
        {
            return;
        }
        let velocity = Point::from(travel / (dt_us as f64 / MICROS_PER_S));
        for (other, state) in self.cameras.iter().enumerate() {
            if other == camera {
                continue;
            }
            let Some(recent) = state.recent.get(r) else {
                continue;
            };
            for seen in recent {
                if seen.clean && seen.t_us > previous.t_us && seen.t_us <= now.t_us {
                    let share = (seen.t_us - previous.t_us) as f64 / dt_us as f64;
                    let here = previous.floor + travel * share;
                    self.offsets.add(other, seen.floor, camera, here, velocity);
                }
            }
        }
    }

    /// Fuses and writes the pending step.
    fn close(&mut self, emit: &mut dyn FnMut(&FusedStep)) {
        let Some(pending) = self.pending.take() else {
            return;
        };
        let t_us = pending.t_us;
        let tracks = (1..=self.config.robots)
            .map(|id| self.fuse(id, t_us))
            .collect();
        self.last_step_us = Some(t_us);
        self.counts.steps += 1;
        emit(&FusedStep {
            t_us,
            unit: self.unit,
            tracks,
        });
    }

    /// Robot `id` (1-based) at `t_us`.
    fn fuse(&self, id: u32, t_us: i64) -> FusedTrack {
        let r = (id - 1) as usize;
        struct Part {
            camera: usize,
            floor: Point,
            velocity: Option<Point>,
            sigma_px: f64,
            head: bool,
            floor_per_px: Option<f64>,
            age_share: f64,
            edge: f64,
        }
        // A camera that has reported once has no interval of its own yet: the others' (cameras
        // of one arena run at one rate) bounds its age until it has.
        let any_interval_us = self.cameras.iter().filter_map(|c| c.interval_us).min();
        let mut parts = Vec::new();
        for (camera, state) in self.cameras.iter().enumerate() {
            let Some(Some(l)) = state.latest.get(r) else {
                continue;
            };
            let s = &l.sighting;
            let (true, Some(floor), false) = (s.found, s.floor, s.floor_stale) else {
                continue;
            };
            let age_us = t_us - l.t_us;
            let interval_us = state.interval_us.or(any_interval_us).filter(|&i| i > 0);
            let age_share = interval_us.map_or(0.0, |i| age_us as f64 / i as f64);
            let fresh = age_us < STEP_TOLERANCE_US;
            if !(fresh || (interval_us.is_some() && age_share <= MAX_AGE_INTERVALS)) {
                continue;
            }
            let age_s = age_us as f64 / MICROS_PER_S;
            let floor = match (age_us > 0)
                .then(|| state.travel_velocity(r, l.t_us, interval_us))
                .flatten()
                .or(s.floor_velocity)
            {
                Some(v) => floor + v.coords * age_s,
                None => floor,
            };
            parts.push(Part {
                camera,
                floor,
                velocity: s.floor_velocity,
                sigma_px: weight::sigma_px(s),
                head: s.head,
                floor_per_px: state.floor_per_px.get(r).copied().flatten(),
                age_share,
                edge: weight::edge_weight(s, self.config.picture_px),
            });
        }
        if parts.is_empty() {
            return FusedTrack {
                id,
                found: false,
                floor: None,
                velocity: None,
                sigma: None,
                cameras: Vec::new(),
                head: false,
            };
        }
        let scaled = parts.iter().all(|p| p.floor_per_px.is_some());
        let variance = |p: &Part| {
            let sigma = p.sigma_px
                * if scaled {
                    p.floor_per_px.unwrap_or(1.0)
                } else {
                    1.0
                };
            sigma * sigma * (1.0 + p.age_share * p.age_share)
        };
        let mut weights: Vec<f64> = parts.iter().map(|p| p.edge / variance(p)).collect();
        if weights.iter().sum::<f64>() <= 0.0 {
            // Every view cuts the spot: what they say is still all there is.
            weights = parts.iter().map(|p| 1.0 / variance(p)).collect();
        }
        let total: f64 = weights.iter().sum();
        let mut floor = Point::origin();
        for (p, w) in parts.iter().zip(&weights) {
            floor += p.floor.coords * (w / total);
        }
        let known: f64 = parts
            .iter()
            .zip(&weights)
            .filter(|(p, _)| p.velocity.is_some())
            .map(|(_, w)| w)
            .sum();
        let velocity = (known > 0.0).then(|| {
            let mut v = Point::origin();
            for (p, w) in parts.iter().zip(&weights) {
                if let Some(pv) = p.velocity {
                    v += pv.coords * (w / known);
                }
            }
            v
        });
        let sigma = scaled.then(|| {
            parts
                .iter()
                .zip(&weights)
                .map(|(p, w)| (w / total).powi(2) * variance(p))
                .sum::<f64>()
                .sqrt()
        });
        FusedTrack {
            id,
            found: true,
            floor: Some(floor),
            velocity,
            sigma: sigma.filter(|s| s.is_finite()),
            cameras: parts
                .iter()
                .zip(&weights)
                .filter(|(_, w)| **w > 0.0)
                .map(|(p, w)| (p.camera, w / total))
                .collect(),
            head: parts.iter().all(|p| p.head),
        }
    }
}

#[cfg(test)]
mod tests;
