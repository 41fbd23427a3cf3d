//! Finding the LED: luma threshold, bit-packed morphology, blobs and streak geometry.

pub mod bitimage;
pub mod morph;
pub mod threshold;
