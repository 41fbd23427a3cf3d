//! Golden-section search: the minimum of a function of one variable that falls and then rises
//! over a bracket, found without derivatives in a fixed number of evaluations (one a step).
//! The line profile's spot width and the row time's band frequency are both found so.

use nalgebra::RealField;

/// Shrinks the bracket `(lo, hi)` around the minimum of `f` by `steps` golden-section steps
/// (to 0.618^steps of its width) and returns it; `f` is evaluated `steps + 2` times. A tie
/// keeps the lower side.
pub fn minimise<T: RealField + Copy>(
    mut f: impl FnMut(T) -> T,
    (mut lo, mut hi): (T, T),
    steps: usize,
) -> (T, T) {
    let inv_phi: T = nalgebra::convert(0.618_033_988_749_895);
    let mut x1 = hi - inv_phi * (hi - lo);
    let mut x2 = lo + inv_phi * (hi - lo);
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..steps {
        if f1 <= f2 {
            hi = x2;
            (x2, f2) = (x1, f1);
            x1 = hi - inv_phi * (hi - lo);
            f1 = f(x1);
        } else {
            lo = x1;
            (x1, f1) = (x2, f2);
            x2 = lo + inv_phi * (hi - lo);
            f2 = f(x2);
        }
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bracket_closes_on_the_minimum_in_f32_and_f64() {
        let (lo, hi) = minimise(|x: f64| (x - 0.3).powi(2), (-2.0, 5.0), 40);
        assert!(lo <= 0.3 && 0.3 <= hi && hi - lo < 7.0 * 0.62f64.powi(40));
        let (lo, hi) = minimise(|x: f32| (x.exp() - 2.0).abs(), (0.0, 1.0), 12);
        let middle = 0.5 * (lo + hi);
        assert!((middle - 2f32.ln()).abs() < 1e-2, "{middle}");
        // A function that rises from the start: the bracket shrinks onto its lower end.
        let (lo, hi) = minimise(|x: f64| x, (1.0, 2.0), 30);
        assert!(lo == 1.0 && hi < 1.0 + 1e-5);
    }
}
