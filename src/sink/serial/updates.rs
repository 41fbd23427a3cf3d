//! From per-frame results to the wire's messages: a position update for every frame (found or
//! lost) and a heartbeat about once a second of frame time.
//!
//! Everything here is plain state and arithmetic, so it runs on the capture thread without
//! allocating; the messages are encoded into buffers the caller owns.

use glint_protocol::{
    Heartbeat, Position, Quantised, Reading, Status, TrackerState, Units, PROTOCOL_VERSION,
};

use crate::report::{
    Estimate, FloorFix, FloorUnit, FrameMeta, PositionMethod, TrackState, VelocityMethod,
};

/// Frame time between heartbeats.
pub const HEARTBEAT_INTERVAL_US: u64 = 1_000_000;

/// Quality points for a found light; a measured head and a measured velocity each add as much
/// again, so the quality says how much of the estimate was measured: 85, 170 or 255.
const QUALITY_STEP: u8 = 85;

/// Hundredths of a hertz per frame per microsecond: fps × 100 = frames × 10⁸ / µs.
const CENTIHZ_PER_FRAME_US: f64 = 1e8;

/// A position estimate ready for the wire, in the units it was measured in: floor millimetres
/// when the frame maps to the floor, image pixels otherwise ([`Located::from_estimate`]). The
/// units travel with every update, so the robot always knows which it got.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Located {
    /// Frame of reference of `position` and `velocity_per_s`.
    pub units: Units,
    /// Where the light is, in px or mm.
    pub position: (f32, f32),
    /// How fast it moves, in px/s or mm/s, when known.
    pub velocity_per_s: Option<(f32, f32)>,
    /// How the velocity was measured, when known.
    pub velocity_method: Option<VelocityMethod>,
    /// Detection quality, 0 (none) to 255 (best).
    pub quality: u8,
}

impl Located {
    /// The tracker's estimate in image pixels. Quality: see `quality`.
    pub fn from_pixels(estimate: &Estimate) -> Located {
        Located {
            units: Units::Pixels,
            position: estimate.position_px,
            velocity_per_s: estimate.velocity_px_s.map(|(v, _)| v),
            velocity_method: estimate.velocity_px_s.map(|(_, m)| m),
            quality: quality(estimate),
        }
    }

    /// The frame's estimate on the floor, in millimetres, when a calibration mapped it there;
    /// in pixels otherwise (no calibration, or a position on or beyond the floor's horizon).
    /// Quality as for [`Located::from_pixels`].
    pub fn from_estimate(estimate: &Estimate, floor: Option<&FloorFix>) -> Located {
        match floor {
            Some(FloorFix::Mapped(f)) => {
                let mm = mm_per_unit(f.unit);
                Located {
                    units: Units::Floor,
                    position: ((f.position.x * mm) as f32, (f.position.y * mm) as f32),
                    velocity_per_s: f
                        .velocity_per_s
                        .map(|v| ((v.x * mm) as f32, (v.y * mm) as f32)),
                    velocity_method: estimate.velocity_px_s.map(|(_, m)| m),
                    quality: quality(estimate),
                }
            }
            Some(FloorFix::BeyondHorizon) | None => Located::from_pixels(estimate),
        }
    }
}

/// Millimetres per floor unit of a calibration.
fn mm_per_unit(unit: FloorUnit) -> f64 {
    match unit {
        FloorUnit::Mm => 1.0,
        FloorUnit::Cm => 10.0,
        FloorUnit::M => 1000.0,
        FloorUnit::In => 25.4,
    }
}

/// Detection quality: [`QUALITY_STEP`] for a found light, plus one step when the position is the streak's head
/// (not just its middle), plus one when the velocity is known.
fn quality(estimate: &Estimate) -> u8 {
    let head = estimate.position_method == PositionMethod::Head;
    let steps = 1 + u8::from(head) + u8::from(estimate.velocity_px_s.is_some());
    QUALITY_STEP.saturating_mul(steps)
}

/// Builds the messages for each frame: numbers the position updates, remembers the last known
/// position for lost frames, and keeps the heartbeat's clock and frame rate (the tracker's state
/// comes with each frame's report).
#[derive(Debug, Default)]
pub struct Updates {
    /// Sequence number of the next position update.
    next_seq: u8,
    /// The last position sent as found, repeated in lost updates (as the protocol asks).
    last_found: Option<(Units, (f32, f32))>,
    /// Frame time of the last heartbeat.
    heartbeat_at_us: Option<u64>,
    /// Frames processed since the last heartbeat.
    frames_since_heartbeat: u32,
    /// Frames the source reported dropped since the start.
    dropped_frames: u64,
}

impl Updates {
    /// No frames seen yet.
    pub fn new() -> Self {
        Updates::default()
    }

    /// The position update for a frame: found with `located`, or lost (repeating the last known
    /// position, zero velocity) without. Advances the sequence number.
    pub fn position(&mut self, meta: &FrameMeta, located: Option<&Located>) -> Quantised {
        let seq = self.next_seq;
        self.next_seq = seq.wrapping_add(1);
        // The wire's timestamp wraps every 2³² µs; the firmware takes differences modulo 2³².
        let timestamp_us = meta.timestamp_us as u32;
        let (status, quality, reading) = match located {
            Some(l) => {
                self.last_found = Some((l.units, l.position));
                let (vx_per_s, vy_per_s) = l.velocity_per_s.unwrap_or((0.0, 0.0));
                let reading = Reading {
                    units: l.units,
                    x: l.position.0,
                    y: l.position.1,
                    vx_per_s,
                    vy_per_s,
                };
                (Status::Found, l.quality, reading)
            }
            None => {
                let (units, (x, y)) = self.last_found.unwrap_or((Units::Pixels, (0.0, 0.0)));
                let reading = Reading {
                    units,
                    x,
                    y,
                    vx_per_s: 0.0,
                    vy_per_s: 0.0,
                };
                (Status::Lost, 0, reading)
            }
        };
        Position::from_reading(seq, timestamp_us, status, quality, reading)
    }

    /// Counts the frame for the heartbeat and returns one when it is due: on the first frame
    /// (so the firmware learns the protocol version at once), then once per
    /// [`HEARTBEAT_INTERVAL_US`] of frame time, carrying the tracker's `state` in that frame.
    ///
    /// Heartbeats follow frame time, not the wall clock: when frames stop, heartbeats stop, and
    /// the robot can tell a stalled tracker from a quiet one.
    pub fn heartbeat(&mut self, meta: &FrameMeta, state: TrackState) -> Option<Heartbeat> {
        self.dropped_frames = self.dropped_frames.saturating_add(meta.dropped);
        self.frames_since_heartbeat = self.frames_since_heartbeat.saturating_add(1);
        let frame_rate_centihz = match self.heartbeat_at_us {
            // The first heartbeat: no rate measured yet.
            None => 0,
            Some(at_us) => match meta.timestamp_us.checked_sub(at_us) {
                Some(elapsed_us) if elapsed_us >= HEARTBEAT_INTERVAL_US => {
                    centihz(self.frames_since_heartbeat, elapsed_us)
                }
                Some(_) => return None,
                // Time went backwards (a restarted source): start the clock again.
                None => {
                    self.heartbeat_at_us = Some(meta.timestamp_us);
                    self.frames_since_heartbeat = 0;
                    return None;
                }
            },
        };
        self.heartbeat_at_us = Some(meta.timestamp_us);
        self.frames_since_heartbeat = 0;
        Some(Heartbeat {
            protocol_version: PROTOCOL_VERSION,
            frame_rate_centihz,
            dropped_frames: u32::try_from(self.dropped_frames).unwrap_or(u32::MAX),
            tracker_state: wire_state(state),
        })
    }
}

/// The tracker's state as the wire names it.
fn wire_state(state: TrackState) -> TrackerState {
    match state {
        TrackState::Searching => TrackerState::Searching,
        TrackState::Tracking => TrackerState::Tracking,
        TrackState::Coasting => TrackerState::Coasting,
    }
}

/// Frame rate in hundredths of a hertz, saturating at the field's maximum.
fn centihz(frames: u32, elapsed_us: u64) -> u16 {
    let rate = (f64::from(frames) * CENTIHZ_PER_FRAME_US / elapsed_us as f64).round();
    if rate >= f64::from(u16::MAX) {
        u16::MAX
    } else {
        rate as u16
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn meta(index: u64, timestamp_us: u64) -> FrameMeta {
        FrameMeta {
            index,
            sequence: index,
            dropped: 0,
            timestamp_us,
            monotonic_us: timestamp_us,
        }
    }

    fn estimate(x: f32, y: f32) -> Estimate {
        Estimate {
            position_px: (x, y),
            position_method: PositionMethod::Head,
            mid_px: (x - 1.0, y),
            velocity_px_s: Some(((30.0, -4.5), VelocityMethod::Streak)),
        }
    }

    #[test]
    fn found_then_lost_repeats_the_last_position_and_numbers_every_update() {
        let mut u = Updates::new();
        let found = Located::from_pixels(&estimate(320.5, 10.125));
        let a = u.position(&meta(0, 5), Some(&found)).position;
        assert_eq!((a.seq, a.timestamp_us, a.status), (0, 5, Status::Found));
        assert_eq!((a.x, a.y, a.vx_per_s, a.vy_per_s), (2564, 81, 240, -36));
        assert_eq!((a.units, a.quality), (Units::Pixels, 255));

        let b = u.position(&meta(1, 33_338), None).position;
        assert_eq!((b.seq, b.status, b.quality), (1, Status::Lost, 0));
        assert_eq!((b.x, b.y, b.vx_per_s, b.vy_per_s), (2564, 81, 0, 0));
    }

    #[test]
    fn lost_before_anything_was_found_is_at_the_origin() {
        let mut u = Updates::new();
        let p = u.position(&meta(0, 0), None).position;
        assert_eq!((p.status, p.x, p.y), (Status::Lost, 0, 0));
    }

    #[test]
    fn sequence_wraps_and_timestamp_truncates() {
        let mut u = Updates::new();
        let mut last = None;
        for i in 0..300u64 {
            last = Some(u.position(&meta(i, (1 << 32) + 7), None).position);
        }
        let p = last.unwrap();
        assert_eq!(p.seq, (299 % 256) as u8);
        assert_eq!(p.timestamp_us, 7);
    }

    #[test]
    fn quality_counts_the_measured_parts() {
        let mut e = estimate(1.0, 1.0);
        assert_eq!(Located::from_pixels(&e).quality, 255);
        e.position_method = PositionMethod::Mid;
        assert_eq!(Located::from_pixels(&e).quality, 170);
        e.velocity_px_s = None;
        assert_eq!(Located::from_pixels(&e).quality, 85);
    }

    #[test]
    fn a_mapped_floor_position_goes_out_in_millimetres() {
        use crate::report::FloorEstimate;
        use nalgebra::{Point2, Vector2};
        let e = estimate(320.0, 240.0);
        let fix = FloorFix::Mapped(FloorEstimate {
            position: Point2::new(152.04, -31.0),
            velocity_per_s: Some(Vector2::new(25.0, 0.5)),
            heading_deg: None,
            unit: FloorUnit::Cm,
        });
        let l = Located::from_estimate(&e, Some(&fix));
        assert_eq!(l.units, Units::Floor);
        let mut u = Updates::new();
        let p = u.position(&meta(0, 0), Some(&l)).position;
        assert_eq!((p.x, p.y, p.vx_per_s, p.vy_per_s), (1520, -310, 250, 5));
        assert_eq!(p.quality, 255);
        // Beyond the horizon, or without a calibration: pixels, and the flag says so.
        for floor in [Some(&FloorFix::BeyondHorizon), None] {
            let l = Located::from_estimate(&e, floor);
            assert_eq!((l.units, l.position), (Units::Pixels, (320.0, 240.0)));
        }
        assert!((mm_per_unit(FloorUnit::In) - 25.4).abs() < 1e-12);
        assert_eq!(mm_per_unit(FloorUnit::M), 1000.0);
    }

    #[test]
    fn floor_units_pass_through_per_update() {
        let mut u = Updates::new();
        let floor = Located {
            units: Units::Floor,
            position: (1520.4, -310.0),
            velocity_per_s: None,
            velocity_method: None,
            quality: 200,
        };
        let p = u.position(&meta(0, 0), Some(&floor)).position;
        assert_eq!((p.units, p.x, p.y), (Units::Floor, 1520, -310));
        let lost = u.position(&meta(1, 1), None).position;
        assert_eq!((lost.units, lost.x, lost.y), (Units::Floor, 1520, -310));
    }

    #[test]
    fn heartbeat_first_frame_then_once_per_second_with_the_measured_rate() {
        let mut u = Updates::new();
        let frame_us = 33_333;
        let mut beats = Vec::new();
        for i in 0..91u64 {
            let mut m = meta(i, i * frame_us);
            m.dropped = u64::from(i == 40) * 3;
            u.position(&m, None);
            if let Some(h) = u.heartbeat(&m, TrackState::Searching) {
                beats.push((i, h));
            }
        }
        // Frame 0, then the first frame at least 1 s of frame time after the last heartbeat:
        // 30 × 33 333 µs falls 10 µs short of a second, so frame 31, then frame 62.
        let at: Vec<u64> = beats.iter().map(|(i, _)| *i).collect();
        assert_eq!(at, [0, 31, 62]);
        assert_eq!(beats[0].1.frame_rate_centihz, 0);
        // 31 frames over 31 × 33 333 µs: 30.0003 fps.
        assert_eq!(beats[1].1.frame_rate_centihz, 3000);
        assert_eq!(beats[1].1.dropped_frames, 0);
        assert_eq!(beats[2].1.dropped_frames, 3);
        assert!(beats
            .iter()
            .all(|(_, h)| h.protocol_version == PROTOCOL_VERSION));
    }

    #[test]
    fn the_heartbeat_carries_the_reported_tracker_state() {
        let states = [
            (TrackState::Searching, TrackerState::Searching),
            (TrackState::Tracking, TrackerState::Tracking),
            (TrackState::Coasting, TrackerState::Coasting),
        ];
        for (state, wire) in states {
            let mut u = Updates::new();
            let h = u.heartbeat(&meta(0, 0), state).unwrap();
            assert_eq!(h.tracker_state, wire);
        }
    }

    #[test]
    fn time_going_backwards_restarts_the_heartbeat_clock() {
        let mut u = Updates::new();
        assert!(u
            .heartbeat(&meta(0, 5_000_000), TrackState::Tracking)
            .is_some());
        assert!(u.heartbeat(&meta(1, 0), TrackState::Tracking).is_none());
        assert!(u
            .heartbeat(&meta(2, 900_000), TrackState::Tracking)
            .is_none());
        let h = u
            .heartbeat(&meta(3, 1_000_000), TrackState::Tracking)
            .unwrap();
        // Two frames (2 and 3) since the restart at frame 1, over one second.
        assert_eq!(h.frame_rate_centihz, 200);
    }

    #[test]
    fn frame_rate_saturates() {
        assert_eq!(centihz(1_000_000, 1), u16::MAX);
        assert_eq!(centihz(30, 1_000_000), 3000);
    }
}
