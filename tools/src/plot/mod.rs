//! Plots of a JSON-lines track (`glint track --format jsonl`): the trajectory, on the floor
//! when the track carries floor coordinates (`floor_x`, `floor_y`) and in image pixels
//! otherwise, above the speed over time. The `glint-plot` binary writes them as a PNG.
//!
//! The speed is the distance between the positions of consecutive frames over the time between
//! them, in the track's units per second; a frame without a position breaks both curves.

mod axes;
mod render;
mod track;

pub use render::{render, style, MAX_SIDE_PX, MIN_SIDE_PX};
pub use track::{Sample, Track, TrackError, Units};

#[cfg(test)]
mod tests;
