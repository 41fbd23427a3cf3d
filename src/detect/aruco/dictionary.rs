//! Marker dictionaries, bit-compatible with OpenCV's predefined ones, and decoding against them.
//!
//! The bit tables are data dumped from OpenCV by `tools/opencv/dump_dictionaries.py` into
//! `dict/*.rs`. A code is the marker's inner grid as printed, row by row from the top-left cell,
//! most significant bit first, a set bit being a white cell.

use core::fmt;
use core::str::FromStr;

#[path = "dict/dict_4x4_50.rs"]
mod dict_4x4_50;
#[path = "dict/dict_5x5_100.rs"]
mod dict_5x5_100;
#[path = "dict/dict_6x6_250.rs"]
mod dict_6x6_250;
#[path = "dict/dict_7x7_250.rs"]
mod dict_7x7_250;
#[path = "dict/dict_apriltag_36h11.rs"]
mod dict_apriltag_36h11;

/// Share of a dictionary's correction capacity that decoding uses, as OpenCV's
/// `errorCorrectionRate` default: correcting every correctable bit would accept random patterns.
pub const ERROR_CORRECTION_RATE: f64 = 0.6;

/// One of the supported predefined dictionaries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Dictionary {
    /// `DICT_4X4_50`.
    Aruco4x4_50,
    /// `DICT_5X5_100`.
    Aruco5x5_100,
    /// `DICT_6X6_250`, the seed's dictionary.
    Aruco6x6_250,
    /// `DICT_7X7_250`.
    Aruco7x7_250,
    /// `DICT_APRILTAG_36h11`.
    AprilTag36h11,
}

/// A dictionary name that is not one of [`Dictionary::ALL`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnknownDictionary(pub String);

impl fmt::Display for UnknownDictionary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "unknown marker dictionary {:?}; known: ", self.0)?;
        for (i, d) in Dictionary::ALL.iter().enumerate() {
            let sep = if i == 0 { "" } else { ", " };
            write!(f, "{sep}{}", d.name())?;
        }
        Ok(())
    }
}

impl std::error::Error for UnknownDictionary {}

/// A decoded marker pattern.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Decoded {
    /// The marker's id in its dictionary.
    pub id: u16,
    /// Quarter turns clockwise from the printed marker to the sampled grid.
    pub rotation: u8,
    /// Bits that differed from the dictionary's code and were corrected.
    pub corrected_bits: u32,
}

impl Dictionary {
    /// Every supported dictionary.
    pub const ALL: [Dictionary; 5] = [
        Dictionary::Aruco4x4_50,
        Dictionary::Aruco5x5_100,
        Dictionary::Aruco6x6_250,
        Dictionary::Aruco7x7_250,
        Dictionary::AprilTag36h11,
    ];

    /// OpenCV's name, e.g. `DICT_6X6_250`.
    pub fn name(self) -> &'static str {
        match self {
            Dictionary::Aruco4x4_50 => "DICT_4X4_50",
            Dictionary::Aruco5x5_100 => "DICT_5X5_100",
            Dictionary::Aruco6x6_250 => "DICT_6X6_250",
            Dictionary::Aruco7x7_250 => "DICT_7X7_250",
            Dictionary::AprilTag36h11 => "DICT_APRILTAG_36h11",
        }
    }

    /// Cells on one side of the inner bit grid (the black border adds one more on each side).
    pub fn marker_bits(self) -> usize {
        match self {
            Dictionary::Aruco4x4_50 => dict_4x4_50::MARKER_BITS,
            Dictionary::Aruco5x5_100 => dict_5x5_100::MARKER_BITS,
            Dictionary::Aruco6x6_250 => dict_6x6_250::MARKER_BITS,
            Dictionary::Aruco7x7_250 => dict_7x7_250::MARKER_BITS,
            Dictionary::AprilTag36h11 => dict_apriltag_36h11::MARKER_BITS,
        }
    }

    /// Bits the dictionary can correct (OpenCV's `maxCorrectionBits`).
    pub fn max_correction_bits(self) -> u32 {
        match self {
            Dictionary::Aruco4x4_50 => dict_4x4_50::MAX_CORRECTION_BITS,
            Dictionary::Aruco5x5_100 => dict_5x5_100::MAX_CORRECTION_BITS,
            Dictionary::Aruco6x6_250 => dict_6x6_250::MAX_CORRECTION_BITS,
            Dictionary::Aruco7x7_250 => dict_7x7_250::MAX_CORRECTION_BITS,
            Dictionary::AprilTag36h11 => dict_apriltag_36h11::MAX_CORRECTION_BITS,
        }
    }

    /// Bits decoding corrects, as OpenCV does with its default error-correction rate.
    pub fn corrected_bits(self) -> u32 {
        (f64::from(self.max_correction_bits()) * ERROR_CORRECTION_RATE) as u32
    }

    fn codes(self) -> &'static [u64] {
        match self {
            Dictionary::Aruco4x4_50 => &dict_4x4_50::CODES,
            Dictionary::Aruco5x5_100 => &dict_5x5_100::CODES,
            Dictionary::Aruco6x6_250 => &dict_6x6_250::CODES,
            Dictionary::Aruco7x7_250 => &dict_7x7_250::CODES,
            Dictionary::AprilTag36h11 => &dict_apriltag_36h11::CODES,
        }
    }

    /// Number of markers in the dictionary.
    pub fn len(self) -> usize {
        self.codes().len()
    }

    /// Never true; here because `len` is.
    pub fn is_empty(self) -> bool {
        self.codes().is_empty()
    }

    /// Whether inner cell `(row, col)` of marker `id` is white as printed; `None` outside.
    pub fn is_white(self, id: u16, row: usize, col: usize) -> Option<bool> {
        let n = self.marker_bits();
        if row >= n || col >= n {
            return None;
        }
        let code = *self.codes().get(usize::from(id))?;
        Some(code >> (n * n - 1 - (row * n + col)) & 1 == 1)
    }

    /// The code closest to the sampled grid in any of the four rotations, if within the
    /// dictionary's correction capacity ([`Dictionary::corrected_bits`]).
    pub fn decode(self, observed: u64) -> Option<Decoded> {
        let n = self.marker_bits();
        let mut grid = observed;
        let mut best: Option<Decoded> = None;
        for rotation in 0..4u8 {
            for (id, &code) in self.codes().iter().enumerate() {
                let distance = (grid ^ code).count_ones();
                if best.is_none_or(|b| distance < b.corrected_bits) {
                    best = Some(Decoded {
                        id: id as u16,
                        rotation,
                        corrected_bits: distance,
                    });
                }
            }
            // The grid turned one more quarter counter-clockwise: it now equals the printed
            // code if the printing was turned `rotation + 1` quarters clockwise.
            grid = rotate_counter_clockwise(grid, n);
        }
        best.filter(|b| b.corrected_bits <= self.corrected_bits())
    }
}

impl FromStr for Dictionary {
    type Err = UnknownDictionary;

    /// Accepts OpenCV's names, case-insensitively, with or without the `DICT_` prefix.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let t = s.trim();
        Dictionary::ALL
            .into_iter()
            .find(|d| {
                let name = d.name();
                name.eq_ignore_ascii_case(t)
                    || name
                        .strip_prefix("DICT_")
                        .is_some_and(|short| short.eq_ignore_ascii_case(t))
            })
            .ok_or_else(|| UnknownDictionary(s.to_owned()))
    }
}

impl fmt::Display for Dictionary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Turns an `n`×`n` row-major bit grid (first cell in the most significant bit) a quarter
/// counter-clockwise.
fn rotate_counter_clockwise(bits: u64, n: usize) -> u64 {
    let cells = n * n;
    let mut out = 0u64;
    for row in 0..n {
        for col in 0..n {
            // out[row][col] = in[col][n - 1 - row]
            let src = col * n + (n - 1 - row);
            let bit = bits >> (cells - 1 - src) & 1;
            out |= bit << (cells - 1 - (row * n + col));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rotate_clockwise(bits: u64, n: usize) -> u64 {
        (0..3).fold(bits, |b, _| rotate_counter_clockwise(b, n))
    }

    #[test]
    fn opencv_tables_have_their_published_sizes() {
        let sizes: Vec<_> = Dictionary::ALL
            .iter()
            .map(|d| (d.marker_bits(), d.len(), d.max_correction_bits()))
            .collect();
        assert_eq!(
            sizes,
            [
                (4, 50, 1),
                (5, 100, 3),
                (6, 250, 5),
                (7, 250, 8),
                (6, 587, 5)
            ]
        );
        // DICT_4X4_50 id 0 as OpenCV's generateImageMarker prints it (1 = white).
        let rows: Vec<Vec<bool>> = (0..4)
            .map(|r| {
                (0..4)
                    .map(|c| Dictionary::Aruco4x4_50.is_white(0, r, c).unwrap())
                    .collect()
            })
            .collect();
        let b = |s: &str| s.chars().map(|c| c == '#').collect::<Vec<_>>();
        assert_eq!(rows, [b("#.##"), b(".#.#"), b("..##"), b("..#.")]);
    }

    #[test]
    fn every_code_decodes_in_every_rotation_with_correctable_errors() {
        for d in Dictionary::ALL {
            let n = d.marker_bits();
            for (id, &code) in d.codes().iter().enumerate() {
                let mut seen = code;
                for rotation in 0..4u8 {
                    // Flip as many bits as the dictionary corrects, spread over the grid.
                    let mut noisy = seen;
                    for k in 0..d.corrected_bits() as usize {
                        noisy ^= 1 << ((id * 7 + k * 11) % (n * n));
                    }
                    let got = d.decode(noisy).unwrap();
                    assert_eq!(
                        (got.id as usize, got.rotation),
                        (id, rotation),
                        "{d} id {id}"
                    );
                    seen = rotate_clockwise(seen, n);
                }
            }
        }
    }

    #[test]
    fn patterns_too_far_from_any_code_are_refused() {
        let d = Dictionary::Aruco6x6_250;
        assert_eq!(d.decode(0), None, "an all-black grid is no marker");
        let code = d.codes()[17];
        let too_noisy = code ^ 0b1_0010_0100_1001; // four flips, three are corrected
        assert!(d.decode(too_noisy).is_none_or(|m| m.id != 17));
    }

    #[test]
    fn names_parse_like_opencv() {
        assert_eq!("DICT_6X6_250".parse(), Ok(Dictionary::Aruco6x6_250));
        assert_eq!("apriltag_36h11".parse(), Ok(Dictionary::AprilTag36h11));
        let err = "DICT_9X9_1".parse::<Dictionary>().unwrap_err();
        assert!(err.to_string().contains("DICT_4X4_50"));
    }
}
