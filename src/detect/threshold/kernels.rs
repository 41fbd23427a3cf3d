//! Row kernels of the threshold stage: a portable reference, an SSE2 one on x86_64, a NEON one
//! on aarch64, and a word-at-a-time (SWAR) one for other targets (armv7, whose Rust target does
//! not enable NEON). SSE2 and NEON are part of their architecture's baseline, so no run-time
//! detection is needed. Tests hold every kernel to the portable reference on random rows; CI
//! runs them natively on x86_64 and under `qemu-aarch64` for NEON.

/// Bytes of packed YUYV that hold one 64-pixel mask word.
const BYTES_PER_WORD: usize = 128;

/// Portable reference kernels.
pub(crate) mod portable {
    use super::BYTES_PER_WORD;

    /// [`row_threshold`], also returning the brightest luma of the row.
    pub fn row_threshold_max(row: &[u8], threshold: u8, words: &mut [u64]) -> (usize, u8) {
        let top = row.iter().step_by(2).copied().max().unwrap_or(0);
        (row_threshold(row, threshold, words), top)
    }

    /// Sets bit `x` of `words` where the luma of pixel `x` is at least `threshold`; returns
    /// the number of bits set.
    pub fn row_threshold(row: &[u8], threshold: u8, words: &mut [u64]) -> usize {
        let mut count = 0;
        for (word, chunk) in words.iter_mut().zip(row.chunks(BYTES_PER_WORD)) {
            let mut bits = 0u64;
            for (i, pixel) in chunk.chunks_exact(2).enumerate() {
                bits |= u64::from(pixel[0] >= threshold) << i;
            }
            *word = bits;
            count += bits.count_ones() as usize;
        }
        count
    }
}

/// Word-at-a-time kernels: two luma bytes per `u32`, compared in 16-bit lanes without branches.
/// On armv7 the portable reference spends about 26 instructions per pixel (a variable 64-bit
/// shift per pixel, two instructions per 64-bit operation); these spend about 9.5, running
/// maximum included (`tools/pi-cost.sh`).
#[cfg(any(test, not(any(target_arch = "x86_64", target_arch = "aarch64"))))]
pub(crate) mod swar {
    use super::{portable, BYTES_PER_WORD};

    /// The luma bytes of two packed pixels `Y0 U Y1 V`, read little-endian.
    const LUMA_LANES: u32 = 0x00FF_00FF;
    /// One in each 16-bit lane.
    const LANE_ONES: u32 = 0x0001_0001;
    /// Bytes of packed YUYV that hold one 32-pixel half of a mask word.
    const BYTES_PER_HALF: usize = BYTES_PER_WORD / 2;

    pub fn row_threshold(row: &[u8], threshold: u8, words: &mut [u64]) -> usize {
        kernel::<false>(row, threshold, words).0
    }

    pub fn row_threshold_max(row: &[u8], threshold: u8, words: &mut [u64]) -> (usize, u8) {
        kernel::<true>(row, threshold, words)
    }

    fn kernel<const MAX: bool>(row: &[u8], threshold: u8, words: &mut [u64]) -> (usize, u8) {
        // A lane holding luma y becomes y + 256 - threshold: bit 8 is set exactly when
        // y >= threshold, and the lane stays below 512, so no carry crosses into the next lane.
        let bias = (256 - u32::from(threshold)) * LANE_ONES;
        let (mut count, mut top) = (0, 0u32);
        let full_words = (row.len() / BYTES_PER_WORD).min(words.len());
        for (word, chunk) in words.iter_mut().zip(row.chunks_exact(BYTES_PER_WORD)) {
            let mut halves = [0u32; 2];
            for (half, bytes) in halves.iter_mut().zip(chunk.chunks_exact(BYTES_PER_HALF)) {
                for (pair, quad) in bytes.as_chunks::<4>().0.iter().enumerate() {
                    let luma = u32::from_le_bytes(*quad) & LUMA_LANES;
                    if MAX {
                        top = top.max(luma & 0xFF).max(luma >> 16);
                    }
                    let at_least = ((luma + bias) >> 8) & LANE_ONES;
                    *half |= ((at_least | at_least >> 15) & 0b11) << (2 * pair);
                }
            }
            let bits = u64::from(halves[0]) | u64::from(halves[1]) << 32;
            *word = bits;
            count += bits.count_ones() as usize;
        }
        let tail_row = row.get(full_words * BYTES_PER_WORD..).unwrap_or(&[]);
        let tail_words = words.get_mut(full_words..).unwrap_or(&mut []);
        let (tail_count, tail_top) = portable::row_threshold_max(tail_row, threshold, tail_words);
        // `top` holds one luma byte's value, so the conversion never saturates.
        let top = u8::try_from(top).unwrap_or(u8::MAX).max(tail_top);
        (count + tail_count, top)
    }
}

#[cfg(target_arch = "x86_64")]
mod sse2 {
    use core::arch::x86_64::*;

    use super::{portable, BYTES_PER_WORD};

    pub fn row_threshold(row: &[u8], threshold: u8, words: &mut [u64]) -> usize {
        kernel::<false>(row, threshold, words).0
    }

    pub fn row_threshold_max(row: &[u8], threshold: u8, words: &mut [u64]) -> (usize, u8) {
        kernel::<true>(row, threshold, words)
    }

    /// Both kernels in one body; `MAX` adds the running maximum, which costs one
    /// instruction per 16 pixels.
    #[inline(always)]
    fn kernel<const MAX: bool>(row: &[u8], threshold: u8, words: &mut [u64]) -> (usize, u8) {
        let full_words = (row.len() / BYTES_PER_WORD).min(words.len());
        let mut count = 0;
        let mut top_lanes = [0u8; 16];
        // SAFETY: SSE2 is always available on x86_64; word `k < full_words` reads bytes
        // `128 k .. 128 k + 128`, all within `row`.
        unsafe {
            let luma_mask = _mm_set1_epi16(0x00FF);
            let level = _mm_set1_epi8(threshold as i8);
            let mut top = _mm_setzero_si128();
            for (k, word) in words.iter_mut().enumerate().take(full_words) {
                let base = row.as_ptr().add(k * BYTES_PER_WORD);
                let mut bits = 0u64;
                for quarter in 0..4 {
                    let a = _mm_loadu_si128(base.add(32 * quarter).cast());
                    let b = _mm_loadu_si128(base.add(32 * quarter + 16).cast());
                    let luma =
                        _mm_packus_epi16(_mm_and_si128(a, luma_mask), _mm_and_si128(b, luma_mask));
                    if MAX {
                        top = _mm_max_epu8(top, luma);
                    }
                    let at_least = _mm_cmpeq_epi8(_mm_max_epu8(luma, level), luma);
                    let lanes = _mm_movemask_epi8(at_least) as u32 as u64;
                    bits |= lanes << (16 * quarter);
                }
                *word = bits;
                count += bits.count_ones() as usize;
            }
            _mm_storeu_si128(top_lanes.as_mut_ptr().cast(), top);
        }
        let tail_row = row.get(full_words * BYTES_PER_WORD..).unwrap_or(&[]);
        let tail_words = words.get_mut(full_words..).unwrap_or(&mut []);
        let (tail_count, tail_top) = portable::row_threshold_max(tail_row, threshold, tail_words);
        let top = top_lanes.iter().copied().max().unwrap_or(0).max(tail_top);
        (count + tail_count, top)
    }
}

#[cfg(target_arch = "aarch64")]
mod neon {
    use core::arch::aarch64::*;

    use super::{portable, BYTES_PER_WORD};

    pub fn row_threshold(row: &[u8], threshold: u8, words: &mut [u64]) -> usize {
        kernel::<false>(row, threshold, words).0
    }

    pub fn row_threshold_max(row: &[u8], threshold: u8, words: &mut [u64]) -> (usize, u8) {
        kernel::<true>(row, threshold, words)
    }

    /// The weight of each lane's bit within its byte of the mask word: lane `i` of a 16-pixel
    /// quarter is pixel `i`, whose bit is `i % 8` of byte `i / 8`.
    const LANE_BITS: [u8; 16] = [1, 2, 4, 8, 16, 32, 64, 128, 1, 2, 4, 8, 16, 32, 64, 128];

    /// Both kernels in one body, as in the SSE2 version. NEON has no `movemask`: each 0xFF/0x00
    /// comparison lane is ANDed with its bit weight, and three rounds of pairwise adds sum
    /// every 8 lanes into one byte of the 64-bit mask.
    #[inline(always)]
    fn kernel<const MAX: bool>(row: &[u8], threshold: u8, words: &mut [u64]) -> (usize, u8) {
        let full_words = (row.len() / BYTES_PER_WORD).min(words.len());
        let mut count = 0;
        let top_vector_luma;
        // SAFETY: NEON is always available on aarch64; word `k < full_words` reads bytes
        // `128 k .. 128 k + 128` (four 32-byte `vld2q_u8` loads), all within `row`.
        unsafe {
            let level = vdupq_n_u8(threshold);
            let lane_bits = vld1q_u8(LANE_BITS.as_ptr());
            let mut top = vdupq_n_u8(0);
            for (k, word) in words.iter_mut().enumerate().take(full_words) {
                let base = row.as_ptr().add(k * BYTES_PER_WORD);
                // `vld2q_u8` deinterleaves 16 pixels: `.0` holds the Y bytes, `.1` the U/V.
                let mut weighted = [vdupq_n_u8(0); 4];
                for (quarter, slot) in weighted.iter_mut().enumerate() {
                    let luma = vld2q_u8(base.add(32 * quarter)).0;
                    if MAX {
                        top = vmaxq_u8(top, luma);
                    }
                    *slot = vandq_u8(vcgeq_u8(luma, level), lane_bits);
                }
                let halves = vpaddq_u8(
                    vpaddq_u8(weighted[0], weighted[1]),
                    vpaddq_u8(weighted[2], weighted[3]),
                );
                let bytes = vpaddq_u8(halves, halves);
                let bits = vgetq_lane_u64::<0>(vreinterpretq_u64_u8(bytes));
                *word = bits;
                count += bits.count_ones() as usize;
            }
            top_vector_luma = vmaxvq_u8(top);
        }
        let tail_row = row.get(full_words * BYTES_PER_WORD..).unwrap_or(&[]);
        let tail_words = words.get_mut(full_words..).unwrap_or(&mut []);
        let (tail_count, tail_top) = portable::row_threshold_max(tail_row, threshold, tail_words);
        (count + tail_count, top_vector_luma.max(tail_top))
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use sse2::{row_threshold, row_threshold_max};

#[cfg(target_arch = "aarch64")]
pub(crate) use neon::{row_threshold, row_threshold_max};

#[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
pub(crate) use swar::{row_threshold, row_threshold_max};

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn vector_kernels_match_the_portable_ones(
            pixels in 1usize..300,
            seed in any::<u64>(),
            threshold in any::<u8>(),
        ) {
            let mut state = seed | 1;
            let row: Vec<u8> = (0..pixels * 2)
                .map(|_| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    (state >> 24) as u8
                })
                .collect();
            let words_len = pixels.div_ceil(64);
            let mut fast = vec![!0u64; words_len];
            let mut reference = vec![!0u64; words_len];
            let n_fast = row_threshold(&row, threshold, &mut fast);
            let n_ref = portable::row_threshold(&row, threshold, &mut reference);
            prop_assert_eq!(&fast, &reference);
            prop_assert_eq!(n_fast, n_ref);
            let mut fast_max = vec![0u64; words_len];
            let got = row_threshold_max(&row, threshold, &mut fast_max);
            let want = portable::row_threshold_max(&row, threshold, &mut reference);
            prop_assert_eq!(got, want);
            prop_assert_eq!(&fast_max, &reference);
            // The SWAR kernels (armv7's) are tested on every target.
            let mut swar_words = vec![!0u64; words_len];
            prop_assert_eq!(swar::row_threshold(&row, threshold, &mut swar_words), n_ref);
            prop_assert_eq!(&swar_words, &reference);
            let mut swar_max = vec![!0u64; words_len];
            prop_assert_eq!(swar::row_threshold_max(&row, threshold, &mut swar_max), want);
            prop_assert_eq!(&swar_max, &reference);
        }
    }

    #[test]
    fn portable_threshold_reads_only_luma() {
        // Chroma bytes of 255 must not set bits; luma 200 must, at threshold 200.
        let row = [200, 255, 10, 255, 199, 255, 201, 255];
        let mut words = [0u64; 1];
        assert_eq!(portable::row_threshold(&row, 200, &mut words), 2);
        assert_eq!(words[0], 0b1001);
        assert_eq!(portable::row_threshold_max(&row, 200, &mut words), (2, 201));
    }
}
