//! A differential-drive robot following a figure-eight by pure pursuit, steered by glint's floor
//! positions, with the latency compensation that the age of each position (protocol version 2)
//! makes possible.
//!
//! Glint's position is where the light was at the end of an exposure some tens of
//! milliseconds ago. Steering from it as if it were now makes the robot react late on every
//! bend. With compensation on, the controller drives the position (and the heading, the
//! direction of glint's velocity) on over its age by the commands it gave since that exposure,
//! through the motors' lag ([`crate::reckon`]), then steers from there. With compensation off
//! it steers from the position as it came, which is also what a firmware that does not know the
//! age frame does.
//!
//! One wheel command per position update: when its age arrives (once ages are seen on the
//! link), at once otherwise.

use glint_protocol::{Position, Status, Units};
use libm::{atan2f, cosf, fmodf, hypotf, sinf};

use crate::control::{ArrivedAge, ControlLoop};
use crate::reckon::{self, CommandHistory};

/// Microseconds per second.
const US_PER_S: f32 = 1e6;
/// Full turn, radians.
const TAU: f32 = core::f32::consts::TAU;
/// Parameter step of the searches along the path, radians of the figure's phase.
const SEARCH_STEP_RAD: f32 = 0.005;
/// The nearest point is searched this far behind and ahead of the last one (rad of phase): the
/// robot moves about 0.04 rad between updates, and a window this narrow never jumps to the
/// other branch where the figure crosses itself.
const SEARCH_BEHIND_RAD: f32 = 0.1;
const SEARCH_AHEAD_RAD: f32 = 0.25;
/// Below this speed, glint's velocity says nothing about the heading, mm/s: the robot is then
/// taken to face along the path where it is (as it is put down at the start).
const MIN_HEADING_SPEED_MM_S: f32 = 50.0;

/// The planned path: `x = a sin φ, y = b sin 2φ` (a figure-eight `2a` wide and `2b` high,
/// centred on the floor origin), driven with φ increasing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FigureEight {
    /// Half the width, mm.
    pub half_width_mm: f32,
    /// Half the height, mm.
    pub half_height_mm: f32,
}

impl FigureEight {
    /// The rig's figure-eight, 1.2 m × 0.6 m.
    pub const RIG: FigureEight = FigureEight {
        half_width_mm: 600.0,
        half_height_mm: 300.0,
    };

    /// The point at phase `phi_rad`, mm.
    pub fn point(&self, phi_rad: f32) -> (f32, f32) {
        (
            self.half_width_mm * sinf(phi_rad),
            self.half_height_mm * sinf(2.0 * phi_rad),
        )
    }

    /// Squared distance from `p` to the point at `phi_rad`, mm².
    fn distance2(&self, p: (f32, f32), phi_rad: f32) -> f32 {
        let q = self.point(phi_rad);
        (q.0 - p.0) * (q.0 - p.0) + (q.1 - p.1) * (q.1 - p.1)
    }

    /// The phase in `[from, to]` (stepped by [`SEARCH_STEP_RAD`]) nearest to `p`.
    fn nearest_in(&self, p: (f32, f32), from_rad: f32, to_rad: f32) -> f32 {
        let steps = ((to_rad - from_rad) / SEARCH_STEP_RAD) as u32;
        (0..=steps)
            .map(|k| from_rad + k as f32 * SEARCH_STEP_RAD)
            .fold((from_rad, f32::INFINITY), |best, phi| {
                let d = self.distance2(p, phi);
                if d < best.1 {
                    (phi, d)
                } else {
                    best
                }
            })
            .0
    }

    /// The phase `length_mm` of path ahead of `phi_rad`.
    fn ahead(&self, phi_rad: f32, length_mm: f32) -> f32 {
        let mut phi = phi_rad;
        let mut walked = 0.0;
        let mut at = self.point(phi);
        while walked < length_mm {
            phi += SEARCH_STEP_RAD;
            let next = self.point(phi);
            walked += hypotf(next.0 - at.0, next.1 - at.1);
            at = next;
        }
        phi
    }
}

/// The robot's build and how it drives the path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PursuitParams {
    /// The path.
    pub path: FigureEight,
    /// Forward speed, mm/s.
    pub speed_mm_s: f32,
    /// Distance between the wheels, mm.
    pub wheel_base_mm: f32,
    /// Pure pursuit's lookahead along the path, mm.
    pub lookahead_mm: f32,
    /// The wheels follow a command with this first-order lag (the motors and their drivers),
    /// µs.
    pub motor_lag_us: u32,
    /// Move positions on by their age (see the module's doc).
    pub compensate: bool,
}

/// A wheel speed command, mm/s, and what it was computed from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WheelCommand {
    /// The position update it answers.
    pub seq: u8,
    /// That update's capture timestamp (glint's frame clock), µs.
    pub timestamp_us: u32,
    /// The light was in view: a command to follow the path, not to stop.
    pub steering: bool,
    /// Left wheel, mm/s.
    pub left_mm_s: i32,
    /// Right wheel, mm/s.
    pub right_mm_s: i32,
    /// The position's age when the command was computed (glint's age on arrival plus the time
    /// since), µs, when the age arrived.
    pub age: Option<ArrivedAge>,
}

/// The robot's pose as the controller takes it, mm and radians.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Pose {
    x_mm: f32,
    y_mm: f32,
    /// `None` at rest, when glint's velocity gives no direction.
    heading_rad: Option<f32>,
}

/// The controller: positions and ages in, one [`WheelCommand`] per update out.
#[derive(Debug, Clone, PartialEq)]
pub struct PurePursuit {
    params: PursuitParams,
    /// Phase of the path point nearest to the last pose, once known.
    phase_rad: Option<f32>,
    /// The position waiting for its age.
    pending: Option<Position>,
    /// Ages have been seen on the link: positions wait for theirs.
    ages_seen: bool,
    /// The last command's turn rate, rad/s: the arc along which positions are moved on before
    /// any command's moment is known.
    turn_rad_s: f32,
    /// The commands given, with their moments, since ages arrive.
    given: CommandHistory,
    /// glint has found the robot at least once.
    seen: bool,
    ready: Option<WheelCommand>,
}

/// Straight-ahead speed before glint has found the robot once, mm/s. glint never takes a light
/// that has stood still since it appeared (it could be glare), so a robot that waited for its
/// first position would wait for ever: it creeps until it is seen. After that, a lost light
/// stops it.
pub const CREEP_MM_S: f32 = 100.0;

impl PurePursuit {
    /// A controller at the start of the path.
    pub fn new(params: PursuitParams) -> Self {
        PurePursuit {
            params,
            phase_rad: None,
            pending: None,
            ages_seen: false,
            seen: false,
            turn_rad_s: 0.0,
            given: CommandHistory::new(),
            ready: None,
        }
    }

    /// The settings.
    pub fn params(&self) -> PursuitParams {
        self.params
    }

    /// Switches latency compensation on or off.
    pub fn set_compensation(&mut self, on: bool) {
        self.params.compensate = on;
    }

    /// The command computed since the last call, if any.
    pub fn take_command(&mut self) -> Option<WheelCommand> {
        self.ready.take()
    }

    /// The pose glint measured and the speed, or `None` if it cannot be steered from.
    fn measured_pose(p: &Position) -> Option<(Pose, f32)> {
        if p.units != Units::Floor || p.status == Status::Lost {
            return None;
        }
        let (vx, vy) = (f32::from(p.vx_per_s), f32::from(p.vy_per_s));
        let speed = hypotf(vx, vy);
        let pose = Pose {
            x_mm: f32::from(p.x),
            y_mm: f32::from(p.y),
            heading_rad: (speed >= MIN_HEADING_SPEED_MM_S).then(|| atan2f(vy, vx)),
        };
        Some((pose, speed))
    }

    /// `pose` moved on for `age_s` at `speed_mm_s` along an arc of the last turn rate.
    fn moved_on(&self, pose: Pose, speed_mm_s: f32, age_s: f32) -> Pose {
        let Some(h) = pose.heading_rad else {
            return pose;
        };
        let turn = self.turn_rad_s * age_s;
        let (dx, dy) = if turn.abs() < 1e-6 {
            (speed_mm_s * age_s * cosf(h), speed_mm_s * age_s * sinf(h))
        } else {
            let r = speed_mm_s / self.turn_rad_s;
            (
                r * (sinf(h + turn) - sinf(h)),
                -r * (cosf(h + turn) - cosf(h)),
            )
        };
        Pose {
            x_mm: pose.x_mm + dx,
            y_mm: pose.y_mm + dy,
            heading_rad: Some(h + turn),
        }
    }

    /// Pure pursuit from `pose`: the wheel speeds of the arc through the path point one
    /// lookahead ahead of the nearest one.
    fn steer(&mut self, pose: Pose) -> (f32, f32) {
        let path = self.params.path;
        let at = (pose.x_mm, pose.y_mm);
        let phase = match self.phase_rad {
            Some(phi) => path.nearest_in(at, phi - SEARCH_BEHIND_RAD, phi + SEARCH_AHEAD_RAD),
            None => path.nearest_in(at, 0.0, TAU),
        };
        // Kept within a turn, so that f32 keeps its precision lap after lap.
        let phase = fmodf(phase + TAU, TAU);
        self.phase_rad = Some(phase);
        let goal = path.point(path.ahead(phase, self.params.lookahead_mm));
        let (dx, dy) = (goal.0 - pose.x_mm, goal.1 - pose.y_mm);
        let heading = pose.heading_rad.unwrap_or_else(|| {
            let (a, b) = (path.point(phase), path.point(phase + SEARCH_STEP_RAD));
            atan2f(b.1 - a.1, b.0 - a.0)
        });
        let (sin, cos) = (sinf(heading), cosf(heading));
        let lateral = -sin * dx + cos * dy;
        let chord2 = (dx * dx + dy * dy).max(1.0);
        let curvature_per_mm = 2.0 * lateral / chord2;
        let v = self.params.speed_mm_s;
        self.turn_rad_s = v * curvature_per_mm;
        let half_diff = 0.5 * self.turn_rad_s * self.params.wheel_base_mm;
        (v - half_diff, v + half_diff)
    }

    /// `pose`, measured `age_us` before `now_us`, driven on to now by the commands given since
    /// (along the last commanded arc before any command's moment is known).
    fn compensated(&self, pose: Pose, speed_mm_s: f32, age_us: u32, now_us: u32) -> Pose {
        let Some(heading_rad) = pose.heading_rad else {
            return pose;
        };
        let measured = reckon::Pose {
            x_mm: pose.x_mm,
            y_mm: pose.y_mm,
            heading_rad,
        };
        let since_us = now_us.wrapping_sub(age_us);
        match self
            .given
            .drive_on(measured, since_us, now_us, self.params.motor_lag_us)
        {
            Some(p) => Pose {
                x_mm: p.x_mm,
                y_mm: p.y_mm,
                heading_rad: Some(p.heading_rad),
            },
            None => self.moved_on(pose, speed_mm_s, age_us as f32 / US_PER_S),
        }
    }

    /// Computes the command for `p`, `age` old (zero when not compensating or unknown).
    fn command_for(&mut self, p: &Position, age: Option<ArrivedAge>, now_us: Option<u32>) {
        let measured = Self::measured_pose(p);
        let (left, right) = match measured {
            Some((pose, speed)) => {
                let pose = match (self.params.compensate, age, now_us) {
                    (true, Some(a), Some(now)) => {
                        self.compensated(pose, speed, a.age_at_us(now), now)
                    }
                    _ => pose,
                };
                self.steer(pose)
            }
            None => {
                self.turn_rad_s = 0.0;
                let creep = if self.seen { 0.0 } else { CREEP_MM_S };
                (creep, creep)
            }
        };
        self.seen |= measured.is_some();
        if let Some(now) = now_us {
            let turn_rad_s = (right - left) / self.params.wheel_base_mm;
            self.given.push(now, 0.5 * (left + right), turn_rad_s);
        }
        self.ready = Some(WheelCommand {
            seq: p.seq,
            timestamp_us: p.timestamp_us,
            steering: measured.is_some(),
            left_mm_s: left as i32,
            right_mm_s: right as i32,
            age,
        });
    }
}

impl ControlLoop for PurePursuit {
    fn on_position(&mut self, p: &Position) {
        if self.ages_seen {
            self.pending = Some(*p);
        } else {
            self.command_for(p, None, None);
        }
    }

    fn on_age(&mut self, age: &ArrivedAge) {
        self.ages_seen = true;
        if let Some(p) = self.pending.take().filter(|p| p.seq == age.seq) {
            // Computed as the age arrives: its receive latency so far is nil.
            self.command_for(&p, Some(*age), Some(age.received_at_us));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PARAMS: PursuitParams = PursuitParams {
        path: FigureEight::RIG,
        speed_mm_s: 500.0,
        wheel_base_mm: 120.0,
        lookahead_mm: 100.0,
        motor_lag_us: 30_000,
        compensate: true,
    };

    fn position(seq: u8, at: (f32, f32), v: (f32, f32)) -> Position {
        Position {
            seq,
            timestamp_us: 0,
            units: Units::Floor,
            x: at.0 as i16,
            y: at.1 as i16,
            vx_per_s: v.0 as i16,
            vy_per_s: v.1 as i16,
            status: Status::Found,
            quality: 255,
        }
    }

    fn age(seq: u8, age_us: u32) -> ArrivedAge {
        ArrivedAge {
            seq,
            age_us,
            received_at_us: 1_000,
            predicted: false,
        }
    }

    #[test]
    fn on_the_path_and_along_it_both_wheels_drive_at_the_speed() {
        // At φ = π/2 the path runs straight down (−y) through (600, 0), bending to the right
        // (toward the centre, −x) with a 600 mm radius: left wheel a little faster.
        let mut c = PurePursuit::new(PARAMS);
        c.on_position(&position(1, (600.0, 0.0), (0.0, -500.0)));
        let cmd = c.take_command().unwrap();
        let mean = (cmd.left_mm_s + cmd.right_mm_s) / 2;
        assert!((mean - 500).abs() <= 1, "{cmd:?}");
        // ω = v/R = 0.83 rad/s; wheels ±ω·60 mm = ±50 mm/s (the chord shortens R a little).
        let diff = cmd.left_mm_s - cmd.right_mm_s;
        assert!((90..=110).contains(&diff), "{cmd:?}");
        assert!(c.take_command().is_none());
    }

    #[test]
    fn a_robot_off_the_path_turns_back_toward_it() {
        let mut c = PurePursuit::new(PARAMS);
        // 30 mm outside the right lobe, heading down: turn right (toward −x) harder than on
        // the path; 30 mm inside: turn left, back out.
        c.on_position(&position(1, (630.0, 0.0), (0.0, -500.0)));
        let outside = c.take_command().unwrap();
        let mut c = PurePursuit::new(PARAMS);
        c.on_position(&position(1, (570.0, 0.0), (0.0, -500.0)));
        let inside = c.take_command().unwrap();
        let right_turn = |c: WheelCommand| c.left_mm_s - c.right_mm_s;
        assert!(
            right_turn(outside) > 110 && right_turn(inside) < 0,
            "{outside:?} {inside:?}"
        );
    }

    #[test]
    fn once_ages_are_seen_a_position_waits_for_its_age_and_is_moved_on_by_it() {
        let mut c = PurePursuit::new(PARAMS);
        // A first age teaches the controller that the link carries them.
        c.on_position(&position(1, (600.0, 0.0), (0.0, -500.0)));
        assert!(c.take_command().is_some());
        c.on_age(&age(1, 10_000));
        // Outside the lobe by 30 mm but heading back in (−x): 60 ms later the robot is on the
        // path. Without the age it looks 30 mm out.
        c.on_position(&position(2, (630.0, 0.0), (-500.0, 0.0)));
        assert!(c.take_command().is_none());
        c.on_age(&age(2, 60_000));
        let moved = c.take_command().unwrap();
        assert_eq!(moved.seq, 2);
        assert_eq!(moved.age.map(|a| a.age_us), Some(60_000));
        let mut raw = PurePursuit::new(PursuitParams {
            compensate: false,
            ..PARAMS
        });
        raw.on_position(&position(1, (600.0, 0.0), (0.0, -500.0)));
        raw.on_age(&age(1, 10_000));
        raw.on_position(&position(2, (630.0, 0.0), (-500.0, 0.0)));
        raw.on_age(&age(2, 60_000));
        let stale = raw.take_command().unwrap();
        // Both see the robot heading across the path, toward the centre; the goal ahead lies
        // to its left. From 30 mm further in (compensated) it is nearer, so that command turns
        // harder.
        let turn = |c: WheelCommand| c.right_mm_s - c.left_mm_s;
        assert!(turn(moved) > turn(stale) + 50, "{moved:?} {stale:?}");
    }

    #[test]
    fn a_robot_at_rest_on_the_path_sets_off_along_it() {
        // At the crossing, the path heads up-right at 45°: no turn needed.
        let mut c = PurePursuit::new(PARAMS);
        c.on_position(&position(1, (0.0, 0.0), (0.0, 0.0)));
        let cmd = c.take_command().unwrap();
        assert!(cmd.steering);
        assert!((cmd.left_mm_s - 500).abs() < 30 && (cmd.right_mm_s - 500).abs() < 30);
    }

    #[test]
    fn a_robot_not_yet_seen_creeps_straight_ahead() {
        let mut c = PurePursuit::new(PARAMS);
        let mut p = position(1, (0.0, 0.0), (0.0, 0.0));
        p.status = Status::Lost;
        c.on_position(&p);
        let cmd = c.take_command().unwrap();
        let creep = CREEP_MM_S as i32;
        assert_eq!(
            (cmd.left_mm_s, cmd.right_mm_s, cmd.steering),
            (creep, creep, false)
        );
    }

    #[test]
    fn a_lost_light_or_screen_units_stop_the_robot() {
        let mut c = PurePursuit::new(PARAMS);
        c.on_position(&position(0, (600.0, 0.0), (0.0, -500.0)));
        assert!(c.take_command().unwrap().steering, "seen once");
        let mut p = position(1, (600.0, 0.0), (0.0, -500.0));
        p.status = Status::Lost;
        c.on_position(&p);
        let cmd = c.take_command().unwrap();
        assert_eq!((cmd.left_mm_s, cmd.right_mm_s, cmd.steering), (0, 0, false));
        let mut p = position(2, (600.0, 0.0), (0.0, -500.0));
        p.units = Units::Pixels;
        c.on_position(&p);
        let cmd = c.take_command().unwrap();
        assert_eq!((cmd.left_mm_s, cmd.right_mm_s), (0, 0));
    }
}
