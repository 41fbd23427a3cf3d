//! A borrowed, checked view of one packed YUYV 4:2:2 frame.
//!
//! YUYV stores two pixels in four bytes, `Y0 U Y1 V`, so luma sits at every even byte of a row.
//! V4L2 drivers may pad each row (`bytesperline` larger than `2 * width`), so rows are addressed
//! through a stride. Everything is checked once in [`Frame::new_checked`]; after that the
//! accessors cannot panic, which keeps a malformed buffer from ever taking the process down.
//! The view borrows the bytes: frames are never copied in the per-frame path.

mod size;

pub use size::{FrameSize, SizeError};

use core::fmt;

/// Bytes per pixel in packed YUYV.
pub const YUYV_BYTES_PER_PIXEL: usize = 2;

/// Why a byte buffer is not a valid YUYV frame of the stated geometry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameError {
    /// The stride is shorter than one row of pixels.
    StrideTooSmall {
        stride_bytes: usize,
        row_bytes: usize,
    },
    /// The buffer ends before the last row does.
    TooShort {
        needed_bytes: usize,
        got_bytes: usize,
    },
    /// `width * height * 2` overflows the address space.
    TooLarge,
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            FrameError::StrideTooSmall {
                stride_bytes,
                row_bytes,
            } => write!(
                f,
                "row stride of {stride_bytes} bytes is shorter than one YUYV row of {row_bytes} bytes"
            ),
            FrameError::TooShort {
                needed_bytes,
                got_bytes,
            } => write!(
                f,
                "frame buffer holds {got_bytes} bytes but the frame needs {needed_bytes}"
            ),
            FrameError::TooLarge => write!(f, "frame size overflows memory"),
        }
    }
}

impl std::error::Error for FrameError {}

/// One YUYV frame, borrowed from a dump buffer or a V4L2 mmap buffer.
#[derive(Debug, Clone, Copy)]
pub struct Frame<'a> {
    bytes: &'a [u8],
    size: FrameSize,
    stride_bytes: usize,
}

impl<'a> Frame<'a> {
    /// Checks that `bytes` holds `size.height_px` rows `stride_bytes` apart, each at least
    /// `2 * width` bytes long. The last row need not carry its padding.
    pub fn new_checked(
        bytes: &'a [u8],
        size: FrameSize,
        stride_bytes: usize,
    ) -> Result<Self, FrameError> {
        let row_bytes = size.row_bytes();
        if stride_bytes < row_bytes {
            return Err(FrameError::StrideTooSmall {
                stride_bytes,
                row_bytes,
            });
        }
        let needed_bytes = stride_bytes
            .checked_mul(size.height() - 1)
            .and_then(|b| b.checked_add(row_bytes))
            .ok_or(FrameError::TooLarge)?;
        if bytes.len() < needed_bytes {
            return Err(FrameError::TooShort {
                needed_bytes,
                got_bytes: bytes.len(),
            });
        }
        Ok(Frame {
            bytes,
            size,
            stride_bytes,
        })
    }

    /// The frame's size in pixels.
    pub fn size(&self) -> FrameSize {
        self.size
    }

    /// Bytes from the start of one row to the next.
    pub fn stride_bytes(&self) -> usize {
        self.stride_bytes
    }

    /// The packed `Y0 U Y1 V` bytes of row `y`, exactly `2 * width` long, or `None` past the
    /// last row.
    #[inline]
    pub fn row(&self, y: usize) -> Option<&'a [u8]> {
        if y >= self.size.height() {
            return None;
        }
        let start = y * self.stride_bytes;
        self.bytes.get(start..start + self.size.row_bytes())
    }

    /// All rows, top to bottom, each exactly `2 * width` bytes long.
    pub fn rows(&self) -> impl ExactSizeIterator<Item = &'a [u8]> + 'a {
        let row_bytes = self.size.row_bytes();
        let bytes = self.bytes;
        let stride = self.stride_bytes;
        (0..self.size.height()).map(move |y| {
            // In range by the check in `new_checked`; an empty row is never reached.
            bytes.get(y * stride..y * stride + row_bytes).unwrap_or(&[])
        })
    }

    /// The luma of pixel `(x, y)`, or `None` outside the frame.
    #[inline]
    pub fn luma(&self, x: usize, y: usize) -> Option<u8> {
        if x >= self.size.width() {
            return None;
        }
        self.row(y)?.get(x * YUYV_BYTES_PER_PIXEL).copied()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn size(w: u32, h: u32) -> FrameSize {
        FrameSize::new(w, h).unwrap()
    }

    #[test]
    fn rows_honour_a_padded_stride() {
        // 2x2 pixels, stride 6: two padding bytes after each row.
        let bytes = [10, 1, 11, 2, 0xEE, 0xEE, 20, 3, 21, 4];
        let frame = Frame::new_checked(&bytes, size(2, 2), 6).unwrap();
        assert_eq!(frame.row(1), Some(&[20, 3, 21, 4][..]));
        assert_eq!(frame.luma(1, 0), Some(11));
        assert_eq!(frame.luma(0, 1), Some(20));
        assert_eq!(frame.luma(2, 0), None);
        assert_eq!(frame.row(2), None);
        let rows: Vec<_> = frame.rows().collect();
        assert_eq!(rows, vec![&bytes[0..4], &bytes[6..10]]);
    }

    #[test]
    fn short_buffers_and_strides_are_refused() {
        let bytes = [0u8; 15];
        assert_eq!(
            Frame::new_checked(&bytes, size(4, 2), 8).err(),
            Some(FrameError::TooShort {
                needed_bytes: 16,
                got_bytes: 15
            })
        );
        assert_eq!(
            Frame::new_checked(&bytes, size(4, 1), 6).err(),
            Some(FrameError::StrideTooSmall {
                stride_bytes: 6,
                row_bytes: 8
            })
        );
    }
}
