//! The robot's own microsecond clock, which the link reads when bytes arrive: a position's age
//! (sent by glint for the moment its last byte left) plus the time since then in this clock is
//! the position's age now, with no need for the host's and the robot's clocks to agree.

/// A free-running microsecond counter that wraps at 2³² (a timer peripheral, `micros()`).
pub trait Clock {
    /// Now, in µs; only differences taken with `wrapping_sub` mean anything.
    fn now_us(&mut self) -> u32;
}

impl<F: FnMut() -> u32> Clock for F {
    fn now_us(&mut self) -> u32 {
        self()
    }
}

/// Whether `t_us` is at or after `since_us` on a clock that wraps at 2³² (within half a wrap,
/// 35 minutes).
pub fn reached(t_us: u32, since_us: u32) -> bool {
    (t_us.wrapping_sub(since_us) as i32) >= 0
}
