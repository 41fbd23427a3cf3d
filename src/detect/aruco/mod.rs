//! ArUco / AprilTag marker detection on the luma plane of YUYV frames, with sub-pixel corners.
//!
//! Stages, one file each, called in order by [`Detector::detect`]:
//! 1. [`threshold`]: adaptive threshold of the region of interest into a mask, once for each of
//!    OpenCV's three window sizes (a marker missed by one window is caught by another);
//! 2. [`contour`]: outer borders of the mask's dark regions;
//! 3. [`quad`]: borders with four straight sides become candidates;
//! 4. [`grid`]: each candidate's cell grid is sampled through its perspective, longest
//!    candidates first, each outline once;
//! 5. [`dictionary`]: the bits are decoded in all four rotations, with error correction;
//! 6. [`refine`]: the corners of decoded markers are refined to sub-pixel by edge-line fits.
//!
//! The cost per frame is bounded whatever the frame shows: contour tracing has a step budget
//! per frame, at most [`MAX_CANDIDATES`] candidates are kept (the longest) and at most
//! [`MAX_DECODES`] grids are read. When a cap is hit, [`DetectionStats::capped`] says so.
//!
//! Corners come as OpenCV gives them: top-left, top-right, bottom-right, bottom-left of the
//! marker as printed, pixel centres at integer coordinates.
//!
//! All scratch is allocated in [`Detector::new`]; detection allocates nothing.

pub mod contour;
pub mod dictionary;
pub mod grid;
pub mod quad;
pub mod refine;
pub mod threshold;

use core::fmt;

use crate::frame::{Frame, FrameSize};
use crate::geometry::Point;

pub use dictionary::{Dictionary, UnknownDictionary};
pub use threshold::Roi;

/// Most markers reported per frame.
pub const MAX_MARKERS: usize = 32;
/// Closest a candidate's border may come to the edge of the frame or region, in pixels (as
/// OpenCV's `minDistanceToBorder`): a marker cut off by the edge has no trustworthy corners.
pub const MIN_EDGE_DISTANCE_PX: i32 = 3;
/// Most quadrilateral candidates kept per frame, the longest first: a frame full of squares
/// (tiles, a checkerboard, printed text) has thousands, and each costs a grid read.
pub const MAX_CANDIDATES: usize = 128;
/// Most candidates whose grid is read per frame (each reads about a thousand samples).
pub const MAX_DECODES: usize = 64;
/// Threshold passes per frame (OpenCV's window sizes).
pub const PASSES: usize = 3;
/// Two candidates whose corners lie this close on average (pixels) are one outline found twice
/// (by two threshold passes): it is decoded once.
const SAME_CANDIDATE_PX: f64 = 2.0;

/// One adaptive-threshold pass: its window and whether its ratio test is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ThresholdPass {
    /// Half the side of the window, in pixels (the window is `2 × radius + 1` square).
    pub radius_px: usize,
    /// A dark pixel is also below this share of the window mean, in percent
    /// ([`threshold::NO_RATIO_PCT`] for none).
    pub ratio_pct: u32,
}

/// Detector settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectorConfig {
    /// The dictionary markers are decoded against.
    pub dictionary: Dictionary,
    /// The threshold passes, each traced for candidates. By default OpenCV's windows (3, 13 and
    /// 23 pixels: small markers need a small window, thick borders under blur a large one) with
    /// the margin alone, as OpenCV does, so that grey ink is found. The ratio test
    /// ([`threshold::MAX_DARK_RATIO_PCT`]) keeps black ink's outline apart from a hard shadow's
    /// edge even in a wide window, at the cost of grey ink.
    pub threshold_passes: [ThresholdPass; PASSES],
    /// How much darker than the window mean a pixel must be to count as dark (luma levels).
    pub threshold_offset: u8,
    /// Shortest marker outline accepted, as a share of the frame's larger side (OpenCV's
    /// `minMarkerPerimeterRate`).
    pub min_perimeter_rate: f64,
    /// Longest marker border traced, in pixels (bounds the work on huge regions).
    pub max_perimeter_px: usize,
    /// Most contour-tracing steps per frame, over all threshold passes (each pixel on a border
    /// is about one a pass): bounds the time spent on frames with borders everywhere (speckle,
    /// mazes). At 640×480 a textured floor takes about 82 000, OpenCV's tutorial photo 36 000
    /// and its photo of a ChArUco board (a chessboard with text around it) 169 000.
    pub max_trace_steps: usize,
    /// Whether corners are refined to sub-pixel (costs a little time per marker found).
    pub refine: bool,
}

impl DetectorConfig {
    /// Defaults for a dictionary, suited to 640×480 webcams.
    pub fn new(dictionary: Dictionary) -> Self {
        let margin_only = |radius_px| ThresholdPass {
            radius_px,
            ratio_pct: threshold::NO_RATIO_PCT,
        };
        DetectorConfig {
            dictionary,
            threshold_passes: [margin_only(1), margin_only(6), margin_only(11)],
            threshold_offset: 7,
            min_perimeter_rate: 0.03,
            max_perimeter_px: 4000,
            max_trace_steps: 200_000,
            refine: true,
        }
    }
}

/// One detected marker.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Marker {
    /// Id in the detector's dictionary.
    pub id: u16,
    /// Top-left, top-right, bottom-right, bottom-left of the printed marker, frame pixels.
    pub corners: [Point; 4],
    /// Bits that were corrected while decoding.
    pub corrected_bits: u32,
    /// Whether `corners` are sub-pixel refined (false if refinement was off or failed).
    pub refined: bool,
}

impl Marker {
    /// Centre: where the diagonals cross (exact under perspective, unlike the corners' mean).
    pub fn centre(&self) -> Point {
        diagonals_cross(&self.corners)
    }
}

/// Where a quadrilateral's diagonals cross (the corners' mean if they are parallel).
pub fn diagonals_cross(corners: &[Point; 4]) -> Point {
    let [a, b, c, d] = *corners;
    let (r, s) = (c - a, d - b);
    let denom = r.perp(&s);
    if denom.abs() < f64::EPSILON {
        return Point::from((a.coords + b.coords + c.coords + d.coords) / 4.0);
    }
    let t = (b - a).perp(&s) / denom;
    a + r * t
}

/// Whether `p` lies inside the convex quadrilateral `q` (clockwise on screen).
fn inside_quad(q: &[Point; 4], p: Point) -> bool {
    (0..4).all(|k| (q[(k + 1) % 4] - q[k]).perp(&(p - q[k])) >= 0.0)
}

/// What the last detection saw, for diagnostics (why a marker was not found).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DetectionStats {
    /// Outer borders long enough to be a marker, over all threshold passes.
    pub borders: u32,
    /// Borders that were quadrilaterals.
    pub quads: u32,
    /// Borders that touched the frame or region edge (a marker may be cut off).
    pub touching_edge: u32,
    /// Contour-tracing steps taken, over all threshold passes.
    pub trace_steps: u32,
    /// Candidates whose grid was read.
    pub read: u32,
    /// Quadrilaterals decoded as markers.
    pub decoded: u32,
    /// Markers beyond [`MAX_MARKERS`], not reported.
    pub dropped: u32,
    /// A cost cap was hit (tracing steps, [`MAX_CANDIDATES`] or [`MAX_DECODES`]): some of the
    /// frame was not searched, and a marker there may have been missed.
    pub capped: bool,
}

/// Why detection could not run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DetectError {
    /// The frame is not the size the detector was built for.
    FrameSize { expected: FrameSize, got: FrameSize },
    /// The region of interest is empty or outside the frame.
    EmptyRoi(Roi),
}

impl fmt::Display for DetectError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DetectError::FrameSize { expected, got } => write!(
                f,
                "frame is {got} but the marker detector was built for {expected}"
            ),
            DetectError::EmptyRoi(r) => write!(
                f,
                "region of interest {}x{} at ({}, {}) has no pixels inside the frame",
                r.width_px, r.height_px, r.x_px, r.y_px
            ),
        }
    }
}

impl std::error::Error for DetectError {}

/// A quadrilateral candidate, ordered by the length of its traced border.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    border_px: usize,
    corners: [Point; 4],
}

impl PartialEq for Candidate {
    fn eq(&self, other: &Self) -> bool {
        self.border_px == other.border_px
    }
}
impl Eq for Candidate {}
impl PartialOrd for Candidate {
    fn partial_cmp(&self, other: &Self) -> Option<core::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Candidate {
    fn cmp(&self, other: &Self) -> core::cmp::Ordering {
        self.border_px.cmp(&other.border_px)
    }
}

/// A marker detector for one frame size, with all its scratch.
#[derive(Debug)]
pub struct Detector {
    config: DetectorConfig,
    size: FrameSize,
    thresholder: threshold::Thresholder,
    contour: Vec<(i32, i32)>,
    edge_samples: Vec<refine::EdgeSample>,
    /// The longest candidates so far (a min-heap, so the shortest is dropped first).
    candidates: heapless::BinaryHeap<Candidate, heapless::binary_heap::Min, MAX_CANDIDATES>,
    /// The candidates in decoding order, longest first.
    ordered: heapless::Vec<Candidate, MAX_CANDIDATES>,
    /// Outlines already read this frame.
    read: heapless::Vec<[Point; 4], MAX_DECODES>,
    markers: heapless::Vec<Marker, MAX_MARKERS>,
    stats: DetectionStats,
}

impl Detector {
    /// Allocates the scratch for frames of `size`.
    pub fn new(size: FrameSize, config: DetectorConfig) -> Self {
        Detector {
            config,
            size,
            thresholder: threshold::Thresholder::new(size.width(), size.height()),
            contour: Vec::with_capacity(config.max_perimeter_px.max(4)),
            // One profile every half pixel along the longest side a traced border allows.
            edge_samples: Vec::with_capacity(config.max_perimeter_px.max(4)),
            candidates: heapless::BinaryHeap::new(),
            ordered: heapless::Vec::new(),
            read: heapless::Vec::new(),
            markers: heapless::Vec::new(),
            stats: DetectionStats::default(),
        }
    }

    /// The settings.
    pub fn config(&self) -> &DetectorConfig {
        &self.config
    }

    /// What the last call to [`Detector::detect`] saw.
    pub fn stats(&self) -> DetectionStats {
        self.stats
    }

    /// Finds markers in `frame`, or only inside `roi` (clipped to the frame) when given.
    /// Markers touching the region's edge are not reported: they may be cut off.
    pub fn detect(
        &mut self,
        frame: &Frame<'_>,
        roi: Option<Roi>,
    ) -> Result<&[Marker], DetectError> {
        if frame.size() != self.size {
            return Err(DetectError::FrameSize {
                expected: self.size,
                got: frame.size(),
            });
        }
        let roi = clip_roi(roi, self.size)?;
        self.markers.clear();
        self.candidates.clear();
        self.ordered.clear();
        self.read.clear();
        self.stats = DetectionStats::default();
        let cfg = self.config;
        let frame_side_px = self.size.width().max(self.size.height()) as f64;
        let min_border_len =
            (cfg.min_perimeter_rate * frame_side_px).max(4.0 * quad::MIN_SIDE_PX) as usize;
        let origin = nalgebra::Vector2::new(roi.x_px as f64, roi.y_px as f64);
        self.thresholder.load(frame, roi);
        let mut steps_left = cfg.max_trace_steps;
        for pass in cfg.threshold_passes {
            if steps_left == 0 {
                // The tracing budget is spent: a further pass would find no border.
                self.stats.capped = true;
                break;
            }
            self.thresholder
                .run(pass.radius_px, cfg.threshold_offset, pass.ratio_pct);
            let (mask, w, h) = self.thresholder.mask_mut();
            let limits = quad::QuadLimits {
                min_edge_distance_px: MIN_EDGE_DISTANCE_PX,
                width_px: w as i32,
                height_px: h as i32,
            };
            let stats = &mut self.stats;
            let candidates = &mut self.candidates;
            let complete = contour::trace_borders(
                mask,
                w,
                h,
                min_border_len,
                &mut self.contour,
                &mut steps_left,
                |border| {
                    stats.borders += 1;
                    // With the heap full, a border no longer than its shortest candidate would
                    // be dropped even as a quadrilateral: don't fit it.
                    let shortest = candidates.peek().map_or(0, |c| c.border_px);
                    if candidates.len() == MAX_CANDIDATES && border.len() <= shortest {
                        stats.capped = true;
                        return;
                    }
                    let quad = match quad::fit_quad(border, &limits) {
                        Ok(q) => q,
                        Err(quad::Rejection::TouchesEdge) => {
                            stats.touching_edge += 1;
                            return;
                        }
                        Err(_) => return,
                    };
                    stats.quads += 1;
                    let candidate = Candidate {
                        border_px: border.len(),
                        corners: quad.map(|p| p + origin),
                    };
                    if let Err(c) = candidates.push(candidate) {
                        stats.capped = true;
                        // Full: the shortest candidate makes way for a longer one.
                        if candidates.peek().is_some_and(|shortest| c > *shortest) {
                            candidates.pop();
                            let _ = candidates.push(c);
                        }
                    }
                },
            );
            self.stats.capped |= !complete;
        }
        let steps = cfg.max_trace_steps - steps_left;
        self.stats.trace_steps = u32::try_from(steps).unwrap_or(u32::MAX);
        // Longest first: a marker is larger than most of the clutter around it.
        while let Some(c) = self.candidates.pop() {
            let _ = self.ordered.push(c);
        }
        self.ordered.reverse();
        for c in &self.ordered {
            let centre = diagonals_cross(&c.corners);
            if self.markers.iter().any(|m| inside_quad(&m.corners, centre))
                || self.read.iter().any(|r| same_outline(r, &c.corners))
            {
                continue;
            }
            if self.read.push(c.corners).is_err() {
                self.stats.capped = true;
                break;
            }
            self.stats.read += 1;
            if let Some(marker) = decode_candidate(frame, &c.corners, &cfg, &mut self.edge_samples)
            {
                self.stats.decoded += 1;
                if self.markers.push(marker).is_err() {
                    self.stats.dropped += 1;
                }
            }
        }
        Ok(&self.markers)
    }
}

impl Detector {
    /// The markers the last call to [`Detector::detect`] found.
    pub fn markers(&self) -> &[Marker] {
        &self.markers
    }

    /// `marker`'s corners (as found in `frame` with refinement off) refined to sub-pixel, for
    /// a caller that needs them only now and then; `None` when refinement fails.
    pub fn refine(&mut self, frame: &Frame<'_>, marker: &Marker) -> Option<[Point; 4]> {
        if frame.size() != self.size {
            return None;
        }
        let cells = self.config.dictionary.marker_bits() + 2;
        refine::refine_corners(frame, &marker.corners, cells, &mut self.edge_samples).ok()
    }
}

/// Whether two clockwise outlines are the same one, whichever corner each starts at.
fn same_outline(a: &[Point; 4], b: &[Point; 4]) -> bool {
    (0..4).any(|shift| {
        (0..4)
            .map(|k| (a[k] - b[(k + shift) % 4]).norm())
            .sum::<f64>()
            < 4.0 * SAME_CANDIDATE_PX
    })
}

/// Samples, decodes and (if configured) refines one candidate.
fn decode_candidate(
    frame: &Frame<'_>,
    corners: &[Point; 4],
    cfg: &DetectorConfig,
    edge_samples: &mut Vec<refine::EdgeSample>,
) -> Option<Marker> {
    let dict = cfg.dictionary;
    let bits = grid::read_bits(frame, corners, dict.marker_bits()).ok()?;
    let decoded = dict.decode(bits)?;
    // The grid was sampled from corner 0; the printed top-left is `rotation` corners on.
    let r = usize::from(decoded.rotation);
    let mut ordered = [Point::origin(); 4];
    for (k, o) in ordered.iter_mut().enumerate() {
        *o = corners[(k + r) % 4];
    }
    let refined = if cfg.refine {
        refine::refine_corners(frame, &ordered, dict.marker_bits() + 2, edge_samples).ok()
    } else {
        None
    };
    Some(Marker {
        id: decoded.id,
        corners: refined.unwrap_or(ordered),
        corrected_bits: decoded.corrected_bits,
        refined: refined.is_some(),
    })
}

/// The region clipped to the frame (the whole frame when `None`).
fn clip_roi(roi: Option<Roi>, size: FrameSize) -> Result<Roi, DetectError> {
    let (fw, fh) = (size.width(), size.height());
    let Some(r) = roi else {
        return Ok(Roi {
            x_px: 0,
            y_px: 0,
            width_px: fw,
            height_px: fh,
        });
    };
    let x1 = r.x_px.saturating_add(r.width_px).min(fw);
    let y1 = r.y_px.saturating_add(r.height_px).min(fh);
    if r.x_px >= x1 || r.y_px >= y1 {
        return Err(DetectError::EmptyRoi(r));
    }
    Ok(Roi {
        x_px: r.x_px,
        y_px: r.y_px,
        width_px: x1 - r.x_px,
        height_px: y1 - r.y_px,
    })
}
