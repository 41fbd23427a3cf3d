//! Row kernels of the threshold stage: a portable reference, an SSE2 one on x86_64, a NEON one
//! on aarch64, and a word-at-a-time (SWAR) one for other targets (armv7, whose Rust target does
//! not enable NEON). SSE2 and NEON are part of their architecture's baseline, so no run-time
//! detection is needed. Tests hold every kernel to the portable reference on random rows; CI
//! runs them natively on x86_64 and under `qemu-aarch64` for NEON.
//!
//! Each kernel reads a raw row of one [`PixelFormat`]: packed 4:2:2 with luma at the even
//! bytes (YUYV) or the odd bytes (UYVY, the same loads with the other byte of each pair), or
//! GREY, where every byte is luma and one mask word takes 64 bytes instead of 128.

use crate::frame::PixelFormat;

/// Bytes of packed 4:2:2 that hold one 64-pixel mask word.
const BYTES_PER_WORD: usize = 128;

/// Bytes of GREY that hold one 64-pixel mask word.
const GREY_BYTES_PER_WORD: usize = 64;

/// Sets bit `x` of `words` where the luma of pixel `x` of `row` (a raw row of `format`) is
/// at least `threshold`; returns the number of bits set.
#[inline]
pub(crate) fn row_threshold(
    format: PixelFormat,
    row: &[u8],
    threshold: u8,
    words: &mut [u64],
) -> usize {
    match format {
        PixelFormat::Yuyv => fast::packed::<false, false>(row, threshold, words).0,
        PixelFormat::Uyvy => fast::packed::<true, false>(row, threshold, words).0,
        PixelFormat::Grey => fast::grey::<false>(row, threshold, words).0,
    }
}

/// [`row_threshold`], also returning the brightest luma of the row.
#[inline]
pub(crate) fn row_threshold_max(
    format: PixelFormat,
    row: &[u8],
    threshold: u8,
    words: &mut [u64],
) -> (usize, u8) {
    match format {
        PixelFormat::Yuyv => fast::packed::<false, true>(row, threshold, words),
        PixelFormat::Uyvy => fast::packed::<true, true>(row, threshold, words),
        PixelFormat::Grey => fast::grey::<true>(row, threshold, words),
    }
}

/// Portable reference kernels.
pub(crate) mod portable {
    use super::{BYTES_PER_WORD, GREY_BYTES_PER_WORD};

    /// Packed 4:2:2: luma at byte `2 x` (`ODD` false, YUYV) or `2 x + 1` (UYVY). `MAX` also
    /// measures the row's brightest luma (else 0 is returned for it).
    pub fn packed<const ODD: bool, const MAX: bool>(
        row: &[u8],
        threshold: u8,
        words: &mut [u64],
    ) -> (usize, u8) {
        cut(
            row,
            usize::from(ODD),
            2,
            BYTES_PER_WORD,
            threshold,
            words,
            MAX,
        )
    }

    /// GREY: every byte is a pixel's luma.
    pub fn grey<const MAX: bool>(row: &[u8], threshold: u8, words: &mut [u64]) -> (usize, u8) {
        cut(row, 0, 1, GREY_BYTES_PER_WORD, threshold, words, MAX)
    }

    fn cut(
        row: &[u8],
        offset: usize,
        step: usize,
        bytes_per_word: usize,
        threshold: u8,
        words: &mut [u64],
        max: bool,
    ) -> (usize, u8) {
        let mut count = 0;
        let mut top = 0;
        for (word, chunk) in words.iter_mut().zip(row.chunks(bytes_per_word)) {
            let mut bits = 0u64;
            let lumas = chunk.get(offset..).unwrap_or(&[]).iter().step_by(step);
            for (i, &luma) in lumas.enumerate() {
                bits |= u64::from(luma >= threshold) << i;
                if max {
                    top = top.max(luma);
                }
            }
            *word = bits;
            count += bits.count_ones() as usize;
        }
        (count, top)
    }
}

/// Word-at-a-time kernels: two luma bytes per `u32`, compared in 16-bit lanes without branches.
/// On armv7 the portable reference spends about 26 instructions per pixel (a variable 64-bit
/// shift per pixel, two instructions per 64-bit operation); these spend about 9.5, running
/// maximum included (`tools/pi-cost.sh`).
#[cfg(any(test, not(any(target_arch = "x86_64", target_arch = "aarch64"))))]
pub(crate) mod swar {
    use super::{portable, BYTES_PER_WORD, GREY_BYTES_PER_WORD};

    /// The even bytes of a little-endian `u32`: the luma of two YUYV pixels `Y0 U Y1 V`.
    const LUMA_LANES: u32 = 0x00FF_00FF;
    /// One in each 16-bit lane.
    const LANE_ONES: u32 = 0x0001_0001;
    /// Bytes of packed 4:2:2 that hold one 32-pixel half of a mask word.
    const BYTES_PER_HALF: usize = BYTES_PER_WORD / 2;

    /// The bits of the two 16-bit lanes of `lanes` at or above the threshold, as bits 0 and 16.
    /// A lane holding luma y becomes y + 256 - threshold: bit 8 is set exactly when
    /// y >= threshold, and the lane stays below 512, so no carry crosses into the next lane.
    #[inline(always)]
    fn at_least(lanes: u32, bias: u32) -> u32 {
        ((lanes + bias) >> 8) & LANE_ONES
    }

    pub fn packed<const ODD: bool, const MAX: bool>(
        row: &[u8],
        threshold: u8,
        words: &mut [u64],
    ) -> (usize, u8) {
        let bias = (256 - u32::from(threshold)) * LANE_ONES;
        let (mut count, mut top) = (0, 0u32);
        let full_words = (row.len() / BYTES_PER_WORD).min(words.len());
        for (word, chunk) in words.iter_mut().zip(row.chunks_exact(BYTES_PER_WORD)) {
            let mut halves = [0u32; 2];
            for (half, bytes) in halves.iter_mut().zip(chunk.chunks_exact(BYTES_PER_HALF)) {
                for (pair, quad) in bytes.as_chunks::<4>().0.iter().enumerate() {
                    let quad = u32::from_le_bytes(*quad);
                    let luma = if ODD { quad >> 8 } else { quad } & LUMA_LANES;
                    if MAX {
                        top = top.max(luma & 0xFF).max(luma >> 16);
                    }
                    let bits = at_least(luma, bias);
                    *half |= ((bits | bits >> 15) & 0b11) << (2 * pair);
                }
            }
            let bits = u64::from(halves[0]) | u64::from(halves[1]) << 32;
            *word = bits;
            count += bits.count_ones() as usize;
        }
        let tail_row = row.get(full_words * BYTES_PER_WORD..).unwrap_or(&[]);
        let tail_words = words.get_mut(full_words..).unwrap_or(&mut []);
        let (tail_count, tail_top) = portable::packed::<ODD, MAX>(tail_row, threshold, tail_words);
        // `top` holds one luma byte's value, so the conversion never saturates.
        let top = u8::try_from(top).unwrap_or(u8::MAX).max(tail_top);
        (count + tail_count, top)
    }

    /// GREY: four pixels per `u32`, split into the even and the odd bytes' lanes.
    pub fn grey<const MAX: bool>(row: &[u8], threshold: u8, words: &mut [u64]) -> (usize, u8) {
        let bias = (256 - u32::from(threshold)) * LANE_ONES;
        let (mut count, mut top) = (0, 0u32);
        let full_words = (row.len() / GREY_BYTES_PER_WORD).min(words.len());
        for (word, chunk) in words.iter_mut().zip(row.chunks_exact(GREY_BYTES_PER_WORD)) {
            let mut bits = 0u64;
            for (quad_index, quad) in chunk.as_chunks::<4>().0.iter().enumerate() {
                let quad = u32::from_le_bytes(*quad);
                let (even, odd) = (quad & LUMA_LANES, (quad >> 8) & LUMA_LANES);
                if MAX {
                    top = top.max(even & 0xFF).max(even >> 16);
                    top = top.max(odd & 0xFF).max(odd >> 16);
                }
                let (e, o) = (at_least(even, bias), at_least(odd, bias));
                // Pixels 0..4 of the quad: even lane 0, odd lane 0, even lane 1, odd lane 1.
                let nibble = (e & 1) | (o & 1) << 1 | (e >> 16) << 2 | (o >> 16) << 3;
                bits |= u64::from(nibble) << (4 * quad_index);
            }
            *word = bits;
            count += bits.count_ones() as usize;
        }
        let tail_row = row.get(full_words * GREY_BYTES_PER_WORD..).unwrap_or(&[]);
        let tail_words = words.get_mut(full_words..).unwrap_or(&mut []);
        let (tail_count, tail_top) = portable::grey::<MAX>(tail_row, threshold, tail_words);
        let top = u8::try_from(top).unwrap_or(u8::MAX).max(tail_top);
        (count + tail_count, top)
    }
}

#[cfg(target_arch = "x86_64")]
mod sse2 {
    use core::arch::x86_64::*;

    use super::{portable, BYTES_PER_WORD, GREY_BYTES_PER_WORD};

    /// Packed 4:2:2. `ODD` takes the high byte of each 16-bit pair (UYVY) instead of the low
    /// one (YUYV): a shift instead of a mask, the same cost. `MAX` adds the running maximum,
    /// which costs one instruction per 16 pixels.
    #[inline(always)]
    pub fn packed<const ODD: bool, const MAX: bool>(
        row: &[u8],
        threshold: u8,
        words: &mut [u64],
    ) -> (usize, u8) {
        let full_words = (row.len() / BYTES_PER_WORD).min(words.len());
        let mut count = 0;
        let mut top_lanes = [0u8; 16];
        // SAFETY: SSE2 is always available on x86_64; word `k < full_words` reads bytes
        // `128 k .. 128 k + 128`, all within `row`.
        unsafe {
            let luma_mask = _mm_set1_epi16(0x00FF);
            let level = _mm_set1_epi8(threshold as i8);
            let mut top = _mm_setzero_si128();
            let luma_of = |v: __m128i| {
                if ODD {
                    _mm_srli_epi16::<8>(v)
                } else {
                    _mm_and_si128(v, luma_mask)
                }
            };
            for (k, word) in words.iter_mut().enumerate().take(full_words) {
                let base = row.as_ptr().add(k * BYTES_PER_WORD);
                let mut bits = 0u64;
                for quarter in 0..4 {
                    let a = _mm_loadu_si128(base.add(32 * quarter).cast());
                    let b = _mm_loadu_si128(base.add(32 * quarter + 16).cast());
                    let luma = _mm_packus_epi16(luma_of(a), luma_of(b));
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
        let (tail_count, tail_top) = portable::packed::<ODD, MAX>(tail_row, threshold, tail_words);
        let top = top_lanes.iter().copied().max().unwrap_or(0).max(tail_top);
        (count + tail_count, top)
    }

    /// GREY: 16 pixels per load, no unpacking.
    #[inline(always)]
    pub fn grey<const MAX: bool>(row: &[u8], threshold: u8, words: &mut [u64]) -> (usize, u8) {
        let full_words = (row.len() / GREY_BYTES_PER_WORD).min(words.len());
        let mut count = 0;
        let mut top_lanes = [0u8; 16];
        // SAFETY: SSE2 is always available on x86_64; word `k < full_words` reads bytes
        // `64 k .. 64 k + 64`, all within `row`.
        unsafe {
            let level = _mm_set1_epi8(threshold as i8);
            let mut top = _mm_setzero_si128();
            for (k, word) in words.iter_mut().enumerate().take(full_words) {
                let base = row.as_ptr().add(k * GREY_BYTES_PER_WORD);
                let mut bits = 0u64;
                for quarter in 0..4 {
                    let luma = _mm_loadu_si128(base.add(16 * quarter).cast());
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
        let tail_row = row.get(full_words * GREY_BYTES_PER_WORD..).unwrap_or(&[]);
        let tail_words = words.get_mut(full_words..).unwrap_or(&mut []);
        let (tail_count, tail_top) = portable::grey::<MAX>(tail_row, threshold, tail_words);
        let top = top_lanes.iter().copied().max().unwrap_or(0).max(tail_top);
        (count + tail_count, top)
    }
}

#[cfg(target_arch = "aarch64")]
mod neon {
    use core::arch::aarch64::*;

    use super::{portable, BYTES_PER_WORD, GREY_BYTES_PER_WORD};

    /// The weight of each lane's bit within its byte of the mask word: lane `i` of a 16-pixel
    /// quarter is pixel `i`, whose bit is `i % 8` of byte `i / 8`.
    const LANE_BITS: [u8; 16] = [1, 2, 4, 8, 16, 32, 64, 128, 1, 2, 4, 8, 16, 32, 64, 128];

    /// Folds four quarters of 0xFF/0x00 comparison lanes, each ANDed with its bit weight, into
    /// one 64-bit mask word: NEON has no `movemask`, so three rounds of pairwise adds sum every
    /// 8 lanes into one byte.
    #[inline(always)]
    fn fold(weighted: [uint8x16_t; 4]) -> u64 {
        // SAFETY: NEON is always available on aarch64; only registers are touched.
        unsafe {
            let halves = vpaddq_u8(
                vpaddq_u8(weighted[0], weighted[1]),
                vpaddq_u8(weighted[2], weighted[3]),
            );
            let bytes = vpaddq_u8(halves, halves);
            vgetq_lane_u64::<0>(vreinterpretq_u64_u8(bytes))
        }
    }

    /// Packed 4:2:2: `vld2q_u8` deinterleaves 16 pixels, `.0` the even bytes (YUYV luma) and
    /// `.1` the odd ones (UYVY luma).
    #[inline(always)]
    pub fn packed<const ODD: bool, const MAX: bool>(
        row: &[u8],
        threshold: u8,
        words: &mut [u64],
    ) -> (usize, u8) {
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
                let mut weighted = [vdupq_n_u8(0); 4];
                for (quarter, slot) in weighted.iter_mut().enumerate() {
                    let pair = vld2q_u8(base.add(32 * quarter));
                    let luma = if ODD { pair.1 } else { pair.0 };
                    if MAX {
                        top = vmaxq_u8(top, luma);
                    }
                    *slot = vandq_u8(vcgeq_u8(luma, level), lane_bits);
                }
                let bits = fold(weighted);
                *word = bits;
                count += bits.count_ones() as usize;
            }
            top_vector_luma = vmaxvq_u8(top);
        }
        let tail_row = row.get(full_words * BYTES_PER_WORD..).unwrap_or(&[]);
        let tail_words = words.get_mut(full_words..).unwrap_or(&mut []);
        let (tail_count, tail_top) = portable::packed::<ODD, MAX>(tail_row, threshold, tail_words);
        (count + tail_count, top_vector_luma.max(tail_top))
    }

    /// GREY: 16 pixels per plain load.
    #[inline(always)]
    pub fn grey<const MAX: bool>(row: &[u8], threshold: u8, words: &mut [u64]) -> (usize, u8) {
        let full_words = (row.len() / GREY_BYTES_PER_WORD).min(words.len());
        let mut count = 0;
        let top_vector_luma;
        // SAFETY: NEON is always available on aarch64; word `k < full_words` reads bytes
        // `64 k .. 64 k + 64` (four 16-byte loads), all within `row`.
        unsafe {
            let level = vdupq_n_u8(threshold);
            let lane_bits = vld1q_u8(LANE_BITS.as_ptr());
            let mut top = vdupq_n_u8(0);
            for (k, word) in words.iter_mut().enumerate().take(full_words) {
                let base = row.as_ptr().add(k * GREY_BYTES_PER_WORD);
                let mut weighted = [vdupq_n_u8(0); 4];
                for (quarter, slot) in weighted.iter_mut().enumerate() {
                    let luma = vld1q_u8(base.add(16 * quarter));
                    if MAX {
                        top = vmaxq_u8(top, luma);
                    }
                    *slot = vandq_u8(vcgeq_u8(luma, level), lane_bits);
                }
                let bits = fold(weighted);
                *word = bits;
                count += bits.count_ones() as usize;
            }
            top_vector_luma = vmaxvq_u8(top);
        }
        let tail_row = row.get(full_words * GREY_BYTES_PER_WORD..).unwrap_or(&[]);
        let tail_words = words.get_mut(full_words..).unwrap_or(&mut []);
        let (tail_count, tail_top) = portable::grey::<MAX>(tail_row, threshold, tail_words);
        (count + tail_count, top_vector_luma.max(tail_top))
    }
}

#[cfg(target_arch = "x86_64")]
use sse2 as fast;

#[cfg(target_arch = "aarch64")]
use neon as fast;

#[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
use swar as fast;

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The portable reference for `format`.
    fn reference(format: PixelFormat, row: &[u8], threshold: u8, words: &mut [u64]) -> (usize, u8) {
        match format {
            PixelFormat::Yuyv => portable::packed::<false, true>(row, threshold, words),
            PixelFormat::Uyvy => portable::packed::<true, true>(row, threshold, words),
            PixelFormat::Grey => portable::grey::<true>(row, threshold, words),
        }
    }

    /// The SWAR kernel for `format` (armv7's, tested on every target).
    fn swar_max(format: PixelFormat, row: &[u8], threshold: u8, words: &mut [u64]) -> (usize, u8) {
        match format {
            PixelFormat::Yuyv => swar::packed::<false, true>(row, threshold, words),
            PixelFormat::Uyvy => swar::packed::<true, true>(row, threshold, words),
            PixelFormat::Grey => swar::grey::<true>(row, threshold, words),
        }
    }

    proptest! {
        #[test]
        fn vector_kernels_match_the_portable_ones(
            pixels in 1usize..300,
            seed in any::<u64>(),
            threshold in any::<u8>(),
            format_index in 0usize..3,
        ) {
            let format = PixelFormat::ALL[format_index];
            let mut state = seed | 1;
            let row: Vec<u8> = (0..pixels * format.bytes_per_pixel())
                .map(|_| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    (state >> 24) as u8
                })
                .collect();
            let words_len = pixels.div_ceil(64);
            let mut fast = vec![!0u64; words_len];
            let mut expected = vec![!0u64; words_len];
            let n_fast = row_threshold(format, &row, threshold, &mut fast);
            let want = reference(format, &row, threshold, &mut expected);
            prop_assert_eq!(&fast, &expected);
            prop_assert_eq!(n_fast, want.0);
            let mut fast_max = vec![0u64; words_len];
            let got = row_threshold_max(format, &row, threshold, &mut fast_max);
            prop_assert_eq!(got, want);
            prop_assert_eq!(&fast_max, &expected);
            let mut swar_words = vec![!0u64; words_len];
            prop_assert_eq!(swar_max(format, &row, threshold, &mut swar_words), want);
            prop_assert_eq!(&swar_words, &expected);
            let mut swar_plain = vec![!0u64; words_len];
            let plain = match format {
                PixelFormat::Yuyv => swar::packed::<false, false>(&row, threshold, &mut swar_plain),
                PixelFormat::Uyvy => swar::packed::<true, false>(&row, threshold, &mut swar_plain),
                PixelFormat::Grey => swar::grey::<false>(&row, threshold, &mut swar_plain),
            };
            prop_assert_eq!(plain.0, want.0);
            prop_assert_eq!(&swar_plain, &expected);
        }
    }

    #[test]
    fn portable_threshold_reads_only_luma() {
        // Chroma bytes of 255 must not set bits; luma 200 must, at threshold 200.
        let yuyv = [200, 255, 10, 255, 199, 255, 201, 255];
        let uyvy = [255, 200, 255, 10, 255, 199, 255, 201];
        let grey = [200, 10, 199, 201];
        for (format, row) in [
            (PixelFormat::Yuyv, &yuyv[..]),
            (PixelFormat::Uyvy, &uyvy[..]),
            (PixelFormat::Grey, &grey[..]),
        ] {
            let mut words = [0u64; 1];
            assert_eq!(
                reference(format, row, 200, &mut words),
                (2, 201),
                "{format}"
            );
            assert_eq!(words[0], 0b1001, "{format}");
        }
    }
}
