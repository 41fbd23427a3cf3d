//! Plane-to-plane homographies: exact from four point pairs, least squares from more.
//!
//! The floor is a plane and the camera a pinhole, so screen and floor positions are related by a
//! 3×3 projective matrix. Four exact correspondences fix it (this is OpenCV's
//! `getPerspectiveTransform`); more correspondences, each with measurement noise, are combined by
//! the normalised direct linear transform of Hartley & Zisserman, so that one marker map with many
//! corners gives one well-conditioned fit.
//!
//! Only fixed-size `nalgebra` matrices are used, so this module needs no allocator and works
//! `no_std` (nalgebra's `libm` feature supplies the maths).

use core::fmt;

use nalgebra::{ComplexField, Matrix3, Point2, SMatrix, SVector, SymmetricEigen, Vector3};

/// A point in either plane (screen pixels or floor units).
pub type Point = Point2<f64>;

/// Points this close together (relative to the spread of the set) count as the same point.
const DUPLICATE_RELATIVE: f64 = 1e-9;
/// Three points whose triangle has less area than this (relative to the squared spread of the
/// set) count as collinear.
const COLLINEAR_RELATIVE: f64 = 1e-9;
/// A projective scale `w` this small (relative to the matrix) means the point maps to infinity.
const INFINITY_RELATIVE: f64 = 1e-12;
/// A normalised DLT whose second-smallest eigenvalue is below this has more than one solution:
/// the points do not pin a homography down (all but one collinear, or too many duplicates).
const RANK_DEFICIENT_EIGENVALUE: f64 = 1e-12;

/// Why a homography can't be built or applied.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HomographyError {
    /// Fewer than four point pairs.
    TooFewPoints { got: usize },
    /// The two point lists differ in length.
    LengthMismatch { src: usize, dst: usize },
    /// A coordinate is NaN or infinite.
    NonFinite,
    /// Two points of one set coincide.
    DuplicatePoints { first: usize, second: usize },
    /// Three of four points are on one line, or a larger set is nearly all on one line.
    CollinearPoints,
    /// The fitted matrix is singular or not finite: it would map the plane onto a line.
    Singular,
    /// The point maps to infinity, or to the far side of the horizon (behind the camera).
    PointAtInfinity,
    /// The calibration's screen points lie on both sides of the horizon: no camera sees that.
    StraddlesHorizon,
}

impl fmt::Display for HomographyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            HomographyError::TooFewPoints { got } => {
                write!(f, "a homography needs at least 4 point pairs, got {got}")
            }
            HomographyError::LengthMismatch { src, dst } => write!(
                f,
                "point lists differ in length ({src} source points, {dst} destination points)"
            ),
            HomographyError::NonFinite => write!(f, "a point coordinate is NaN or infinite"),
            HomographyError::DuplicatePoints { first, second } => {
                write!(f, "points {first} and {second} coincide")
            }
            HomographyError::CollinearPoints => write!(
                f,
                "the points are (nearly) collinear, so they do not determine a plane mapping"
            ),
            HomographyError::Singular => write!(f, "the homography is singular"),
            HomographyError::PointAtInfinity => write!(
                f,
                "the point maps to infinity (it lies on or beyond the horizon of the plane)"
            ),
            HomographyError::StraddlesHorizon => write!(
                f,
                "the calibration points lie on both sides of the horizon; the mapping is not a view"
            ),
        }
    }
}

impl core::error::Error for HomographyError {}

/// An invertible 3×3 projective mapping `dst ~ H · src`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Homography {
    matrix: Matrix3<f64>,
}

impl Homography {
    /// Wraps a matrix, refusing a singular or non-finite one.
    pub fn from_matrix(matrix: Matrix3<f64>) -> Result<Self, HomographyError> {
        if matrix.iter().any(|v| !v.is_finite()) {
            return Err(HomographyError::Singular);
        }
        let scale = matrix.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let det = matrix.determinant();
        if scale == 0.0 || !det.is_finite() || det.abs() <= 1e-14 * scale * scale * scale {
            return Err(HomographyError::Singular);
        }
        Ok(Homography { matrix })
    }

    /// The matrix, scaled as built (`m[(2, 2)] == 1` for [`Homography::from_four`] and
    /// [`Homography::fit`] whenever that entry is not zero).
    pub fn matrix(&self) -> &Matrix3<f64> {
        &self.matrix
    }

    /// The exact mapping of four source points onto four destination points, as OpenCV's
    /// `getPerspectiveTransform(src, dst)`: the 8×8 linear system with `h22 = 1`, solved by LU.
    pub fn from_four(src: &[Point; 4], dst: &[Point; 4]) -> Result<Self, HomographyError> {
        check_points(src)?;
        check_points(dst)?;
        check_no_three_collinear(src)?;
        check_no_three_collinear(dst)?;
        let mut a = SMatrix::<f64, 8, 8>::zeros();
        let mut b = SVector::<f64, 8>::zeros();
        for (i, (s, d)) in src.iter().zip(dst).enumerate() {
            let (x, y, u, v) = (s.x, s.y, d.x, d.y);
            let r = 2 * i;
            a.row_mut(r)
                .copy_from_slice(&[x, y, 1.0, 0.0, 0.0, 0.0, -x * u, -y * u]);
            a.row_mut(r + 1)
                .copy_from_slice(&[0.0, 0.0, 0.0, x, y, 1.0, -x * v, -y * v]);
            b[r] = u;
            b[r + 1] = v;
        }
        let h = a.lu().solve(&b).ok_or(HomographyError::CollinearPoints)?;
        Homography::from_matrix(Matrix3::new(
            h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], 1.0,
        ))
    }

    /// The least-squares mapping of `src` onto `dst` (at least four pairs): the normalised DLT
    /// (both sets moved to their centroid and scaled to mean distance √2, which keeps the 9×9
    /// normal matrix well conditioned whatever the units), then polished to minimise the
    /// distances between mapped `src` and `dst` points, as OpenCV's `findHomography` does.
    pub fn fit(src: &[Point], dst: &[Point]) -> Result<Self, HomographyError> {
        if src.len() != dst.len() {
            return Err(HomographyError::LengthMismatch {
                src: src.len(),
                dst: dst.len(),
            });
        }
        if src.len() < 4 {
            return Err(HomographyError::TooFewPoints { got: src.len() });
        }
        check_points(src)?;
        check_points(dst)?;
        let t_src = normalising_transform(src)?;
        let t_dst = normalising_transform(dst)?;
        let mut ata = SMatrix::<f64, 9, 9>::zeros();
        for (s, d) in src.iter().zip(dst) {
            let s = t_src.transform_point(s);
            let d = t_dst.transform_point(d);
            let (x, y, u, v) = (s.x, s.y, d.x, d.y);
            let r1 = SVector::<f64, 9>::from([x, y, 1.0, 0.0, 0.0, 0.0, -u * x, -u * y, -u]);
            let r2 = SVector::<f64, 9>::from([0.0, 0.0, 0.0, x, y, 1.0, -v * x, -v * y, -v]);
            ata += r1 * r1.transpose() + r2 * r2.transpose();
        }
        let eigen = SymmetricEigen::new(ata);
        let mut order = [0usize, 1, 2, 3, 4, 5, 6, 7, 8];
        order.sort_unstable_by(|&a, &b| eigen.eigenvalues[a].total_cmp(&eigen.eigenvalues[b]));
        let [smallest, second, ..] = order;
        let largest = eigen.eigenvalues.amax();
        if eigen.eigenvalues[second] <= RANK_DEFICIENT_EIGENVALUE * largest {
            return Err(HomographyError::CollinearPoints);
        }
        let h = eigen.eigenvectors.column(smallest);
        let algebraic = Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
        let normalised = minimise_transfer_error(algebraic, src, dst, &t_src, &t_dst);
        let t_dst_inv = t_dst
            .to_homogeneous()
            .try_inverse()
            .ok_or(HomographyError::Singular)?;
        let m = t_dst_inv * normalised * t_src.to_homogeneous();
        Homography::from_matrix(scale_to_unit_corner(m))
    }

    /// The inverse mapping.
    pub fn inverse(&self) -> Result<Self, HomographyError> {
        let inv = self.matrix.try_inverse().ok_or(HomographyError::Singular)?;
        Homography::from_matrix(scale_to_unit_corner(inv))
    }

    /// Maps one point, with its projective scale `w` (whose sign tells the side of the horizon).
    fn apply_with_w(&self, p: &Point) -> Result<(Point, f64), HomographyError> {
        if !p.x.is_finite() || !p.y.is_finite() {
            return Err(HomographyError::NonFinite);
        }
        let q = self.matrix * Vector3::new(p.x, p.y, 1.0);
        let row_scale = self.matrix[(2, 0)].abs() * p.x.abs()
            + self.matrix[(2, 1)].abs() * p.y.abs()
            + self.matrix[(2, 2)].abs();
        if q.z.abs() <= INFINITY_RELATIVE * row_scale || row_scale == 0.0 {
            return Err(HomographyError::PointAtInfinity);
        }
        let out = Point::new(q.x / q.z, q.y / q.z);
        if !out.x.is_finite() || !out.y.is_finite() {
            return Err(HomographyError::PointAtInfinity);
        }
        Ok((out, q.z))
    }

    /// Maps one point; refuses a point that lands at infinity.
    pub fn apply(&self, p: &Point) -> Result<Point, HomographyError> {
        self.apply_with_w(p).map(|(q, _)| q)
    }
}

/// Screen ↔ floor mapping, fitted from corresponding points.
///
/// A camera sees only one side of the floor's horizon. Points on the other side still have a
/// projective image, but it is meaningless (it would be behind the camera), so the mapping
/// remembers on which side its calibration points were and refuses points on the other side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FloorMapping {
    floor_to_screen: Homography,
    screen_to_floor: Homography,
    /// Sign of `w` when mapping the calibration's screen points to the floor.
    visible_side: f64,
}

impl FloorMapping {
    /// Fits the mapping from pairs of floor points (in floor units) and their screen positions
    /// (pixels): exactly for four pairs, by least squares for more.
    pub fn fit(floor: &[Point], screen: &[Point]) -> Result<Self, HomographyError> {
        let floor_to_screen = match (
            <&[Point; 4]>::try_from(floor),
            <&[Point; 4]>::try_from(screen),
        ) {
            (Ok(f), Ok(s)) => Homography::from_four(f, s)?,
            _ => Homography::fit(floor, screen)?,
        };
        FloorMapping::from_floor_to_screen(floor_to_screen, screen)
    }

    /// Wraps a floor→screen homography; `screen_samples` (at least one point the camera
    /// really sees, e.g. the calibration corners) tell which side of the horizon is visible.
    pub fn from_floor_to_screen(
        floor_to_screen: Homography,
        screen_samples: &[Point],
    ) -> Result<Self, HomographyError> {
        let screen_to_floor = floor_to_screen.inverse()?;
        let first = screen_samples
            .first()
            .ok_or(HomographyError::TooFewPoints { got: 0 })?;
        let (_, w) = screen_to_floor.apply_with_w(first)?;
        let visible_side = w.signum();
        for p in screen_samples {
            let (_, w) = screen_to_floor.apply_with_w(p)?;
            if w.signum() != visible_side {
                return Err(HomographyError::StraddlesHorizon);
            }
        }
        Ok(FloorMapping {
            floor_to_screen,
            screen_to_floor,
            visible_side,
        })
    }

    /// The floor→screen homography.
    pub fn floor_to_screen_homography(&self) -> &Homography {
        &self.floor_to_screen
    }

    /// Floor position of a screen point; refuses points on or above the floor's horizon.
    pub fn screen_to_floor(&self, screen_px: &Point) -> Result<Point, HomographyError> {
        let (p, w) = self.screen_to_floor.apply_with_w(screen_px)?;
        if w.signum() != self.visible_side {
            return Err(HomographyError::PointAtInfinity);
        }
        Ok(p)
    }

    /// Screen position of a floor point; refuses points the camera could not see (behind it).
    pub fn floor_to_screen(&self, floor: &Point) -> Result<Point, HomographyError> {
        let (p, _) = self.floor_to_screen.apply_with_w(floor)?;
        // Going back must land on the visible side, or the floor point is behind the camera.
        let (_, w) = self.screen_to_floor.apply_with_w(&p)?;
        if w.signum() != self.visible_side {
            return Err(HomographyError::PointAtInfinity);
        }
        Ok(p)
    }
}

/// Gauss-Newton iterations polishing the algebraic fit (at most; it stops when converged).
const REFINE_ITERATIONS: usize = 20;
/// Relative decrease of the squared error below which refinement has converged.
const REFINE_CONVERGED: f64 = 1e-12;

/// Polishes a normalised homography so that it minimises the squared distances between mapped
/// source points and destination points (OpenCV's `findHomography` does the same after its DLT).
/// This is the maximum-likelihood fit when the destination (screen) points carry the noise.
/// Damped Gauss-Newton (Levenberg-Marquardt) on the eight entries with `h22 = 1`; if the
/// algebraic fit can't be put in that form it is returned unchanged.
fn minimise_transfer_error(
    algebraic: Matrix3<f64>,
    src: &[Point],
    dst: &[Point],
    t_src: &nalgebra::Similarity2<f64>,
    t_dst: &nalgebra::Similarity2<f64>,
) -> Matrix3<f64> {
    let corner = algebraic[(2, 2)];
    if corner.abs() < 1e-6 * algebraic.amax() {
        return algebraic;
    }
    let to_params = |m: &Matrix3<f64>| {
        SVector::<f64, 8>::from([
            m[(0, 0)],
            m[(0, 1)],
            m[(0, 2)],
            m[(1, 0)],
            m[(1, 1)],
            m[(1, 2)],
            m[(2, 0)],
            m[(2, 1)],
        ])
    };
    let to_matrix =
        |h: &SVector<f64, 8>| Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], 1.0);
    // Squared error, normal matrix and gradient at `h`, or `None` if a point maps to infinity.
    let linearise = |h: &SVector<f64, 8>| {
        let mut jtj = SMatrix::<f64, 8, 8>::zeros();
        let mut jtr = SVector::<f64, 8>::zeros();
        let mut cost = 0.0;
        for (s, d) in src.iter().zip(dst) {
            let s = t_src.transform_point(s);
            let d = t_dst.transform_point(d);
            let w = h[6] * s.x + h[7] * s.y + 1.0;
            if w.abs() < 1e-12 {
                return None;
            }
            let u = (h[0] * s.x + h[1] * s.y + h[2]) / w;
            let v = (h[3] * s.x + h[4] * s.y + h[5]) / w;
            let (ru, rv) = (u - d.x, v - d.y);
            cost += ru * ru + rv * rv;
            let ju = SVector::<f64, 8>::from([
                s.x / w,
                s.y / w,
                1.0 / w,
                0.0,
                0.0,
                0.0,
                -u * s.x / w,
                -u * s.y / w,
            ]);
            let jv = SVector::<f64, 8>::from([
                0.0,
                0.0,
                0.0,
                s.x / w,
                s.y / w,
                1.0 / w,
                -v * s.x / w,
                -v * s.y / w,
            ]);
            jtj += ju * ju.transpose() + jv * jv.transpose();
            jtr += ju * ru + jv * rv;
        }
        Some((cost, jtj, jtr))
    };
    let mut h = to_params(&(algebraic / corner));
    let Some((mut cost, mut jtj, mut jtr)) = linearise(&h) else {
        return algebraic;
    };
    let mut damping = 1e-3;
    for _ in 0..REFINE_ITERATIONS {
        let mut a = jtj;
        for i in 0..8 {
            a[(i, i)] *= 1.0 + damping;
        }
        let Some(step) = a.cholesky().map(|c| c.solve(&(-jtr))) else {
            break;
        };
        let trial = h + step;
        match linearise(&trial) {
            Some((c, j, g)) if c < cost => {
                let converged = cost - c <= REFINE_CONVERGED * cost;
                (h, cost, jtj, jtr) = (trial, c, j, g);
                damping *= 0.1;
                if converged {
                    break;
                }
            }
            _ => damping *= 10.0,
        }
    }
    to_matrix(&h)
}

/// Scales a matrix so that its bottom-right entry is 1 (OpenCV's convention), when it can.
fn scale_to_unit_corner(m: Matrix3<f64>) -> Matrix3<f64> {
    let c = m[(2, 2)];
    if c.abs() > 1e-12 * m.amax() {
        m / c
    } else {
        m / m.amax()
    }
}

fn check_points(points: &[Point]) -> Result<(), HomographyError> {
    if points.iter().any(|p| !p.x.is_finite() || !p.y.is_finite()) {
        return Err(HomographyError::NonFinite);
    }
    let spread = spread(points);
    for (i, a) in points.iter().enumerate() {
        for (j, b) in points.iter().enumerate().skip(i + 1) {
            if (a - b).norm() <= DUPLICATE_RELATIVE * spread {
                return Err(HomographyError::DuplicatePoints {
                    first: i,
                    second: j,
                });
            }
        }
    }
    Ok(())
}

/// The largest coordinate distance from the first point: a scale for relative tolerances.
fn spread(points: &[Point]) -> f64 {
    let Some(first) = points.first() else {
        return 0.0;
    };
    points.iter().fold(0.0f64, |m, p| m.max((p - first).amax()))
}

fn check_no_three_collinear(points: &[Point; 4]) -> Result<(), HomographyError> {
    let s = spread(points);
    const TRIPLES: [[usize; 3]; 4] = [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]];
    for [a, b, c] in TRIPLES {
        let (pa, pb, pc) = (points[a], points[b], points[c]);
        let cross = (pb - pa).perp(&(pc - pa));
        if cross.abs() <= COLLINEAR_RELATIVE * s * s {
            return Err(HomographyError::CollinearPoints);
        }
    }
    Ok(())
}

/// Hartley's normalisation: centroid to the origin, mean distance from it √2.
fn normalising_transform(points: &[Point]) -> Result<nalgebra::Similarity2<f64>, HomographyError> {
    let n = points.len() as f64;
    let (sx, sy) = points
        .iter()
        .fold((0.0, 0.0), |(x, y), p| (x + p.x, y + p.y));
    let centroid = Point::new(sx / n, sy / n);
    let mean_dist = points.iter().map(|p| (p - centroid).norm()).sum::<f64>() / n;
    if mean_dist.is_nan() || mean_dist <= 0.0 {
        return Err(HomographyError::CollinearPoints);
    }
    // A set spread along one line only (the scatter matrix has rank one) fixes no plane.
    let (sxx, sxy, syy) = points.iter().fold((0.0, 0.0, 0.0), |(a, b, c), p| {
        let d = p - centroid;
        (a + d.x * d.x, b + d.x * d.y, c + d.y * d.y)
    });
    let det = sxx * syy - sxy * sxy;
    let trace = sxx + syy;
    if det <= COLLINEAR_RELATIVE * trace * trace {
        return Err(HomographyError::CollinearPoints);
    }
    let scale = ComplexField::sqrt(2.0f64) / mean_dist;
    Ok(nalgebra::Similarity2::new(
        -centroid.coords * scale,
        0.0,
        scale,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pts(v: &[[f64; 2]]) -> std::vec::Vec<Point> {
        v.iter().map(|&[x, y]| Point::new(x, y)).collect()
    }

    fn numbers(line: &str) -> std::vec::Vec<f64> {
        line.split_whitespace()
            .skip(1)
            .map(|t| t.parse().unwrap())
            .collect()
    }

    const FIXTURE: &str = include_str!("../../tools/opencv/fixtures/homography.txt");

    /// A view of the floor from an oblique camera, as a ground-truth homography.
    fn oblique_view() -> Homography {
        Homography::from_matrix(Matrix3::new(
            2.1, 0.3, 320.0, -0.2, 1.4, 240.0, 0.0004, 0.0021, 1.0,
        ))
        .unwrap()
    }

    #[test]
    fn four_points_match_opencv_get_perspective_transform() {
        let mut cases = 0;
        for line in FIXTURE.lines().filter(|l| l.starts_with("four ")) {
            let v = numbers(line);
            let p = |i: usize| Point::new(v[2 * i], v[2 * i + 1]);
            let src = [p(0), p(1), p(2), p(3)];
            let dst = [p(4), p(5), p(6), p(7)];
            let h = Homography::from_four(&src, &dst).unwrap();
            // OpenCV 5 solves this system with float rounding somewhere: its entries are within
            // 1e-6 (relative) of the exact solution, which ours matches to double precision.
            for (i, want) in v[16..25].iter().enumerate() {
                let got = h.matrix()[(i / 3, i % 3)];
                assert!(
                    (got - want).abs() <= 1e-5 * (1.0 + want.abs()),
                    "{line}: entry {i} {got} vs {want}"
                );
            }
            for (s, d) in src.iter().zip(&dst) {
                assert!((h.apply(s).unwrap() - d).norm() < 1e-9);
            }
            cases += 1;
        }
        assert_eq!(cases, 5);
    }

    #[test]
    fn least_squares_agrees_with_opencv_find_homography() {
        let mut cases = 0;
        for line in FIXTURE.lines().filter(|l| l.starts_with("fit ")) {
            let v = numbers(line);
            let n = v[0] as usize;
            let p = |i: usize| Point::new(v[1 + 2 * i], v[2 + 2 * i]);
            let src: std::vec::Vec<_> = (0..n).map(p).collect();
            let dst: std::vec::Vec<_> = (n..2 * n).map(p).collect();
            let ours = Homography::fit(&src, &dst).unwrap();
            let m = &v[1 + 4 * n..];
            let theirs = Homography::from_matrix(Matrix3::from_row_slice(&m[..9])).unwrap();
            // Both minimise the reprojection error, so they agree far below the noise level.
            for s in &src {
                let d = (ours.apply(s).unwrap() - theirs.apply(s).unwrap()).norm();
                assert!(d < 1e-3, "{line}: {d} px apart");
            }
            cases += 1;
        }
        assert_eq!(cases, 2);
    }

    #[test]
    fn least_squares_is_exact_on_exact_data_in_any_units() {
        let truth = oblique_view();
        for scale in [0.01, 1.0, 1000.0] {
            let src: std::vec::Vec<Point> = (0..12)
                .map(|i| Point::new((i % 4) as f64 * 30.0 * scale, (i / 4) as f64 * 25.0 * scale))
                .collect();
            let m = Matrix3::new(1.0 / scale, 0.0, 0.0, 0.0, 1.0 / scale, 0.0, 0.0, 0.0, 1.0);
            let truth = Homography::from_matrix(truth.matrix() * m).unwrap();
            let dst: std::vec::Vec<Point> = src.iter().map(|p| truth.apply(p).unwrap()).collect();
            let fit = Homography::fit(&src, &dst).unwrap();
            for (s, d) in src.iter().zip(&dst) {
                assert!((fit.apply(s).unwrap() - d).norm() < 1e-6);
            }
        }
    }

    #[test]
    fn floor_mapping_round_trips_and_refuses_the_sky() {
        let truth = oblique_view();
        let floor = pts(&[[0.0, 0.0], [20.0, 0.0], [20.0, 20.0], [0.0, 20.0]]);
        let screen: std::vec::Vec<Point> = floor.iter().map(|p| truth.apply(p).unwrap()).collect();
        let map = FloorMapping::fit(&floor, &screen).unwrap();
        let far = Point::new(150.0, -40.0);
        let back = map
            .screen_to_floor(&map.floor_to_screen(&far).unwrap())
            .unwrap();
        assert!((back - far).norm() < 1e-9);
        // The floor's horizon: w = 0.0004 x + 0.0021 y + 1 = 0. Points beyond it are behind
        // the camera; mapping them would silently give a mirror-image floor position.
        let behind = Point::new(0.0, -1000.0);
        assert_eq!(
            map.floor_to_screen(&behind),
            Err(HomographyError::PointAtInfinity)
        );
        let inv = truth.inverse().unwrap().matrix().clone_owned();
        // A screen point on the horizon line of the inverse.
        let on_horizon = Point::new(0.0, -inv[(2, 2)] / inv[(2, 1)]);
        assert_eq!(
            map.screen_to_floor(&on_horizon),
            Err(HomographyError::PointAtInfinity)
        );
        let away_from_view = (on_horizon.y - screen[0].y).signum();
        let sky = Point::new(0.0, on_horizon.y + 50.0 * away_from_view);
        assert_eq!(
            map.screen_to_floor(&sky),
            Err(HomographyError::PointAtInfinity)
        );
    }

    #[test]
    fn degenerate_inputs_get_typed_errors() {
        let square = pts(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
        let line = pts(&[[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [0.0, 1.0]]);
        let dup = pts(&[[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
        let a = |v: &[Point]| -> [Point; 4] { [v[0], v[1], v[2], v[3]] };
        assert_eq!(
            Homography::from_four(&a(&square), &a(&line)),
            Err(HomographyError::CollinearPoints)
        );
        assert_eq!(
            Homography::from_four(&a(&dup), &a(&square)),
            Err(HomographyError::DuplicatePoints {
                first: 1,
                second: 2
            })
        );
        let all_on_line: std::vec::Vec<Point> = (0..10)
            .map(|i| Point::new(i as f64, 2.0 * i as f64))
            .collect();
        let grid: std::vec::Vec<Point> = (0..10)
            .map(|i| Point::new((i % 5) as f64, (i / 5) as f64))
            .collect();
        assert_eq!(
            Homography::fit(&grid, &all_on_line),
            Err(HomographyError::CollinearPoints)
        );
        assert_eq!(
            Homography::fit(&square[..3], &square[..3]),
            Err(HomographyError::TooFewPoints { got: 3 })
        );
        assert_eq!(
            Homography::fit(&grid, &square),
            Err(HomographyError::LengthMismatch { src: 10, dst: 4 })
        );
        let nan = pts(&[[0.0, 0.0], [1.0, f64::NAN], [1.0, 1.0], [0.0, 1.0]]);
        assert_eq!(
            FloorMapping::fit(&nan, &square),
            Err(HomographyError::NonFinite)
        );
        assert_eq!(
            Homography::from_matrix(Matrix3::zeros()),
            Err(HomographyError::Singular)
        );
    }
}
