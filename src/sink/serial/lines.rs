//! One serial line per robot (`--serial ID=PORT`): each robot's line carries only its own
//! updates, as plain position updates (it is the only robot on it), and its own LED requests.

use core::fmt;
use std::io;

use super::{bound_track, Located, SerialError, SerialSink};
use crate::report::FrameReport;
use crate::sink::Sink;

/// A serial sink per robot, by robot id.
pub struct RobotLines {
    lines: Vec<(u8, SerialSink)>,
}

impl RobotLines {
    /// Opens each robot's port at `baud`; failing to open any is an error naming it.
    pub fn open(ports: &[(u8, String)], baud: u32) -> Result<RobotLines, SerialError> {
        let lines = ports
            .iter()
            .map(|(robot, path)| Ok((*robot, SerialSink::open(path, baud)?)))
            .collect::<Result<_, SerialError>>()?;
        Ok(RobotLines { lines })
    }
}

impl Sink for RobotLines {
    /// Robot k's line gets the track bound to robot k, found or lost: a provisional track goes
    /// out on no robot's line. A LED request goes out on its robot's line only.
    fn write(&mut self, report: &FrameReport) -> io::Result<()> {
        for (robot, line) in &mut self.lines {
            let bound = if report.several() {
                bound_track(report, *robot)
            } else {
                // One robot: its track is certain.
                report.tracks.first()
            };
            let located = bound.and_then(|t| {
                t.estimate
                    .map(|e| Located::from_estimate(&e, t.floor.as_ref()))
            });
            let state = bound.map_or(crate::report::TrackState::Searching, |t| t.state);
            line.send(&report.meta, located.as_ref(), state);
            // After the frame's update, so that the request's host time counts from this frame.
            if let Some(blink) = report.blink.filter(|b| b.robot == *robot) {
                line.request_led(blink.robot, blink.delay_us, blink.off_us);
            }
        }
        Ok(())
    }

    fn finish(&mut self) -> io::Result<()> {
        for (_, line) in &mut self.lines {
            line.finish()?;
        }
        Ok(())
    }

    /// Each line's status, as one robot's serial sink shows it.
    fn status(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (robot, line) in &self.lines {
            write!(out, " [robot {robot}]")?;
            line.status(out)?;
        }
        Ok(())
    }
}
