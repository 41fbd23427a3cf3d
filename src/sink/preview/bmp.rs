//! The frame as a 24-bit BMP: the simplest image format every browser shows, written by hand
//! in a few lines (no encoder crate for an uncompressed header and rows).
//!
//! Luma is grey; pixels at or above the frame's saturation threshold (the mask the detector
//! cut) are tinted [`MASK_TINT`], keeping a trace of their luma so edges stay visible.

use super::Snapshot;

/// File header (14 bytes) plus BITMAPINFOHEADER (40 bytes).
const HEADER_BYTES: usize = 54;
const INFO_HEADER_BYTES: u32 = 40;
/// Bytes per pixel of a 24-bit BMP (blue, green, red).
const PIXEL_BYTES: usize = 3;
/// BMP rows are padded to a multiple of this.
const ROW_ALIGN: usize = 4;
/// Pixels per metre written in the header (72 dpi); browsers ignore it.
const PX_PER_M: u32 = 2835;
/// Saturated pixels: red, with a quarter of their luma in green and blue.
pub const MASK_TINT: [u8; 3] = [255, 0, 0];
const TINT_LUMA_SHIFT: u32 = 2;

/// Encodes the snapshot's frame into `out` (cleared first).
pub fn encode(snapshot: &Snapshot, out: &mut Vec<u8>) {
    let width = snapshot.size.width();
    let height = snapshot.size.height();
    let row_bytes = (width * PIXEL_BYTES).div_ceil(ROW_ALIGN) * ROW_ALIGN;
    let image_bytes = row_bytes * height;
    let file_bytes = HEADER_BYTES + image_bytes;
    let u32_of = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
    out.clear();
    out.reserve(file_bytes);
    out.extend_from_slice(b"BM");
    out.extend_from_slice(&u32_of(file_bytes).to_le_bytes());
    out.extend_from_slice(&[0; 4]);
    out.extend_from_slice(&u32_of(HEADER_BYTES).to_le_bytes());
    out.extend_from_slice(&INFO_HEADER_BYTES.to_le_bytes());
    out.extend_from_slice(&u32_of(width).to_le_bytes());
    // Positive height: rows bottom-up, which every reader supports.
    out.extend_from_slice(&u32_of(height).to_le_bytes());
    out.extend_from_slice(&1u16.to_le_bytes()); // planes
    out.extend_from_slice(&24u16.to_le_bytes()); // bits per pixel
    out.extend_from_slice(&0u32.to_le_bytes()); // no compression
    out.extend_from_slice(&u32_of(image_bytes).to_le_bytes());
    out.extend_from_slice(&PX_PER_M.to_le_bytes());
    out.extend_from_slice(&PX_PER_M.to_le_bytes());
    out.extend_from_slice(&[0; 8]); // palette sizes
    let padding = row_bytes - width * PIXEL_BYTES;
    let threshold = snapshot.threshold_luma;
    for row in snapshot.luma.chunks_exact(width).rev() {
        for &y in row {
            let [r, g, b] = match threshold {
                Some(t) if y >= t => {
                    let trace = y >> TINT_LUMA_SHIFT;
                    MASK_TINT.map(|c| c.saturating_add(trace))
                }
                _ => [y, y, y],
            };
            out.extend_from_slice(&[b, g, r]);
        }
        out.extend(core::iter::repeat_n(0, padding));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::FrameSize;

    /// Reads pixel (x, y) (top-down) of a BMP written by `encode`, as RGB.
    fn pixel(bmp: &[u8], width: usize, height: usize, x: usize, y: usize) -> [u8; 3] {
        let row_bytes = (width * 3).div_ceil(4) * 4;
        let at = HEADER_BYTES + (height - 1 - y) * row_bytes + 3 * x;
        [bmp[at + 2], bmp[at + 1], bmp[at]]
    }

    #[test]
    fn grey_below_the_threshold_tinted_at_or_above_it() {
        // 2×2, so each 6-byte row carries 2 bytes of padding.
        let mut snapshot = Snapshot::new(FrameSize::new(2, 2).unwrap());
        snapshot.luma = vec![10, 200, 255, 199];
        snapshot.threshold_luma = Some(200);
        let mut bmp = Vec::new();
        encode(&snapshot, &mut bmp);
        assert_eq!(&bmp[..2], b"BM");
        assert_eq!(bmp.len(), HEADER_BYTES + 2 * 8);
        let size = u32::from_le_bytes(bmp[2..6].try_into().unwrap());
        assert_eq!(size as usize, bmp.len());
        assert_eq!(pixel(&bmp, 2, 2, 0, 0), [10, 10, 10]);
        assert_eq!(pixel(&bmp, 2, 2, 1, 0), [255, 50, 50]);
        assert_eq!(pixel(&bmp, 2, 2, 0, 1), [255, 63, 63]);
        assert_eq!(pixel(&bmp, 2, 2, 1, 1), [199, 199, 199]);
        // Without a threshold nothing is masked.
        snapshot.threshold_luma = None;
        encode(&snapshot, &mut bmp);
        assert_eq!(pixel(&bmp, 2, 2, 0, 1), [255, 255, 255]);
    }
}
