//! Finding the LED: luma threshold, bit-packed morphology, blobs and streak geometry; and
//! finding ArUco / AprilTag markers ([`aruco`]), for calibration and for a robot carrying one.
//!
//! [`Detector`] owns every buffer the stage needs, sized once from the frame size, and runs
//! the stages in order on each frame without allocating.

mod arc_path;
pub mod aruco;
pub mod bgdiff;
mod bilinear;
pub mod bitimage;
pub mod blobs;
mod body_line;
pub mod cascade;
mod clip_spread;
pub mod edge_memory;
pub mod fit;
pub mod floor_bg;
mod level_falls;
pub mod light_centre;
pub mod line_profile;
pub(crate) mod luma_histogram;
pub mod mirror_middle;
pub mod moments;
pub mod morph;
mod normal;
pub mod place_memory;
mod ray_floor;
pub mod satellite;
pub mod skeleton;
pub mod spot_memory;
pub mod spot_shape;
pub mod streak;
pub mod threshold;
pub mod tips;
pub mod tone_memory;

use bgdiff::{Background, BackgroundError};
use bitimage::{BitImage, Window};
use blobs::{Blob, Labeler, Overflow};
use edge_memory::EdgeMemory;
use floor_bg::FloorBackground;
use morph::Kernel;
use skeleton::SkeletonMethod;
use spot_memory::SpotMemory;
use spot_shape::{Skewed, SpotOptics};
use streak::{Streak, StreakModel, StreakScratch};
use threshold::large_blob::{LastBlobs, MovedLarge};
use threshold::static_map::StaticMap;
use threshold::steady::SteadyPixels;
use threshold::{blob_level, Levels, Threshold, AUTO_MARGIN_LUMA};

use crate::frame::{Frame, FrameSize};

/// The seed's noise filter: 10 erosions with a 3×3 square. It erases anything narrower than
/// 21 px, so it is available (`--erode 10`) but not the default.
pub const SEED_EROSIONS: u32 = 10;

/// A frame with more than this fraction of its pixels saturated is blinded (a lamp in the
/// lens, a white frame): no blob in it can be told from the glare.
pub const BLINDED_FRACTION: f32 = 0.25;

/// Blobs larger than this fraction of the frame are glare, not an LED, unless they moved
/// since the last frame (an LED in a wide glow; automatic threshold only, see
/// [`threshold::large_blob`]).
pub const MAX_BLOB_FRACTION: f32 = 0.02;

/// The static map does not learn within this many pixels of the last analysed blob (the
/// tracked LED) beyond its own size: the LED moves by at most about its streak's length
/// between frames, and a robot parked in view must never be learned as a window.
pub const KEEP_OUT_MARGIN_PX: usize = 24;

/// How many analysed blobs a frame keeps out of the static map: one per tracked LED, so that
/// every robot of a fleet (at most `track::MAX_ROBOTS`, checked there) may stand still.
pub const MAX_KEEP_OUT: usize = 16;

/// The frame interval assumed by [`Detector::segment`], which is given no frame times.
pub const NOMINAL_FRAME_US: u64 = 33_333;

/// Settings of the detection stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectorConfig {
    /// Which mask the blobs are found in.
    pub method: MaskMethod,
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
    /// How the LED's positions at the ends of the exposure are measured.
    pub streak_model: StreakModel,
}

impl Default for DetectorConfig {
    fn default() -> Self {
        DetectorConfig {
            method: MaskMethod::Saturation,
            threshold: Threshold::Auto,
            erosions: 0,
            erosion_kernel: Kernel::Square,
            skeleton: SkeletonMethod::Thinning,
            min_area_px: 2,
            streak_model: StreakModel::default(),
        }
    }
}

/// Which pixels make the mask.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MaskMethod {
    /// Saturated pixels (the seed's part III).
    Saturation,
    /// Pixels that differ from a learned background (the seed's part I). `frames` is how many
    /// of the first frames the background is learned from, unless it is learned beforehand
    /// with [`Detector::learn_background`].
    BackgroundDifference { diff_luma: u8, frames: usize },
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
    /// More than [`BLINDED_FRACTION`] of the frame is saturated (counted before the erosions).
    pub blinded: bool,
    /// The frame went into the background model instead of being searched.
    pub learning: bool,
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
    /// Whether the labeller's tables hold the last frame's blobs.
    labeled: bool,
    /// The background model, for [`MaskMethod::BackgroundDifference`].
    background: Option<Background>,
    /// The floor without the light, for the streak fit ([`StreakModel::Fit`] and
    /// [`StreakModel::Auto`]).
    floor: Option<FloorBackground>,
    /// Whether the floor is kept learned after its first frames (which learn it everywhere):
    /// always for the fit; for the cascade once it has fitted a streak ([`cascade`]), so that
    /// a camera whose LED the ramps read does not pay for its upkeep on every frame.
    floor_learning: bool,
    /// The spots fitted in the last frames, each LED's next fit's start.
    spot_memory: SpotMemory,
    /// The edges' falls read in the last frames, each LED's by place (the cascade's).
    edge_memory: EdgeMemory,
    /// The static bright pixels learned by the automatic threshold.
    statics: StaticMap,
    /// How long each bright pixel has been bright: what is fresh in a large blob that stood
    /// still, before the static map has learned it.
    steady: SteadyPixels,
    /// Around the blob analysed in the last frame (the LED): not learned as static.
    keep_out: heapless::Vec<Window, MAX_KEEP_OUT>,
    /// The first cut's blobs of the last frame, to tell a large blob that moved.
    last_blobs: LastBlobs,
    /// The sensor's clip level as the last frame that showed one showed it: the plateau of a
    /// blob too thin for its own pixels to show one (see [`threshold::blob_level`]). A
    /// camera's clip is the same level in every frame until its settings change.
    sensor_clip_luma: Option<u8>,
    /// This frame's large first-cut blobs that moved: what is cut from them is a candidate
    /// whatever its size (only the largest piece of each).
    moved_large: MovedLarge,
    /// The blobs of this frame's mask that are pieces of a large blob's glow, not its light.
    glow_pieces: [bool; blobs::MAX_BLOBS],
    /// Frames segmented so far, for a clock when the caller gives none.
    frames_segmented: u64,
    /// The time of the frame being segmented.
    t_us: u64,
    /// The lens, when it squeezes a round spot: streak tips are placed for the spot's shape.
    optics: Option<Box<dyn SpotOptics>>,
    /// A rolling shutter's skew of the next analysed LED's spot (see [`Detector::set_row_skew`]).
    row_skew: Option<[[f32; 2]; 2]>,
}

impl Detector {
    /// Allocates every buffer for frames of `size`, including the background model's.
    pub fn new(size: FrameSize, config: DetectorConfig) -> Result<Self, BackgroundError> {
        let background = match config.method {
            MaskMethod::Saturation => None,
            MaskMethod::BackgroundDifference { frames, .. } => Some(Background::new(size, frames)?),
        };
        Ok(Detector {
            config,
            size,
            mask: BitImage::new(size),
            erosion_scratch: BitImage::new(size),
            labeler: Labeler::new(),
            streak: StreakScratch::new(size.width(), size.height()),
            max_area_px: (size.pixels() as f32 * MAX_BLOB_FRACTION) as u32,
            labeled: false,
            background,
            floor: (config.streak_model != StreakModel::Ramps).then(|| FloorBackground::new(size)),
            floor_learning: config.streak_model == StreakModel::Fit,
            spot_memory: SpotMemory::new(None),
            edge_memory: EdgeMemory::new(None),
            statics: StaticMap::new(size.width(), size.height()),
            steady: SteadyPixels::new(size.width(), size.height()),
            keep_out: heapless::Vec::new(),
            last_blobs: LastBlobs::new(),
            sensor_clip_luma: None,
            moved_large: MovedLarge::new(),
            glow_pieces: [false; blobs::MAX_BLOBS],
            frames_segmented: 0,
            t_us: 0,
            optics: None,
            row_skew: None,
        })
    }

    /// Feeds a frame to the background model (for a background taken from a separate
    /// recording before tracking starts). Does nothing for the saturation method.
    pub fn learn_background(&mut self, frame: &Frame<'_>) -> Result<(), BackgroundError> {
        match &mut self.background {
            Some(background) => background.learn(frame),
            None => Ok(()),
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

    /// Runs threshold, erosion and labelling on `frame`, which must have the detector's size
    /// (a mismatched frame is simply found empty). `best` is left empty: the caller picks a
    /// candidate (see [`Detector::candidates`]) and analyses it with [`Detector::analyze`].
    pub fn segment(&mut self, frame: &Frame<'_>) -> Detection {
        let t_us = self.frames_segmented.saturating_mul(NOMINAL_FRAME_US);
        self.segment_at(frame, t_us)
    }

    /// [`Detector::segment`] for the frame taken at `t_us`: what the static map learns is
    /// counted in frame time (see [`threshold::static_map`]).
    pub fn segment_at(&mut self, frame: &Frame<'_>, t_us: u64) -> Detection {
        self.frames_segmented += 1;
        self.t_us = t_us;
        self.spot_memory.next_frame(t_us);
        self.edge_memory.next_frame(t_us);
        self.moved_large.clear();
        self.streak.reset();
        let mut learning = false;
        let mut glare_px = 0;
        let (levels, mut mask_px) = match (&mut self.background, self.config.method) {
            (Some(background), MaskMethod::BackgroundDifference { diff_luma, .. }) => {
                learning = !background.is_ready();
                if learning {
                    // A frame of the wrong size is refused by `segment` below anyway.
                    let _ = background.learn(frame);
                    self.mask.clear_all();
                    (
                        threshold::Levels {
                            top_luma: 0,
                            threshold_luma: None,
                        },
                        0,
                    )
                } else {
                    let count = background.difference_into(frame, diff_luma, &mut self.mask);
                    (
                        threshold::Levels {
                            top_luma: 0,
                            threshold_luma: None,
                        },
                        count,
                    )
                }
            }
            (_, _) if self.config.threshold == Threshold::Auto => {
                let (levels, count, glare) = self.cut_auto(frame);
                glare_px = glare;
                (levels, count)
            }
            _ => threshold::apply(frame, self.config.threshold, &mut self.mask),
        };
        // Blinded is read before the erosions: they thin what was saturated, not the glare. A
        // frame of one level under the automatic level is saturated throughout, and three
        // erosions left a 2 px band of an 8 px wide frame, under the fraction, that was
        // reported as the LED.
        let saturated_px = mask_px;
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
            blinded: (saturated_px + glare_px) as f32
                > self.size.pixels() as f32 * BLINDED_FRACTION,
            learning,
            best: None,
        };
        self.labeled = false;
        if detection.blinded || frame.size() != self.size {
            return detection;
        }
        if mask_px == 0 {
            if !learning {
                self.learn_floor(frame);
            }
            return detection;
        }
        self.labeler.label(&self.mask);
        self.labeled = true;
        self.moved_large
            .mark_glow_pieces(self.labeler.blobs(), &mut self.glow_pieces);
        detection.blob_count = self.labeler.blobs().len();
        detection.overflow = self.labeler.overflow();
        if !detection.overflow.any() {
            self.learn_floor(frame);
        }
        detection
    }

    /// Learns the floor (for the streak fit) from `frame` away from the blobs just labelled:
    /// none of the pixels the fit will read in this frame is learned from it.
    fn learn_floor(&mut self, frame: &Frame<'_>) {
        let Some(floor) = self
            .floor
            .as_mut()
            .filter(|f| self.floor_learning || f.learns_everywhere())
        else {
            return;
        };
        let blobs = if self.labeled {
            self.labeler.blobs()
        } else {
            &[]
        };
        floor.update(frame, blobs.iter(), fit::sample_margin_px);
    }

    /// The automatic threshold, blob by blob: a low first cut, its blobs, and each blob cut
    /// again at its own top level (see [`threshold::blob_level`]). When the first cut is too
    /// busy for the blob tables, one level for the whole frame instead.
    ///
    /// Static bright pixels (see [`threshold::static_map`]) are learned from the first cut
    /// and taken out of it before any blob is found, so they set no level and are never
    /// candidates.
    ///
    /// A clipped blob larger than an LED's usual size is cut too when it moved since the last
    /// frame (see [`threshold::large_blob`]), and dropped as glare when it did not, all but
    /// the pixels that have just come into it (see [`threshold::steady`]).
    ///
    /// Returns the levels, the pixels left in the mask, and the pixels of glare dropped as
    /// too large to be an LED.
    fn cut_auto(&mut self, frame: &Frame<'_>) -> (Levels, usize, usize) {
        let (top_luma, count) = threshold::first_cut(frame, &mut self.mask);
        let mut levels = Levels {
            top_luma,
            threshold_luma: None,
        };
        if frame.size() == self.size {
            self.statics.observe(&self.mask, &self.keep_out, self.t_us);
            self.steady.observe(&self.mask, self.t_us);
        }
        self.keep_out.clear();
        let count = count.saturating_sub(self.statics.clear_static(&mut self.mask));
        if frame.size() != self.size {
            self.last_blobs.forget();
            self.mask.clear_all();
            return (levels, 0, 0);
        }
        if count == 0 {
            self.last_blobs.remember(&[]);
            self.mask.clear_all();
            return (levels, 0, 0);
        }
        self.labeler.label(&self.mask);
        let first_cut = self.labeler.blobs();
        for blob in first_cut.iter().filter(|b| b.area_px > self.max_area_px) {
            let b = &blob.bbox;
            let window = self
                .mask
                .window_around(b.x_min_px, b.y_min_px, b.x_max_px, b.y_max_px, 1);
            self.steady.find_fresh(window, &mut self.erosion_scratch);
        }
        let (last_blobs, moved_large, steady) =
            (&self.last_blobs, &mut self.moved_large, &self.steady);
        let cut = blob_level::cut_each_blob(
            frame,
            &self.labeler,
            self.config.min_area_px,
            self.max_area_px,
            self.sensor_clip_luma,
            |blob| {
                let moved = last_blobs.moved(blob, first_cut);
                if moved {
                    moved_large.push(blob);
                }
                moved
            },
            |x, y| steady.is_fresh(x, y),
            &mut self.mask,
        );
        if self.labeler.overflow().any() {
            self.last_blobs.forget();
        } else {
            self.last_blobs.remember(self.labeler.blobs());
        }
        match cut {
            Some(cut) => {
                self.sensor_clip_luma = cut.sensor_clip_luma.or(self.sensor_clip_luma);
                levels.threshold_luma = cut.brightest_level_luma;
                (levels, cut.count, cut.glare_px)
            }
            // Too busy to cut blob by blob: one level for the frame, and only for a frame
            // with something clipped in it.
            None if top_luma < threshold::MIN_CLIP_LUMA => {
                self.mask.clear_all();
                (levels, 0, 0)
            }
            None => {
                let level = top_luma.saturating_sub(AUTO_MARGIN_LUMA);
                levels.threshold_luma = Some(level);
                (
                    levels,
                    threshold::recut_rows(frame, level, &mut self.mask, count),
                    0,
                )
            }
        }
    }

    /// The levels blob `index` of the last segmented frame was cut at: its own (automatic
    /// threshold, background difference) or the fixed level.
    pub fn levels_of(&self, frame: &Frame<'_>, index: usize, frame_levels: Levels) -> Levels {
        match (self.config.method, self.config.threshold) {
            (MaskMethod::Saturation, Threshold::Fixed(_)) => frame_levels,
            _ => blob_level::levels_of_blob(frame, &self.labeler, index, self.sensor_clip_luma),
        }
    }

    /// Segments `frame` and analyses its largest candidate: detection without tracking.
    pub fn detect(&mut self, frame: &Frame<'_>) -> Detection {
        let mut detection = self.segment(frame);
        detection.best = self
            .candidates()
            .max_by_key(|(_, b)| b.area_px)
            .and_then(|(index, _)| self.analyze(frame, index, detection.levels));
        detection
    }

    /// The blobs of the last segmented frame that may be the LED: neither noise nor glare
    /// (larger than [`MAX_BLOB_FRACTION`] of the frame only when they moved, and then not
    /// the pieces of its glow, see [`threshold::large_blob`]). None when the frame overflowed the blob tables or was
    /// blinded.
    pub fn candidates(&self) -> impl Iterator<Item = (usize, Blob)> + Clone + '_ {
        let usable = self.labeled && !self.labeler.overflow().any();
        self.labeler
            .blobs()
            .iter()
            .copied()
            .enumerate()
            .filter(move |(i, b)| {
                usable
                    && b.area_px >= self.config.min_area_px
                    && (b.area_px <= self.max_area_px || self.moved_large.holds(b))
                    && !self.glow_pieces.get(*i).copied().unwrap_or(false)
            })
    }

    /// The streak geometry of blob `index` of the last segmented frame.
    pub fn analyze(
        &mut self,
        frame: &Frame<'_>,
        index: usize,
        levels: Levels,
    ) -> Option<(Blob, Streak)> {
        if levels.threshold_luma.is_none() && self.background.is_none() {
            return None;
        }
        let blob = *self.labeler.blobs().get(index)?;
        let b = blob.bbox;
        let margin_px = b.width_px().max(b.height_px()) + KEEP_OUT_MARGIN_PX;
        // Full only with more tracks than the bound, which the tracker refuses at start.
        let _ = self.keep_out.push(
            self.mask
                .window_around(b.x_min_px, b.y_min_px, b.x_max_px, b.y_max_px, margin_px),
        );
        // Each blob was cut at its own level (automatic threshold), and a difference mask has
        // no saturation level at all: the blob's brightest pixel stands in for it, so rim
        // weights and tip ramps work as on a saturated blob.
        let levels = self.levels_of(frame, index, levels);
        let skewed = self.row_skew.map(|unskew| Skewed {
            lens: self.optics.as_deref(),
            unskew,
        });
        let optics = match &skewed {
            Some(skewed) => Some(skewed as &dyn SpotOptics),
            None => self.optics.as_deref(),
        };
        let streak = streak::analyze(
            frame,
            &self.labeler,
            index,
            &blob,
            levels,
            self.config.skeleton,
            self.config.streak_model,
            self.floor.as_ref(),
            optics,
            (&mut self.spot_memory, &mut self.edge_memory),
            &mut self.streak,
        );
        // The cascade fitted a streak: the camera shows spots the ramps cannot read, and the
        // fit wants the floor kept from now on (until then, it was learned in full in the
        // run's first frames only).
        self.floor_learning |= streak.fitted();
        Some((blob, streak))
    }

    /// Analyses blob `index` as [`Detector::analyze`] does, and leaves nothing behind: the
    /// memories the next frames' fits start from, the floor's upkeep and the keep-out window
    /// are as they were. For a blob the tracker asks about before it chooses (see
    /// [`crate::track::Tracker::smear_in_question`]): one it then does not take (a glare spot)
    /// must not change how the LED is read later, as the spot fitted to it would, warming the
    /// next fit at its place (sweep seed 12's point 109, a bloom whose first frame stayed
    /// `ambiguous`, read its next frames' speeds 10.2 % off at p95 instead of 6.3 %). A blob
    /// it takes is analysed again, from the same memories, to the same streak.
    pub fn probe(
        &mut self,
        frame: &Frame<'_>,
        index: usize,
        levels: Levels,
    ) -> Option<(Blob, Streak)> {
        let spots = self.spot_memory.clone();
        let edges = self.edge_memory.clone();
        let (floor_learning, keep_out) = (self.floor_learning, self.keep_out.len());
        let analysed = self.analyze(frame, index, levels);
        self.spot_memory = spots;
        self.edge_memory = edges;
        self.floor_learning = floor_learning;
        self.keep_out.truncate(keep_out);
        analysed
    }

    /// The camera's exposure time (set once, at start-up; `None`, the default, when unknown):
    /// how far an LED can move between frames for its last fitted spot to start its next fit
    /// ([`SpotMemory`]) and its last edges to be pooled with its next ([`EdgeMemory`]).
    /// Forgets both.
    pub fn set_exposure_us(&mut self, exposure_us: Option<u32>) {
        self.spot_memory = SpotMemory::new(exposure_us);
        self.edge_memory = EdgeMemory::new(exposure_us);
    }

    /// Places streak tips for the spot shape `optics` makes of a round spot (set once, at
    /// start-up, from the calibration's lens; without it a spot is taken to be round).
    pub fn set_optics(&mut self, optics: Box<dyn SpotOptics>) {
        self.optics = Some(optics);
    }

    /// How a rolling shutter skews the spot of the LED analysed next (its picture moving as
    /// the tracker expects it to in this frame): the map from the skewed picture back to a
    /// global shutter's, which makes its spot round again (see
    /// [`RollingShutter::unskew`](crate::track::shutter::RollingShutter::unskew)); `None`
    /// for a global shutter or an LED whose velocity is not expected yet. Set each frame.
    pub fn set_row_skew(&mut self, unskew: Option<[[f32; 2]; 2]>) {
        self.row_skew = unskew;
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

    /// The floor learned without the light, for the streak fit (`None` with the ramps).
    pub fn floor_background(&self) -> Option<&FloorBackground> {
        self.floor.as_ref()
    }

    /// The pixels learned as static bright things (automatic threshold only).
    pub fn static_pixels(&self) -> &BitImage {
        self.statics.flag()
    }
}
