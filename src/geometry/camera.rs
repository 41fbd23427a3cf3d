//! The camera: OpenCV's pinhole intrinsics with Brown–Conrady lens distortion, and the camera's
//! pose over the floor.
//!
//! The lens model is exactly OpenCV's (`calibrateCamera`, `projectPoints`, `undistortPoints`),
//! so numbers and files carry over both ways: a normalised point `(x, y)` (a ray `(x, y, 1)` in
//! the camera's axes: x right, y down, z forward) is seen at
//!
//! ```text
//! r² = x² + y²,   radial = 1 + k1 r² + k2 r⁴ + k3 r⁶
//! x' = x radial + 2 p1 x y + p2 (r² + 2 x²)
//! y' = y radial + p1 (r² + 2 y²) + 2 p2 x y
//! u = fx x' + cx,   v = fy y' + cy          (pixel centres at integers)
//! ```
//!
//! Going back (a pixel to its ray) has no closed form. OpenCV iterates a fixed-point map a fixed
//! number of times, which stops short of the answer near the edge of a wide lens; here Newton's
//! method with the model's exact Jacobian is used, with a bounded count, and a pixel that does
//! not converge is refused rather than given a wrong ray. Only points are undistorted, never
//! images, and nothing allocates.
//!
//! The floor frame is the floor map's: x to the right, y down the map (as seen from above), so
//! the right-handed z axis points *into* the floor and a point `h` above the floor has
//! `z = −h`. The pose maps floor coordinates to camera coordinates, `X_cam = R X_floor + t`.

use core::fmt;

use nalgebra::{Matrix2, Matrix3, Rotation3, Vector2, Vector3};

use super::homography::Point;
use crate::detect::spot_shape::{SpotOptics, SpotShape};
use crate::frame::FrameSize;

/// Newton steps at most when undistorting one point. Each step roughly squares the error, so a
/// point that has not converged by then is beyond where the lens folds over.
const MAX_UNDISTORT_STEPS: usize = 20;
/// A Newton step shorter than this (normalised units, about 1e-9 px) has converged.
const UNDISTORT_CONVERGED: f64 = 1e-12;
/// Largest focal length accepted, in multiples of the frame's width (a 0.6° field of view).
const MAX_FOCAL_PER_WIDTH: f64 = 100.0;
/// Largest distortion coefficient accepted in size. Real lenses, fisheyes aside, stay within
/// single digits; a larger number is a mistyped file.
const MAX_COEFFICIENT: f64 = 100.0;
/// Radial steps when checking that the lens does not fold over inside the picture.
const FOLD_CHECK_STEPS: usize = 256;

/// Why a lens or a camera cannot be used.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CameraError {
    /// A number is NaN or infinite.
    NonFinite,
    /// A focal length is not positive, or absurdly long for the frame.
    BadFocalLength,
    /// The principal point is outside the frame.
    PrincipalPointOutside,
    /// A distortion coefficient is absurdly large.
    AbsurdCoefficient,
    /// The distortion folds the picture over itself before the frame's edge.
    LensFolds,
    /// A pixel's ray could not be found (beyond where the lens folds).
    NoConvergence,
    /// The ray does not meet the plane in front of the camera (on or above its horizon).
    BeyondHorizon,
    /// The point is behind the camera.
    BehindCamera,
    /// The rotation is not a rotation (not orthonormal with determinant 1).
    NotARotation,
}

impl fmt::Display for CameraError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            CameraError::NonFinite => "a number is NaN or infinite",
            CameraError::BadFocalLength => {
                "the focal lengths must be positive and at most 100 frame widths"
            }
            CameraError::PrincipalPointOutside => "the principal point is outside the frame",
            CameraError::AbsurdCoefficient => {
                "a distortion coefficient is absurdly large (more than 100 in size)"
            }
            CameraError::LensFolds => {
                "the distortion folds the picture over before its edge (not a real lens)"
            }
            CameraError::NoConvergence => "the pixel's ray cannot be found through the lens",
            CameraError::BeyondHorizon => "the ray does not meet the floor in front of the camera",
            CameraError::BehindCamera => "the point is behind the camera",
            CameraError::NotARotation => "the rotation matrix is not a rotation",
        })
    }
}

impl core::error::Error for CameraError {}

/// OpenCV's camera matrix and distortion coefficients `(k1, k2, p1, p2, k3)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lens {
    /// Focal lengths, pixels.
    pub fx: f64,
    pub fy: f64,
    /// Principal point, pixels (pixel centres at integers).
    pub cx: f64,
    pub cy: f64,
    /// Radial distortion.
    pub k1: f64,
    pub k2: f64,
    pub k3: f64,
    /// Tangential (decentring) distortion.
    pub p1: f64,
    pub p2: f64,
}

impl Lens {
    /// A distortion-free lens.
    pub fn ideal(fx: f64, fy: f64, cx: f64, cy: f64) -> Lens {
        Lens {
            fx,
            fy,
            cx,
            cy,
            k1: 0.0,
            k2: 0.0,
            k3: 0.0,
            p1: 0.0,
            p2: 0.0,
        }
    }

    /// Whether every distortion coefficient is zero.
    pub fn is_ideal(&self) -> bool {
        [self.k1, self.k2, self.k3, self.p1, self.p2]
            .iter()
            .all(|&k| k == 0.0)
    }

    /// OpenCV's coefficient vector `(k1, k2, p1, p2, k3)`.
    pub fn coefficients(&self) -> [f64; 5] {
        [self.k1, self.k2, self.p1, self.p2, self.k3]
    }

    /// Checks that the lens can be used for frames of `size`: finite, focal lengths positive
    /// and sane, the principal point inside the frame, coefficients of sane size, and the
    /// distortion one-to-one out to the frame's farthest corner.
    pub fn check(&self, size: FrameSize) -> Result<(), CameraError> {
        let all = [
            self.fx, self.fy, self.cx, self.cy, self.k1, self.k2, self.k3, self.p1, self.p2,
        ];
        if all.iter().any(|v| !v.is_finite()) {
            return Err(CameraError::NonFinite);
        }
        let (w, h) = (size.width() as f64, size.height() as f64);
        let max_focal = MAX_FOCAL_PER_WIDTH * w;
        if !(self.fx > 0.0 && self.fy > 0.0 && self.fx <= max_focal && self.fy <= max_focal) {
            return Err(CameraError::BadFocalLength);
        }
        if !((-0.5..=w - 0.5).contains(&self.cx) && (-0.5..=h - 0.5).contains(&self.cy)) {
            return Err(CameraError::PrincipalPointOutside);
        }
        if self
            .coefficients()
            .iter()
            .any(|k| k.abs() > MAX_COEFFICIENT)
        {
            return Err(CameraError::AbsurdCoefficient);
        }
        // Along every direction to a frame corner, the distorted radius must keep growing
        // until it reaches that corner.
        for (u, v) in [
            (-0.5, -0.5),
            (w - 0.5, -0.5),
            (-0.5, h - 0.5),
            (w - 0.5, h - 0.5),
        ] {
            let (xd, yd) = ((u - self.cx) / self.fx, (v - self.cy) / self.fy);
            let reach = xd.hypot(yd);
            if reach == 0.0 {
                continue;
            }
            let (dx, dy) = (xd / reach, yd / reach);
            let mut last = 0.0;
            let mut reached = false;
            // Out to twice the distorted radius: a barrel lens sees farther than its picture.
            for step in 1..=FOLD_CHECK_STEPS {
                let r = 4.0 * reach * step as f64 / FOLD_CHECK_STEPS as f64;
                let (px, py) = self.distort(r * dx, r * dy);
                let along = px * dx + py * dy;
                if along <= last {
                    break;
                }
                last = along;
                if along >= reach {
                    reached = true;
                    break;
                }
            }
            if !reached {
                return Err(CameraError::LensFolds);
            }
        }
        Ok(())
    }

    /// OpenCV's distortion of a normalised point.
    pub fn distort(&self, x: f64, y: f64) -> (f64, f64) {
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        (
            x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x),
            y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y,
        )
    }

    /// The derivative of [`Lens::distort`] at `(x, y)`.
    fn distortion_jacobian(&self, x: f64, y: f64) -> Matrix2<f64> {
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        let d_radial = self.k1 + r2 * (2.0 * self.k2 + 3.0 * r2 * self.k3);
        let cross = 2.0 * x * y * d_radial + 2.0 * self.p1 * x + 2.0 * self.p2 * y;
        Matrix2::new(
            radial + 2.0 * x * x * d_radial + 2.0 * self.p1 * y + 6.0 * self.p2 * x,
            cross,
            cross,
            radial + 2.0 * y * y * d_radial + 6.0 * self.p1 * y + 2.0 * self.p2 * x,
        )
    }

    /// The pixel where the normalised point `(x, y)` is seen.
    pub fn project(&self, x: f64, y: f64) -> Point {
        let (xd, yd) = self.distort(x, y);
        Point::new(self.fx * xd + self.cx, self.fy * yd + self.cy)
    }

    /// The normalised point seen at pixel `px`: Newton's method on the distortion from the
    /// distorted point, at most `MAX_UNDISTORT_STEPS` steps.
    pub fn undistort(&self, px: &Point) -> Result<Vector2<f64>, CameraError> {
        if !(px.x.is_finite() && px.y.is_finite()) {
            return Err(CameraError::NonFinite);
        }
        let target = Vector2::new((px.x - self.cx) / self.fx, (px.y - self.cy) / self.fy);
        if self.is_ideal() {
            return Ok(target);
        }
        let mut p = target;
        for _ in 0..MAX_UNDISTORT_STEPS {
            let (u, v) = self.distort(p.x, p.y);
            let residual = Vector2::new(u, v) - target;
            let step = self
                .distortion_jacobian(p.x, p.y)
                .try_inverse()
                .ok_or(CameraError::NoConvergence)?
                * residual;
            p -= step;
            if !(p.x.is_finite() && p.y.is_finite()) {
                return Err(CameraError::NoConvergence);
            }
            if step.amax() < UNDISTORT_CONVERGED {
                return Ok(p);
            }
        }
        Err(CameraError::NoConvergence)
    }
}

/// Through the lens's local Jacobian at the pixel: how it squeezes a round spot there.
impl SpotOptics for Lens {
    fn spot_shape_at(&self, px: (f32, f32)) -> Option<SpotShape> {
        let n = self
            .undistort(&Point::new(f64::from(px.0), f64::from(px.1)))
            .ok()?;
        // In pixels: image = K D(K⁻¹ ideal), so the image's Jacobian is K J K⁻¹ with K the
        // focal lengths' diagonal; its inverse maps image pixels to ideal pixels.
        let j = self.distortion_jacobian(n.x, n.y);
        let (sx, sy) = (self.fx / self.fy, self.fy / self.fx);
        let pixel = Matrix2::new(j[(0, 0)], j[(0, 1)] * sx, j[(1, 0)] * sy, j[(1, 1)]);
        let a = pixel.try_inverse()?;
        SpotShape::new([
            [a[(0, 0)] as f32, a[(0, 1)] as f32],
            [a[(1, 0)] as f32, a[(1, 1)] as f32],
        ])
    }
}

/// Where the camera is: floor coordinates to camera coordinates, `X_cam = R X_floor + t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// `R`.
    pub rotation: Rotation3<f64>,
    /// `t`, floor units.
    pub translation: Vector3<f64>,
}

impl Pose {
    /// A pose from a matrix that must be a rotation (to 1e-6) and a finite translation.
    pub fn new(rotation: Matrix3<f64>, translation: Vector3<f64>) -> Result<Pose, CameraError> {
        if rotation
            .iter()
            .chain(translation.iter())
            .any(|v| !v.is_finite())
        {
            return Err(CameraError::NonFinite);
        }
        let orthonormal = (rotation.transpose() * rotation - Matrix3::identity()).amax() < 1e-6;
        if !orthonormal || (rotation.determinant() - 1.0).abs() > 1e-6 {
            return Err(CameraError::NotARotation);
        }
        Ok(Pose {
            rotation: Rotation3::from_matrix_unchecked(rotation),
            translation,
        })
    }

    /// A camera at `centre` looking at `target` (floor coordinates, z down into the floor),
    /// held level: its image x axis is horizontal. `NotARotation` when it looks straight up or
    /// down, or at its own centre, where "level" means nothing.
    pub fn looking_at(centre: Vector3<f64>, target: Vector3<f64>) -> Result<Pose, CameraError> {
        let forward = (target - centre)
            .try_normalize(f64::EPSILON)
            .ok_or(CameraError::NotARotation)?;
        let right = forward
            .cross(&Vector3::new(0.0, 0.0, -1.0))
            .try_normalize(f64::EPSILON)
            .ok_or(CameraError::NotARotation)?;
        let down = forward.cross(&right);
        let r = Matrix3::from_rows(&[right.transpose(), down.transpose(), forward.transpose()]);
        Pose::new(r, -(r * centre))
    }

    /// The camera's centre in floor coordinates.
    pub fn centre(&self) -> Vector3<f64> {
        -(self.rotation.inverse() * self.translation)
    }

    /// The camera's height above the floor (floor units).
    pub fn height(&self) -> f64 {
        -self.centre().z
    }
}

/// A camera over the floor: its lens and its pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraModel {
    pub lens: Lens,
    pub pose: Pose,
}

impl CameraModel {
    /// The pixel where the point `floor` (x, y on the map, `height` above the floor) is seen.
    pub fn project(&self, floor: &Point, height: f64) -> Result<Point, CameraError> {
        let p =
            self.pose.rotation * Vector3::new(floor.x, floor.y, -height) + self.pose.translation;
        if p.z.is_nan() || p.z <= 0.0 {
            return Err(CameraError::BehindCamera);
        }
        Ok(self.lens.project(p.x / p.z, p.y / p.z))
    }

    /// The floor point under the point `height` above the floor that is seen at pixel `px`.
    pub fn floor_point(&self, px: &Point, height: f64) -> Result<Point, CameraError> {
        let n = self.lens.undistort(px)?;
        let direction = self.pose.rotation.inverse() * Vector3::new(n.x, n.y, 1.0);
        let centre = self.pose.centre();
        // Along the ray, z goes from the centre's to the plane's −height.
        let t = (-height - centre.z) / direction.z;
        if !(t.is_finite() && t > 0.0) {
            return Err(CameraError::BeyondHorizon);
        }
        Ok(Point::new(
            centre.x + t * direction.x,
            centre.y + t * direction.y,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wide() -> Lens {
        Lens {
            k1: -0.30,
            k2: 0.09,
            ..Lens::ideal(460.0, 460.0, 319.5, 239.5)
        }
    }

    fn vga() -> FrameSize {
        FrameSize::new(640, 480).unwrap()
    }

    #[test]
    fn undistorting_inverts_the_model_to_the_frames_corners() {
        let lens = Lens {
            p1: 0.001,
            p2: -0.0007,
            k3: 0.01,
            ..wide()
        };
        lens.check(vga()).unwrap();
        for v in (0..=480).step_by(48) {
            for u in (0..=640).step_by(64) {
                let px = Point::new(f64::from(u) - 0.5, f64::from(v) - 0.5);
                let n = lens.undistort(&px).unwrap();
                let back = lens.project(n.x, n.y);
                assert!((back - px).norm() < 1e-9, "{px:?} → {back:?}");
            }
        }
    }

    #[test]
    fn the_spot_shape_is_the_lens_seen_up_close() {
        // A decentred lens with unequal focal lengths: every term of the pixel Jacobian counts.
        let lens = Lens {
            p1: 0.001,
            p2: -0.0015,
            ..Lens {
                fy: 440.0,
                cx: 325.5,
                ..wide()
            }
        };
        let step = 1e-3; // ideal pixels
        for (u, v) in [(20.0, 15.0), (600.0, 400.0), (320.0, 240.0), (100.0, 420.0)] {
            let shape = lens.spot_shape_at((u as f32, v as f32)).unwrap();
            let n = lens.undistort(&Point::new(u, v)).unwrap();
            for angle_deg in [0.0f64, 35.0, 90.0, 150.0] {
                // An ideal displacement, through the lens: the shape maps it back.
                let (c, s) = (angle_deg.to_radians().cos(), angle_deg.to_radians().sin());
                let seen = lens.project(n.x + step * c / lens.fx, n.y + step * s / lens.fy);
                let (du, dv) = (seen.x - u, seen.y - v);
                let image = du.hypot(dv);
                let d = ((du / image) as f32, (dv / image) as f32);
                let ratio = f64::from(shape.ideal_per_image_px(d)) * image / step;
                assert!(
                    (ratio - 1.0).abs() < 1e-3,
                    "({u}, {v}) at {angle_deg}°: {ratio}"
                );
            }
        }
        // Near the corner, the wide lens squeezes a round spot radially by a fifth or more.
        let corner = wide().spot_shape_at((600.0, 450.0)).unwrap();
        let radial = (0.8, 0.6);
        assert!(corner.along_over_across(radial) < 0.8);
        assert!(corner.along_over_across((-0.6, 0.8)) > 1.2);
    }

    /// OpenCV's own numbers (`tools/opencv/make_lens_fixture.py`): `projectPoints` and
    /// `undistortPoints` for three lenses.
    #[test]
    fn the_model_is_opencvs() {
        const FIXTURE: &str = include_str!("../../tools/opencv/fixtures/lens.txt");
        let mut lens = None;
        let (mut projected, mut undistorted) = (0, 0);
        for line in FIXTURE.lines() {
            let mut words = line.split_whitespace();
            let kind = words.next().unwrap();
            let v: Vec<f64> = words.map(|w| w.parse().unwrap()).collect();
            match kind {
                "lens" => {
                    lens = Some(Lens {
                        fx: v[0],
                        fy: v[1],
                        cx: v[2],
                        cy: v[3],
                        k1: v[4],
                        k2: v[5],
                        p1: v[6],
                        p2: v[7],
                        k3: v[8],
                    })
                }
                "project" => {
                    let l = lens.unwrap();
                    let p = l.project(v[0] / v[2], v[1] / v[2]);
                    assert!((p - Point::new(v[3], v[4])).norm() < 1e-6, "{line}: {p:?}");
                    projected += 1;
                }
                "undist" => {
                    let n = lens.unwrap().undistort(&Point::new(v[0], v[1])).unwrap();
                    assert!(
                        (n - Vector2::new(v[2], v[3])).norm() < 1e-7,
                        "{line}: {n:?}"
                    );
                    undistorted += 1;
                }
                _ => panic!("{line}"),
            }
        }
        assert_eq!((projected, undistorted), (24, 24));
    }

    #[test]
    fn lenses_that_cannot_be_are_refused() {
        let size = vga();
        let nan = Lens {
            k2: f64::NAN,
            ..wide()
        };
        assert_eq!(nan.check(size), Err(CameraError::NonFinite));
        let absurd = Lens { k1: 1e6, ..wide() };
        assert_eq!(absurd.check(size), Err(CameraError::AbsurdCoefficient));
        // Strong barrel distortion with nothing to stop it turns back before the corner.
        let folds = Lens {
            k1: -0.9,
            k2: 0.0,
            ..wide()
        };
        assert_eq!(folds.check(size), Err(CameraError::LensFolds));
        let off = Lens {
            cx: 900.0,
            ..wide()
        };
        assert_eq!(off.check(size), Err(CameraError::PrincipalPointOutside));
        let flat = Lens { fx: 0.0, ..wide() };
        assert_eq!(flat.check(size), Err(CameraError::BadFocalLength));
    }

    #[test]
    fn a_pixel_maps_to_the_floor_under_a_point_at_any_height() {
        // Camera 130 up over (10, -70), looking down 60° from the horizontal along +y.
        let tilt = 60f64.to_radians();
        // Camera axes in floor coordinates: x right (−x of the floor: the camera faces +y with
        // z into the floor), y down the picture, z forward.
        let forward = Vector3::new(0.0, tilt.cos(), tilt.sin());
        let right = Vector3::new(-1.0, 0.0, 0.0);
        let down = forward.cross(&right);
        let r = Matrix3::from_rows(&[right.transpose(), down.transpose(), forward.transpose()]);
        let centre = Vector3::new(10.0, -70.0, -130.0);
        let pose = Pose::new(r, -(r * centre)).unwrap();
        assert!((pose.height() - 130.0).abs() < 1e-9);
        // The same camera, set up by where it looks.
        let looking = Pose::looking_at(centre, centre + forward).unwrap();
        assert!((looking.rotation.matrix() - r).amax() < 1e-12);
        assert!((looking.translation - pose.translation).amax() < 1e-9);
        assert_eq!(
            Pose::looking_at(centre, Vector3::new(10.0, -70.0, 0.0)),
            Err(CameraError::NotARotation),
            "straight down has no level"
        );
        let camera = CameraModel { lens: wide(), pose };
        for (floor, h) in [(Point::new(0.0, 0.0), 0.0), (Point::new(-40.0, 60.0), 12.0)] {
            let px = camera.project(&floor, h).unwrap();
            let back = camera.floor_point(&px, h).unwrap();
            assert!((back - floor).norm() < 1e-9, "{back:?}");
            // Read as a floor point, the raised point lands farther from the camera.
            let naive = camera.floor_point(&px, 0.0).unwrap();
            if h > 0.0 {
                assert!(naive.y > floor.y + 1.0, "{naive:?}");
            }
        }
        // Straight ahead, level: never meets the floor.
        let r = Matrix3::new(-1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0);
        let level = CameraModel {
            lens: wide(),
            pose: Pose::new(r, -(r * Vector3::new(0.0, 0.0, -50.0))).unwrap(),
        };
        assert_eq!(
            level.floor_point(&Point::new(320.0, 100.0), 0.0),
            Err(CameraError::BeyondHorizon)
        );
    }
}
