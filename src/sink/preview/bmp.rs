//! The frame as a 24-bit BMP: the simplest image format every browser shows, written by hand
//! in a few lines (no encoder crate for an uncompressed header and rows).
//!
//! Luma is grey; pixels at or above the frame's saturation threshold (the mask the detector
//! cut) are tinted [`MASK_TINT`], keeping a trace of their luma so edges stay visible.

use super::Snapshot;
use crate::frame::FrameSize;

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

/// Bytes of one row, padded.
fn row_bytes(width: usize) -> usize {
    (width * PIXEL_BYTES).div_ceil(ROW_ALIGN) * ROW_ALIGN
}

/// Bytes of the whole file for a frame of `size`: what [`encode`] writes.
pub fn file_bytes(size: FrameSize) -> usize {
    HEADER_BYTES + row_bytes(size.width()) * size.height()
}

/// Encodes the snapshot's frame into `out`, which should be [`file_bytes`] long (a shorter
/// one gets what fits, a longer one is written up to that length).
pub fn encode(snapshot: &Snapshot, out: &mut [u8]) {
    let width = snapshot.seen.size.width();
    let height = snapshot.seen.size.height();
    let row_bytes = row_bytes(width);
    let image_bytes = row_bytes * height;
    let u32_of = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
    let mut header = [0u8; HEADER_BYTES];
    let fields: [&[u8]; 14] = [
        b"BM",
        &u32_of(file_bytes(snapshot.seen.size)).to_le_bytes(),
        &[0; 4],
        &u32_of(HEADER_BYTES).to_le_bytes(),
        &INFO_HEADER_BYTES.to_le_bytes(),
        &u32_of(width).to_le_bytes(),
        // Positive height: rows bottom-up, which every reader supports.
        &u32_of(height).to_le_bytes(),
        &1u16.to_le_bytes(),  // planes
        &24u16.to_le_bytes(), // bits per pixel
        &0u32.to_le_bytes(),  // no compression
        &u32_of(image_bytes).to_le_bytes(),
        &PX_PER_M.to_le_bytes(),
        &PX_PER_M.to_le_bytes(),
        &[0; 8], // palette sizes
    ];
    let mut at = 0;
    for field in fields {
        for (dst, src) in header.iter_mut().skip(at).zip(field) {
            *dst = *src;
        }
        at += field.len();
    }
    let (head, image) = out.split_at_mut(HEADER_BYTES.min(out.len()));
    head.copy_from_slice(header.get(..head.len()).unwrap_or_default());
    let threshold = snapshot.seen.threshold_luma;
    let rows = snapshot.luma.chunks_exact(width).rev();
    for (dst, row) in image.chunks_mut(row_bytes).zip(rows) {
        let (pixels, padding) = dst.split_at_mut((width * PIXEL_BYTES).min(dst.len()));
        for (px, &y) in pixels.chunks_exact_mut(PIXEL_BYTES).zip(row) {
            let [r, g, b] = match threshold {
                Some(t) if y >= t => {
                    let trace = y >> TINT_LUMA_SHIFT;
                    MASK_TINT.map(|c| c.saturating_add(trace))
                }
                _ => [y, y, y],
            };
            px.copy_from_slice(&[b, g, r]);
        }
        padding.fill(0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        snapshot.seen.threshold_luma = Some(200);
        let mut bmp = vec![1; file_bytes(snapshot.seen.size)];
        encode(&snapshot, &mut bmp);
        assert_eq!(&bmp[..2], b"BM");
        assert_eq!(bmp.len(), HEADER_BYTES + 2 * 8);
        assert_eq!(
            &bmp[10..14],
            &54u32.to_le_bytes(),
            "pixels after the headers"
        );
        assert_eq!(&bmp[18..26], &[2, 0, 0, 0, 2, 0, 0, 0], "width and height");
        assert_eq!(&bmp[28..30], &24u16.to_le_bytes(), "bits per pixel");
        assert_eq!(&bmp[50..54], &[0; 4], "the last header field");
        // Row padding is written, whatever the buffer held.
        assert_eq!(&bmp[HEADER_BYTES + 6..HEADER_BYTES + 8], &[0, 0]);
        let size = u32::from_le_bytes(bmp[2..6].try_into().unwrap());
        assert_eq!(size as usize, bmp.len());
        assert_eq!(pixel(&bmp, 2, 2, 0, 0), [10, 10, 10]);
        assert_eq!(pixel(&bmp, 2, 2, 1, 0), [255, 50, 50]);
        assert_eq!(pixel(&bmp, 2, 2, 0, 1), [255, 63, 63]);
        assert_eq!(pixel(&bmp, 2, 2, 1, 1), [199, 199, 199]);
        // Without a threshold nothing is masked.
        snapshot.seen.threshold_luma = None;
        encode(&snapshot, &mut bmp);
        assert_eq!(pixel(&bmp, 2, 2, 0, 1), [255, 255, 255]);
        // A short buffer gets what fits, and nothing panics.
        let mut short = vec![0; HEADER_BYTES + 3];
        encode(&snapshot, &mut short);
        assert_eq!(&short[..2], b"BM");
        assert_eq!(
            &short[HEADER_BYTES..],
            &[255, 255, 255],
            "the bottom row's first pixel"
        );
    }
}
