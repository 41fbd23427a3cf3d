//! Protocol version 2's request from glint to a robot: switch your LED off for a while.
//!
//! glint uses it to measure its own latency (`glint latency`: the time from the request to the
//! first frame where the LED is gone) and, with several robots on one line, to learn which
//! track is which robot (the one that went dark). The robot's own code switches the LED; the
//! firmware only decodes the request and calls it.

use serde::{Deserialize, Serialize};

/// Message id of a [`LedRequest`].
pub const LED_ID: u8 = 0x04;

/// The robot id that every robot answers to.
pub const EVERY_ROBOT: u8 = 0;

/// "Robot `robot`, switch your LED off for `off_us`, starting `delay_us` after `at_us`."
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct LedRequest {
    /// The robot addressed; [`EVERY_ROBOT`] (0) addresses them all.
    pub robot: u8,
    /// Request number, +1 per request, wrapping at 256: a repeated number is a repeat.
    pub request: u8,
    /// Host time, in the clock of the positions' `timestamp_us` (µs, wrapping at 2³²), at which
    /// the last byte of this frame leaves the host.
    // Fixed width, like the positions' timestamp: it uses all 32 bits almost always.
    #[serde(with = "postcard::fixint::le")]
    pub at_us: u32,
    /// How long after `at_us` the LED goes off; 0 for at once. A robot that does not track the
    /// host's clock counts it from the arrival of the frame's last byte.
    pub delay_us: u32,
    /// How long the LED stays off before it comes back on; 0 switches it back on now (and
    /// cancels a pending request).
    pub off_us: u32,
}
