//! The robot-in-the-loop rig (`glint-loop`, issue 15): a simulated differential-drive robot
//! whose LED glint's own renderer films in real time, the frames delivered a camera's delay after
//! their exposure and stamped with it, `glint run --stamped` (or `glint latency`) tracking them
//! and sending positions over a pseudo-terminal, at the line's baud, to the example firmware
//! running in qemu-system-arm, whose wheel commands (and LED) drive the robot. See
//! [`run::run_loop`].
//!
//! - [`drive`]: the robot, 1 kHz physics, wheel limits and motor lag.
//! - [`path`]: the planned figure-eight and the path error.
//! - [`camera`]: the renderer set up as the rig's camera, with its calibration markers.
//! - [`wire`]: the serial line at its baud between glint's pty and the board's UART.
//! - [`board`]: qemu and the firmware's two UARTs.
//! - [`lines`]: what the firmware says back.
//! - [`run`]: one run of the loop, and what it measured.

pub mod board;
pub mod camera;
pub mod drive;
pub mod lines;
pub mod path;
pub mod run;
pub mod wire;

pub use drive::{DiffDrive, DriveParams, WheelSpeeds};
pub use run::{run_loop, LoopConfig, LoopReport};
