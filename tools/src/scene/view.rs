//! A real camera in front of the scene: a pinhole over the floor, a lens with Brown–Conrady
//! distortion, markers lying on the floor, an LED at a height, a knock that turns the camera
//! mid-run, and a bump that moves one marker on the floor mid-run.
//!
//! A scene's trajectory, floor texture and glare are drawn in the pixels of a *reference*
//! ideal camera (the pinhole [`MarkerCamera`], no lens). The picture the real camera delivers
//! is made by mapping each of its own pixels back through the lens (undistorted by Newton's
//! method), through the knock's rotation, into the reference camera's pixels, and sampling the
//! scene there: every output pixel is distorted, and nothing is ever undistorted as an image.
//! Both cameras share one centre, so the reference pixels map to the real camera's pixels by
//! rotation and intrinsics alone, whatever the depth of what is seen.
//!
//! The ground truth follows the same formulas forward: a reference pixel goes through the
//! knock and the lens (closed form, as OpenCV's `projectPoints`) to the pixel glint should
//! report, and through the reference camera onto the plane `led_height_cm` above the floor for
//! the floor point under the LED.
//!
//! The distortion is implemented here on its own, independent of glint's camera model, so
//! that tests comparing the two can fail.

use glint::geometry::Point as FloorPoint;

use crate::markers::{Camera as MarkerCamera, PlacedMarker};

use super::floor::Floor;
use super::trajectory::Point;

/// Newton steps when inverting the lens; each step roughly squares the error, so a handful
/// reach machine precision for any lens that is invertible over the picture.
const UNDISTORT_STEPS: usize = 12;
/// Converged when a step moves the normalised point by less than this.
const UNDISTORT_CONVERGED: f64 = 1e-14;
/// Step of the central differences that give the truth's velocity through the lens, px.
const JACOBIAN_STEP_PX: f64 = 1e-3;

/// OpenCV's camera matrix and Brown–Conrady distortion `(k1, k2, p1, p2, k3)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lens {
    /// Focal lengths, px.
    pub fx: f64,
    pub fy: f64,
    /// Principal point, px (pixel centres at integers).
    pub cx: f64,
    pub cy: f64,
    /// Radial coefficients.
    pub k1: f64,
    pub k2: f64,
    pub k3: f64,
    /// Tangential (decentring) coefficients.
    pub p1: f64,
    pub p2: f64,
}

impl Lens {
    /// A distortion-free lens with the reference camera's intrinsics.
    pub fn ideal(camera: &MarkerCamera) -> Lens {
        Lens {
            fx: camera.focal_px,
            fy: camera.focal_px,
            cx: (camera.width_px as f64 - 1.0) / 2.0,
            cy: (camera.height_px as f64 - 1.0) / 2.0,
            k1: 0.0,
            k2: 0.0,
            k3: 0.0,
            p1: 0.0,
            p2: 0.0,
        }
    }

    /// The same intrinsics with radial and tangential distortion.
    pub fn with_distortion(self, k1: f64, k2: f64, k3: f64, p1: f64, p2: f64) -> Lens {
        Lens {
            k1,
            k2,
            k3,
            p1,
            p2,
            ..self
        }
    }

    fn is_finite(&self) -> bool {
        [
            self.fx, self.fy, self.cx, self.cy, self.k1, self.k2, self.k3, self.p1, self.p2,
        ]
        .iter()
        .all(|v| v.is_finite())
    }

    /// OpenCV's model: normalised `(x, y)` to distorted normalised coordinates.
    pub fn distort(&self, x: f64, y: f64) -> (f64, f64) {
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        (
            x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x),
            y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y,
        )
    }

    /// Pixel of a normalised point.
    pub fn project(&self, x: f64, y: f64) -> Point {
        let (xd, yd) = self.distort(x, y);
        Point::new(self.fx * xd + self.cx, self.fy * yd + self.cy)
    }

    /// Normalised point seen at a pixel: Newton's method on the distortion, started from the
    /// distorted point itself. `None` if it does not converge (beyond where the lens folds).
    pub fn unproject(&self, px: Point) -> Option<(f64, f64)> {
        let (xd, yd) = ((px.x - self.cx) / self.fx, (px.y - self.cy) / self.fy);
        let (mut x, mut y) = (xd, yd);
        for _ in 0..UNDISTORT_STEPS {
            let (u, v) = self.distort(x, y);
            let (ru, rv) = (u - xd, v - yd);
            let j = self.jacobian(x, y);
            let det = j[0] * j[3] - j[1] * j[2];
            if !det.is_finite() || det <= 0.0 {
                return None;
            }
            let dx = (j[3] * ru - j[1] * rv) / det;
            let dy = (j[0] * rv - j[2] * ru) / det;
            x -= dx;
            y -= dy;
            if dx.abs().max(dy.abs()) < UNDISTORT_CONVERGED {
                return Some((x, y));
            }
        }
        let (u, v) = self.distort(x, y);
        ((u - xd).hypot(v - yd) < 1e-9).then_some((x, y))
    }

    /// ∂(distorted)/∂(x, y), row-major.
    fn jacobian(&self, x: f64, y: f64) -> [f64; 4] {
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        // d(radial)/d(r²)
        let dradial = self.k1 + r2 * (2.0 * self.k2 + 3.0 * r2 * self.k3);
        let (p1, p2) = (self.p1, self.p2);
        [
            radial + 2.0 * x * x * dradial + 2.0 * p1 * y + 6.0 * p2 * x,
            2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y,
            2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y,
            radial + 2.0 * y * y * dradial + 6.0 * p1 * y + 2.0 * p2 * x,
        ]
    }
}

/// The camera turned at a frame: from frame `frame` on, it looks `pan_deg` further right,
/// `tilt_deg` further down and is rolled `roll_deg` clockwise (as seen in its picture).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Knock {
    pub frame: usize,
    pub pan_deg: f64,
    pub tilt_deg: f64,
    pub roll_deg: f64,
}

impl Knock {
    /// Rotation taking a ray in the reference camera's axes (x right, y down, z forward) to
    /// the same ray in the knocked camera's axes.
    fn rotation(&self) -> [[f64; 3]; 3] {
        let (sp, cp) = self.pan_deg.to_radians().sin_cos();
        let (st, ct) = self.tilt_deg.to_radians().sin_cos();
        let (sr, cr) = self.roll_deg.to_radians().sin_cos();
        // The camera turning by R turns what it sees by Rᵀ: pan about y, tilt about x, roll
        // about z, each inverted.
        let pan = [[cp, 0.0, -sp], [0.0, 1.0, 0.0], [sp, 0.0, cp]];
        let tilt = [[1.0, 0.0, 0.0], [0.0, ct, -st], [0.0, st, ct]];
        let roll = [[cr, sr, 0.0], [-sr, cr, 0.0], [0.0, 0.0, 1.0]];
        mul(&roll, &mul(&tilt, &pan))
    }
}

/// One marker moved on the floor mid-run (kicked, or picked up and put down elsewhere): from
/// frame `frame` on, marker `marker` (an index into [`View::markers`]) lies `dx_cm, dy_cm`
/// further along the floor's axes and is turned `turn_deg` more about its centre. The floor
/// truth is the LED's and does not change; the marker map given to glint (the markers as
/// placed at the start) becomes wrong for that marker.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bump {
    pub frame: usize,
    pub marker: usize,
    pub dx_cm: f64,
    pub dy_cm: f64,
    pub turn_deg: f64,
}

fn mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut out = [[0.0; 3]; 3];
    for (r, row) in out.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| a[r][k] * b[k][c]).sum();
        }
    }
    out
}

fn apply(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
}

fn transpose(m: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    [0, 1, 2].map(|r| [m[0][r], m[1][r], m[2][r]])
}

/// The real camera and what lies on the floor in front of it.
#[derive(Clone, Debug, PartialEq)]
pub struct View {
    /// The reference ideal camera: its pose over the floor, and the pixels the scene's
    /// trajectory, floor texture and glare are given in. Same frame size as the scene.
    pub camera: MarkerCamera,
    /// The real camera's lens (intrinsics and distortion).
    pub lens: Lens,
    /// Height of the LED above the floor, cm (the floor truth is the point under it).
    pub led_height_cm: f64,
    /// A knock mid-run, if any.
    pub knock: Option<Knock>,
    /// A marker moved mid-run, if any.
    pub bump: Option<Bump>,
    /// Markers on the floor, each on white paper (as placed at the start).
    pub markers: Vec<PlacedMarker>,
}

/// Paper margin around each marker, in cells of that marker (as the marker renderer's).
const PAPER_MARGIN_CELLS: f64 = 1.5;
/// Marker ink and paper, in linear sensor units (1.0 = clip): the paper well below clip, as
/// under an exposure set short for the LED (with its glow and noise it must never saturate).
const MARKER_BLACK: f64 = 0.05;
const MARKER_WHITE: f64 = 0.6;

impl View {
    /// Checks the view against the scene's frame size.
    pub(crate) fn validate(&self, width_px: u32, height_px: u32) -> Result<(), &'static str> {
        if self.camera.width_px != width_px as usize || self.camera.height_px != height_px as usize
        {
            return Err("the view's camera must have the scene's frame size");
        }
        let c = &self.camera;
        let finite = c.focal_px.is_finite()
            && c.focal_px > 0.0
            && c.position_cm
                .iter()
                .chain(&c.look_at_cm)
                .all(|v| v.is_finite())
            && c.position_cm[2] > 0.0;
        if !finite || !self.lens.is_finite() || self.lens.fx <= 0.0 || self.lens.fy <= 0.0 {
            return Err(
                "camera and lens must be finite, focal lengths positive, camera above the floor",
            );
        }
        if !(self.led_height_cm.is_finite()
            && self.led_height_cm >= 0.0
            && self.led_height_cm < c.position_cm[2])
        {
            return Err("led_height_cm must be at least 0 and below the camera");
        }
        let markers_ok = self.markers.iter().all(|m| {
            m.size_cm.is_finite()
                && m.size_cm > 0.0
                && m.origin_cm.x.is_finite()
                && m.origin_cm.y.is_finite()
        });
        if !markers_ok {
            return Err("markers must have a positive size and a finite position");
        }
        if let Some(b) = self.bump {
            if b.marker >= self.markers.len()
                || ![b.dx_cm, b.dy_cm, b.turn_deg].iter().all(|v| v.is_finite())
            {
                return Err("a bump must move one of the view's markers by a finite amount");
            }
        }
        // Every pixel of the picture must see through the lens.
        let (w, h) = (width_px as f64, height_px as f64);
        for (x, y) in [
            (-0.5, -0.5),
            (w - 0.5, -0.5),
            (-0.5, h - 0.5),
            (w - 0.5, h - 0.5),
        ] {
            if self.lens.unproject(Point::new(x, y)).is_none() {
                return Err("the lens folds over inside the picture");
            }
        }
        Ok(())
    }

    /// The rotation in force at `frame` (reference axes → camera axes), if any.
    fn rotation_at(&self, frame: usize) -> Option<[[f64; 3]; 3]> {
        self.knock
            .filter(|k| frame >= k.frame)
            .map(|k| k.rotation())
    }

    /// How many poses the camera takes over the run (1, or 2 with a knock).
    fn pose_count(&self) -> usize {
        1 + usize::from(self.knock.is_some())
    }

    /// The pose index at `frame`.
    fn pose_at(&self, frame: usize) -> usize {
        usize::from(self.knock.is_some_and(|k| frame >= k.frame))
    }

    /// How many static pictures the run has: one per pose, each with the markers as placed
    /// and, with a bump, as moved.
    pub(crate) fn image_count(&self) -> usize {
        self.pose_count() * (1 + usize::from(self.bump.is_some()))
    }

    /// The static picture's index at `frame`: its pose, plus [`View::pose_count`] once the
    /// marker is bumped.
    pub(crate) fn image_at(&self, frame: usize) -> usize {
        let bumped = self.bump.is_some_and(|b| frame >= b.frame);
        self.pose_at(frame) + self.pose_count() * usize::from(bumped)
    }

    /// The markers on the floor in static picture `image`.
    fn markers_in(&self, image: usize) -> Vec<PlacedMarker> {
        let mut markers = self.markers.clone();
        if let Some(b) = self.bump.filter(|_| image >= self.pose_count()) {
            if let Some(m) = markers.get_mut(b.marker) {
                m.origin_cm = FloorPoint::new(m.origin_cm.x + b.dx_cm, m.origin_cm.y + b.dy_cm);
                m.rotation_deg += b.turn_deg;
            }
        }
        markers
    }

    fn pose_rotation(&self, pose: usize) -> Option<[[f64; 3]; 3]> {
        (pose > 0)
            .then(|| self.knock.map(|k| k.rotation()))
            .flatten()
    }

    fn principal(&self) -> (f64, f64) {
        (
            (self.camera.width_px as f64 - 1.0) / 2.0,
            (self.camera.height_px as f64 - 1.0) / 2.0,
        )
    }

    /// Output pixel of a reference pixel at `frame`, or `None` behind the camera.
    pub fn to_output(&self, reference_px: Point, frame: usize) -> Option<Point> {
        self.to_output_in(reference_px, self.rotation_at(frame))
    }

    fn to_output_in(&self, reference_px: Point, rotation: Option<[[f64; 3]; 3]>) -> Option<Point> {
        let (cx, cy) = self.principal();
        let f = self.camera.focal_px;
        let ray = [(reference_px.x - cx) / f, (reference_px.y - cy) / f, 1.0];
        let ray = match rotation {
            Some(r) => apply(&r, ray),
            None => ray,
        };
        if ray[2] <= 0.0 {
            return None;
        }
        Some(self.lens.project(ray[0] / ray[2], ray[1] / ray[2]))
    }

    /// Reference pixel seen at an output pixel in pose `pose`.
    pub(crate) fn to_reference(&self, output_px: Point, pose: usize) -> Option<Point> {
        let (x, y) = self.lens.unproject(output_px)?;
        let ray = match self.pose_rotation(pose) {
            Some(r) => apply(&transpose(&r), [x, y, 1.0]),
            None => [x, y, 1.0],
        };
        if ray[2] <= 0.0 {
            return None;
        }
        let (cx, cy) = self.principal();
        let f = self.camera.focal_px;
        Some(Point::new(
            cx + f * ray[0] / ray[2],
            cy + f * ray[1] / ray[2],
        ))
    }

    /// An output velocity from a reference velocity at a reference position (chain rule by
    /// central differences of the forward mapping).
    pub(crate) fn velocity_to_output(&self, at: Point, v: Point, frame: usize) -> Option<Point> {
        let h = JACOBIAN_STEP_PX;
        let d = |dx: f64, dy: f64| -> Option<Point> {
            let a = self.to_output(Point::new(at.x - dx, at.y - dy), frame)?;
            let b = self.to_output(Point::new(at.x + dx, at.y + dy), frame)?;
            Some(Point::new((b.x - a.x) / (2.0 * h), (b.y - a.y) / (2.0 * h)))
        };
        let (jx, jy) = (d(h, 0.0)?, d(0.0, h)?);
        Some(Point::new(jx.x * v.x + jy.x * v.y, jx.y * v.x + jy.y * v.y))
    }

    /// Floor point (cm) under an LED seen at a reference pixel, or `None` at or above the
    /// LED plane's horizon.
    pub fn floor_under(&self, reference_px: Point) -> Option<FloorPoint> {
        self.camera.unproject_at_height(
            FloorPoint::new(reference_px.x, reference_px.y),
            self.led_height_cm,
        )
    }

    /// The `glint calibrate --marker ID:SIZE_CM@X,Y` arguments for the view's markers.
    pub fn marker_args(&self) -> Vec<String> {
        self.markers
            .iter()
            .map(|m| format!("{}:{}@{},{}", m.id, m.size_cm, m.origin_cm.x, m.origin_cm.y))
            .collect()
    }

    /// The floor point (cm) under the LED's plane seen at a picture pixel at `frame`: the truth
    /// for a position glint reports, whatever its pixel error.
    pub fn floor_seen_at(&self, output_px: Point, frame: usize) -> Option<FloorPoint> {
        self.floor_under(self.to_reference(output_px, self.pose_at(frame))?)
    }

    /// Radiance of a reference pixel if one of `markers` or its paper covers what it sees.
    fn marker_radiance(&self, markers: &[PlacedMarker], reference_px: Point) -> Option<f64> {
        if markers.is_empty() {
            return None;
        }
        let floor = self
            .camera
            .unproject(FloorPoint::new(reference_px.x, reference_px.y))?;
        crate::markers::albedo_of(
            markers,
            PAPER_MARGIN_CELLS,
            floor,
            MARKER_BLACK,
            MARKER_WHITE,
        )
    }
}

/// Samples over a pixel that a marker's edge crosses (a Hammersley set: every sample has its
/// own row and column, so an edge along the pixel grid is placed to 1/64 px).
const EDGE_SAMPLES: usize = 64;
/// Radiance differences between a pixel's corners below this are smooth floor shading.
const FLAT_TOLERANCE: f64 = 0.02;

/// What the camera sees of everything that does not move, in one pose.
#[derive(Clone, Debug)]
pub(crate) struct PoseImage {
    /// Radiance of every output pixel, row-major.
    pub radiance: Vec<f32>,
    /// Reference pixel seen at each output pixel's centre (NaN where nothing is seen).
    pub reference_px: Vec<[f32; 2]>,
    /// Smallest and largest reference coordinates seen, for the LED's patch.
    pub reference_min: Point,
    pub reference_max: Point,
}

impl View {
    /// Radiance of the floor (or one of `markers` on it) seen at a reference pixel, and
    /// whether a marker (or its paper) was seen.
    fn radiance_at(
        &self,
        floor: &Floor,
        markers: &[PlacedMarker],
        seed: u64,
        r: Point,
    ) -> (f64, bool) {
        match self.marker_radiance(markers, r) {
            Some(v) => (v, true),
            None => (floor.radiance(r.x, r.y, seed), false),
        }
    }

    /// Static picture `image` (see [`View::image_at`]): each output pixel is the average of
    /// the scene over the pixel's area as seen through the lens (corners mapped exactly; inside
    /// a pixel the mapping is bilinear, which the lens is to far below a thousandth of a
    /// pixel).
    pub(crate) fn render_static(
        &self,
        floor: &Floor,
        seed: u64,
        width: usize,
        height: usize,
        image: usize,
    ) -> PoseImage {
        let pose = image % self.pose_count();
        let markers = self.markers_in(image);
        let nan = Point::new(f64::NAN, f64::NAN);
        let corners: Vec<Point> = (0..=height)
            .flat_map(|y| (0..=width).map(move |x| (x, y)))
            .map(|(x, y)| {
                self.to_reference(Point::new(x as f64 - 0.5, y as f64 - 0.5), pose)
                    .unwrap_or(nan)
            })
            .collect();
        let corner_values: Vec<(f64, bool)> = corners
            .iter()
            .map(|&r| {
                if r.is_finite() {
                    self.radiance_at(floor, &markers, seed, r)
                } else {
                    (0.0, false)
                }
            })
            .collect();
        let mut radiance = Vec::with_capacity(width * height);
        let mut reference_px = Vec::with_capacity(width * height);
        let (mut lo, mut hi) = (
            Point::new(f64::MAX, f64::MAX),
            Point::new(f64::MIN, f64::MIN),
        );
        for y in 0..height {
            for x in 0..width {
                let at = |dx: usize, dy: usize| (y + dy) * (width + 1) + x + dx;
                let idx = [at(0, 0), at(1, 0), at(0, 1), at(1, 1)];
                let quad = idx.map(|i| corners.get(i).copied().unwrap_or(nan));
                let values = idx.map(|i| corner_values.get(i).copied().unwrap_or((0.0, false)));
                let (vmin, vmax) = values
                    .iter()
                    .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v.0), b.max(v.0)));
                let any_marker = values.iter().any(|v| v.1);
                let all_seen = quad.iter().all(|p| p.is_finite());
                let value = if !all_seen {
                    0.0
                } else if any_marker && vmax - vmin >= FLAT_TOLERANCE {
                    let mut sum = 0.0;
                    for k in 0..EDGE_SAMPLES {
                        let (fx, fy) = hammersley(k);
                        let top = lerp(quad[0], quad[1], fx);
                        let bottom = lerp(quad[2], quad[3], fx);
                        sum += self
                            .radiance_at(floor, &markers, seed, lerp(top, bottom, fy))
                            .0;
                    }
                    sum / EDGE_SAMPLES as f64
                } else {
                    0.25 * values.iter().map(|v| v.0).sum::<f64>()
                };
                radiance.push(value as f32);
                let centre = self
                    .to_reference(Point::new(x as f64, y as f64), pose)
                    .unwrap_or(nan);
                if centre.is_finite() {
                    lo = Point::new(lo.x.min(centre.x), lo.y.min(centre.y));
                    hi = Point::new(hi.x.max(centre.x), hi.y.max(centre.y));
                }
                reference_px.push([centre.x as f32, centre.y as f32]);
            }
        }
        PoseImage {
            radiance,
            reference_px,
            reference_min: lo,
            reference_max: hi,
        }
    }
}

fn lerp(a: Point, b: Point, t: f64) -> Point {
    Point::new(a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t)
}

/// Sample `k` of [`EDGE_SAMPLES`] in the unit square: x evenly spaced, y bit-reversed.
fn hammersley(k: usize) -> (f64, f64) {
    let n = EDGE_SAMPLES as f64;
    let reversed = f64::from((k as u8).reverse_bits() >> 2);
    ((k as f64 + 0.5) / n, (reversed + 0.5) / n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::markers::reference_camera;

    fn wide() -> Lens {
        Lens::ideal(&reference_camera()).with_distortion(-0.30, 0.09, 0.0, 0.001, -0.0005)
    }

    #[test]
    fn distortion_is_opencvs_formula() {
        // A point worked by hand from OpenCV's documented model.
        let lens = Lens {
            fx: 500.0,
            fy: 510.0,
            cx: 320.0,
            cy: 240.0,
            k1: -0.3,
            k2: 0.09,
            k3: 0.01,
            p1: 0.001,
            p2: -0.002,
        };
        let (x, y) = (0.4, -0.3);
        let r2: f64 = 0.25;
        let radial = 1.0 - 0.3 * r2 + 0.09 * r2 * r2 + 0.01 * r2 * r2 * r2;
        let xd = x * radial + 2.0 * 0.001 * x * y - 0.002 * (r2 + 2.0 * x * x);
        let yd = y * radial + 0.001 * (r2 + 2.0 * y * y) + 2.0 * -0.002 * x * y;
        let p = lens.project(x, y);
        assert!((p.x - (500.0 * xd + 320.0)).abs() < 1e-12);
        assert!((p.y - (510.0 * yd + 240.0)).abs() < 1e-12);
    }

    #[test]
    fn unproject_inverts_project_over_the_picture() {
        let lens = wide();
        for py in (0..480).step_by(40) {
            for px in (0..640).step_by(40) {
                let (x, y) = lens.unproject(Point::new(px as f64, py as f64)).unwrap();
                let back = lens.project(x, y);
                assert!((back.x - px as f64).abs() < 1e-9 && (back.y - py as f64).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn a_bump_moves_one_marker_from_its_frame_on() {
        let placed = |x: f64| PlacedMarker {
            dictionary: glint::detect::aruco::Dictionary::Aruco6x6_250,
            id: 3,
            size_cm: 18.0,
            origin_cm: FloorPoint::new(x, 10.0),
            rotation_deg: 0.0,
        };
        let view = View {
            camera: reference_camera(),
            lens: wide(),
            led_height_cm: 0.0,
            knock: Some(Knock {
                frame: 10,
                pan_deg: 0.0,
                tilt_deg: 0.8,
                roll_deg: 0.0,
            }),
            bump: Some(Bump {
                frame: 20,
                marker: 1,
                dx_cm: 4.0,
                dy_cm: -3.0,
                turn_deg: 10.0,
            }),
            markers: vec![placed(-40.0), placed(40.0)],
        };
        assert_eq!(view.image_count(), 4);
        let images = [9, 10, 19, 20, 99].map(|f| view.image_at(f));
        assert_eq!(images, [0, 1, 1, 3, 3]);
        for image in [0, 1] {
            assert_eq!(view.markers_in(image), view.markers);
        }
        let moved = view.markers_in(3);
        assert_eq!(moved[0], view.markers[0]);
        assert_eq!(moved[1].origin_cm, FloorPoint::new(44.0, 7.0));
        assert_eq!(moved[1].rotation_deg, 10.0);
    }

    #[test]
    fn a_knock_moves_the_picture_and_comes_back_exactly() {
        let view = View {
            camera: reference_camera(),
            lens: wide(),
            led_height_cm: 0.0,
            knock: Some(Knock {
                frame: 10,
                pan_deg: 0.0,
                tilt_deg: 0.8,
                roll_deg: 0.3,
            }),
            bump: None,
            markers: Vec::new(),
        };
        let p = Point::new(400.0, 300.0);
        let before = view.to_output(p, 9).unwrap();
        let after = view.to_output(p, 10).unwrap();
        // 0.8° of tilt at 460 px focal length is about 6 px: the scene moves up the picture.
        assert!(after.y < before.y - 4.0, "{before:?} {after:?}");
        for (out, pose) in [(before, 0), (after, 1)] {
            let back = view.to_reference(out, pose).unwrap();
            assert!((back.x - p.x).abs() < 1e-8 && (back.y - p.y).abs() < 1e-8);
        }
    }
}
