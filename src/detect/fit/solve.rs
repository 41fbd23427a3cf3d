//! Levenberg–Marquardt on the streak model: the model's luma at a pixel, the residuals (a
//! clipped pixel says "at least the clip"), the cost and the normal equations with the model's
//! slopes in closed form, in the fitted coordinates where the model's valleys run straight.

use super::samples::Samples;
use super::swept::Path;
use super::{
    clamp_params, Normal, Params, CONVERGED_COST, GLOW_RATIO, LN_AMPLITUDE, MAX_ITERATIONS,
    MAX_PATH_STEP_PX, PARAMS, PATH_PARAMS, PEDESTAL, SAGITTA, SETTLED_COST, SETTLED_PATH_PX, TONE,
    TONE_RANGE,
};

/// The fitted parameters of the model's `p`: the spot's widths and amplitude as the pixels
/// see them through the tone curve: `ln σ − ½ ln k` for each width (a Gaussian seen through
/// `v^k` is `1/√k` as wide) and `k ln A` for the amplitude (its peak's log luma). The model is
/// nearly unchanged along `σ²/k` and `A^k` constant (exactly so across the path, on a dark
/// floor), a curved valley in `(ln σ, ln A, k)` that Levenberg–Marquardt's straight steps
/// crept along to the iteration cap; in these coordinates the valley runs along `k` alone.
pub(super) fn fitted(p: &Params) -> Params {
    let mut t = *p;
    let half_ln_k = 0.5 * p[TONE].ln();
    t[5] -= half_ln_k;
    t[6] -= half_ln_k;
    t[LN_AMPLITUDE] *= p[TONE];
    t
}

/// The model's parameters of the fitted `t` (the inverse of [`fitted`]).
pub(super) fn native(t: &Params) -> Params {
    let mut p = *t;
    let half_ln_k = 0.5 * t[TONE].ln();
    p[5] += half_ln_k;
    p[6] += half_ln_k;
    p[LN_AMPLITUDE] /= t[TONE];
    p
}

/// [`clamp_params`] on fitted parameters.
pub(super) fn clamp_fitted(mut t: Params) -> Params {
    t[TONE] = t[TONE].clamp(TONE_RANGE.0, TONE_RANGE.1);
    fitted(&clamp_params(native(&t)))
}

/// Holds the parameters not `active` in the normal equations `jtj`, `jtr`: their rows and
/// columns zero, a unit diagonal, so that a step leaves them where they are and the matrix
/// stays invertible.
pub(super) fn hold_inactive(jtj: &mut Normal, jtr: &mut Params, active: &[bool; PARAMS]) {
    for (i, &on) in active.iter().enumerate() {
        if !on {
            jtj.row_mut(i).fill(0.0);
            jtj.column_mut(i).fill(0.0);
            jtj[(i, i)] = 1.0;
            jtr[i] = 0.0;
        }
    }
}

/// Levenberg–Marquardt from `p` over the parameters marked `active` (the others stay
/// put), at most [`MAX_ITERATIONS`] iterations. Returns the parameters and the cost.
pub(super) fn levenberg_marquardt(
    samples: &Samples,
    mut p: Params,
    clip: f32,
    active: &[bool; PARAMS],
) -> Option<(Params, f32)> {
    let mut cost = cost_of(samples, &p, clip, active, f32::INFINITY)?;
    let mut lambda = 1e-2f32;
    for _ in 0..MAX_ITERATIONS {
        let (mut jtj, mut jtr) = normal_equations(samples, &p, clip, active, None)?;
        hold_inactive(&mut jtj, &mut jtr, active);
        let mut improved = false;
        for _ in 0..4 {
            let mut damped = jtj;
            for i in 0..PARAMS {
                damped[(i, i)] += lambda * jtj[(i, i)].max(1e-6);
            }
            let Some(mut step) = damped.cholesky().map(|c| c.solve(&jtr)) else {
                lambda *= 10.0;
                continue;
            };
            // A trust region on the path: no point of it moves more than a few pixels a step.
            let reach = step.rows(0, PATH_PARAMS).amax();
            if reach > MAX_PATH_STEP_PX {
                step *= MAX_PATH_STEP_PX / reach;
            }
            let trial = clamp_fitted(p + step);
            match cost_of(samples, &trial, clip, active, cost) {
                Some(c) if c < cost => {
                    let path_moved_px = (trial - p).rows(0, PATH_PARAMS).amax();
                    let converged = (cost - c) < CONVERGED_COST * cost
                        || (path_moved_px < SETTLED_PATH_PX && (cost - c) < SETTLED_COST * cost);
                    p = trial;
                    cost = c;
                    lambda = (lambda * 0.3).max(1e-6);
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
    Some((p, cost))
}

/// The floor in the model's linear light: where known, the measured one seen through the
/// fitted tone curve plus the fitted pedestal, else the fitted flat floor.
#[inline]
pub(super) fn floor_of(p: &Params, floor_ln: Option<f32>) -> f32 {
    match floor_ln {
        Some(l) => (l / p[9]).exp() + p[PEDESTAL],
        None => p[10],
    }
}

/// The model's luma at a pixel, `clip · (floor + A (core + r glow))^k`, with the light `Q =
/// core + r glow` and the glow's light there.
#[inline]
pub(super) fn model(
    path: &Path,
    p: &Params,
    (x, y): (f32, f32),
    floor_ln: Option<f32>,
    clip: f32,
) -> (f32, (f32, f32)) {
    let (core, glow) = path.light2(x, y);
    let q = core + p[8].max(0.0) * glow;
    let v = (floor_of(p, floor_ln) + p[LN_AMPLITUDE].exp() * q).max(1e-6);
    (clip * (p[9] * v.ln()).exp(), (q, glow))
}

/// A sample's residual: luma minus model, or for a clipped pixel how far the model falls
/// short of the clip level (zero when it reaches it).
#[inline]
pub(super) fn residual(luma: f32, model: f32, clip: f32) -> f32 {
    if luma >= clip {
        (clip - model).max(0.0)
    } else {
        luma - model
    }
}

/// The sum of squared residuals at `p` (the glow drawn only when it is `active`), or, once
/// the sum reaches `bound`, the partial sum (itself at least `bound`). A trial step is taken
/// only when its cost is below the current one, and a sum of squares only grows, so the
/// pixels after that point cannot change the verdict: a rejected trial mostly stops early.
pub(super) fn cost_of(
    s: &Samples,
    p: &Params,
    clip: f32,
    active: &[bool; PARAMS],
    bound: f32,
) -> Option<f32> {
    let mut cost = prior_cost(s, p);
    let p = &native(p);
    let path = Path::new(p, active[GLOW_RATIO], s.gradient);
    for ((&xy, &luma), &floor_ln) in s.xy.iter().zip(&s.luma).zip(&s.floor_ln).take(s.len) {
        let r = residual(luma, model(&path, p, xy, floor_ln, clip).0, clip);
        cost += r * r;
        if cost >= bound {
            break;
        }
    }
    cost.is_finite().then_some(cost)
}

/// `JᵀJ` and `Jᵀr` at `p`, with the model's derivatives in closed form (see
/// [`Path::lights`]), and into `spread`, when given, `Jᵀ diag(r²) J` (see [`super::finish`]).
/// Derivatives of parameters not `active` are left zero.
pub(super) fn normal_equations(
    s: &Samples,
    p: &Params,
    clip: f32,
    active: &[bool; PARAMS],
    mut spread: Option<&mut Normal>,
) -> Option<(Normal, Params)> {
    let fit = p;
    let p = &native(fit);
    let path = Path::with_slopes(p, active[GLOW_RATIO], active[SAGITTA], s.gradient);
    let ratio = p[GLOW_RATIO].max(0.0);
    let inv_k = 1.0 / p[TONE];
    let amplitude = p[LN_AMPLITUDE].exp();
    let mut jtj = Normal::zeros();
    let mut jtr = Params::zeros();
    for ((&(x, y), &luma), &floor_ln) in s.xy.iter().zip(&s.luma).zip(&s.floor_ln).take(s.len) {
        let [core, glow] = path.lights(x, y);
        let q = core.value + ratio * glow.value;
        let floor = floor_of(p, floor_ln);
        let v = (floor + amplitude * q).max(1e-6);
        let m = clip * (p[9] * v.ln()).exp();
        // A clipped pixel the model already reaches carries no gradient.
        if luma >= clip && m >= clip {
            continue;
        }
        let r = residual(luma, m, clip);
        let slope = p[9] * m / v;
        let light_slope = slope * amplitude;
        let mut row = Params::zeros();
        for (j, (c, g)) in core.d_path.iter().zip(&glow.d_path).enumerate() {
            row[j] = light_slope * (c + ratio * g);
        }
        row[5] = light_slope * core.d_ln_sigma;
        row[6] = light_slope * ratio * glow.d_ln_sigma;
        row[LN_AMPLITUDE] = light_slope * q;
        row[8] = light_slope * glow.value;
        row[9] = m * v.ln();
        match floor_ln {
            // A measured floor moves with the tone curve: d floor / dk = -floor · l / k².
            Some(l) => {
                row[9] -= slope * (floor - p[PEDESTAL]) * l / (p[9] * p[9]);
                row[PEDESTAL] = slope;
            }
            None => row[10] = slope,
        }
        // To the fitted parameters (see [`fitted`]).
        row[TONE] +=
            0.5 * inv_k * (row[5] + row[6]) - row[LN_AMPLITUDE] * fit[LN_AMPLITUDE] * inv_k * inv_k;
        row[LN_AMPLITUDE] *= inv_k;
        for (value, &on) in row.iter_mut().zip(active) {
            if !on {
                *value = 0.0;
            }
        }
        let outer = row * row.transpose();
        if let Some(spread) = spread.as_deref_mut() {
            *spread += outer * (r * r);
        }
        jtj += outer;
        jtr += row * r;
    }
    // The prior on the tone exponent, a pseudo-pixel whose residual is its distance from the
    // prior (`k` is the same in the fitted coordinates).
    if let Some((tone, weight)) = s.tone_prior.filter(|_| active[TONE]) {
        jtj[(TONE, TONE)] += weight;
        jtr[TONE] += weight * (tone - fit[TONE]);
    }
    (jtr.iter().all(|v| v.is_finite())).then_some((jtj, jtr))
}

/// The cost of the prior on the tone exponent at the fitted `p` (0 without one).
pub(super) fn prior_cost(s: &Samples, p: &Params) -> f32 {
    s.tone_prior
        .map_or(0.0, |(tone, weight)| weight * (p[TONE] - tone).powi(2))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::fit::tests::{paths, samples_of};

    /// A cost bounded below the full one stops at or above the bound, so a trial is judged
    /// as the full sum would judge it, and a low bound stops before the last pixel; a bound
    /// above the full cost changes nothing.
    #[test]
    fn a_bounded_cost_keeps_the_verdict() {
        let clip = 250.0;
        let all = [true; PARAMS];
        for truth in paths() {
            let s = samples_of(&truth, clip);
            let mut p = truth;
            p[0] += 0.7;
            p[LN_AMPLITUDE] += 1.3f32.ln();
            let full = cost_of(&s, &p, clip, &all, f32::INFINITY).expect("finite");
            for bound in [0.1 * full, 0.5 * full, 0.99 * full] {
                let bounded = cost_of(&s, &p, clip, &all, bound).expect("finite");
                assert!(
                    bounded >= bound && bounded <= full,
                    "{truth:?}: bounded at {bound} the cost read {bounded} (full {full})"
                );
            }
            let early = cost_of(&s, &p, clip, &all, 0.1 * full).expect("finite");
            assert!(
                early < full,
                "{truth:?}: a tenth of the cost summed every pixel"
            );
            for bound in [full * 1.01, 2.0 * full] {
                let bounded = cost_of(&s, &p, clip, &all, bound).expect("finite");
                assert_eq!(bounded, full, "{truth:?}: bounded at {bound}");
            }
        }
    }

    /// The fitted coordinates read back as the model's, and a step in the tone alone keeps
    /// the spot as the pixels see it: its width `σ/√k` and its peak `A^k`.
    #[test]
    fn the_fitted_parameters_read_back() {
        for p in paths() {
            let back = native(&fitted(&p));
            for j in 0..PARAMS {
                assert!(
                    (back[j] - p[j]).abs() < 1e-5 * (1.0 + p[j].abs()),
                    "{p:?}: {back:?}"
                );
            }
            let mut steeper = fitted(&p);
            steeper[TONE] *= 1.5;
            let moved = native(&steeper);
            assert!(
                (moved[5] - p[5] - 0.5 * 1.5f32.ln()).abs() < 1e-5,
                "{moved:?}"
            );
            assert!((moved[TONE] * moved[LN_AMPLITUDE] - p[TONE] * p[LN_AMPLITUDE]).abs() < 1e-5);
        }
    }

    #[test]
    fn the_normal_equations_descend_the_cost() {
        let clip = 250.0;
        let all = [true; PARAMS];
        for truth in paths() {
            let s = samples_of(&truth, clip);
            // Away from the truth, so that every residual and slope is in play.
            let mut p = truth;
            for (j, shift) in [
                0.4, -0.3, 0.2, 0.5, 0.3, 0.1, -0.1, 0.3, 0.05, 0.04, 0.02, 0.01,
            ]
            .into_iter()
            .enumerate()
            {
                p[j] += shift;
            }
            let (_, jtr) = normal_equations(&s, &p, clip, &all, None).expect("finite");
            let scale = jtr.amax();
            for j in 0..PARAMS {
                let h = 1e-3;
                let cost_at = |delta: f32| {
                    let mut q = p;
                    q[j] += delta;
                    cost_of(&s, &q, clip, &all, f32::INFINITY).expect("finite")
                };
                // The cost is Σ r², so its slope is −2 Jᵀr.
                let numeric = -(cost_at(h) - cost_at(-h)) / (4.0 * h);
                assert!(
                    (numeric - jtr[j]).abs() < 1e-2 * scale,
                    "parameter {j} of {truth:?}: differences {numeric}, closed form {}",
                    jtr[j]
                );
            }
        }
    }
}
