//! The streak model's light: the LED's spot (a Gaussian core and a Gaussian glow) swept along
//! its path, drawn as straight pieces, with the light's slopes in the path and the spots'
//! widths in closed form (see [`Path::lights`]).

use super::{dist, path_of, Params, PATH_PARAMS};
use crate::detect::arc_path::{ArcPieces, MAX_PIECES};
use crate::detect::normal::{normal_cdf, normal_cdf_and_density};

/// The arc of parameters `p`, drawn as straight pieces ([`ArcPieces`]).
pub(super) struct Path {
    /// Each piece's start, unit direction and length; the first `arc.count` are drawn.
    pieces: [Piece; MAX_PIECES],
    length: f32,
    /// The corners and their slopes in the path's parameters, for the derivatives.
    pub(super) arc: ArcPieces,
    /// How the path's length moves with each corner: `∂L/∂E = d` for a piece's end and
    /// `∂L/∂S = −d` for its start (`d` its direction), summed over the pieces that share it.
    length_at_corners: [(f32, f32); MAX_PIECES + 1],
    /// The core's and the glow's σ as the pixels see them: widened by the pixel's own area
    /// ([`PIXEL_VARIANCE_PX2`]).
    sigmas: [f32; 2],
    /// How the seen σ's logarithm moves with the spot's own (`σ² / σ_seen²`): the lights'
    /// slopes are taken in the seen σ and carried to the fitted one by it.
    ln_sigma_slopes: [f32; 2],
    /// Components whose light is drawn: the core alone while the glow is left out (the
    /// first stage), which halves that stage's cost.
    components: usize,
    /// The light laid along the path per pixel of it, relative to its mean, is
    /// `1 + gradient (s/L − ½)` at `s` of the path's `L` from its start: an LED that speeds
    /// up during the exposure lays less light at its fast end (see
    /// [`super::samples::Samples::gradient`]).
    gradient: f32,
}

#[derive(Clone, Copy, Default)]
struct Piece {
    start: (f32, f32),
    unit: (f32, f32),
    length: f32,
}

impl Path {
    /// The path of `p`, with the glow's light drawn when `glow` (else it reads zero), and
    /// the light laid along it with `gradient` ([`Path::gradient`]).
    pub(super) fn new(p: &Params, glow: bool, gradient: f32) -> Path {
        Path::drawn(p, glow, ArcPieces::new(path_of(p), false), gradient)
    }

    /// The path of `p` with its corners' slopes in the path's parameters, for
    /// [`Path::lights`]; with `bend`, in at least two pieces, so that a straight path's
    /// sagitta has a slope too ([`ArcPieces::bendable`]).
    pub(super) fn with_slopes(p: &Params, glow: bool, bend: bool, gradient: f32) -> Path {
        let arc = if bend {
            ArcPieces::bendable(path_of(p))
        } else {
            ArcPieces::new(path_of(p), true)
        };
        Path::drawn(p, glow, arc, gradient)
    }

    fn drawn(p: &Params, glow: bool, arc: ArcPieces, gradient: f32) -> Path {
        let mut pieces = [Piece::default(); MAX_PIECES];
        let mut length = 0.0;
        let mut length_at_corners = [(0.0f32, 0.0f32); MAX_PIECES + 1];
        for (k, (piece, ends)) in pieces
            .iter_mut()
            .zip(arc.corners.windows(2))
            .take(arc.count)
            .enumerate()
        {
            let (s, e) = (ends[0], ends[1]);
            let l = dist(s, e);
            let unit = if l > 1e-6 {
                ((e.0 - s.0) / l, (e.1 - s.1) / l)
            } else {
                (1.0, 0.0)
            };
            *piece = Piece {
                start: s,
                unit,
                length: l,
            };
            length += l;
            if let Some(c) = length_at_corners.get_mut(k) {
                *c = (c.0 - unit.0, c.1 - unit.1);
            }
            if let Some(c) = length_at_corners.get_mut(k + 1) {
                *c = (c.0 + unit.0, c.1 + unit.1);
            }
        }
        // The spot's own variances, which the pixel's area widens.
        let variances = [p[5], p[6]].map(|ln_sigma| ln_sigma.exp().powi(2));
        Path {
            pieces,
            length,
            arc,
            length_at_corners,
            sigmas: variances.map(|v| (v + PIXEL_VARIANCE_PX2).sqrt()),
            ln_sigma_slopes: variances.map(|v| v / (v + PIXEL_VARIANCE_PX2)),
            components: if glow { 2 } else { 1 },
            gradient,
        }
    }

    pub(super) fn length(&self) -> f32 {
        self.length
    }

    /// The light laid along a piece that starts `piece_start_px` along the path, per pixel
    /// of it, as `c0 + c1 τ` at `τ` along the piece (see [`Path::gradient`]).
    fn density_along(&self, piece_start_px: f32) -> (f32, f32) {
        let c1 = self.gradient / self.length;
        (1.0 + c1 * piece_start_px - 0.5 * self.gradient, c1)
    }

    /// The swept Gaussians' light at `(x, y)` (core, glow), each relative to a still spot's
    /// centre: the spot's line integral along the path over the path's length.
    pub(super) fn light2(&self, x: f32, y: f32) -> (f32, f32) {
        let mut out = [0.0f32; 2];
        for (light, &sigma) in out.iter_mut().zip(&self.sigmas).take(self.components) {
            let inv = 1.0 / sigma;
            if self.length < STILL_PATH_SIGMAS * sigma {
                let (dx, dy) = (x - self.arc.mid.0, y - self.arc.mid.1);
                *light = (-0.5 * (dx * dx + dy * dy) * inv * inv).exp();
                continue;
            }
            let mut sum = 0.0;
            let mut start_px = 0.0;
            for piece in self.pieces.iter().take(self.arc.count) {
                let piece_start_px = start_px;
                start_px += piece.length;
                if piece.length < MIN_PIECE_PX {
                    continue;
                }
                let (px, py) = (x - piece.start.0, y - piece.start.1);
                let across = (px * -piece.unit.1 + py * piece.unit.0) * inv;
                if across.abs() > ACROSS_REACH_SIGMAS {
                    continue;
                }
                let along = (px * piece.unit.0 + py * piece.unit.1) * inv;
                if beyond_piece(along, piece.length * inv) {
                    continue;
                }
                let length = piece.length * inv;
                if self.gradient == 0.0 {
                    let span = normal_cdf(along) - normal_cdf(along - length);
                    if span > 0.0 {
                        sum += (-0.5 * across * across).exp() * span;
                    }
                    continue;
                }
                let (cdf_s, density_s) = normal_cdf_and_density(along);
                let (cdf_e, density_e) = normal_cdf_and_density(along - length);
                // In units of σ√(2π): the light laid evenly, and its first moment along the
                // piece over σ (see [`Path::swept_light`]).
                let even = cdf_s - cdf_e;
                let moment = along * even - (density_e - density_s);
                let (c0, c1) = self.density_along(piece_start_px);
                sum += (-0.5 * across * across).exp() * (c0 * even + c1 * sigma * moment);
            }
            *light = sum * SQRT_TAU * sigma / self.length;
        }
        (out[0], out[1])
    }

    /// The light of [`Path::light2`] with its derivatives in the path's parameters and in
    /// each component's `ln σ`, in closed form: one evaluation of each piece gives all
    /// of them, where differencing took a model evaluation per parameter.
    pub(super) fn lights(&self, x: f32, y: f32) -> [Light; 2] {
        let mut out = [Light::default(); 2];
        for ((light, &sigma), &slope) in out
            .iter_mut()
            .zip(&self.sigmas)
            .zip(&self.ln_sigma_slopes)
            .take(self.components)
        {
            *light = if self.length < STILL_PATH_SIGMAS * sigma {
                self.still_light(x, y, sigma)
            } else {
                self.swept_light(x, y, sigma)
            };
            light.d_ln_sigma *= slope;
        }
        out
    }

    /// A still spot at the middle, `exp(−r²/2σ²)`: its slope in the middle is `r/σ² ·` that.
    fn still_light(&self, x: f32, y: f32, sigma: f32) -> Light {
        let inv2 = 1.0 / (sigma * sigma);
        let (dx, dy) = (x - self.arc.mid.0, y - self.arc.mid.1);
        let r2 = (dx * dx + dy * dy) * inv2;
        let value = (-0.5 * r2).exp();
        // The middle is the arc's point at half time.
        let path = self
            .arc
            .mid_gradient((value * dx * inv2, value * dy * inv2));
        Light {
            value,
            d_path: path,
            d_ln_sigma: value * r2,
        }
    }

    /// The swept spot. For one piece from `S` to `E` (length `L`, direction `d`, normal `n`),
    /// at a pixel `t` along it and `c` across it, the light is
    /// `I = e^(−c²/2σ²) σ√(2π) (Φ(t/σ) − Φ((t−L)/σ))`, whose slopes in `t`, `c`, `L` and `σ`
    /// are closed forms in the same normal densities; `t`, `c` and `L` move with the corners
    /// as `∂I/∂E = (I_t c/L − I_c t/L) n + I_L d` and `∂I/∂S = −∂I/∂X − ∂I/∂E`, with
    /// `∂I/∂X = I_t d + I_c n` (moving the pixel is moving the piece the other way).
    fn swept_light(&self, x: f32, y: f32, sigma: f32) -> Light {
        let inv = 1.0 / sigma;
        let (mut sum, mut d_sigma_sum) = (0.0f32, 0.0f32);
        // ∂(Σ I)/∂ corner, and the path's length per corner (∂L/∂E = d, ∂L/∂S = −d).
        let mut at_corners = [(0.0f32, 0.0f32); MAX_PIECES + 1];
        // With a gradient, the light of a piece also moves with the whole length and with
        // where the piece starts along the path: ∂(Σ I)/∂(whole length), and per piece
        // ∂I/∂(its start along the path).
        let mut at_total = 0.0f32;
        let mut at_start = [0.0f32; MAX_PIECES];
        let mut start_px = 0.0f32;
        for (k, piece) in self.pieces.iter().enumerate().take(self.arc.count) {
            let piece_start_px = start_px;
            start_px += piece.length;
            let d = piece.unit;
            if piece.length < MIN_PIECE_PX {
                continue;
            }
            let n = (-d.1, d.0);
            let (px, py) = (x - piece.start.0, y - piece.start.1);
            let across = (px * n.0 + py * n.1) * inv;
            if across.abs() > ACROSS_REACH_SIGMAS {
                continue;
            }
            let along = (px * d.0 + py * d.1) * inv;
            let length = piece.length * inv;
            if beyond_piece(along, length) {
                continue;
            }
            let (cdf_s, density_s) = normal_cdf_and_density(along);
            let (cdf_e, density_e) = normal_cdf_and_density(along - length);
            let span = cdf_s - cdf_e;
            if span <= 0.0 {
                continue;
            }
            // e^(−c²/2σ²) √(2π): the densities' constant folded in.
            let across_weight = (-0.5 * across * across).exp() * SQRT_TAU;
            let even = across_weight * sigma * span;
            let even_t = across_weight * (density_s - density_e);
            let even_sigma = even * (across * across + 1.0) * inv
                + across_weight * ((along - length) * density_e - along * density_s);
            let (i, i_t, i_l, i_sigma) = if self.gradient == 0.0 {
                (even, even_t, across_weight * density_e, even_sigma)
            } else {
                // The light laid evenly (B above) and its first moment along the piece,
                // M = ∫ τ e^(−(t−τ)²/2σ²) dτ = t B + σ² (e_0 − e_L), each times e^(−c²/2σ²)
                // (e the densities at the piece's ends, with the constant above): the piece's
                // light is c0 B + c1 M for the density c0 + c1 τ. M's slopes: in t,
                // B − L e_L; in L, L e_L; in σ, t ∂B/∂σ + 2σ (e_0 − e_L) + σ (u_0² e_0 −
                // u_L² e_L) with the across part c²/σ³ (M − t B) = c²/σ (e_0 − e_L) (u = the
                // ends' along / σ).
                let (c0, c1) = self.density_along(piece_start_px);
                let t_px = along * sigma;
                let ends = across_weight * (density_s - density_e);
                let at_end_density = piece.length * across_weight * density_e;
                let moment = t_px * even + sigma * sigma * ends;
                let moment_sigma = t_px * even_sigma
                    + 2.0 * sigma * ends
                    + sigma
                        * across_weight
                        * (along * along * density_s - (along - length).powi(2) * density_e)
                    + across * across * sigma * ends;
                let i = c0 * even + c1 * moment;
                at_total -=
                    self.gradient * (piece_start_px * even + moment) / (self.length * self.length);
                if let Some(a) = at_start.get_mut(k) {
                    *a = c1 * even;
                }
                (
                    i,
                    c0 * even_t + c1 * (even - at_end_density),
                    c0 * across_weight * density_e + c1 * at_end_density,
                    c0 * even_sigma + c1 * moment_sigma,
                )
            };
            let i_c = -across * inv * i;
            sum += i;
            d_sigma_sum += i_sigma;
            let bend = (i_t * across - i_c * along) / length;
            let at_end = (bend * n.0 + i_l * d.0, bend * n.1 + i_l * d.1);
            let at_pixel = (i_t * d.0 + i_c * n.0, i_t * d.1 + i_c * n.1);
            if let Some(s) = at_corners.get_mut(k) {
                *s = (s.0 - at_pixel.0 - at_end.0, s.1 - at_pixel.1 - at_end.1);
            }
            if let Some(e) = at_corners.get_mut(k + 1) {
                *e = (e.0 + at_end.0, e.1 + at_end.1);
            }
        }
        if self.gradient != 0.0 {
            self.gradient_slopes(&mut at_corners, &at_start, at_total);
        }
        // The light is Σ I / length: its slope is (∂ΣI − light ∂length) / length.
        let inv_length = 1.0 / self.length;
        let value = sum * inv_length;
        let corners = self.arc.count + 1;
        for (g, l) in at_corners
            .iter_mut()
            .zip(&self.length_at_corners)
            .take(corners)
        {
            *g = (
                (g.0 - value * l.0) * inv_length,
                (g.1 - value * l.1) * inv_length,
            );
        }
        Light {
            value,
            d_path: self.arc.gradient(&at_corners),
            d_ln_sigma: sigma * d_sigma_sum * inv_length,
        }
    }

    /// Adds to `at_corners` (∂(Σ I)/∂ corner) what a gradient along the path adds: the whole
    /// length moves with every corner (`at_total` of light per pixel of it, along
    /// [`Path::length_at_corners`]), and a piece's start along the path with the pieces before it
    /// (`at_start` per piece: piece j's length moves its end corner along its direction and
    /// its start corner against it).
    fn gradient_slopes(
        &self,
        at_corners: &mut [(f32, f32); MAX_PIECES + 1],
        at_start: &[f32; MAX_PIECES],
        at_total: f32,
    ) {
        let mut later = 0.0f32;
        for (j, piece) in self.pieces.iter().enumerate().take(self.arc.count).rev() {
            let d = piece.unit;
            if let Some(s) = at_corners.get_mut(j) {
                *s = (s.0 - later * d.0, s.1 - later * d.1);
            }
            if let Some(e) = at_corners.get_mut(j + 1) {
                *e = (e.0 + later * d.0, e.1 + later * d.1);
            }
            later += at_start.get(j).copied().unwrap_or(0.0);
        }
        let corners = self.arc.count + 1;
        for (c, l) in at_corners
            .iter_mut()
            .zip(&self.length_at_corners)
            .take(corners)
        {
            *c = (c.0 + at_total * l.0, c.1 + at_total * l.1);
        }
    }
}

/// One component's light at a pixel and its slopes.
#[derive(Clone, Copy, Default)]
pub(super) struct Light {
    pub(super) value: f32,
    /// In the path's parameters: start x, y, end x, y, sagitta.
    pub(super) d_path: [f32; PATH_PARAMS],
    /// In the component's `ln σ`.
    pub(super) d_ln_sigma: f32,
}

/// A pixel reads the mean of the light over its area, a unit square: along each axis, a box
/// of variance 1/12 px². The model's Gaussians are widened by it (a box is near enough a
/// Gaussian of its variance once blurred by the spot), so that a spot narrower than a pixel is
/// drawn as the pixels see it. Drawn at their centres alone, a 0.83 px disk's streak (sweep
/// seed 11, point 111) fitted σ at its lower bound, a residual of 9 luma and ends uncertain
/// by 11 px, so that the moving streak read still and its head came 3.5 px off.
const PIXEL_VARIANCE_PX2: f32 = 1.0 / 12.0;

/// A path shorter than this many σ is drawn as a still spot at its middle.
const STILL_PATH_SIGMAS: f32 = 1e-3;
/// A piece shorter than this draws nothing.
const MIN_PIECE_PX: f32 = 1e-6;
/// Pixels farther than this many σ across a piece, or beyond its ends, get none of its light.
const ACROSS_REACH_SIGMAS: f32 = 5.0;

pub(super) const SQRT_TAU: f32 = 2.506_628_3;

/// Whether a pixel `along` σ along a piece `length` σ long lies beyond either end by more than
/// [`ACROSS_REACH_SIGMAS`]: the piece's light and slopes there are below 3·10⁻⁷ of a still
/// spot's, and an arc drawn by many pieces would otherwise evaluate every piece at every pixel.
#[inline]
fn beyond_piece(along: f32, length: f32) -> bool {
    along < -ACROSS_REACH_SIGMAS || along - length > ACROSS_REACH_SIGMAS
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::fit::tests::{paths, pixels_around};

    #[test]
    fn the_lights_slopes_are_those_of_its_values() {
        // Laid evenly along the path, and unevenly (a fast end, then a slow one), whose
        // light's slopes have their own terms.
        for (gradient, p) in [0.0, 0.3, -0.6]
            .into_iter()
            .flat_map(|g| paths().map(move |p| (g, p)))
        {
            let path = Path::with_slopes(&p, true, false, gradient);
            // A still path stays still under the step: f32 cannot resolve the light of a
            // path a few thousandths of a pixel long, which is why that is drawn as a spot.
            let path_h = if path.length < 0.1 { 5e-4 } else { 2e-3 };
            for (x, y) in pixels_around(&p) {
                let lights = path.lights(x, y);
                let (core, glow) = path.light2(x, y);
                assert!((lights[0].value - core).abs() < 1e-6, "{p:?} at {x}, {y}");
                assert!((lights[1].value - glow).abs() < 1e-6, "{p:?} at {x}, {y}");
                for j in 0..PATH_PARAMS + 2 {
                    let h = if j < PATH_PARAMS { path_h } else { 1e-3 };
                    let light_at = |delta: f32| {
                        let mut q = p;
                        q[j] += delta;
                        Path::new(&q, true, gradient).light2(x, y)
                    };
                    let (plus, minus) = (light_at(h), light_at(-h));
                    let numeric = [
                        (plus.0 - minus.0) / (2.0 * h),
                        (plus.1 - minus.1) / (2.0 * h),
                    ];
                    let analytic = match j {
                        5 => [lights[0].d_ln_sigma, 0.0],
                        6 => [0.0, lights[1].d_ln_sigma],
                        _ => [lights[0].d_path[j], lights[1].d_path[j]],
                    };
                    for (n, a) in numeric.iter().zip(&analytic) {
                        assert!(
                            (n - a).abs() < 2e-3 + 1e-2 * n.abs(),
                            "parameter {j} of {p:?}, gradient {gradient}, at ({x}, {y}): differences \
                             {n}, closed form {a}"
                        );
                    }
                }
            }
        }
    }
}
