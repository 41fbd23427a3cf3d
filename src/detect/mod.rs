//! Finding the LED: luma threshold, bit-packed morphology, blobs and streak geometry.

pub mod bitimage;
pub mod blobs;
pub mod morph;
pub mod skeleton;
pub mod threshold;
