//! Fitting the camera (lens and pose over the floor) to the marker map's corners.
//!
//! A homography is exact only for an ideal lens; a webcam's barrel distortion bends straight
//! floor lines by pixels at the picture's edges, and no homography can follow that. Here every
//! corner of every marker goes into one bundle adjustment: Levenberg–Marquardt over the pose
//! (rotation vector and translation), the focal length (square pixels) and OpenCV's
//! `k1, k2, p1, p2`, minimising the pixel distances between detected corners and the
//! floor corners projected through the model. It starts where Zhang's method puts it: the
//! homography of the corners gives the focal length (with the principal point at the picture's
//! centre) and the pose; a pinhole fit of pose and focal length comes first, then the lens.
//!
//! The principal point stays at the picture's centre: one view of one plane cannot tell it
//! from a tilt of the camera (the floor fits either way, but the camera's centre, and with it
//! every plane above the floor, moves), and a lens whose distortion is off-centre is what the
//! tangential terms `p1, p2` describe to first order.
//!
//! One view of one plane does not always pin a lens down: with every marker near the centre,
//! nothing tells how the edges bend. So the fit says how well it is determined: the parameters'
//! covariance (the corner noise, measured as the fit's residual, through the inverse normal
//! matrix) is carried to the floor point of each part of the picture. Where that uncertainty,
//! in pixels, is large, the lens is not known there, and the caller is told which parts of the
//! picture need markers.
//!
//! Several views (a board moved over the picture between dumps) share the lens and get a pose
//! each: the parameters are the lens's, then one pose per view (at most [`MAX_VIEWS`]), and a
//! corner moves only its own view's pose. The uncertainty is carried to the floor of one view,
//! the floor view, whose pose is the calibration's; far from that view's own markers it is the
//! pose's extrapolation, not the lens, that limits it. The principal point stays at the centre
//! here too (one view of a plane per pose is still one plane per pose).
//!
//! Fitting runs once, at calibration, or for the pose alone when a knocked camera is refitted
//! while tracking; it uses fixed-size matrices (13 parameters for one view, 31 for several) and
//! allocates nothing.

use core::fmt;

use nalgebra::{Rotation3, SMatrix, SVector, Vector2, Vector3};

use super::camera::{CameraError, CameraModel, Lens, Pose};
use super::homography::{FloorMapping, HomographyError, Point};
use crate::frame::FrameSize;

/// Lens parameters, first in the parameter vector: focal length, principal point (2),
/// `k1, k2, p1, p2`. Each view's pose follows: rotation vector (3), translation (3).
const LENS_PARAMS: usize = 7;
const POSE_PARAMS: usize = 6;
/// Parameters of a one-view fit (the pose re-fit while tracking uses this size).
const ONE_VIEW_PARAMS: usize = LENS_PARAMS + POSE_PARAMS;
/// Most views pooled into one lens.
pub const MAX_VIEWS: usize = 4;
/// Parameters of a several-view fit.
const MANY_VIEW_PARAMS: usize = LENS_PARAMS + POSE_PARAMS * MAX_VIEWS;
type Params<const P: usize> = SVector<f64, P>;
type Normal<const P: usize> = SMatrix<f64, P, P>;

const FOCAL: usize = 0;
const CX: usize = 1;
const CY: usize = 2;
const K1: usize = 3;

/// Index of view `view`'s pose parameters.
fn pose_at(view: usize) -> usize {
    LENS_PARAMS + POSE_PARAMS * view
}

/// Levenberg–Marquardt iterations at most per stage.
const MAX_ITERATIONS: usize = 200;
/// A relative decrease of the squared error below this has converged.
const CONVERGED: f64 = 1e-14;
/// Relative step of the numerical derivatives.
const DERIVATIVE_STEP: f64 = 1e-6;
/// The corner noise is measured as the fit's residual, but never taken below this: the
/// sub-pixel refiner's own accuracy on sharp, noise-free corners (about a twentieth of a
/// pixel), so that a perfect synthetic fit is not taken for perfect knowledge.
const MIN_CORNER_NOISE_PX: f64 = 0.05;
/// Where the mapping of a part of the picture is uncertain by more than this (1σ, pixels),
/// the lens is not determined there: a few pixels is centimetres on the floor, more than the
/// detector's own error by an order of magnitude.
pub const LENS_UNDETERMINED_PX: f64 = 2.0;
/// Where it is uncertain by more than this, more markers there would improve it.
pub const LENS_WEAK_PX: f64 = 0.5;
/// Points of the picture the uncertainty is evaluated at, per side.
const GRID_X: usize = 16;
const GRID_Y: usize = 12;
/// Most corners fitted.
pub const MAX_FIT_POINTS: usize = 4 * crate::detect::aruco::MAX_MARKERS;

/// What the fit may change of the lens.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LensChoice {
    /// Fit the focal length and distortion with the pose (the principal point at the
    /// picture's centre).
    Fit,
    /// An ideal pinhole with its principal point at the picture's centre: fit the focal
    /// length with the pose.
    Ideal,
    /// A lens calibrated elsewhere: fit the pose only.
    Known(Lens),
}

/// Why the camera could not be fitted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CameraFitError {
    /// The corners do not give a homography to start from.
    Homography(HomographyError),
    /// More corners than supported, or floor and screen lists of different lengths.
    BadInput,
    /// The model cannot be evaluated (e.g. a corner behind the camera) from where Zhang's
    /// method starts.
    NoStart(CameraError),
    /// The fitted lens is not a lens (it folds over, or has absurd numbers).
    BadLens(CameraError),
}

impl fmt::Display for CameraFitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CameraFitError::Homography(e) => write!(f, "the marker corners: {e}"),
            CameraFitError::BadInput => write!(
                f,
                "at most {MAX_FIT_POINTS} corners, with one floor point for each"
            ),
            CameraFitError::NoStart(e) => write!(f, "no camera fits the corners: {e}"),
            CameraFitError::BadLens(e) => write!(f, "the fitted lens cannot be used: {e}"),
        }
    }
}

impl core::error::Error for CameraFitError {}

impl From<HomographyError> for CameraFitError {
    fn from(e: HomographyError) -> Self {
        CameraFitError::Homography(e)
    }
}

/// Parts of the picture, a 3 × 3 grid, for saying where markers are missing.
pub const REGION_NAMES: [&str; 9] = [
    "top left",
    "top",
    "top right",
    "left",
    "centre",
    "right",
    "bottom left",
    "bottom",
    "bottom right",
];

/// A fitted camera and how well the corners determine it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraFit {
    pub camera: CameraModel,
    /// Root-mean-square corner residual, pixels.
    pub rms_residual_px: f64,
    /// Largest corner residual, pixels.
    pub max_residual_px: f64,
    /// Corners fitted, over all views.
    pub corners: usize,
    /// Views pooled into the lens.
    pub views: usize,
    /// The corner noise the uncertainty assumes (1σ per coordinate), pixels.
    pub noise_px: f64,
    /// Largest uncertainty (1σ) of the mapping over the picture's floor, in pixels;
    /// infinite when the corners do not determine the parameters at all.
    pub picture_uncertainty_px: f64,
    /// Largest uncertainty (1σ) of a floor position over the markers' area, floor units.
    pub markers_area_uncertainty: f64,
    /// Largest uncertainty (1σ) of a floor position over the whole picture's floor.
    pub picture_uncertainty: f64,
    /// For each of [`REGION_NAMES`]: the largest uncertainty (1σ) of the mapping there,
    /// pixels (0 where no floor is seen).
    pub region_uncertainty_px: [f64; 9],
}

impl CameraFit {
    /// Whether the lens is determined everywhere in the picture.
    pub fn determined(&self) -> bool {
        self.picture_uncertainty_px <= LENS_UNDETERMINED_PX
    }

    /// The parts of the picture where the mapping is uncertain by more than `threshold_px`.
    pub fn regions_above(&self, threshold_px: f64) -> impl Iterator<Item = &'static str> + '_ {
        REGION_NAMES
            .iter()
            .zip(&self.region_uncertainty_px)
            .filter(move |(_, &u)| u.is_nan() || u > threshold_px)
            .map(|(name, _)| *name)
    }
}

/// The corners of one view: where they lie on the floor (floor units) and where they were
/// detected (pixels). In a view of a moved board, "floor" is the board's own coordinates.
#[derive(Debug, Clone, Copy)]
pub struct ViewCorners<'a> {
    pub floor: &'a [Point],
    pub screen: &'a [Point],
}

/// The model of view `view` for a parameter vector.
fn model<const P: usize>(p: &Params<P>, choice: &LensChoice, view: usize) -> CameraModel {
    let o = pose_at(view);
    let at = |k: usize| p.get(k).copied().unwrap_or(f64::NAN);
    let rotation = Rotation3::new(Vector3::new(at(o), at(o + 1), at(o + 2)));
    let translation = Vector3::new(at(o + 3), at(o + 4), at(o + 5));
    let lens = match choice {
        LensChoice::Known(lens) => *lens,
        _ => Lens {
            fx: at(FOCAL),
            fy: at(FOCAL),
            cx: at(CX),
            cy: at(CY),
            k1: at(K1),
            k2: at(K1 + 1),
            p1: at(K1 + 2),
            p2: at(K1 + 3),
            k3: 0.0,
        },
    };
    CameraModel {
        lens,
        pose: Pose {
            rotation,
            translation,
        },
    }
}

/// Which parameters a stage changes, for `views` views.
fn free_mask<const P: usize>(choice: &LensChoice, with_lens: bool, views: usize) -> [bool; P] {
    let mut free = [false; P];
    for f in free.iter_mut().skip(LENS_PARAMS).take(POSE_PARAMS * views) {
        *f = true;
    }
    match choice {
        LensChoice::Known(_) => {}
        LensChoice::Ideal => free[FOCAL] = true,
        LensChoice::Fit => {
            free[FOCAL] = true;
            if with_lens {
                for f in free.iter_mut().take(LENS_PARAMS).skip(K1) {
                    *f = true;
                }
            }
        }
    }
    free
}

/// Squared error over all corners of all views, or `None` if a corner cannot be projected.
fn cost<const P: usize>(p: &Params<P>, choice: &LensChoice, views: &[ViewCorners]) -> Option<f64> {
    let mut sum = 0.0;
    for (v, view) in views.iter().enumerate() {
        let m = model(p, choice, v);
        for (f, s) in view.floor.iter().zip(view.screen) {
            let q = m.project(f, 0.0).ok()?;
            sum += (q - s).norm_squared();
        }
    }
    sum.is_finite().then_some(sum)
}

fn step_of(value: f64) -> f64 {
    DERIVATIVE_STEP * value.abs().max(1.0)
}

/// The parameters a corner of view `view` depends on: the lens's and that view's pose.
fn params_of(view: usize) -> impl Iterator<Item = usize> {
    (0..LENS_PARAMS).chain(pose_at(view)..pose_at(view) + POSE_PARAMS)
}

/// The 2 × P derivative of the projection of `f` in view `view` by central differences.
fn point_jacobian<const P: usize>(
    p: &Params<P>,
    choice: &LensChoice,
    free: &[bool; P],
    view: usize,
    f: &Point,
) -> Option<SMatrix<f64, 2, P>> {
    let mut j = SMatrix::<f64, 2, P>::zeros();
    for k in params_of(view) {
        if !free.get(k).copied().unwrap_or(false) {
            continue;
        }
        let h = step_of(p[k]);
        let (mut a, mut b) = (*p, *p);
        a[k] -= h;
        b[k] += h;
        let qa = model(&a, choice, view).project(f, 0.0).ok()?;
        let qb = model(&b, choice, view).project(f, 0.0).ok()?;
        let d = (qb - qa) / (2.0 * h);
        j[(0, k)] = d.x;
        j[(1, k)] = d.y;
    }
    Some(j)
}

/// Normal matrix and gradient at `p`.
fn linearise<const P: usize>(
    p: &Params<P>,
    choice: &LensChoice,
    free: &[bool; P],
    views: &[ViewCorners],
) -> Option<(Normal<P>, Params<P>)> {
    let mut jtj = Normal::<P>::zeros();
    let mut jtr = Params::<P>::zeros();
    for (v, view) in views.iter().enumerate() {
        let m = model(p, choice, v);
        for (f, s) in view.floor.iter().zip(view.screen) {
            let r = m.project(f, 0.0).ok()? - s;
            let j = point_jacobian(p, choice, free, v, f)?;
            jtj += j.transpose() * j;
            jtr += j.transpose() * Vector2::new(r.x, r.y);
        }
    }
    Some((jtj, jtr))
}

/// Levenberg–Marquardt over the free parameters.
fn minimise<const P: usize>(
    mut p: Params<P>,
    choice: &LensChoice,
    free: &[bool; P],
    views: &[ViewCorners],
) -> Params<P> {
    let Some(mut c) = cost(&p, choice, views) else {
        return p;
    };
    let mut lambda = 1e-3;
    for _ in 0..MAX_ITERATIONS {
        let Some((jtj, jtr)) = linearise(&p, choice, free, views) else {
            break;
        };
        let mut improved = false;
        while lambda < 1e12 {
            let mut a = jtj;
            for (k, &is_free) in free.iter().enumerate() {
                if is_free {
                    a[(k, k)] += lambda * jtj[(k, k)].max(1e-12);
                } else {
                    a[(k, k)] = 1.0;
                }
            }
            let Some(step) = a.cholesky().map(|ch| ch.solve(&(-jtr))) else {
                lambda *= 10.0;
                continue;
            };
            let trial = p + step;
            match cost(&trial, choice, views) {
                Some(tc) if tc < c => {
                    let converged = c - tc <= CONVERGED * c;
                    p = trial;
                    c = tc;
                    lambda = (lambda * 0.3).max(1e-12);
                    improved = !converged;
                    break;
                }
                _ => lambda *= 10.0,
            }
        }
        if !improved {
            break;
        }
    }
    p
}

/// The homography of one view's corners in the frame of `K`: pixels about the picture's
/// centre, or a known lens's normalised rays.
fn view_homography(
    view: &ViewCorners,
    centre: Point,
    choice: &LensChoice,
) -> Result<nalgebra::Matrix3<f64>, CameraFitError> {
    let mut local: heapless::Vec<Point, MAX_FIT_POINTS> = heapless::Vec::new();
    for s in view.screen {
        let q = match choice {
            LensChoice::Known(lens) => {
                let n = lens.undistort(s).map_err(CameraFitError::NoStart)?;
                Point::new(n.x, n.y)
            }
            _ => Point::new(s.x - centre.x, s.y - centre.y),
        };
        local.push(q).map_err(|_| CameraFitError::BadInput)?;
    }
    Ok(*FloorMapping::fit(view.floor, &local)?
        .floor_to_screen_homography()
        .matrix())
}

/// The pose (rotation vector, translation) of a homography for focal length `focal`.
fn pose_of(h: &nalgebra::Matrix3<f64>, focal: f64) -> (Vector3<f64>, Vector3<f64>) {
    let a = nalgebra::Matrix3::new(1.0 / focal, 0.0, 0.0, 0.0, 1.0 / focal, 0.0, 0.0, 0.0, 1.0) * h;
    let (a1, a2, a3) = (
        a.column(0).into_owned(),
        a.column(1).into_owned(),
        a.column(2).into_owned(),
    );
    let mut scale = 2.0 / (a1.norm() + a2.norm());
    if a3.z * scale < 0.0 {
        scale = -scale;
    }
    let (r1, r2, t) = (a1 * scale, a2 * scale, a3 * scale);
    let r3 = r1.cross(&r2);
    let m = nalgebra::Matrix3::from_columns(&[r1, r2, r3]);
    (Rotation3::from_matrix(&m).scaled_axis(), t)
}

/// Zhang's start: the focal length from the views' homographies (principal point at the
/// centre; their mean where more than one view says), then each view's pose from `K⁻¹ H`. For
/// a known lens, the corners are undistorted first and `K` is that lens's.
fn start<const P: usize>(
    views: &[ViewCorners],
    size: FrameSize,
    choice: &LensChoice,
) -> Result<Params<P>, CameraFitError> {
    let centre = Point::new(
        (size.width() as f64 - 1.0) / 2.0,
        (size.height() as f64 - 1.0) / 2.0,
    );
    let mut homographies: heapless::Vec<nalgebra::Matrix3<f64>, MAX_VIEWS> = heapless::Vec::new();
    for view in views {
        homographies
            .push(view_homography(view, centre, choice)?)
            .map_err(|_| CameraFitError::BadInput)?;
    }
    let focal = match choice {
        LensChoice::Known(_) => 1.0,
        _ => {
            let (sum, n) = homographies
                .iter()
                .filter_map(zhang_focal)
                .fold((0.0, 0u32), |(s, n), f| (s + f, n + 1));
            if n > 0 {
                sum / f64::from(n)
            } else {
                size.width() as f64
            }
        }
    };
    let mut p = Params::<P>::zeros();
    for (v, h) in homographies.iter().enumerate() {
        let (axis, t) = pose_of(h, focal);
        let o = pose_at(v);
        if o + POSE_PARAMS > P {
            return Err(CameraFitError::BadInput);
        }
        p.fixed_rows_mut::<3>(o).copy_from(&axis);
        p.fixed_rows_mut::<3>(o + 3).copy_from(&t);
    }
    p[FOCAL] = focal;
    p[CX] = centre.x;
    p[CY] = centre.y;
    if !p.iter().all(|v| v.is_finite()) {
        return Err(CameraFitError::NoStart(CameraError::NonFinite));
    }
    Ok(p)
}

/// The focal length (square pixels, principal point at the origin) that makes the
/// homography's first two columns orthogonal and of equal length, by least squares over both
/// of Zhang's constraints; `None` for a view square to the floor, where they say nothing.
fn zhang_focal(h: &nalgebra::Matrix3<f64>) -> Option<f64> {
    let (a1, b1) = (
        h[(0, 0)] * h[(0, 1)] + h[(1, 0)] * h[(1, 1)],
        h[(2, 0)] * h[(2, 1)],
    );
    let (a2, b2) = (
        h[(0, 0)].powi(2) + h[(1, 0)].powi(2) - h[(0, 1)].powi(2) - h[(1, 1)].powi(2),
        h[(2, 0)].powi(2) - h[(2, 1)].powi(2),
    );
    // a / f² + b = 0 for both: 1/f² = −(a₁b₁ + a₂b₂) / (a₁² + a₂²).
    let denominator = a1 * a1 + a2 * a2;
    let inverse_square = -(a1 * b1 + a2 * b2) / denominator;
    (inverse_square.is_finite() && inverse_square > 0.0).then(|| 1.0 / inverse_square.sqrt())
}

/// Fits the camera to corners at `floor` (floor units) detected at `screen` (pixels) in
/// frames of `size`.
pub fn fit_camera(
    floor: &[Point],
    screen: &[Point],
    size: FrameSize,
    choice: LensChoice,
) -> Result<CameraFit, CameraFitError> {
    fit_camera_views(&[ViewCorners { floor, screen }], 0, size, choice)
}

/// Fits one lens to the corners of several views (at most [`MAX_VIEWS`]) of frames of `size`,
/// with one pose per view: a board moved between views, or the camera turned. The fitted
/// camera's pose, and the uncertainty of the mapping, are those of view `floor_view`.
pub fn fit_camera_views(
    views: &[ViewCorners],
    floor_view: usize,
    size: FrameSize,
    choice: LensChoice,
) -> Result<CameraFit, CameraFitError> {
    let well_formed = views
        .iter()
        .all(|v| v.floor.len() == v.screen.len() && v.floor.len() <= MAX_FIT_POINTS);
    if views.is_empty() || views.len() > MAX_VIEWS || floor_view >= views.len() || !well_formed {
        return Err(CameraFitError::BadInput);
    }
    if views.len() == 1 {
        fit::<ONE_VIEW_PARAMS>(views, floor_view, size, choice)
    } else {
        fit::<MANY_VIEW_PARAMS>(views, floor_view, size, choice)
    }
}

fn fit<const P: usize>(
    views: &[ViewCorners],
    floor_view: usize,
    size: FrameSize,
    choice: LensChoice,
) -> Result<CameraFit, CameraFitError> {
    let count = views.len();
    let start = start::<P>(views, size, &choice)?;
    let pinhole_free = free_mask::<P>(&choice, false, count);
    let pinhole = minimise(start, &choice, &pinhole_free, views);
    let free = free_mask::<P>(&choice, true, count);
    let p = if free == pinhole_free {
        pinhole
    } else {
        minimise(pinhole, &choice, &free, views)
    };
    let camera = model(&p, &choice, floor_view);
    camera.lens.check(size).map_err(CameraFitError::BadLens)?;
    let mut sum_sq = 0.0;
    let mut max_px: f64 = 0.0;
    let mut n: usize = 0;
    for (v, view) in views.iter().enumerate() {
        let m = model(&p, &choice, v);
        for (f, s) in view.floor.iter().zip(view.screen) {
            let d = (m.project(f, 0.0).map_err(CameraFitError::BadLens)? - s).norm();
            sum_sq += d * d;
            max_px = max_px.max(d);
            n += 1;
        }
    }
    let rms = (sum_sq / n.max(1) as f64).sqrt();
    let free_count = free.iter().filter(|&&f| f).count();
    // The corner noise per coordinate, from the residual with the fitted degrees removed.
    let dof = (2 * n).saturating_sub(free_count);
    let noise_px = if dof > 0 {
        (sum_sq / dof as f64).sqrt().max(MIN_CORNER_NOISE_PX)
    } else {
        f64::INFINITY
    };
    let covariance = linearise(&p, &choice, &free, views)
        .and_then(|(jtj, _)| {
            let mut a = jtj;
            for (k, &is_free) in free.iter().enumerate() {
                if !is_free {
                    a[(k, k)] = 1.0;
                }
            }
            a.cholesky().map(|c| c.inverse())
        })
        .filter(|c| c.iter().all(|v| v.is_finite()) && noise_px.is_finite())
        .map(|mut c| {
            for (k, &free_k) in free.iter().enumerate() {
                for (l, &free_l) in free.iter().enumerate() {
                    if !(free_k && free_l) {
                        c[(k, l)] = 0.0;
                    }
                }
            }
            c * noise_px * noise_px
        });
    let markers = views.get(floor_view).map_or(&[][..], |v| v.floor);
    let uncertainty =
        Uncertainty::over_picture(&p, &choice, floor_view, covariance.as_ref(), size, markers);
    Ok(CameraFit {
        camera,
        rms_residual_px: rms,
        max_residual_px: max_px,
        corners: n,
        views: count,
        noise_px,
        picture_uncertainty_px: uncertainty.max_px,
        markers_area_uncertainty: uncertainty.markers_area,
        picture_uncertainty: uncertainty.picture,
        region_uncertainty_px: uncertainty.regions_px,
    })
}

/// The covariance carried to the floor over a grid of the picture.
struct Uncertainty {
    max_px: f64,
    markers_area: f64,
    picture: f64,
    regions_px: [f64; 9],
}

impl Uncertainty {
    fn over_picture<const P: usize>(
        p: &Params<P>,
        choice: &LensChoice,
        view: usize,
        covariance: Option<&Normal<P>>,
        size: FrameSize,
        markers: &[Point],
    ) -> Uncertainty {
        let Some(covariance) = covariance else {
            return Uncertainty {
                max_px: f64::INFINITY,
                markers_area: f64::INFINITY,
                picture: f64::INFINITY,
                regions_px: [f64::INFINITY; 9],
            };
        };
        let (lo, hi) = markers.iter().fold(
            (
                Point::new(f64::MAX, f64::MAX),
                Point::new(f64::MIN, f64::MIN),
            ),
            |(lo, hi), m| {
                (
                    Point::new(lo.x.min(m.x), lo.y.min(m.y)),
                    Point::new(hi.x.max(m.x), hi.y.max(m.y)),
                )
            },
        );
        let camera = model(p, choice, view);
        let (w, h) = (size.width() as f64, size.height() as f64);
        let mut out = Uncertainty {
            max_px: 0.0,
            markers_area: 0.0,
            picture: 0.0,
            regions_px: [0.0; 9],
        };
        for gy in 0..GRID_Y {
            for gx in 0..GRID_X {
                let q = Point::new(
                    (gx as f64 + 0.5) * w / GRID_X as f64 - 0.5,
                    (gy as f64 + 0.5) * h / GRID_Y as f64 - 0.5,
                );
                let Ok(floor) = camera.floor_point(&q, 0.0) else {
                    continue;
                };
                // A variance that cannot be computed is no knowledge at all.
                let sigma = floor_sigma(p, choice, view, covariance, &q).unwrap_or(f64::INFINITY);
                // Floor per pixel here, to say the uncertainty in pixels.
                let Some(scale) = floor_per_px(&camera, &q) else {
                    continue;
                };
                let sigma_px = sigma / scale;
                // NaN-safe: an undetermined point makes everything infinite.
                let sigma_px = if sigma_px.is_nan() {
                    f64::INFINITY
                } else {
                    sigma_px
                };
                out.max_px = out.max_px.max(sigma_px);
                out.picture = out.picture.max(sigma);
                let inside = (lo.x..=hi.x).contains(&floor.x) && (lo.y..=hi.y).contains(&floor.y);
                if inside {
                    out.markers_area = out.markers_area.max(sigma);
                }
                let region = (3 * gy / GRID_Y) * 3 + 3 * gx / GRID_X;
                if let Some(u) = out.regions_px.get_mut(region) {
                    *u = u.max(sigma_px);
                }
            }
        }
        out
    }
}

/// 1σ of the floor point seen at `q` (root of the covariance's trace), floor units.
fn floor_sigma<const P: usize>(
    p: &Params<P>,
    choice: &LensChoice,
    view: usize,
    covariance: &Normal<P>,
    q: &Point,
) -> Option<f64> {
    let mut g = SMatrix::<f64, 2, P>::zeros();
    for k in params_of(view) {
        if covariance.get((k, k)).is_none_or(|&c| c == 0.0) {
            continue;
        }
        let h = step_of(p[k]);
        let (mut a, mut b) = (*p, *p);
        a[k] -= h;
        b[k] += h;
        let fa = model(&a, choice, view).floor_point(q, 0.0).ok()?;
        let fb = model(&b, choice, view).floor_point(q, 0.0).ok()?;
        let d = (fb - fa) / (2.0 * h);
        g[(0, k)] = d.x;
        g[(1, k)] = d.y;
    }
    let c = g * covariance * g.transpose();
    let variance = c.trace();
    (variance.is_finite() && variance >= 0.0).then(|| variance.sqrt())
}

/// Floor units per pixel at `q`: the root of the mapping's area scale.
fn floor_per_px(camera: &CameraModel, q: &Point) -> Option<f64> {
    const H_PX: f64 = 0.5;
    let at = |dx: f64, dy: f64| {
        camera
            .floor_point(&Point::new(q.x + dx, q.y + dy), 0.0)
            .ok()
    };
    let dx = (at(H_PX, 0.0)? - at(-H_PX, 0.0)?) / (2.0 * H_PX);
    let dy = (at(0.0, H_PX)? - at(0.0, -H_PX)?) / (2.0 * H_PX);
    let area = (dx.x * dy.y - dx.y * dy.x).abs();
    (area > 0.0 && area.is_finite()).then(|| area.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn size() -> FrameSize {
        FrameSize::new(640, 480).unwrap()
    }

    /// The reference camera of the accuracy tests: 1.3 m up, looking obliquely down.
    fn truth(lens: Lens) -> CameraModel {
        let centre = Vector3::new(10.0, -70.0, -130.0);
        CameraModel {
            lens,
            pose: Pose::looking_at(centre, Vector3::new(10.0, -5.0, 0.0)).unwrap(),
        }
    }

    /// Corners of 18 cm markers with top-left corners at `origins`, and where `camera` sees
    /// them, with a small deterministic jitter standing for detection noise.
    fn corners(camera: &CameraModel, origins: &[(f64, f64)]) -> (Vec<Point>, Vec<Point>) {
        let (mut floor, mut screen) = (Vec::new(), Vec::new());
        for (i, &(x, y)) in origins.iter().enumerate() {
            for (k, (dx, dy)) in [(0.0, 0.0), (18.0, 0.0), (18.0, 18.0), (0.0, 18.0)]
                .into_iter()
                .enumerate()
            {
                let f = Point::new(x + dx, y + dy);
                let jitter = 0.05 * (((i * 4 + k) * 7919 % 13) as f64 / 6.0 - 1.0);
                let s = camera.project(&f, 0.0).unwrap();
                floor.push(f);
                screen.push(Point::new(s.x + jitter, s.y - jitter));
            }
        }
        (floor, screen)
    }

    const SPREAD: [(f64, f64); 6] = [
        (93.0, 54.0),
        (1.0, 59.0),
        (-91.0, 54.0),
        (65.0, -62.0),
        (1.0, -65.0),
        (-64.0, -62.0),
    ];

    #[test]
    fn a_wide_lens_is_recovered_from_markers_spread_over_the_picture() {
        let lens = Lens {
            k1: -0.30,
            k2: 0.09,
            ..Lens::ideal(460.0, 460.0, 319.5, 239.5)
        };
        let camera = truth(lens);
        let (floor, screen) = corners(&camera, &SPREAD);
        let fit = fit_camera(&floor, &screen, size(), LensChoice::Fit).unwrap();
        assert!(fit.rms_residual_px < 0.1, "{fit:?}");
        assert!(fit.determined(), "{fit:?}");
        // Floor positions over the picture agree with the true camera.
        let mut worst: f64 = 0.0;
        for v in (40..480).step_by(40) {
            for u in (40..640).step_by(40) {
                let q = Point::new(f64::from(u), f64::from(v));
                let want = camera.floor_point(&q, 0.0).unwrap();
                let got = fit.camera.floor_point(&q, 0.0).unwrap();
                worst = worst.max((got - want).norm());
            }
        }
        assert!(worst < 0.5, "worst floor error {worst:.3} cm");
        assert!((fit.camera.pose.height() - 130.0).abs() < 2.0, "{fit:?}");
    }

    #[test]
    fn markers_only_near_the_centre_leave_the_lens_undetermined() {
        let lens = Lens {
            k1: -0.30,
            k2: 0.09,
            ..Lens::ideal(460.0, 460.0, 319.5, 239.5)
        };
        let (floor, screen) = corners(&truth(lens), &[(0.0, 0.0), (20.0, -15.0)]);
        let fit = fit_camera(&floor, &screen, size(), LensChoice::Fit).unwrap();
        assert!(!fit.determined(), "{fit:?}");
        let regions: Vec<&str> = fit.regions_above(LENS_UNDETERMINED_PX).collect();
        assert!(
            regions.contains(&"top left") && regions.contains(&"bottom right"),
            "{regions:?}"
        );
        // An ideal lens is what the user asked for: fitted, and exact for an ideal camera.
        let ideal = Lens::ideal(460.0, 460.0, 319.5, 239.5);
        let (floor, screen) = corners(&truth(ideal), &[(0.0, 0.0), (20.0, -15.0)]);
        let fit = fit_camera(&floor, &screen, size(), LensChoice::Ideal).unwrap();
        assert!(fit.camera.lens.is_ideal());
        assert!((fit.camera.lens.fx - 460.0).abs() < 15.0, "{fit:?}");
    }

    #[test]
    fn a_known_lens_fits_the_pose_only() {
        let lens = Lens {
            k1: -0.12,
            p1: 0.001,
            p2: -0.001,
            ..Lens::ideal(455.0, 462.0, 325.5, 235.5)
        };
        let camera = truth(lens);
        let (floor, screen) = corners(&camera, &SPREAD[..2]);
        let fit = fit_camera(&floor, &screen, size(), LensChoice::Known(lens)).unwrap();
        assert_eq!(fit.camera.lens, lens);
        let centre = fit.camera.pose.centre();
        assert!((centre - camera.pose.centre()).norm() < 1.0, "{centre:?}");
    }

    /// A board of four 18 cm markers, its top-left marker at `at` on the floor; the corners
    /// in the board's own coordinates and where `camera` sees them.
    fn board(camera: &CameraModel, at: (f64, f64)) -> (Vec<Point>, Vec<Point>) {
        let cells = [
            (0.0, 0.0),
            (25.0, 0.0),
            (50.0, 0.0),
            (0.0, 25.0),
            (25.0, 25.0),
            (50.0, 25.0),
        ];
        let on_floor: Vec<(f64, f64)> = cells.iter().map(|&(x, y)| (x + at.0, y + at.1)).collect();
        let (floor, screen) = corners(camera, &on_floor);
        let floor = floor
            .into_iter()
            .map(|f| Point::new(f.x - at.0, f.y - at.1))
            .collect();
        (floor, screen)
    }

    /// Worst reprojection error (px) over the whole picture: the floor point `camera` sees at
    /// each pixel of a grid, in the coordinates of a board at `at`, through `fit`'s camera.
    fn worst_px(fit: &CameraFit, camera: &CameraModel, at: (f64, f64)) -> f64 {
        let mut worst: f64 = 0.0;
        for v in (20..480).step_by(40) {
            for u in (20..640).step_by(40) {
                let q = Point::new(f64::from(u), f64::from(v));
                let want = camera.floor_point(&q, 0.0).unwrap();
                let on_board = Point::new(want.x - at.0, want.y - at.1);
                let got = fit.camera.project(&on_board, 0.0).unwrap();
                worst = worst.max((got - q).norm());
            }
        }
        worst
    }

    #[test]
    fn a_board_moved_over_the_picture_determines_a_lens_one_view_of_it_cannot() {
        let lens = Lens {
            k1: -0.30,
            k2: 0.09,
            ..Lens::ideal(460.0, 460.0, 319.5, 239.5)
        };
        let camera = truth(lens);
        let places = [(-105.0, 45.0), (30.0, -72.0), (50.0, 52.0)];
        let boards: Vec<_> = places.iter().map(|&at| board(&camera, at)).collect();
        for (_, screen) in &boards {
            let inside = screen
                .iter()
                .all(|s| (0.0..639.0).contains(&s.x) && (0.0..479.0).contains(&s.y));
            assert!(inside, "a board leaves the picture: {screen:?}");
        }
        let views: Vec<ViewCorners> = boards
            .iter()
            .map(|(floor, screen)| ViewCorners { floor, screen })
            .collect();
        let one = fit_camera_views(&views[..1], 0, size(), LensChoice::Fit).unwrap();
        assert!(!one.determined(), "{one:?}");
        let one_px = worst_px(&one, &camera, places[0]);
        for count in [2, 3] {
            let fit = fit_camera_views(&views[..count], 0, size(), LensChoice::Fit).unwrap();
            assert_eq!((fit.views, fit.corners), (count, 24 * count));
            let px = worst_px(&fit, &camera, places[0]);
            eprintln!(
                "{count} views: worst {px:.3} px, uncertain by up to {:.2} px \
                 (one view {one_px:.3} px, uncertain by {:.2} px)",
                fit.picture_uncertainty_px, one.picture_uncertainty_px
            );
            assert!(
                px < one_px / 10.0,
                "{count} views: {px:.3} px, one view {one_px:.3} px"
            );
            // The fit's own uncertainty says how far off it may be.
            assert!(
                px < 3.0 * fit.picture_uncertainty_px,
                "{count} views: {px:.3} px"
            );
            assert!(
                (fit.camera.lens.k1 + 0.30).abs() < 0.03,
                "{:?}",
                fit.camera.lens
            );
            // Three boards, one in each of three corners, leave no corner of the picture
            // undetermined; two leave the far ones weak.
            assert!(
                count < 3 || (fit.determined() && px < 1.0),
                "{count} views: {fit:?}"
            );
        }
        // The floor view's pose is the one written: the last board's, here.
        let fit = fit_camera_views(&views, 2, size(), LensChoice::Fit).unwrap();
        assert!(worst_px(&fit, &camera, places[2]) < 1.0);
        assert_eq!(
            fit_camera_views(&views, 3, size(), LensChoice::Fit),
            Err(CameraFitError::BadInput)
        );
    }
}
