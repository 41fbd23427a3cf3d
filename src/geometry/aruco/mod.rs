//! ArUco / AprilTag marker detection on the luma plane of YUYV frames, with sub-pixel corners.
//!
//! Stages, one file each, called in order by [`Detector::detect`]:
//! 1. [`threshold`]: adaptive threshold of the region of interest into a mask;
//! 2. [`contour`]: outer borders of the mask's dark regions;
//! 3. [`quad`]: borders with four straight sides become candidates;
//! 4. [`grid`]: each candidate's cell grid is sampled through its perspective;
//! 5. [`dictionary`]: the bits are decoded in all four rotations, with error correction;
//! 6. [`refine`]: the corners of decoded markers are refined to sub-pixel by edge-line fits.
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
/// Two detections of one id whose centres are closer than this (pixels) are one marker seen
/// twice (e.g. by a second trace of the same border).
const DUPLICATE_CENTRE_PX: f64 = 4.0;

/// Detector settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectorConfig {
    /// The dictionary markers are decoded against.
    pub dictionary: Dictionary,
    /// Half the side of the adaptive threshold's window, in pixels.
    pub threshold_radius_px: usize,
    /// How much darker than the window mean a pixel must be to count as dark (luma levels).
    pub threshold_offset: u8,
    /// Shortest marker side accepted, in pixels.
    pub min_side_px: f64,
    /// Longest marker border traced, in pixels (bounds the work on huge regions).
    pub max_perimeter_px: usize,
    /// Whether corners are refined to sub-pixel (costs a little time per marker found).
    pub refine: bool,
}

impl DetectorConfig {
    /// Defaults for a dictionary, suited to 640×480 webcams.
    pub fn new(dictionary: Dictionary) -> Self {
        DetectorConfig {
            dictionary,
            threshold_radius_px: 7,
            threshold_offset: 7,
            min_side_px: 12.0,
            max_perimeter_px: 4000,
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
        let [a, b, c, d] = self.corners;
        let (r, s) = (c - a, d - b);
        let denom = r.perp(&s);
        if denom.abs() < f64::EPSILON {
            return Point::from((a.coords + b.coords + c.coords + d.coords) / 4.0);
        }
        let t = (b - a).perp(&s) / denom;
        a + r * t
    }
}

/// What the last detection saw, for diagnostics (why a marker was not found).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DetectionStats {
    /// Outer borders long enough to be a marker.
    pub borders: u32,
    /// Borders that were quadrilaterals.
    pub quads: u32,
    /// Borders that touched the frame or region edge (a marker may be cut off).
    pub touching_edge: u32,
    /// Quadrilaterals decoded as markers.
    pub decoded: u32,
    /// Markers beyond [`MAX_MARKERS`], not reported.
    pub dropped: u32,
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

/// A marker detector for one frame size, with all its scratch.
#[derive(Debug)]
pub struct Detector {
    config: DetectorConfig,
    size: FrameSize,
    thresholder: threshold::Thresholder,
    contour: Vec<(i32, i32)>,
    edge_samples: Vec<refine::EdgeSample>,
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
        self.stats = DetectionStats::default();
        let cfg = self.config;
        self.thresholder
            .run(frame, roi, cfg.threshold_radius_px, cfg.threshold_offset);
        let (mask, w, h) = self.thresholder.mask_mut();
        let limits = quad::QuadLimits {
            min_side_px: cfg.min_side_px,
            min_edge_distance_px: MIN_EDGE_DISTANCE_PX,
            width_px: w as i32,
            height_px: h as i32,
        };
        let min_border_len = (4.0 * cfg.min_side_px) as usize;
        let origin = nalgebra::Vector2::new(roi.x_px as f64, roi.y_px as f64);
        let markers = &mut self.markers;
        let stats = &mut self.stats;
        let edge_samples = &mut self.edge_samples;
        contour::trace_borders(mask, w, h, min_border_len, &mut self.contour, |border| {
            stats.borders += 1;
            let quad = match quad::fit_quad(border, &limits) {
                Ok(q) => q,
                Err(quad::Rejection::TouchesEdge) => {
                    stats.touching_edge += 1;
                    return;
                }
                Err(_) => return,
            };
            stats.quads += 1;
            let corners = quad.map(|p| p + origin);
            if let Some(marker) = decode_candidate(frame, &corners, &cfg, edge_samples) {
                stats.decoded += 1;
                let duplicate = markers.iter().any(|m| {
                    m.id == marker.id && (m.centre() - marker.centre()).norm() < DUPLICATE_CENTRE_PX
                });
                if !duplicate && markers.push(marker).is_err() {
                    stats.dropped += 1;
                }
            }
        });
        Ok(&self.markers)
    }
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
