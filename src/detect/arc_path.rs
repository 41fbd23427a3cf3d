//! The LED's path during one exposure as the streak fit draws it: a circular arc from `start`
//! to `end` whose middle lies `sagitta` from the chord's middle (a straight line for sagitta
//! 0), travelled at constant speed, drawn as straight pieces.
//!
//! A robot that turns steadily moves on a circle at a steady speed, so the LED halfway through
//! the exposure is halfway along the arc. A quadratic Bézier through the same three points
//! (what the fit drew before) is neither on the circle nor at constant speed along it: on a
//! 60 px streak turning 30–140° its middle was read 0.2–0.7 px off (README, "Accuracy on
//! independently rendered scenes"). The pieces are as many as keep each within
//! [`PIECE_SAGITTA_PX`] of the arc, so a straight streak is one piece and a tight arc up to
//! [`MAX_PIECES`].

/// Most straight pieces an arc is drawn with.
pub const MAX_PIECES: usize = 16;
/// The most a piece may stray from the arc it stands for, at its middle.
const PIECE_SAGITTA_PX: f64 = 0.1;
/// The path's parameters: start x, y, end x, y, sagitta.
pub const PATH_PARAMS: usize = 5;
/// The step the corners' slopes in the parameters are taken over (central differences, in
/// f64, so that rounding is far below it).
const SLOPE_STEP_PX: f64 = 1e-3;

/// The arc's corners and how they move with the path's parameters.
#[derive(Clone, Copy)]
pub struct ArcPieces {
    /// Corners `0..=count`, from start to end.
    pub corners: [(f32, f32); MAX_PIECES + 1],
    /// Pieces drawn (at least 1).
    pub count: usize,
    /// `slopes[i][axis][j]`: corner `i`'s x (axis 0) or y (axis 1) per unit of parameter `j`.
    pub slopes: [[[f32; PATH_PARAMS]; 2]; MAX_PIECES + 1],
    /// The point halfway along the arc, and its slopes.
    pub mid: (f32, f32),
    pub mid_slopes: [[f32; PATH_PARAMS]; 2],
}

impl ArcPieces {
    /// The arc of `params` (start x, y, end x, y, sagitta), with the corners' slopes in them
    /// when `with_slopes` (the normal equations need them; a cost evaluation does not, and
    /// they take ten times the corners' work).
    pub fn new(params: [f32; PATH_PARAMS], with_slopes: bool) -> ArcPieces {
        ArcPieces::drawn(params, with_slopes, 1)
    }

    /// The arc of `params` with the corners' slopes, in at least two pieces. A path within the
    /// tolerance of straight is one piece, whose two corners do not move with the sagitta, so
    /// its slope in the sagitta is zero there; two collinear pieces draw the same light and
    /// give the bend its slope (their shared corner moves with it).
    pub fn bendable(params: [f32; PATH_PARAMS]) -> ArcPieces {
        ArcPieces::drawn(params, true, 2)
    }

    fn drawn(params: [f32; PATH_PARAMS], with_slopes: bool, min_pieces: usize) -> ArcPieces {
        let p = params.map(f64::from);
        let arc = arc_of(p);
        let count = arc.piece_count().max(min_pieces);
        let (corners, mid) = arc.points(count);
        let mut out = ArcPieces {
            corners: [(0.0, 0.0); MAX_PIECES + 1],
            count,
            slopes: [[[0.0; PATH_PARAMS]; 2]; MAX_PIECES + 1],
            mid: to_f32(mid),
            mid_slopes: [[0.0; PATH_PARAMS]; 2],
        };
        for (c, &point) in out.corners.iter_mut().zip(&corners).take(count + 1) {
            *c = to_f32(point);
        }
        if with_slopes {
            // Central differences, the piece count held.
            for j in 0..PATH_PARAMS {
                let (mut up, mut down) = (p, p);
                up[j] += SLOPE_STEP_PX;
                down[j] -= SLOPE_STEP_PX;
                let ((cu, mu), (cd, md)) = (arc_of(up).points(count), arc_of(down).points(count));
                let slope = |a: f64, b: f64| ((a - b) / (2.0 * SLOPE_STEP_PX)) as f32;
                for i in 0..=count {
                    out.slopes[i][0][j] = slope(cu[i].0, cd[i].0);
                    out.slopes[i][1][j] = slope(cu[i].1, cd[i].1);
                }
                out.mid_slopes[0][j] = slope(mu.0, md.0);
                out.mid_slopes[1][j] = slope(mu.1, md.1);
            }
        }
        out
    }

    /// A gradient in the corners (`at_corners[i]`: ∂/∂x, ∂/∂y of corner `i`) carried to the
    /// path's parameters.
    pub fn gradient(&self, at_corners: &[(f32, f32); MAX_PIECES + 1]) -> [f32; PATH_PARAMS] {
        let mut out = [0.0f32; PATH_PARAMS];
        for (g, [sx, sy]) in at_corners.iter().zip(&self.slopes).take(self.count + 1) {
            for (o, (dx, dy)) in out.iter_mut().zip(sx.iter().zip(sy)) {
                *o += g.0 * dx + g.1 * dy;
            }
        }
        out
    }

    /// A gradient in the middle carried to the path's parameters.
    pub fn mid_gradient(&self, at_mid: (f32, f32)) -> [f32; PATH_PARAMS] {
        let [sx, sy] = &self.mid_slopes;
        let mut out = [0.0f32; PATH_PARAMS];
        for (o, (dx, dy)) in out.iter_mut().zip(sx.iter().zip(sy)) {
            *o = at_mid.0 * dx + at_mid.1 * dy;
        }
        out
    }
}

fn to_f32((x, y): (f64, f64)) -> (f32, f32) {
    (x as f32, y as f32)
}

/// The chord's middle, unit direction and half length; the half turn angle `θ` (the arc
/// turns `2θ`) and `A = Rθ`, half the arc's length, both finite on a straight path.
struct Arc {
    mid: (f64, f64),
    unit: (f64, f64),
    sagitta: f64,
    half_turn: f64,
    half_length: f64,
}

fn arc_of(p: [f64; PATH_PARAMS]) -> Arc {
    let (dx, dy) = (p[2] - p[0], p[3] - p[1]);
    let chord = dx.hypot(dy);
    let unit = if chord > 1e-12 {
        (dx / chord, dy / chord)
    } else {
        (1.0, 0.0)
    };
    let (h, s) = (0.5 * chord, p[4]);
    // R = (h² + s²) / 2s and θ = 2 atan(s / h), so A = Rθ = (h² + s²) atan(s/h) / s, whose
    // limit for s → 0 is h.
    let (half_turn, half_length) = if h < 1e-12 {
        (0.0, 0.0)
    } else {
        let ratio = s / h;
        let atan_over_ratio = if ratio.abs() < 1e-6 {
            1.0 - ratio * ratio / 3.0
        } else {
            ratio.atan() / ratio
        };
        (2.0 * ratio.atan(), (h * h + s * s) * atan_over_ratio / h)
    };
    Arc {
        mid: (0.5 * (p[0] + p[2]), 0.5 * (p[1] + p[3])),
        unit,
        sagitta: s,
        half_turn,
        half_length,
    }
}

impl Arc {
    /// The point a fraction `tau` of the way along the arc. With `k = 2τ − 1` and `φ = kθ`,
    /// it lies `R sin φ = A k sinc φ` along the chord from its middle and `s − R(1 − cos φ) =
    /// s − A k² θ/2 · sinc²(φ/2)` along its left normal: at `τ = 0` that is `−h` and `0`, the
    /// start.
    fn point(&self, tau: f64) -> (f64, f64) {
        let k = 2.0 * tau - 1.0;
        let phi = k * self.half_turn;
        let along = self.half_length * k * sinc(phi);
        let half = sinc(0.5 * phi);
        let across = self.sagitta - self.half_length * k * k * 0.5 * self.half_turn * half * half;
        let (d, n) = (self.unit, (-self.unit.1, self.unit.0));
        (
            self.mid.0 + along * d.0 + across * n.0,
            self.mid.1 + along * d.1 + across * n.1,
        )
    }

    /// As many pieces as keep each piece's sagitta, `R(1 − cos(θ/n)) ≈ Rθ²/2n²`, within
    /// [`PIECE_SAGITTA_PX`]: `n = √(Aθ / 2·tolerance)`.
    fn piece_count(&self) -> usize {
        let n = (self.half_length * self.half_turn.abs() / (2.0 * PIECE_SAGITTA_PX))
            .sqrt()
            .ceil();
        if n.is_finite() {
            (n as usize).clamp(1, MAX_PIECES)
        } else {
            MAX_PIECES
        }
    }

    /// The corners `0..=count` at equal steps along the arc, and its middle.
    fn points(&self, count: usize) -> ([(f64, f64); MAX_PIECES + 1], (f64, f64)) {
        let mut corners = [(0.0, 0.0); MAX_PIECES + 1];
        for (i, c) in corners.iter_mut().enumerate().take(count + 1) {
            *c = self.point(i as f64 / count as f64);
        }
        (corners, self.point(0.5))
    }
}

fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-4 {
        1.0 - x * x / 6.0
    } else {
        x.sin() / x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dist(a: (f32, f32), b: (f64, f64)) -> f64 {
        (f64::from(a.0) - b.0).hypot(f64::from(a.1) - b.1)
    }

    /// A path from `start` turning `turn_rad` on a circle of `radius_px` around `centre`.
    fn on_circle(centre: (f64, f64), radius_px: f64, from_rad: f64, turn_rad: f64) -> [f32; 5] {
        let at = |a: f64| {
            (
                centre.0 + radius_px * a.cos(),
                centre.1 + radius_px * a.sin(),
            )
        };
        let (s, e, m) = (
            at(from_rad),
            at(from_rad + turn_rad),
            at(from_rad + 0.5 * turn_rad),
        );
        // The sagitta: the middle's distance from the chord along the chord's left normal.
        let (dx, dy) = (e.0 - s.0, e.1 - s.1);
        let len = dx.hypot(dy);
        let sagitta = ((m.0 - 0.5 * (s.0 + e.0)) * -dy + (m.1 - 0.5 * (s.1 + e.1)) * dx) / len;
        [s.0, s.1, e.0, e.1, sagitta].map(|v| v as f32)
    }

    #[test]
    fn the_corners_lie_on_the_circle_at_equal_steps() {
        let centre = (100.0, 80.0);
        for (radius, turn) in [(25.0, 2.4), (25.0, -2.4), (60.0, 0.5), (120.0, -0.2)] {
            let pieces = ArcPieces::new(on_circle(centre, radius, 0.7, turn), false);
            assert!(pieces.count > 1, "{radius} {turn}");
            for (i, &c) in pieces.corners.iter().take(pieces.count + 1).enumerate() {
                let a = 0.7 + turn * i as f64 / pieces.count as f64;
                let truth = (centre.0 + radius * a.cos(), centre.1 + radius * a.sin());
                assert!(dist(c, truth) < 1e-3, "corner {i}: {c:?} {truth:?}");
            }
            let a = 0.7 + 0.5 * turn;
            let mid = (centre.0 + radius * a.cos(), centre.1 + radius * a.sin());
            assert!(dist(pieces.mid, mid) < 1e-3);
            // Each piece strays from the arc by at most the tolerance, at its middle, unless
            // the arc takes the most pieces.
            let step = turn.abs() / pieces.count as f64;
            let stray_px = radius * (1.0 - (0.5 * step).cos());
            assert!(
                stray_px <= PIECE_SAGITTA_PX + 1e-9 || pieces.count == MAX_PIECES,
                "{radius} {turn}: {} pieces stray {stray_px} px",
                pieces.count
            );
        }
    }

    #[test]
    fn a_straight_path_is_one_piece_at_constant_speed() {
        let pieces = ArcPieces::new([10.0, 20.0, 70.0, 20.0, 0.0], false);
        assert_eq!(pieces.count, 1);
        assert_eq!(pieces.corners[0], (10.0, 20.0));
        assert_eq!(pieces.corners[1], (70.0, 20.0));
        assert_eq!(pieces.mid, (40.0, 20.0));
        // A sagitta far below the tolerance keeps it one piece, and on the chord.
        let nearly = ArcPieces::new([10.0, 20.0, 70.0, 20.0, 1e-3], false);
        assert_eq!(nearly.count, 1);
    }

    /// A straight path drawn bendable is two collinear pieces: its ends do not move with the
    /// sagitta, and its middle corner moves along the chord's left normal as fast as the
    /// sagitta grows.
    #[test]
    fn a_bendable_straight_path_moves_its_middle_with_the_sagitta() {
        let straight = [10.0, 20.0, 70.0, 50.0, 0.0];
        let pieces = ArcPieces::bendable(straight);
        assert_eq!(pieces.count, 2);
        assert_eq!(ArcPieces::new(straight, true).count, 1);
        let (mid, ends) = (pieces.corners[1], [pieces.corners[0], pieces.corners[2]]);
        assert!(
            (mid.0 - 40.0).abs() < 1e-4 && (mid.1 - 35.0).abs() < 1e-4,
            "{mid:?}"
        );
        assert_eq!(ends, [(10.0, 20.0), (70.0, 50.0)]);
        let chord = 60f32.hypot(30.0);
        let normal = (-30.0 / chord, 60.0 / chord);
        let [sx, sy] = pieces.slopes[1];
        assert!((sx[4] - normal.0).abs() < 1e-3 && (sy[4] - normal.1).abs() < 1e-3);
        for end in [0, 2] {
            let [ex, ey] = pieces.slopes[end];
            assert!(ex[4].abs() < 1e-4 && ey[4].abs() < 1e-4, "corner {end}");
        }
    }

    #[test]
    fn the_slopes_are_those_of_the_corners() {
        let p = on_circle((50.0, 50.0), 30.0, 0.2, 1.5);
        let pieces = ArcPieces::new(p, true);
        for j in 0..PATH_PARAMS {
            let (mut up, mut down) = (p, p);
            up[j] += 0.01;
            down[j] -= 0.01;
            let (u, d) = (ArcPieces::new(up, false), ArcPieces::new(down, false));
            assert_eq!((u.count, d.count), (pieces.count, pieces.count));
            for i in 0..=pieces.count {
                for axis in 0..2 {
                    let pick = |c: (f32, f32)| f64::from(if axis == 0 { c.0 } else { c.1 });
                    let slope = (pick(u.corners[i]) - pick(d.corners[i])) / 0.02;
                    let got = f64::from(pieces.slopes[i][axis][j]);
                    assert!(
                        (slope - got).abs() < 2e-3,
                        "corner {i} axis {axis} param {j}"
                    );
                }
            }
        }
    }
}
