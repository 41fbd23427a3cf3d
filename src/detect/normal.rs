//! The standard normal distribution and its quantile, in `f32` and without `std`, for the
//! streak models: a Gaussian spot swept along a path lights a pixel by an error-function
//! difference (`fit`), and the line profile's pairing needs the quantile (`line_profile`).
//! `libm` has no quantile, and a statistics crate is far more than these three functions.

/// The standard normal cumulative distribution (Abramowitz & Stegun 7.1.26, error < 2e-7).
pub(super) fn normal_cdf(z: f32) -> f32 {
    normal_cdf_and_density(z).0
}

/// The standard normal cumulative distribution and density at `z`. The approximation's
/// `erfc` is a polynomial times `exp(−z²/2)`, which is the density but for its constant, so
/// the fit's derivatives get the density for a multiplication. Beyond ±5.5 the distribution
/// reads 0 or 1 and the density 0 (below 1.1e-7).
pub(super) fn normal_cdf_and_density(z: f32) -> (f32, f32) {
    if z > 5.5 {
        return (1.0, 0.0);
    }
    if z < -5.5 {
        return (0.0, 0.0);
    }
    let x = z.abs() * core::f32::consts::FRAC_1_SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    let poly = t
        * (0.254_829_6
            + t * (-0.284_496_74 + t * (1.421_413_7 + t * (-1.453_152_1 + t * 1.061_405_4))));
    let gaussian = (-x * x).exp();
    let erfc = poly * gaussian;
    let density = gaussian * INV_SQRT_TAU;
    if z >= 0.0 {
        (1.0 - 0.5 * erfc, density)
    } else {
        (0.5 * erfc, density)
    }
}

/// `1 / √(2π)`, the standard normal density's peak.
const INV_SQRT_TAU: f32 = 0.398_942_3;

/// The standard normal quantile of `exp(ln_p)`, for `ln_p < 0`.
pub(super) fn quantile_of_ln(ln_p: f32) -> f32 {
    const LN_P_MAX: f32 = -1e-6;
    let ln_p = ln_p.min(LN_P_MAX);
    if ln_p < P_LOW.ln() {
        tail_quantile((-2.0 * ln_p).sqrt())
    } else {
        inverse_normal_cdf(ln_p.exp())
    }
}

/// The standard normal quantile for `p` in (0, 1) (Acklam's rational approximation, relative
/// error under 1.2e-9 in exact arithmetic; a few f32 ulps here).
fn inverse_normal_cdf(p: f32) -> f32 {
    const A: [f32; 6] = [
        -3.969_683e1,
        2.209_460_9e2,
        -2.759_285e2,
        1.383_577_5e2,
        -3.066_48e1,
        2.506_628_3,
    ];
    const B: [f32; 5] = [
        -5.447_609_9e1,
        1.615_858_4e2,
        -1.556_989_8e2,
        6.680_131e1,
        -1.328_068_2e1,
    ];
    if p < P_LOW {
        tail_quantile((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - P_LOW {
        -tail_quantile((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

/// Below this the quantile takes its tail's form.
const P_LOW: f32 = 0.024_25;

/// Acklam's lower-tail quantile, of `q = sqrt(−2 ln p)`.
fn tail_quantile(q: f32) -> f32 {
    const C: [f32; 6] = [
        -7.784_894e-3,
        -3.223_964_6e-1,
        -2.400_758_3,
        -2.549_732_4,
        4.374_664_1,
        2.938_164,
    ];
    const D: [f32; 4] = [7.784_696e-3, 3.224_671_3e-1, 2.445_134_1, 3.754_408_7];
    (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
        / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_density_is_the_slope_of_the_distribution() {
        for z in [-5.0f32, -2.2, -0.9, -0.1, 0.0, 0.4, 1.3, 3.0, 4.8] {
            let h = 1e-2;
            let slope = (normal_cdf(z + h) - normal_cdf(z - h)) / (2.0 * h);
            let density = normal_cdf_and_density(z).1;
            assert!((slope - density).abs() < 5e-5, "{z}: {slope} vs {density}");
        }
    }

    #[test]
    fn the_quantile_inverts_the_distribution() {
        for z in [-4.0f32, -2.5, -1.0, -0.3, 0.0, 0.7, 1.9, 3.5] {
            let back = inverse_normal_cdf(normal_cdf(z));
            assert!((back - z).abs() < 2e-3, "{z}: {back}");
            if z < 0.0 {
                let from_ln = quantile_of_ln(normal_cdf(z).ln());
                assert!((from_ln - z).abs() < 2e-3, "{z}: {from_ln}");
            }
        }
    }
}
