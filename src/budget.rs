//! What a run's options cost in memory, worked out before anything is allocated, so that
//! `--size 16384x16384 --background-frames 63` (17 GB) is refused with one line naming the
//! option and the need, instead of an abort with a backtrace when the allocator gives up.
//!
//! Everything glint allocates scales with the frame size (see the memory model in `lib.rs`):
//! here each buffer that scales is counted from the same layout the stage allocates (a bit
//! image is `⌈width / 64⌉` words per row, the background model one luma plane per learning
//! frame plus the median, ...). `tests/memory_budget.rs` measures what building the stages
//! really allocates and holds these figures to it, so the two cannot drift apart. Buffers of a
//! fixed size (blob tables, histograms, output buffers) are counted as one allowance.

use core::fmt;
use std::collections::TryReserveError;

use crate::frame::FrameSize;

/// Bytes per mebibyte, the unit of `--max-memory-mb`.
pub const BYTES_PER_MB: u64 = 1024 * 1024;

/// The default `--max-memory-mb`: a quarter of a 1 GB Raspberry Pi 3. 640×480 with every
/// option needs under 40 MB of it.
pub const DEFAULT_MAX_MEMORY_MB: u64 = 256;

/// Buffers whose size does not depend on the options: the blob and run tables, the latency
/// histograms, the output and serial buffers, the allocator's slack.
pub const FIXED_BYTES: u64 = 4 * BYTES_PER_MB;

/// Bit images the LED detector keeps at the frame's size: the mask and the erosion scratch,
/// the streak stage's blob, halo, skeleton and visited images, three skeleton scratches, the
/// static map's seven planes (a 4-bit counter, the period's OR and what it saw, and the static
/// flag), and the steady pixels' five (a 4-bit counter and the fresh pixels).
const LED_BIT_IMAGES: u64 = 21;
/// The LED detector's run table (boxed, about 80 KiB) with room to spare.
const LED_TABLE_BYTES: u64 = 128 * 1024;
/// Byte planes the marker detector keeps at the frame's size: the luma and the mask.
const MARKER_PLANES: u64 = 2;
/// The marker detector's scratch per pixel of frame width (column sums, prefix sums, a luma
/// row) and per pixel of the longest border it traces (the contour, the edge samples).
const MARKER_BYTES_PER_COLUMN: u64 = 16;
const MARKER_BYTES_PER_PERIMETER_PX: u64 = 96;
/// A preview keeps a copy of the frame's luma and one encoded image of it.
const PREVIEW_LUMA_COPIES: u64 = 2;
const PREVIEW_FIXED_BYTES: u64 = 64 * 1024;

/// One buffer (or set of buffers) the options ask for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Need {
    /// What it is: "the background model".
    pub what: &'static str,
    /// The options that size it: "--background-frames 63 × --size 16384x16384".
    pub because: String,
    pub bytes: u64,
}

/// Everything a run will allocate, by what asks for it.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct MemoryPlan {
    needs: Vec<Need>,
}

/// The plan exceeds the limit (or the system would not give that much).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BudgetError {
    /// Above `--max-memory-mb`.
    OverLimit {
        total_bytes: u64,
        limit_bytes: u64,
        largest: Need,
    },
    /// Within the limit, but the system refused to reserve that much (`ulimit -v`, a small
    /// machine without overcommit).
    Unavailable { total_bytes: u64 },
}

impl fmt::Display for BudgetError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BudgetError::OverLimit {
                total_bytes,
                limit_bytes,
                largest,
            } => write!(
                f,
                "the options need {} MB, more than --max-memory-mb {}: {} ({}) takes {} MB",
                mb_rounded_up(*total_bytes),
                limit_bytes / BYTES_PER_MB,
                largest.what,
                largest.because,
                mb_rounded_up(largest.bytes)
            ),
            BudgetError::Unavailable { total_bytes } => write!(
                f,
                "the options need {} MB, which this system will not give (a memory limit?)",
                mb_rounded_up(*total_bytes)
            ),
        }
    }
}

impl std::error::Error for BudgetError {}

fn mb_rounded_up(bytes: u64) -> u64 {
    bytes.div_ceil(BYTES_PER_MB)
}

impl MemoryPlan {
    /// A plan holding the fixed allowance only.
    pub fn new() -> Self {
        let mut plan = MemoryPlan::default();
        plan.add("fixed tables and buffers", "always".into(), FIXED_BYTES);
        plan
    }

    /// Adds a need.
    pub fn add(&mut self, what: &'static str, because: String, bytes: u64) {
        self.needs.push(Need {
            what,
            because,
            bytes,
        });
    }

    /// The needs, in the order they were added.
    pub fn needs(&self) -> &[Need] {
        &self.needs
    }

    /// Bytes of all the needs together.
    pub fn total_bytes(&self) -> u64 {
        self.needs
            .iter()
            .fold(0u64, |sum, n| sum.saturating_add(n.bytes))
    }

    /// Checks the plan against `limit_mb`, then asks the system for that much address space
    /// once (and gives it back at once: nothing is touched), so that a process limit shows
    /// here as a message rather than later as an abort.
    pub fn check(&self, limit_mb: u64) -> Result<(), BudgetError> {
        let total_bytes = self.total_bytes();
        let limit_bytes = limit_mb.saturating_mul(BYTES_PER_MB);
        if total_bytes > limit_bytes {
            let largest = self
                .needs
                .iter()
                .max_by_key(|n| n.bytes)
                .cloned()
                .unwrap_or(Need {
                    what: "nothing",
                    because: String::new(),
                    bytes: 0,
                });
            return Err(BudgetError::OverLimit {
                total_bytes,
                limit_bytes,
                largest,
            });
        }
        probe(total_bytes).map_err(|_| BudgetError::Unavailable { total_bytes })
    }
}

/// Reserves `bytes` of address space and frees it again.
fn probe(bytes: u64) -> Result<(), TryReserveError> {
    let mut probe: Vec<u8> = Vec::new();
    probe.try_reserve_exact(usize::try_from(bytes).unwrap_or(usize::MAX))
}

/// One unpadded YUYV frame: a dump's read buffer, or one camera buffer.
pub fn frame_bytes(size: FrameSize) -> u64 {
    size.frame_bytes() as u64
}

/// One bit image of the frame's size (`⌈width / 64⌉` 64-bit words per row).
fn bit_image_bytes(size: FrameSize) -> u64 {
    (size.width().div_ceil(64) * 8 * size.height()) as u64
}

/// The LED detector's masks and scratch (the background model apart).
pub fn led_detector_bytes(size: FrameSize) -> u64 {
    LED_BIT_IMAGES * bit_image_bytes(size) + LED_TABLE_BYTES
}

/// The background model: `frames` luma planes while learning, plus the median.
pub fn background_bytes(size: FrameSize, frames: usize) -> u64 {
    (frames as u64 + 1).saturating_mul(size.pixels() as u64)
}

/// The streak fit's learned floor (`--streak-model fit`, and `auto`, the default): a 16-bit mean
/// and an 8-bit count per pixel, and a bit image of where the frame's light is.
pub fn fit_floor_bytes(size: FrameSize) -> u64 {
    3 * size.pixels() as u64 + bit_image_bytes(size)
}

/// The marker detector's scratch: the frame's luma plane, loaded once for all its threshold
/// passes, and a threshold mask of it; a few rows; and the longest border it traces
/// (`max_perimeter_px`).
pub fn marker_detector_bytes(size: FrameSize, max_perimeter_px: usize) -> u64 {
    MARKER_PLANES * size.pixels() as u64
        + MARKER_BYTES_PER_COLUMN * (size.width() as u64 + 1)
        + MARKER_BYTES_PER_PERIMETER_PX * max_perimeter_px as u64
}

/// The preview page's copy of the frame and its encoded image.
pub fn preview_bytes(size: FrameSize) -> u64 {
    PREVIEW_LUMA_COPIES * size.pixels() as u64 + PREVIEW_FIXED_BYTES
}

#[cfg(test)]
mod tests {
    use super::*;

    fn size(s: &str) -> FrameSize {
        s.parse().unwrap()
    }

    #[test]
    fn the_issue_s_case_is_refused_naming_the_background() {
        let big = size("16384x16384");
        let mut plan = MemoryPlan::new();
        plan.add(
            "the frame buffer",
            "--size 16384x16384".into(),
            frame_bytes(big),
        );
        plan.add(
            "the background model",
            "--background-frames 63 × --size 16384x16384".into(),
            background_bytes(big, 63),
        );
        let e = plan.check(DEFAULT_MAX_MEMORY_MB).unwrap_err();
        assert_eq!(
            e.to_string(),
            "the options need 16900 MB, more than --max-memory-mb 256: the background model \
             (--background-frames 63 × --size 16384x16384) takes 16384 MB"
        );
    }

    #[test]
    fn a_webcam_run_fits_the_default_with_room() {
        let vga = size("640x480");
        let mut plan = MemoryPlan::new();
        plan.add("frame", String::new(), frame_bytes(vga));
        plan.add("led", String::new(), led_detector_bytes(vga));
        plan.add("bg", String::new(), background_bytes(vga, 63));
        plan.add("preview", String::new(), preview_bytes(vga));
        assert!(plan.total_bytes() < 40 * BYTES_PER_MB, "{plan:?}");
        assert!(plan.check(DEFAULT_MAX_MEMORY_MB).is_ok());
    }

    #[test]
    fn more_than_the_address_space_is_unavailable_not_an_abort() {
        let mut plan = MemoryPlan::new();
        plan.add("huge", String::new(), u64::MAX / 2);
        assert!(matches!(
            plan.check(u64::MAX),
            Err(BudgetError::Unavailable { .. })
        ));
    }
}
