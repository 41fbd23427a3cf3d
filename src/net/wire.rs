//! The compact binary form of a report (`KEY/CAM/bin`): what a consumer needs to track the
//! robot (times, pixel and floor position and velocity, flags) in about 40 bytes, where the
//! JSON line takes about 400.
//!
//! # Format (version 1)
//!
//! [postcard](https://postcard.jamesmunns.com/wire-format): a `u8` as one byte, wider unsigned
//! integers as LEB128 varints, `f32` as 4 little-endian bytes, an option as one byte `0` (none)
//! or `1` followed by the value, fields in this order:
//!
//! | field | type | meaning |
//! |---|---|---|
//! | `version` | byte | 1 |
//! | `frame` | varint | frame index since the start of the run |
//! | `sequence` | varint | the driver's sequence number |
//! | `t_us` | varint | end of the exposure, µs since the first frame |
//! | `unix_us` | varint | the same moment on the wall clock, µs since 1970 |
//! | `position_px` | option of 2 × f32 | where the LED (or marker) is, image pixels |
//! | `velocity_px_s` | option of 2 × f32 | its velocity, px/s |
//! | `floor` | option of floor | the floor fix, with a calibration |
//! | `flags` | byte | bit 0 ambiguous, 1 beyond the horizon, 2 floor stale, 3 blinded, 4 markers capped |
//!
//! floor: `unit` (byte: 0 mm, 1 cm, 2 m, 3 in), `x`, `y` (f32), `velocity` (option of 2 × f32,
//! units/s), `heading_deg` (option of f32).
//!
//! A new field goes at the end with a new version; a reader checks the version first.

use serde::{Deserialize, Serialize};

use crate::geometry::{FloorFix, FloorUnit};
use crate::report::FrameReport;

/// The version this module writes.
pub const VERSION: u8 = 1;

/// Longest encoding: every option present, every varint at its longest.
pub const MAX_BYTES: usize = 1 + 4 * 10 + 9 + 9 + (1 + 1 + 8 + 9 + 5) + 1;

/// Flag bits.
pub const AMBIGUOUS: u8 = 1 << 0;
pub const BEYOND_HORIZON: u8 = 1 << 1;
pub const FLOOR_STALE: u8 = 1 << 2;
pub const BLINDED: u8 = 1 << 3;
pub const MARKERS_CAPPED: u8 = 1 << 4;

/// One report in the binary form.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WireReport {
    pub version: u8,
    pub frame: u64,
    pub sequence: u64,
    pub t_us: u64,
    pub unix_us: u64,
    pub position_px: Option<(f32, f32)>,
    pub velocity_px_s: Option<(f32, f32)>,
    pub floor: Option<WireFloor>,
    pub flags: u8,
}

/// The floor fix in the binary form.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WireFloor {
    /// 0 mm, 1 cm, 2 m, 3 in.
    pub unit: u8,
    pub x: f32,
    pub y: f32,
    pub velocity: Option<(f32, f32)>,
    pub heading_deg: Option<f32>,
}

impl WireReport {
    /// The binary form of `r`, captured at `unix_us` on the wall clock.
    pub fn new(r: &FrameReport, unix_us: u64) -> WireReport {
        let floor = match r.floor {
            Some(FloorFix::Mapped(f)) => Some(WireFloor {
                unit: unit_code(f.unit),
                x: f.position.x as f32,
                y: f.position.y as f32,
                velocity: f.velocity_per_s.map(|v| (v.x as f32, v.y as f32)),
                heading_deg: f.heading_deg.map(|h| h as f32),
            }),
            Some(FloorFix::BeyondHorizon) | None => None,
        };
        let stale = r.calib.is_some_and(|c| c.stale) && r.floor.is_some();
        let flags = [
            (r.ambiguous, AMBIGUOUS),
            (r.floor == Some(FloorFix::BeyondHorizon), BEYOND_HORIZON),
            (stale, FLOOR_STALE),
            (r.detection.blinded, BLINDED),
            (r.markers_capped, MARKERS_CAPPED),
        ]
        .into_iter()
        .filter(|(on, _)| *on)
        .fold(0, |flags, (_, bit)| flags | bit);
        WireReport {
            version: VERSION,
            frame: r.meta.index,
            sequence: r.meta.sequence,
            t_us: r.meta.timestamp_us,
            unix_us,
            position_px: r.position.map(|p| p.position_px),
            velocity_px_s: r.position.and_then(|p| p.velocity_px_s).map(|(v, _)| v),
            floor,
            flags,
        }
    }

    /// Encodes into `out`, returning the bytes written.
    pub fn encode<'a>(&self, out: &'a mut [u8; MAX_BYTES]) -> Result<&'a [u8], postcard::Error> {
        postcard::to_slice(self, out).map(|b| &*b)
    }
}

/// The unit's code in the binary forms (the table above).
pub(super) fn unit_code(unit: FloorUnit) -> u8 {
    match unit {
        FloorUnit::Mm => 0,
        FloorUnit::Cm => 1,
        FloorUnit::M => 2,
        FloorUnit::In => 3,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_longest_report_fits_and_reads_back() {
        let report = WireReport {
            version: VERSION,
            frame: u64::MAX,
            sequence: u64::MAX,
            t_us: u64::MAX,
            unix_us: u64::MAX,
            position_px: Some((1.0, 2.0)),
            velocity_px_s: Some((3.0, 4.0)),
            floor: Some(WireFloor {
                unit: 3,
                x: 5.0,
                y: 6.0,
                velocity: Some((7.0, 8.0)),
                heading_deg: Some(9.0),
            }),
            flags: u8::MAX,
        };
        let mut buf = [0u8; MAX_BYTES];
        let bytes = report.encode(&mut buf).unwrap().to_vec();
        let back: WireReport = postcard::from_bytes(&bytes).unwrap();
        assert_eq!(back, report);
    }

    #[test]
    fn a_lost_frame_is_a_dozen_bytes_in_the_documented_order() {
        let report = WireReport {
            version: VERSION,
            frame: 300,
            sequence: 2,
            t_us: 5,
            unix_us: 1,
            position_px: None,
            velocity_px_s: None,
            floor: None,
            flags: BLINDED,
        };
        let mut buf = [0u8; MAX_BYTES];
        let bytes = report.encode(&mut buf).unwrap();
        // 300 = 0b10_0101100: LEB128 0xac 0x02.
        assert_eq!(bytes, [1, 0xac, 0x02, 2, 5, 1, 0, 0, 0, 8]);
    }
}
