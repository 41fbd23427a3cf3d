//! glint: finds a saturated LED in packed YUYV frames, even when motion smears it into a streak.
//!
//! # Memory model
//!
//! Everything the per-frame path needs is allocated once, at start-up, from the frame size:
//! the read buffer of a dump source, the bit-packed masks, the morphology and skeleton scratch,
//! the bounded run and blob tables, and the output writer's buffer. After that, processing a
//! frame performs **zero heap allocations**: frames are borrowed views of the source's buffer,
//! bounded lists are `heapless` with their capacity in the type, and reports are formatted
//! straight into the reused writer. `tests/alloc_free.rs` installs a counting global
//! allocator and holds the whole per-frame path to this.
//!
//! # The per-frame path
//!
//! [`source`] → [`frame`] → [`detect`] (threshold → morphology → blobs → streak) → [`track`]
//! (or [`track::marker`] for a robot carrying an ArUco marker) → [`geometry::floor`] (screen →
//! floor, with a calibration) → [`pipeline`] → [`sink`]. [`pipeline::Pipeline::process`] reads
//! top to bottom.

pub mod detect;
pub mod frame;
pub mod geometry;
pub mod monitor;
pub mod pipeline;
pub mod sink;
pub mod source;
pub mod stats;
pub mod track;
