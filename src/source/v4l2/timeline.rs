//! Turns the driver's per-buffer sequence numbers and timestamps into [`FrameMeta`]: time since
//! the first frame, a 64-bit sequence that survives the driver's 32-bit wrap and device
//! reopening, and the number of frames lost before each one.

use crate::source::FrameMeta;

/// A sequence step larger than this is taken as the driver restarting its count (or a bogus
/// number), not as billions of lost frames.
const MAX_PLAUSIBLE_GAP: u32 = 1 << 30;

/// The running state of one capture session, possibly spanning several opens of the device.
#[derive(Debug, Clone, Default)]
pub struct Timeline {
    first_timestamp_us: Option<u64>,
    last_timestamp_us: u64,
    /// The driver's sequence number of the previous frame in the current stream.
    last_driver_sequence: Option<u32>,
    /// Sequence reported for the previous frame, continuous across streams.
    last_sequence: Option<u64>,
    next_index: u64,
}

impl Timeline {
    /// A timeline whose first frame will be at t = 0.
    pub fn new() -> Self {
        Self::default()
    }

    /// Marks the start of a new stream (the device was reopened): its driver sequence numbers
    /// start afresh, so the next frame continues the sequence without counting a gap. Time
    /// keeps running from the same origin, since buffer timestamps come from the system's
    /// monotonic clock.
    pub fn restart_stream(&mut self) {
        self.last_driver_sequence = None;
    }

    /// The metadata of the next frame, from the driver's sequence number and its timestamp in
    /// microseconds on the monotonic clock.
    pub fn on_frame(&mut self, driver_sequence: u32, monotonic_us: u64) -> FrameMeta {
        let first = *self.first_timestamp_us.get_or_insert(monotonic_us);
        // A timestamp earlier than the last would break speed estimates; hold time still
        // instead (drivers with broken clocks show up as frames at the same instant).
        let timestamp_us = monotonic_us
            .saturating_sub(first)
            .max(self.last_timestamp_us);
        self.last_timestamp_us = timestamp_us;

        let step = match self.last_driver_sequence {
            Some(last) => {
                let step = driver_sequence.wrapping_sub(last);
                if step == 0 || step > MAX_PLAUSIBLE_GAP {
                    1
                } else {
                    step
                }
            }
            None => 1,
        };
        self.last_driver_sequence = Some(driver_sequence);
        let sequence = match self.last_sequence {
            Some(last) => last + u64::from(step),
            None => u64::from(driver_sequence),
        };
        self.last_sequence = Some(sequence);

        let index = self.next_index;
        self.next_index += 1;
        FrameMeta {
            index,
            sequence,
            dropped: u64::from(step - 1),
            timestamp_us,
            monotonic_us,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_frame_is_time_zero_and_gaps_count_as_drops() {
        let mut timeline = Timeline::new();
        let a = timeline.on_frame(7, 1_000_000);
        let b = timeline.on_frame(8, 1_033_000);
        let c = timeline.on_frame(11, 1_133_000);
        assert_eq!(
            (a.index, a.sequence, a.dropped, a.timestamp_us),
            (0, 7, 0, 0)
        );
        assert_eq!(
            (b.index, b.sequence, b.dropped, b.timestamp_us),
            (1, 8, 0, 33_000)
        );
        assert_eq!(
            (c.index, c.sequence, c.dropped, c.timestamp_us),
            (2, 11, 2, 133_000)
        );
    }

    #[test]
    fn the_32_bit_driver_sequence_wraps_into_a_64_bit_one() {
        let mut timeline = Timeline::new();
        timeline.on_frame(u32::MAX - 1, 0);
        let a = timeline.on_frame(u32::MAX, 10);
        let b = timeline.on_frame(1, 20);
        assert_eq!(a.sequence, u64::from(u32::MAX));
        assert_eq!(b.sequence, u64::from(u32::MAX) + 2);
        assert_eq!(b.dropped, 1);
    }

    #[test]
    fn a_reopened_stream_continues_sequence_and_time() {
        let mut timeline = Timeline::new();
        timeline.on_frame(40, 5_000_000);
        timeline.restart_stream();
        // The new stream counts from 0 again, two seconds later.
        let m = timeline.on_frame(0, 7_000_000);
        assert_eq!(
            (m.index, m.sequence, m.dropped, m.timestamp_us),
            (1, 41, 0, 2_000_000)
        );
    }

    #[test]
    fn time_never_runs_backwards_and_absurd_sequence_jumps_are_not_drops() {
        let mut timeline = Timeline::new();
        timeline.on_frame(5, 2_000);
        let back = timeline.on_frame(3, 1_000);
        assert_eq!(back.timestamp_us, 0);
        assert_eq!(back.dropped, 0);
        assert_eq!(back.sequence, 6);
    }
}
