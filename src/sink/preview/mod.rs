//! A live web page for aiming the camera (`glint run --preview`): the frame in grey with the
//! saturation mask tinted, the streak and the recent track drawn over it, and the frame rate.
//!
//! The pipeline must not notice it. The sink copies a frame's luma into a buffer allocated
//! once, at start, and only while a viewer has asked for something in the last few seconds,
//! at most every [`COPY_PERIOD`], and only if the server is not reading the buffer at that
//! moment (`try_lock`: tracking never waits). Encoding and serving happen on other threads
//! (`http`); a slow or vanished client only ever holds up its own connection's thread.
//!
//! The outside world cannot starve it either: the server bounds the whole time a client may
//! take to send its request and to take the answer, the connections per client address and in
//! all (the oldest are shed for newcomers, `clients`), and the size of a request head. Every
//! viewer of a copied frame is sent the same encoded image (`encoded`): memory does not grow
//! with the number of viewers, and an image nobody is being sent is freed.

mod bmp;
mod clients;
mod encoded;
mod http;

use std::io;
use std::net::{SocketAddr, TcpListener};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use heapless::{Deque, Vec as BoundedVec};

use super::Sink;
use crate::frame::{Frame, FrameSize};
use crate::geometry::floor_grid;
use crate::geometry::CameraModel;
use crate::report::FrameReport;

/// How often a frame is copied while someone watches (2 Hz).
pub const COPY_PERIOD: Duration = Duration::from_millis(500);
/// A viewer counts as gone when it has asked for nothing for this long.
const VIEWER_PATIENCE: Duration = Duration::from_secs(5);
/// Positions kept for the drawn track.
pub const TRACK_POINTS: usize = 128;
/// What the page draws: an image position in pixels.
pub type Px = (f32, f32);
/// Connections one client address may hold open; a newer one sheds its oldest.
pub const CONNECTIONS_PER_CLIENT: usize = clients::PER_CLIENT;
/// How long a client has, from its connection being accepted, to send a whole request head.
pub const REQUEST_TIME: Duration = http::REQUEST_TIME;
/// Longest request head read (request line and headers); a longer one is refused with 431.
pub const MAX_HEAD_BYTES: usize = http::MAX_HEAD_BYTES;

/// The last copied frame and what was found in it: what the server encodes.
#[derive(Debug)]
struct Snapshot {
    /// One luma byte per pixel, rows top to bottom; allocated once in [`PreviewSink::start`].
    luma: Vec<u8>,
    /// Everything but the pixels: small, so a request for the state copies only this.
    seen: Seen,
    /// The camera the floor grid in `seen` was drawn through.
    grid_camera: Option<CameraModel>,
}

/// What the page draws and prints about the copied frame.
#[derive(Debug, Clone)]
struct Seen {
    size: FrameSize,
    /// Copies made so far: which frame an encoded image shows. 0: `luma` holds no frame yet.
    copies: u64,
    index: u64,
    t_s: f64,
    threshold_luma: Option<u8>,
    position_px: Option<Px>,
    mid_px: Option<Px>,
    ends_px: Option<[Px; 2]>,
    marker_px: Option<[(f64, f64); 4]>,
    track_px: BoundedVec<Px, TRACK_POINTS>,
    /// Frames per second over the last copy period; `None` until two copies were made.
    fps: Option<f64>,
    /// The floor's 10 cm grid through the calibration's lens and current pose: polylines
    /// separated by [`floor_grid::BREAK`]. Its capacity is allocated once, when a camera is
    /// given ([`PreviewSink::with_floor_camera`]); empty without one.
    grid_px: Vec<Px>,
}

impl Snapshot {
    fn new(size: FrameSize) -> Self {
        Snapshot {
            luma: vec![0; size.pixels()],
            seen: Seen {
                size,
                copies: 0,
                index: 0,
                t_s: 0.0,
                threshold_luma: None,
                position_px: None,
                mid_px: None,
                ends_px: None,
                marker_px: None,
                track_px: BoundedVec::new(),
                fps: None,
                grid_px: Vec::new(),
            },
            grid_camera: None,
        }
    }

    /// Redraws the floor grid when `camera` is not the one it was drawn for (at start, and
    /// after a re-check refitted the pose), into the capacity allocated at start.
    fn draw_grid(&mut self, camera: Option<CameraModel>) {
        if camera == self.grid_camera {
            return;
        }
        match &camera {
            Some(c) => floor_grid::floor_grid_px(c, self.seen.size, &mut self.seen.grid_px),
            None => self.seen.grid_px.clear(),
        }
        self.grid_camera = camera;
    }

    /// Copies the frame's luma (whatever its pixel format) and the report. A frame of
    /// another size fills what overlaps.
    fn fill(&mut self, frame: &Frame<'_>, report: &FrameReport, track: &Deque<Px, TRACK_POINTS>) {
        let width = self.seen.size.width();
        let step = frame.luma_step();
        for (dst, row) in self.luma.chunks_exact_mut(width).zip(frame.luma_rows()) {
            for (d, y) in dst.iter_mut().zip(row.iter().step_by(step)) {
                *d = *y;
            }
        }
        let seen = &mut self.seen;
        seen.copies = seen.copies.saturating_add(1);
        seen.index = report.meta.index;
        seen.t_s = report.t_s();
        seen.threshold_luma = report.detection.levels.threshold_luma;
        seen.position_px = report.position.map(|p| p.position_px);
        seen.mid_px = report.position.map(|p| p.mid_px);
        seen.ends_px = report.detection.best.map(|(_, streak)| streak.ends_px);
        seen.marker_px = report
            .marker
            .map(|m| m.corners_px.map(|corner| (corner.x, corner.y)));
        seen.track_px.clear();
        for p in track {
            // Both hold TRACK_POINTS: never full here.
            let _ = seen.track_px.push(*p);
        }
    }
}

/// State shared by the sink and the server threads.
#[derive(Debug)]
struct Shared {
    /// Start of the clock of `last_request_ms`.
    epoch: Instant,
    /// Milliseconds after `epoch` of the last request, plus one; 0: none yet.
    last_request_ms: AtomicU64,
    snapshot: Mutex<Snapshot>,
    /// The copied frame as an image, shared by every viewer being sent it (server threads only).
    encoded: encoded::Encoded,
    /// The calibration markers' corners (TL, TR, BR, BL), fixed for the whole run: drawn so
    /// the user sees whether the camera still looks where it was calibrated.
    calibration_markers_px: Vec<[Px; 4]>,
}

impl Shared {
    fn note_request(&self) {
        let ms = u64::try_from(self.epoch.elapsed().as_millis()).unwrap_or(u64::MAX);
        self.last_request_ms
            .store(ms.saturating_add(1), Ordering::Relaxed);
    }

    /// Whether someone asked for something within [`VIEWER_PATIENCE`] of `now`.
    fn watched(&self, now: Instant) -> bool {
        match self.last_request_ms.load(Ordering::Relaxed) {
            0 => false,
            stamp => {
                let asked = self.epoch + Duration::from_millis(stamp - 1);
                now.saturating_duration_since(asked) <= VIEWER_PATIENCE
            }
        }
    }

    /// A copy of what was seen in the last copied frame, without its pixels (on a server
    /// thread).
    fn seen(&self) -> Seen {
        self.snapshot
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .seen
            .clone()
    }
}

/// The preview: a sink that hands frames to a small HTTP server.
#[derive(Debug)]
pub struct PreviewSink {
    shared: Arc<Shared>,
    local_addr: SocketAddr,
    /// Recent positions, every frame (not only copied ones).
    track: Deque<Px, TRACK_POINTS>,
    /// When the last copy was made, while watched.
    last_copy: Option<Instant>,
    /// Frames since `last_copy`.
    frames_since_copy: u64,
    /// The calibration's camera as last known: given at start, then as the re-check reports it.
    camera: Option<CameraModel>,
}

impl PreviewSink {
    /// Binds `addr` (port 0: any free port) and starts serving the page for frames of
    /// `size`. The frame buffer is allocated here, once.
    pub fn start(
        addr: SocketAddr,
        size: FrameSize,
        calibration_markers_px: Vec<[Px; 4]>,
    ) -> io::Result<Self> {
        let listener = TcpListener::bind(addr)?;
        let local_addr = listener.local_addr()?;
        let shared = Arc::new(Shared {
            epoch: Instant::now(),
            last_request_ms: AtomicU64::new(0),
            snapshot: Mutex::new(Snapshot::new(size)),
            encoded: encoded::Encoded::new(),
            calibration_markers_px,
        });
        http::spawn(listener, Arc::clone(&shared))?;
        Ok(PreviewSink {
            shared,
            local_addr,
            track: Deque::new(),
            last_copy: None,
            frames_since_copy: 0,
            camera: None,
        })
    }

    /// The same preview drawing the floor's 10 cm grid through `camera` (the calibration's lens
    /// and pose), redrawn whenever a re-check refits the pose. Allocates the grid's buffer.
    pub fn with_floor_camera(mut self, camera: CameraModel) -> Self {
        self.camera = Some(camera);
        let mut snapshot = self
            .shared
            .snapshot
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        snapshot
            .seen
            .grid_px
            .reserve_exact(floor_grid::MAX_GRID_POINTS);
        snapshot.draw_grid(Some(camera));
        drop(snapshot);
        self
    }

    /// Where the page is served.
    pub fn local_addr(&self) -> SocketAddr {
        self.local_addr
    }
}

impl Sink for PreviewSink {
    /// Without the pixels there is nothing to show but the track.
    fn write(&mut self, report: &FrameReport) -> io::Result<()> {
        if let Some(p) = report.position {
            if self.track.is_full() {
                self.track.pop_front();
            }
            let _ = self.track.push_back(p.position_px);
        }
        Ok(())
    }

    fn write_frame(&mut self, frame: &Frame<'_>, report: &FrameReport) -> io::Result<()> {
        self.write(report)?;
        // Only a preview given a camera at start draws the grid (and has room for it).
        if self.camera.is_some() {
            if let Some(camera) = report.calib.and_then(|c| c.camera) {
                self.camera = Some(camera);
            }
        }
        let now = Instant::now();
        if !self.shared.watched(now) {
            self.last_copy = None;
            return Ok(());
        }
        self.frames_since_copy += 1;
        let since = self.last_copy.map(|t| now.saturating_duration_since(t));
        if since.is_some_and(|s| s < COPY_PERIOD) {
            return Ok(());
        }
        // The server is copying the snapshot out: skip this frame rather than wait.
        let Ok(mut snapshot) = self.shared.snapshot.try_lock() else {
            return Ok(());
        };
        snapshot.fill(frame, report, &self.track);
        snapshot.draw_grid(self.camera);
        snapshot.seen.fps = since.map(|s| self.frames_since_copy as f64 / s.as_secs_f64());
        self.last_copy = Some(now);
        self.frames_since_copy = 0;
        Ok(())
    }

    fn finish(&mut self) -> io::Result<()> {
        Ok(())
    }
}
