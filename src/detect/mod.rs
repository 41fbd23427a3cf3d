//! Finding the LED: luma threshold, bit-packed morphology, blobs and streak geometry.
//!
//! [`Detector`] owns every buffer the stage needs, sized once from the frame size, and runs
//! the stages in order on each frame without allocating.

pub mod bitimage;
pub mod blobs;
pub mod morph;
pub mod skeleton;
pub mod streak;
pub mod threshold;

use bitimage::BitImage;
use blobs::{Blob, Labeler, Overflow};
use morph::Kernel;
use skeleton::SkeletonMethod;
use streak::{Streak, StreakScratch};
use threshold::{Levels, Threshold};

use crate::frame::{Frame, FrameSize};

/// The seed's noise filter: 10 erosions with a 3×3 square. It erases anything narrower than
/// 21 px, so it is available (`--erode 10`) but not the default.
pub const SEED_EROSIONS: u32 = 10;

/// A frame with more than this fraction of its pixels saturated is blinded (a lamp in the
/// lens, a white frame): no blob in it can be told from the glare.
pub const BLINDED_FRACTION: f32 = 0.25;

/// Blobs larger than this fraction of the frame are glare, not an LED.
pub const MAX_BLOB_FRACTION: f32 = 0.02;

/// Settings of the detection stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectorConfig {
    /// How the saturation level is chosen.
    pub threshold: Threshold,
    /// Erosions applied to the mask before blobs are found (0 keeps LEDs a few pixels wide).
    pub erosions: u32,
    /// The structuring element of those erosions.
    pub erosion_kernel: Kernel,
    /// The skeleton used for the streak's middle and ends.
    pub skeleton: SkeletonMethod,
    /// Blobs with fewer pixels are noise.
    pub min_area_px: u32,
}

impl Default for DetectorConfig {
    fn default() -> Self {
        DetectorConfig {
            threshold: Threshold::Auto,
            erosions: 0,
            erosion_kernel: Kernel::Square,
            skeleton: SkeletonMethod::Thinning,
            min_area_px: 2,
        }
    }
}

/// What detection found in one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Detection {
    /// The levels the threshold used.
    pub levels: Levels,
    /// Saturated pixels after erosion.
    pub mask_px: usize,
    /// Blobs in the mask (before size filtering).
    pub blob_count: usize,
    /// What did not fit in the bounded tables.
    pub overflow: Overflow,
    /// More than [`BLINDED_FRACTION`] of the frame is saturated.
    pub blinded: bool,
    /// The chosen blob and its streak geometry; `None` when nothing qualifies.
    pub best: Option<(Blob, Streak)>,
}

/// The detection stage with all its buffers.
pub struct Detector {
    config: DetectorConfig,
    size: FrameSize,
    mask: BitImage,
    erosion_scratch: BitImage,
    labeler: Labeler,
    streak: StreakScratch,
    max_area_px: u32,
}

impl Detector {
    /// Allocates every buffer for frames of `size`.
    pub fn new(size: FrameSize, config: DetectorConfig) -> Self {
        Detector {
            config,
            size,
            mask: BitImage::new(size),
            erosion_scratch: BitImage::new(size),
            labeler: Labeler::new(),
            streak: StreakScratch::new(size.width(), size.height()),
            max_area_px: (size.pixels() as f32 * MAX_BLOB_FRACTION) as u32,
        }
    }

    /// The frame size this detector was built for.
    pub fn size(&self) -> FrameSize {
        self.size
    }

    /// The settings.
    pub fn config(&self) -> &DetectorConfig {
        &self.config
    }

    /// Runs threshold, erosion, labelling and streak analysis on `frame`, which must have the
    /// detector's size (a mismatched frame is simply found empty).
    pub fn detect(&mut self, frame: &Frame<'_>) -> Detection {
        self.streak.reset();
        let (levels, mut mask_px) = threshold::apply(frame, self.config.threshold, &mut self.mask);
        if self.config.erosions > 0 && mask_px > 0 {
            let window = self.mask.full_window();
            morph::erode_n(
                &mut self.mask,
                &mut self.erosion_scratch,
                self.config.erosion_kernel,
                self.config.erosions,
                window,
            );
            mask_px = self.mask.count_ones();
        }
        let mut detection = Detection {
            levels,
            mask_px,
            blob_count: 0,
            overflow: Overflow::default(),
            blinded: mask_px as f32 > self.size.pixels() as f32 * BLINDED_FRACTION,
            best: None,
        };
        if detection.blinded || mask_px == 0 || frame.size() != self.size {
            return detection;
        }
        self.labeler.label(&self.mask);
        detection.blob_count = self.labeler.blobs().len();
        detection.overflow = self.labeler.overflow();
        if detection.overflow.any() {
            return detection;
        }
        let Some(threshold_luma) = levels.threshold_luma else {
            return detection;
        };
        detection.best = self.largest_candidate().map(|(index, blob)| {
            let streak = streak::analyze(
                frame,
                &self.labeler,
                index,
                &blob,
                threshold_luma,
                self.config.skeleton,
                &mut self.streak,
            );
            (blob, streak)
        });
        detection
    }

    /// The largest blob that is neither noise nor glare.
    fn largest_candidate(&self) -> Option<(usize, Blob)> {
        self.labeler
            .blobs()
            .iter()
            .copied()
            .enumerate()
            .filter(|(_, b)| b.area_px >= self.config.min_area_px && b.area_px <= self.max_area_px)
            .max_by_key(|(_, b)| b.area_px)
    }

    /// The saturation mask of the last frame.
    pub fn mask(&self) -> &BitImage {
        &self.mask
    }

    /// The skeleton of the last analysed blob.
    pub fn skeleton(&self) -> &BitImage {
        self.streak.skeleton()
    }

    /// The blobs of the last frame.
    pub fn blobs(&self) -> &[Blob] {
        self.labeler.blobs()
    }
}
