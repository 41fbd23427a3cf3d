//! A tiny deterministic pseudo-random generator (SplitMix64) and coordinate hashing.
//!
//! Hand-written because the renderer needs only a few lines of it, and because its output must
//! never change under a dependency upgrade: a seed names one exact set of frames forever.

/// The SplitMix64 increment (2^64 divided by the golden ratio).
const GOLDEN_GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

/// Width of one uniform lane taken from a 64-bit draw for the approximate Gaussian.
const LANE_BITS: u32 = 16;
const LANE_MASK: u64 = (1 << LANE_BITS) - 1;
/// Mean of the sum of four lanes, each uniform on `0..=LANE_MASK`.
const LANE_SUM_MEAN: f32 = 2.0 * LANE_MASK as f32;
/// Scale that gives the four-lane sum unit variance: each lane has variance about
/// `(2^16)^2 / 12`, four of them `(2^16)^2 / 3`, so divide by `2^16 / sqrt(3)`.
const LANE_SUM_TO_UNIT: f32 = 1.732_050_8 / (1u64 << LANE_BITS) as f32;

/// SplitMix64's output function: a strong 64-bit mixer.
pub(crate) fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A well-mixed hash of a seed and two lattice coordinates (for value noise).
pub(crate) fn hash2(seed: u64, ix: i64, iy: i64) -> u64 {
    // Casting i64 to u64 reinterprets the bits, which is all a hash needs.
    mix64(seed ^ mix64((ix as u64).wrapping_add(mix64(iy as u64 ^ GOLDEN_GAMMA))))
}

/// Maps 64 random bits to a uniform value in `[0, 1)`.
pub(crate) fn unit_from_bits(bits: u64) -> f64 {
    const MANTISSA_BITS: u32 = 53;
    (bits >> (64 - MANTISSA_BITS)) as f64 / (1u64 << MANTISSA_BITS) as f64
}

/// SplitMix64 (Steele, Lea, Flood 2014): one add and one mix per draw.
#[derive(Clone, Debug)]
pub(crate) struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    pub(crate) fn new(seed: u64) -> Self {
        Self { state: seed }
    }

    pub(crate) fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(GOLDEN_GAMMA);
        mix64(self.state)
    }

    /// An approximately standard-normal draw: the Irwin–Hall sum of four 16-bit uniforms,
    /// scaled to unit variance. One 64-bit draw per sample and no transcendental functions,
    /// which keeps per-pixel sensor noise cheap even in debug builds. Its tails end at about
    /// ±3.46 σ, which is harmless for sensor noise.
    pub(crate) fn next_gaussian(&mut self) -> f32 {
        let bits = self.next_u64();
        let sum = (bits & LANE_MASK)
            + ((bits >> LANE_BITS) & LANE_MASK)
            + ((bits >> (2 * LANE_BITS)) & LANE_MASK)
            + (bits >> (3 * LANE_BITS));
        (sum as f32 - LANE_SUM_MEAN) * LANE_SUM_TO_UNIT
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_sequence_other_seed_other_sequence() {
        let mut a = SplitMix64::new(7);
        let mut b = SplitMix64::new(7);
        let mut c = SplitMix64::new(8);
        let a_draws: Vec<u64> = (0..16).map(|_| a.next_u64()).collect();
        let b_draws: Vec<u64> = (0..16).map(|_| b.next_u64()).collect();
        let c_draws: Vec<u64> = (0..16).map(|_| c.next_u64()).collect();
        assert_eq!(a_draws, b_draws);
        assert_ne!(a_draws, c_draws);
    }

    #[test]
    fn gaussian_has_zero_mean_and_unit_variance() {
        let mut rng = SplitMix64::new(42);
        let n = 200_000;
        let draws: Vec<f64> = (0..n).map(|_| f64::from(rng.next_gaussian())).collect();
        let mean = draws.iter().sum::<f64>() / n as f64;
        let var = draws.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((var - 1.0).abs() < 0.01, "variance {var}");
    }

    #[test]
    fn unit_from_bits_stays_in_the_unit_interval() {
        assert_eq!(unit_from_bits(0), 0.0);
        assert!(unit_from_bits(u64::MAX) < 1.0);
        assert!(unit_from_bits(u64::MAX) > 0.999_999);
    }
}
