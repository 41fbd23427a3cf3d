//! The bands between two frames at one spatial frequency: a least-squares fit of the
//! difference of their row profiles.
//!
//! Row `y` of frame `n` is exposed `y τ` after row 0, so a light flickering at `f` puts
//! `A cos(k y + ψₙ)` on its row profile, with `k = 2π f τ` radians a row and `ψₙ` the light's
//! phase when frame `n`'s exposure started. The difference of two frames' profiles is then a
//! sinusoid of the same `k` (whatever stands still cancels), plus a constant (the frames'
//! overall brightness differs: the light's mean over the frame) and a slope (a camera's gain or
//! exposure settling). Each pair of frames is fitted with
//! `c₀ + c₁ y/H + c₂ cos(k y) + c₃ sin(k y)`, rows from the middle; what the sinusoid explains
//! beyond the constant and the slope is the evidence for bands at `k`, and `c₂ − i c₃` is the
//! pair's band as a complex amplitude, `A (e^{iψₙ} − e^{iψₙ₋₁})` up to one factor common to
//! every pair.

use nalgebra::{Complex, Matrix2, Matrix4, Vector2, Vector4};

/// Rows a pair must have for its fit (its four parameters and the noise).
const MIN_ROWS: usize = 8;

/// The fit's regressors at one spatial frequency, row by row.
pub struct Basis {
    k_rad_per_row: f64,
    /// The row from the middle, over the height.
    slope: Vec<f64>,
    cos: Vec<f64>,
    sin: Vec<f64>,
}

impl Basis {
    /// The regressors of `height_px` rows at `k_rad_per_row`.
    pub fn new(height_px: usize, k_rad_per_row: f64) -> Self {
        let mut basis = Basis {
            k_rad_per_row: f64::NAN,
            slope: Vec::with_capacity(height_px),
            cos: Vec::with_capacity(height_px),
            sin: Vec::with_capacity(height_px),
        };
        let middle = (height_px as f64 - 1.0) / 2.0;
        basis
            .slope
            .extend((0..height_px).map(|y| (y as f64 - middle) / height_px as f64));
        basis.set(k_rad_per_row);
        basis
    }

    /// Moves the regressors to `k_rad_per_row`.
    pub fn set(&mut self, k_rad_per_row: f64) {
        if k_rad_per_row == self.k_rad_per_row {
            return;
        }
        let height = self.slope.len() as f64;
        self.cos.clear();
        self.sin.clear();
        for &s in &self.slope {
            let (sin, cos) = (k_rad_per_row * s * height).sin_cos();
            self.cos.push(cos);
            self.sin.push(sin);
        }
        self.k_rad_per_row = k_rad_per_row;
    }

    fn row(&self, y: usize) -> Vector4<f64> {
        Vector4::new(1.0, self.slope[y], self.cos[y], self.sin[y])
    }
}

/// One pair's fit.
#[derive(Debug, Clone, Copy)]
pub struct PairFit {
    /// The squared residual the sinusoid removes beyond the constant and the slope.
    pub explained: f64,
    /// The squared residual left.
    pub residual: f64,
    /// Rows fitted.
    pub rows: usize,
    coefficients: Vector4<f64>,
}

impl PairFit {
    /// The pair's band as a complex amplitude (`c₂ − i c₃`, in `ln` luma).
    pub fn band(&self) -> Complex<f64> {
        Complex::new(self.coefficients[2], -self.coefficients[3])
    }

    /// What the fit leaves of `difference` at row `y`.
    pub fn residual_at(&self, basis: &Basis, y: usize, difference: f64) -> f64 {
        difference - self.coefficients.dot(&basis.row(y))
    }
}

/// Fits the difference `next − previous` of two row profiles over the rows whose `weight` is
/// above 0 (a NaN row in either profile is left out); `None` with fewer than eight rows
/// (`MIN_ROWS`) or regressors that do not span four directions over them.
pub fn fit_pair(previous: &[f32], next: &[f32], weight: &[f32], basis: &Basis) -> Option<PairFit> {
    let mut normal = Matrix4::<f64>::zeros();
    let mut rhs = Vector4::<f64>::zeros();
    let (mut sum_sq, mut rows) = (0.0f64, 0usize);
    for (y, ((&a, &b), &w)) in previous.iter().zip(next).zip(weight).enumerate() {
        let d = f64::from(b - a);
        if !(w > 0.0 && d.is_finite()) {
            continue;
        }
        let (u, w) = (basis.row(y), f64::from(w));
        normal += w * u * u.transpose();
        rhs += w * d * u;
        sum_sq += w * d * d;
        rows += 1;
    }
    if rows < MIN_ROWS {
        return None;
    }
    let coefficients = normal.cholesky()?.solve(&rhs);
    let residual = (sum_sq - coefficients.dot(&rhs)).max(0.0);
    let base_normal: Matrix2<f64> = normal.fixed_view::<2, 2>(0, 0).into();
    let base_rhs: Vector2<f64> = rhs.fixed_rows::<2>(0).into();
    let base = base_normal.cholesky()?.solve(&base_rhs);
    let base_residual = (sum_sq - base.dot(&base_rhs)).max(0.0);
    Some(PairFit {
        explained: (base_residual - residual).max(0.0),
        residual,
        rows,
        coefficients,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sinusoid of `k` with a phase, a constant and a slope, as a profile difference.
    fn difference(height: usize, k: f64, phase: f64) -> (Vec<f32>, Vec<f32>) {
        let middle = (height as f64 - 1.0) / 2.0;
        let previous = vec![3.0f32; height];
        let next = (0..height)
            .map(|y| {
                let y = y as f64 - middle;
                (3.0 + 0.02 + 1e-4 * y + 0.01 * (k * y + phase).cos()) as f32
            })
            .collect();
        (previous, next)
    }

    #[test]
    fn the_fit_finds_the_band_s_amplitude_and_phase_at_its_frequency_only() {
        let (height, k, phase) = (480, 0.03, 0.7);
        let (previous, next) = difference(height, k, phase);
        let weight = vec![1.0; height];
        let at = |k: f64| fit_pair(&previous, &next, &weight, &Basis::new(height, k)).unwrap();
        let fit = at(k);
        // cos(ky + φ) = Re[e^{iφ} e^{iky}]: the band is 0.01 e^{iφ}.
        assert!(
            (fit.band().re.hypot(fit.band().im) - 0.01).abs() < 1e-4,
            "{}",
            fit.band()
        );
        assert!(
            (fit.band().im.atan2(fit.band().re) - phase).abs() < 1e-3,
            "{}",
            fit.band()
        );
        assert!(fit.residual < 1e-3 * fit.explained);
        // At another frequency the sinusoid explains less.
        assert!(at(1.3 * k).explained < 0.5 * fit.explained);
    }

    #[test]
    fn rows_of_no_weight_are_left_out_and_too_few_rows_fit_nothing() {
        let height = 64;
        let (previous, mut next) = difference(height, 0.2, 0.0);
        let mut weight = vec![1.0; height];
        next[10] += 5.0;
        weight[10] = 0.0;
        let basis = Basis::new(height, 0.2);
        let fit = fit_pair(&previous, &next, &weight, &basis).unwrap();
        assert_eq!(fit.rows, height - 1);
        assert!(
            fit.residual < 1e-6,
            "the outlier row was fitted: {}",
            fit.residual
        );
        let few: Vec<f32> = (0..height).map(|y| if y < 7 { 1.0 } else { 0.0 }).collect();
        assert!(fit_pair(&previous, &next, &few, &basis).is_none());
    }
}
