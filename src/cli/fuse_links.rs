//! `glint fuse`'s links to the robots: the fused tracks through the sinks `glint track` uses,
//! glint's position packets on one line (one robot's plain updates, or with `--robots N` a
//! robot position per robot, carrying its id) or a line per robot (`--serial ID=PORT`), or
//! MAVLink to one autopilot (`--mavlink`), its covariance from the fused track's own σ.

use anyhow::{bail, Context, Result};

use glint::fuse::{FusedStep, FusedTrack};
use glint::geometry::FloorUnit;
use glint::sink::mavlink::estimate::metres_per_unit;
use glint::sink::mavlink::{self, Axes, Identity, MavlinkLink};
use glint::sink::serial::Located;
use glint::sink::{SerialSink, Sink};
use glint::source::clock::monotonic_now_us;
use glint::source::FrameMeta;
use glint::track::TrackState;
use glint_protocol::Units;

use super::fuse::FuseArgs;
use super::serial_ports::{self, SerialPlan};

/// Where the fused tracks go to the robots.
pub(super) enum RobotLink {
    None,
    /// One line every robot listens on (boxed: its per-robot tables are the largest variant).
    Shared(Box<SerialSink>),
    /// A line per robot, by id.
    PerRobot(Vec<(u8, SerialSink)>),
    /// One autopilot, robot 1's track.
    Mavlink {
        link: MavlinkLink,
        yaw_offset_deg: f64,
    },
}

impl RobotLink {
    /// Opens what `--serial` and `--mavlink` ask for, after checking them against `--robots`.
    pub(super) fn open(args: &FuseArgs) -> Result<RobotLink> {
        let plan = serial_ports::plan(&args.serial).map_err(anyhow::Error::msg)?;
        match plan {
            SerialPlan::None => Ok(RobotLink::None),
            SerialPlan::PerRobot(ports) => {
                if args.mavlink {
                    bail!("--mavlink talks to one autopilot: give one --serial PORT, not ID=PORT");
                }
                if let Some((robot, port)) =
                    ports.iter().find(|(&k, _)| usize::from(k) > args.robots)
                {
                    bail!(
                        "--serial {robot}={port}: glint fuse follows {} robot(s) (--robots), ids 1 \
                         to {}",
                        args.robots,
                        args.robots
                    );
                }
                let lines = ports
                    .into_iter()
                    .map(|(robot, port)| Ok((robot, SerialSink::open(&port, args.baud)?)))
                    .collect::<Result<_>>()?;
                Ok(RobotLink::PerRobot(lines))
            }
            SerialPlan::Shared(port) if args.mavlink => {
                if args.robots > 1 {
                    bail!("--mavlink talks to one autopilot: leave it out with --robots");
                }
                let identity = Identity {
                    system_id: args.mavlink_system_id,
                    component_id: mavlink::VISION_COMPONENT_ID,
                };
                Ok(RobotLink::Mavlink {
                    link: MavlinkLink::open(&port, args.baud, identity)?,
                    yaw_offset_deg: args.mavlink_yaw_offset_deg,
                })
            }
            SerialPlan::Shared(port) => Ok(RobotLink::Shared(Box::new(SerialSink::open(
                &port, args.baud,
            )?))),
        }
    }

    /// Sends one fused step: `index` counts the steps, `first_us` is the first one's time.
    pub(super) fn send(&mut self, step: &FusedStep, index: u64, first_us: i64) {
        let meta = FrameMeta {
            index,
            sequence: index,
            dropped: 0,
            timestamp_us: u64::try_from(step.t_us.saturating_sub(first_us)).unwrap_or(0),
            // The step was read from a file or a network: its age counts from now.
            monotonic_us: monotonic_now_us(),
        };
        // A line without `floor_unit` (glint's always name it) is taken as glint calibrate's cm.
        let unit = step.unit.unwrap_or(FloorUnit::Cm);
        let mm = 1000.0 * metres_per_unit(unit);
        match self {
            RobotLink::None => {}
            RobotLink::Shared(link) if step.tracks.len() <= 1 => {
                let track = step.tracks.first();
                let located = track.and_then(|t| located(t, mm));
                link.send(&meta, located.as_ref(), state(located.is_some()));
            }
            RobotLink::Shared(link) => {
                let robots: Vec<(u8, Option<Located>)> = step
                    .tracks
                    .iter()
                    .filter_map(|t| Some((u8::try_from(t.id).ok()?, located(t, mm))))
                    .collect();
                let any = robots.iter().any(|(_, l)| l.is_some());
                link.send_robots(&meta, &robots, state(any));
            }
            RobotLink::PerRobot(lines) => {
                for (robot, line) in lines {
                    let located = step
                        .tracks
                        .iter()
                        .find(|t| t.id == u32::from(*robot))
                        .and_then(|t| located(t, mm));
                    line.send(&meta, located.as_ref(), state(located.is_some()));
                }
            }
            RobotLink::Mavlink {
                link,
                yaw_offset_deg,
            } => {
                let Some((track, floor)) = step.tracks.first().and_then(|t| Some((t, t.floor?)))
                else {
                    // The autopilot only takes positions: a step without one sends nothing.
                    return;
                };
                let axes = Axes::new(unit, *yaw_offset_deg);
                let usec = u64::try_from(step.t_us).unwrap_or(0);
                let sigma_m = track.sigma.map(|s| s * axes.metres_per_unit());
                let position = axes.position(usec, floor, sigma_m);
                let speed = track.velocity.map(|v| axes.speed(usec, v));
                link.post(position, speed);
            }
        }
    }

    /// Lets the writers send what is pending, then logs the links' counts.
    pub(super) fn finish(&mut self) -> Result<()> {
        match self {
            RobotLink::None => {}
            RobotLink::Shared(link) => link.finish().context("serial link")?,
            RobotLink::PerRobot(lines) => {
                for (_, line) in lines {
                    line.finish().context("serial link")?;
                }
            }
            RobotLink::Mavlink { link, .. } => link.finish(),
        }
        Ok(())
    }
}

/// A fused track as the serial link's position, in millimetres (`mm` per floor unit), when
/// found on the floor.
fn located(track: &FusedTrack, mm: f64) -> Option<Located> {
    let p = track.floor?;
    Some(Located {
        units: Units::Floor,
        position: ((p.x * mm) as f32, (p.y * mm) as f32),
        velocity_per_s: track
            .velocity
            .map(|v| ((v.x * mm) as f32, (v.y * mm) as f32)),
        velocity_method: None,
        quality: quality(track),
    })
}

/// The heartbeat's tracker state: the fused track is followed while some camera sees it.
fn state(found: bool) -> TrackState {
    if found {
        TrackState::Tracking
    } else {
        TrackState::Searching
    }
}

/// The serial link's quality scale (85 found, +85 a head, +85 a velocity), for a fused track.
fn quality(track: &FusedTrack) -> u8 {
    const QUALITY_STEP: u8 = 85;
    let steps = 1 + u8::from(track.head) + u8::from(track.velocity.is_some());
    QUALITY_STEP.saturating_mul(steps)
}
