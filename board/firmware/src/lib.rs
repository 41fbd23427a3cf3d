//! Example firmware logic for a robot steered by glint: read bytes from a UART, decode glint's
//! frames, hand positions and their age (in the robot's own clock) to the control loop, and
//! switch the LED when glint asks.
//!
//! Everything here is generic over [`embedded_io::Read`], which the UART drivers of the common
//! HALs implement (embassy, esp-hal, the stm32/nrf/rp HALs), so the same code runs on any board
//! and in host tests. Memory is fixed: one read buffer and one frame decoder, no heap.
#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod clock;
pub mod control;
pub mod demo;
pub mod led;
pub mod link;
pub mod pursuit;
pub mod reckon;

pub use clock::Clock;
pub use control::{ArrivedAge, ControlLoop, HoldPosition};
pub use led::{LedPin, WithLed};
pub use link::{Link, LinkStats};
