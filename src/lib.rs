//! glint: finds a saturated LED in packed YUYV frames, even when motion smears it into a streak.
//!
//! # Memory model
//!
//! Everything the per-frame path needs is allocated once, at start-up, from the frame size:
//! the read buffer of a dump source, the bit-packed masks, the morphology scratch and the
//! bounded blob list. After that, processing a frame performs **zero heap allocations**:
//! frames are borrowed views of the source's buffer, bounded lists are `heapless` with their
//! capacity in the type, and output is formatted into reused buffers. The test
//! `tests/alloc_free.rs` installs a counting global allocator and holds the pipeline to this.

pub mod frame;
pub mod geometry;
pub mod source;
