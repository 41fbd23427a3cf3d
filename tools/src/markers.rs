//! Rendered marker scenes with exact ground truth, for testing glint's marker detector and
//! floor calibration.
//!
//! A pinhole camera (no lens distortion) looks obliquely down at the floor plane `z = 0`, on
//! which square markers lie, each printed on white paper. Every pixel is the area average of
//! what it sees (pixel `(x, y)` covers `[x − ½, x + ½] × [y − ½, y + ½]`, so pixel centres sit at
//! integer coordinates as in OpenCV): a pixel whose four corners see the same brightness takes
//! that brightness (a straight edge through a pixel always separates its corners), any other
//! pixel is supersampled at 256 well-spread points. Optional extras: Gaussian noise, studio-range
//! output (luma 16..235), a shadow over a half-plane of the floor, and a textured floor.
//!
//! Floor coordinates are centimetres on a map of the floor seen from above, x to the right and y
//! down the map (as in an image, and as in the seed's floor corners), so a marker whose printed
//! top-left corner is at `origin_cm`, top edge along +x and left edge along +y, is seen as printed,
//! not mirrored. In 3-D this is a right-handed frame whose z axis points down into the floor; the
//! camera's height above the floor is given as a positive number.

use glint::detect::aruco::Dictionary;
use glint::geometry::{MarkerPlacement, Point};

/// Samples for a pixel that straddles an edge. They form a Hammersley set: every sample has
/// its own row and its own column, so an edge parallel to the pixel grid is measured to
/// 1/256 of a pixel (a square 16 × 16 grid would quantise it to 1/16).
const EDGE_SAMPLES: usize = 256;
/// Brightness differences between a pixel's corners below this are treated as flat shading.
const FLAT_TOLERANCE: f64 = 0.02;

/// A pinhole camera: position (floor x, floor y, height above the floor) and the floor point it
/// looks at, in cm; focal length in pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub width_px: usize,
    pub height_px: usize,
    pub focal_px: f64,
    pub position_cm: [f64; 3],
    pub look_at_cm: [f64; 3],
}

type V3 = [f64; 3];

fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn unit(a: V3) -> V3 {
    let n = dot(a, a).sqrt();
    [a[0] / n, a[1] / n, a[2] / n]
}

impl Camera {
    /// The camera centre in the 3-D frame (z down into the floor).
    fn centre(&self) -> V3 {
        let [x, y, height] = self.position_cm;
        [x, y, -height]
    }

    /// Camera axes in the 3-D frame: right, down (image x and y), forward.
    fn axes(&self) -> (V3, V3, V3) {
        let forward = unit(sub(self.look_at_cm, self.centre()));
        let up = [0.0, 0.0, -1.0];
        let right = unit(cross(forward, up));
        let down = cross(forward, right);
        (right, down, forward)
    }

    fn principal_point(&self) -> (f64, f64) {
        (
            (self.width_px as f64 - 1.0) / 2.0,
            (self.height_px as f64 - 1.0) / 2.0,
        )
    }

    /// Image position of a floor point, or `None` if it is behind the camera.
    pub fn project(&self, floor_cm: Point) -> Option<Point> {
        let (right, down, forward) = self.axes();
        let v = sub([floor_cm.x, floor_cm.y, 0.0], self.centre());
        let z = dot(v, forward);
        if z <= 0.0 {
            return None;
        }
        let (cx, cy) = self.principal_point();
        Some(Point::new(
            cx + self.focal_px * dot(v, right) / z,
            cy + self.focal_px * dot(v, down) / z,
        ))
    }

    /// Floor point seen at an image position, or `None` at or above the horizon.
    pub fn unproject(&self, image_px: Point) -> Option<Point> {
        self.unproject_at_height(image_px, 0.0)
    }

    /// Floor point under the point `height_cm` above the floor seen at an image position, or
    /// `None` at or above that plane's horizon.
    pub fn unproject_at_height(&self, image_px: Point, height_cm: f64) -> Option<Point> {
        let (right, down, forward) = self.axes();
        let (cx, cy) = self.principal_point();
        let (a, b) = (
            (image_px.x - cx) / self.focal_px,
            (image_px.y - cy) / self.focal_px,
        );
        let dir = [
            forward[0] + a * right[0] + b * down[0],
            forward[1] + a * right[1] + b * down[1],
            forward[2] + a * right[2] + b * down[2],
        ];
        if dir[2] <= 0.0 {
            return None;
        }
        let t = (self.position_cm[2] - height_cm) / dir[2];
        Some(Point::new(
            self.position_cm[0] + t * dir[0],
            self.position_cm[1] + t * dir[1],
        ))
    }

    /// Whether an image position is inside the frame.
    pub fn in_frame(&self, p: Point) -> bool {
        p.x >= 0.0
            && p.y >= 0.0
            && p.x <= self.width_px as f64 - 1.0
            && p.y <= self.height_px as f64 - 1.0
    }
}

/// A marker lying on the floor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlacedMarker {
    pub dictionary: Dictionary,
    pub id: u16,
    /// Side of the black square, in cm.
    pub size_cm: f64,
    /// Floor position of the printed top-left corner before any rotation, in cm.
    pub origin_cm: Point,
    /// The marker turned about its centre by this angle, from +x towards +y (0: the printed
    /// top edge runs along +x). A robot carrying a marker turns it; calibration markers lie
    /// square to the floor map.
    pub rotation_deg: f64,
}

impl PlacedMarker {
    /// Floor corners: top-left, top-right, bottom-right, bottom-left as printed.
    pub fn corners_cm(&self) -> [Point; 4] {
        let (o, s) = (self.origin_cm, self.size_cm);
        [
            o,
            Point::new(o.x + s, o.y),
            Point::new(o.x + s, o.y + s),
            Point::new(o.x, o.y + s),
        ]
        .map(|p| self.turn(p, self.rotation_deg))
    }

    /// The marker's centre on the floor.
    pub fn centre_cm(&self) -> Point {
        let half = 0.5 * self.size_cm;
        Point::new(self.origin_cm.x + half, self.origin_cm.y + half)
    }

    /// `p` turned about the centre by `deg`, from +x towards +y.
    fn turn(&self, p: Point, deg: f64) -> Point {
        let c = self.centre_cm();
        let (sin, cos) = deg.to_radians().sin_cos();
        let d = p - c;
        Point::new(c.x + cos * d.x - sin * d.y, c.y + sin * d.x + cos * d.y)
    }

    /// The placement glint's calibration takes (calibration markers are not rotated).
    pub fn placement(&self) -> MarkerPlacement {
        MarkerPlacement {
            id: self.id,
            size: self.size_cm,
            origin: self.origin_cm,
        }
    }

    /// Reflectance at a floor point if the marker (not its paper) covers it.
    fn albedo(&self, p: Point, black: f64, white: f64) -> Option<f64> {
        let p = self.turn(p, -self.rotation_deg);
        let cells = self.dictionary.marker_bits() + 2;
        let cell_cm = self.size_cm / cells as f64;
        let (u, v) = (
            (p.x - self.origin_cm.x) / cell_cm,
            (p.y - self.origin_cm.y) / cell_cm,
        );
        if u < 0.0 || v < 0.0 || u >= cells as f64 || v >= cells as f64 {
            return None;
        }
        let (col, row) = (u as usize, v as usize);
        if row == 0 || col == 0 || row == cells - 1 || col == cells - 1 {
            return Some(black);
        }
        let white_cell = self.dictionary.is_white(self.id, row - 1, col - 1)?;
        Some(if white_cell { white } else { black })
    }
}

/// Reflectance at a floor point if one of `markers` or its paper (a margin of
/// `paper_margin_cells` cells round it) covers the point.
pub(crate) fn albedo_of(
    markers: &[PlacedMarker],
    paper_margin_cells: f64,
    p: Point,
    black: f64,
    white: f64,
) -> Option<f64> {
    let mut albedo = None;
    for m in markers {
        if let Some(a) = m.albedo(p, black, white) {
            return Some(a);
        }
        let cells = m.dictionary.marker_bits() as f64 + 2.0;
        let margin_cm = paper_margin_cells * m.size_cm / cells;
        let local = m.turn(p, -m.rotation_deg);
        let (u, v) = (local.x - m.origin_cm.x, local.y - m.origin_cm.y);
        let on_paper = (-margin_cm..m.size_cm + margin_cm).contains(&u)
            && (-margin_cm..m.size_cm + margin_cm).contains(&v);
        if on_paper {
            albedo = Some(white);
        }
    }
    albedo
}

/// What the floor looks like away from the markers.
#[derive(Debug, Clone, Copy)]
pub enum Floor {
    /// One uniform reflectance.
    Plain(f64),
    /// Tiles with dark grout, smooth mottling and dark specks: many false marker candidates.
    Textured { seed: u64 },
}

/// A shadow: the floor on the left of the directed line through `point_cm` along
/// `direction_cm` gets `factor` of the light.
#[derive(Debug, Clone, Copy)]
pub struct Shadow {
    pub point_cm: Point,
    pub direction_cm: Point,
    pub factor: f64,
}

/// A complete scene.
#[derive(Debug, Clone)]
pub struct MarkerScene {
    pub camera: Camera,
    pub markers: Vec<PlacedMarker>,
    /// White paper around each marker, in cells of that marker.
    pub paper_margin_cells: f64,
    pub floor: Floor,
    pub black: f64,
    pub white: f64,
    pub shadow: Option<Shadow>,
    /// Map output to luma 16..235, as many webcams do.
    pub studio_range: bool,
    /// Standard deviation of additive noise, in luma levels.
    pub noise_sigma: f64,
    pub noise_seed: u64,
}

impl MarkerScene {
    /// A plain scene: one camera, these markers, grey floor, mild noise.
    pub fn new(camera: Camera, markers: Vec<PlacedMarker>) -> Self {
        MarkerScene {
            camera,
            markers,
            paper_margin_cells: 1.5,
            floor: Floor::Plain(0.45),
            black: 0.05,
            white: 0.85,
            shadow: None,
            studio_range: false,
            noise_sigma: 2.0,
            noise_seed: 1,
        }
    }

    /// Ground-truth image corners of marker `index`, OpenCV's order.
    pub fn corners_px(&self, index: usize) -> Option<[Point; 4]> {
        let m = self.markers.get(index)?;
        let c = m.corners_cm();
        Some([
            self.camera.project(c[0])?,
            self.camera.project(c[1])?,
            self.camera.project(c[2])?,
            self.camera.project(c[3])?,
        ])
    }

    /// Brightness (0..1) of the floor point, shadow included.
    fn radiance(&self, p: Point) -> f64 {
        let albedo = albedo_of(
            &self.markers,
            self.paper_margin_cells,
            p,
            self.black,
            self.white,
        );
        let albedo = albedo.unwrap_or_else(|| floor_albedo(self.floor, p));
        let light = match self.shadow {
            Some(s) => {
                let d = p - s.point_cm;
                if s.direction_cm.coords.perp(&d) < 0.0 {
                    s.factor
                } else {
                    1.0
                }
            }
            None => 1.0,
        };
        albedo * light
    }

    /// Luma image, row-major, `width × height` bytes.
    pub fn render_luma(&self) -> Vec<u8> {
        let (w, h) = (self.camera.width_px, self.camera.height_px);
        let mut rng = XorShift(self.noise_seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
        let see = |x: f64, y: f64| {
            self.camera
                .unproject(Point::new(x, y))
                .map_or(0.0, |p| self.radiance(p))
        };
        let mut out = Vec::with_capacity(w * h);
        for y in 0..h {
            for x in 0..w {
                let (x0, y0) = (x as f64 - 0.5, y as f64 - 0.5);
                let corners = [
                    see(x0, y0),
                    see(x0 + 1.0, y0),
                    see(x0, y0 + 1.0),
                    see(x0 + 1.0, y0 + 1.0),
                ];
                let (lo, hi) = corners
                    .iter()
                    .fold((f64::MAX, f64::MIN), |(l, h), &c| (l.min(c), h.max(c)));
                let value = if hi - lo < FLAT_TOLERANCE {
                    0.25 * corners.iter().sum::<f64>()
                } else {
                    let mut sum = 0.0;
                    for k in 0..EDGE_SAMPLES {
                        let (fx, fy) = hammersley(k);
                        sum += see(x0 + fx, y0 + fy);
                    }
                    sum / EDGE_SAMPLES as f64
                };
                let mut luma = 255.0 * value;
                if self.studio_range {
                    luma = 16.0 + luma * (219.0 / 255.0);
                }
                luma += self.noise_sigma * rng.gaussian();
                out.push(luma.round().clamp(0.0, 255.0) as u8);
            }
        }
        out
    }

    /// Packed YUYV frame (chroma neutral), `2 × width × height` bytes.
    pub fn render_yuyv(&self) -> Vec<u8> {
        self.render_luma().iter().flat_map(|&l| [l, 128]).collect()
    }
}

/// Sample `k` of [`EDGE_SAMPLES`] in the unit square: x evenly spaced, y the bit-reversed index.
fn hammersley(k: usize) -> (f64, f64) {
    let n = EDGE_SAMPLES as f64;
    let reversed = (k as u8).reverse_bits();
    ((k as f64 + 0.5) / n, (f64::from(reversed) + 0.5) / n)
}

/// Reflectance of the floor itself.
fn floor_albedo(floor: Floor, p: Point) -> f64 {
    match floor {
        Floor::Plain(a) => a,
        Floor::Textured { seed } => {
            const TILE_CM: f64 = 30.0;
            const GROUT_CM: f64 = 0.8;
            const SPECK_CM: f64 = 1.5;
            let (tx, ty) = (p.x.rem_euclid(TILE_CM), p.y.rem_euclid(TILE_CM));
            if tx < GROUT_CM || ty < GROUT_CM {
                return 0.2;
            }
            // Dark specks on a coarse lattice, some of them; smooth mottling elsewhere.
            let (sx, sy) = ((p.x / SPECK_CM).floor(), (p.y / SPECK_CM).floor());
            let h = hash(seed, sx as i64, sy as i64);
            let (fx, fy) = (p.x / SPECK_CM - sx - 0.5, p.y / SPECK_CM - sy - 0.5);
            if h < 0.08 && fx * fx + fy * fy < 0.12 {
                return 0.15;
            }
            let mottle = value_noise(seed, p.x / 7.0, p.y / 7.0);
            0.4 + 0.25 * mottle
        }
    }
}

fn hash(seed: u64, x: i64, y: i64) -> f64 {
    let mut v = seed
        ^ (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    v ^= v >> 31;
    v = v.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    v ^= v >> 29;
    (v >> 11) as f64 / (1u64 << 53) as f64
}

fn value_noise(seed: u64, x: f64, y: f64) -> f64 {
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (sx, sy) = (fx * fx * (3.0 - 2.0 * fx), fy * fy * (3.0 - 2.0 * fy));
    let (i, j) = (x0 as i64, y0 as i64);
    let top = hash(seed, i, j) * (1.0 - sx) + hash(seed, i + 1, j) * sx;
    let bottom = hash(seed, i, j + 1) * (1.0 - sx) + hash(seed, i + 1, j + 1) * sx;
    top * (1.0 - sy) + bottom * sy
}

/// A small deterministic generator, so scenes render the same on every machine.
struct XorShift(u64);

impl XorShift {
    fn next_f64(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    /// Standard normal, by Box-Muller.
    fn gaussian(&mut self) -> f64 {
        let (u, v) = (self.next_f64(), self.next_f64());
        (-2.0 * u.ln()).sqrt() * (2.0 * core::f64::consts::PI * v).cos()
    }
}

/// The camera of the accuracy targets: 640×480, about 70° wide, 1.3 m up and 0.8 m back from a
/// 20 cm marker whose top-left corner is at the floor origin (1.53 m from the marker's centre),
/// looking obliquely down so that a 1.6 m × 1.4 m area centred on the marker,
/// x −70..90 cm, y −60..80 cm, is all in view.
pub fn reference_camera() -> Camera {
    Camera {
        width_px: 640,
        height_px: 480,
        focal_px: 460.0,
        position_cm: [10.0, -70.0, 130.0],
        look_at_cm: [10.0, -5.0, 0.0],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_and_unprojection_agree() {
        let cam = reference_camera();
        for p in [
            Point::new(0.0, 0.0),
            Point::new(-70.0, 90.0),
            Point::new(55.0, -20.0),
        ] {
            let q = cam.project(p).unwrap();
            let back = cam.unproject(q).unwrap();
            assert!((back - p).norm() < 1e-9);
        }
        // The reference marker is about 1.5 m from the camera.
        let d = sub([10.0, 10.0, 0.0], cam.centre());
        let dist = dot(d, d).sqrt();
        assert!((140.0..160.0).contains(&dist), "{dist}");
    }

    #[test]
    fn a_quarter_turn_moves_each_corner_to_the_next() {
        let mut m = PlacedMarker {
            dictionary: Dictionary::Aruco4x4_50,
            id: 0,
            size_cm: 20.0,
            origin_cm: Point::new(5.0, -3.0),
            rotation_deg: 0.0,
        };
        let square = m.corners_cm();
        m.rotation_deg = 90.0;
        let turned = m.corners_cm();
        for k in 0..4 {
            assert!((turned[k] - square[(k + 1) % 4]).norm() < 1e-9, "{k}");
        }
        assert!((m.centre_cm() - Point::new(15.0, 7.0)).norm() < 1e-12);
    }

    #[test]
    fn a_marker_renders_black_border_on_white_paper() {
        let m = PlacedMarker {
            dictionary: Dictionary::Aruco4x4_50,
            id: 0,
            size_cm: 20.0,
            origin_cm: Point::new(0.0, 0.0),
            rotation_deg: 0.0,
        };
        let mut scene = MarkerScene::new(reference_camera(), vec![m]);
        scene.noise_sigma = 0.0;
        let luma = scene.render_luma();
        let at = |p: Point| {
            let q = scene.camera.project(p).unwrap();
            luma[q.y.round() as usize * 640 + q.x.round() as usize]
        };
        let cell = 20.0 / 6.0;
        assert_eq!(
            at(Point::new(0.5 * cell, 0.5 * cell)),
            (255.0f64 * 0.05).round() as u8
        );
        assert_eq!(
            at(Point::new(-0.7 * cell, 3.0 * cell)),
            (255.0f64 * 0.85).round() as u8
        );
        // Inner cell (0, 0) of DICT_4X4_50 id 0 is white, (0, 1) black.
        assert_eq!(
            at(Point::new(1.5 * cell, 1.5 * cell)),
            (255.0f64 * 0.85).round() as u8
        );
        assert_eq!(
            at(Point::new(2.5 * cell, 1.5 * cell)),
            (255.0f64 * 0.05).round() as u8
        );
    }
}
