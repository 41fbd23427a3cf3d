//! Example firmware logic for a robot steered by glint: read bytes from a UART, decode glint's
//! frames, hand positions to the control loop.
//!
//! Everything here is generic over [`embedded_io::Read`], which the UART drivers of the common
//! HALs implement (embassy, esp-hal, the stm32/nrf/rp HALs), so the same code runs on any board
//! and in host tests. Memory is fixed: one read buffer and one frame decoder, no heap.
#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod control;
pub mod demo;
pub mod link;

pub use control::{ControlLoop, HoldPosition};
pub use link::{Link, LinkStats};
