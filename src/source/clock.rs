//! The host's monotonic clock, the one V4L2 stamps camera buffers with, so that a frame's capture
//! time and the moment its position leaves on the serial line can be subtracted.

use nix::time::{clock_gettime, ClockId};

/// Microseconds per second.
const US_PER_S: u64 = 1_000_000;
/// Nanoseconds per microsecond.
const NS_PER_US: u64 = 1_000;

/// Now on `CLOCK_MONOTONIC`, in µs. The clock cannot fail on Linux; if it ever did, 0 (an age
/// measured from it would then be too large, never negative).
pub fn monotonic_now_us() -> u64 {
    match clock_gettime(ClockId::CLOCK_MONOTONIC) {
        Ok(t) => {
            let secs = u64::try_from(t.tv_sec()).unwrap_or(0);
            let nanos = u64::try_from(t.tv_nsec()).unwrap_or(0);
            secs.saturating_mul(US_PER_S)
                .saturating_add(nanos / NS_PER_US)
        }
        Err(_) => 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_clock_moves_forward_with_real_time() {
        let a = monotonic_now_us();
        std::thread::sleep(std::time::Duration::from_millis(2));
        let b = monotonic_now_us();
        assert!(a > 0 && b >= a + 2_000, "{a} then {b}");
    }
}
