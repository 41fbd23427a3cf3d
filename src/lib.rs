//! glint: finds a saturated LED in packed YUYV frames, even when motion smears it into a streak.
//!
//! # Memory model
//!
//! Everything the per-frame path needs is allocated once, at start-up, from the frame size:
//! the read buffer of a dump source (a camera's mmap buffers belong to the driver), the
//! bit-packed masks, the static map (six bit planes), the morphology and skeleton scratch, the
//! bounded run and blob tables, the background model, the streak fit's learned floor
//! (`--streak-model fit` and the default `auto`: a running mean and count per pixel), the marker
//! detector's scratch, the latency histograms, the output writer's buffer, the serial sink's
//! mailbox and writer thread, the marker re-check's luma copy and worker thread (`--calib` with
//! a marker map), and (`--publish`, the `net` feature) the publish queue and its thread. After
//! that, processing a frame
//! performs **zero heap allocations**: frames are borrowed views of the source's buffer,
//! bounded lists are `heapless` with their capacity in the type, reports are formatted straight
//! into the reused writer, and serial packets are encoded into stack buffers.
//! `tests/alloc_free.rs`, `tests/capture_path.rs`, `tests/aruco_alloc_free.rs` and
//! `tests/recheck_alloc_free.rs` (which counts the re-check's worker thread too) install a
//! counting global allocator and hold the per-frame paths to this. Before any of it is
//! allocated, [`budget`] adds it up from the options, so that a size the machine cannot hold is
//! refused with a message (`--max-memory-mb`) instead of aborting the process;
//! `tests/memory_budget.rs` holds that plan to what the stages really allocate.
//!
//! # The per-frame path
//!
//! [`source`] → [`frame`] → [`detect`] (threshold → morphology → blobs → streak) → [`track`]
//! (or [`track::marker`] for a robot carrying an ArUco marker) → [`geometry::floor`] (screen →
//! floor, with a calibration) → [`report`] → [`sink`]. [`pipeline::Pipeline::process`] calls
//! the stages in order and reads top to bottom; it fills a [`report::FrameReport`], the one
//! thing the sinks read (they never import the pipeline). The number of robots is bounded at
//! compile time ([`report::MAX_ROBOTS`]): every per-robot table is sized for it. With several
//! robots and a link to them, [`identify`] binds tracks to robot ids by asking each robot to
//! blink.

pub mod budget;
pub mod decayed_mean;
pub mod detect;
pub mod frame;
pub mod fuse;
pub mod geometry;
pub mod golden;
pub mod identify;
pub mod latency;
pub mod monitor;
#[cfg(feature = "net")]
pub mod net;
pub mod options;
pub mod pipeline;
pub mod report;
pub mod row_time;
pub mod sink;
pub mod small_file;
pub mod source;
pub mod stats;
pub mod track;
