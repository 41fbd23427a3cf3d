//! Parts of the robot-in-the-loop rig of issue 15 (`glint-loop`, not built yet): so far the
//! simulated differential-drive robot. The rest (rendering its LED in real time, `glint run` on
//! the frames, the firmware in qemu, the wheel commands back) is still to come.

pub mod drive;

pub use drive::{DiffDrive, DriveParams, WheelSpeeds};
