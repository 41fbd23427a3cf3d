//! A borrowed, checked view of one frame: packed YUYV 4:2:2 by default, or UYVY, or 8-bit
//! grey ([`PixelFormat`]).
//!
//! YUYV stores two pixels in four bytes, `Y0 U Y1 V`, so luma sits at every even byte of a row;
//! UYVY at every odd byte; GREY is luma alone. The view knows the luma's offset and step in a
//! row, so every stage reads luma the same way whatever the camera sends ([`Frame::luma_row`]).
//! V4L2 drivers may pad each row (`bytesperline` larger than the pixels need), so rows are
//! addressed through a stride. Everything is checked once in [`Frame::new_checked_as`]; after
//! that the accessors cannot panic, which keeps a malformed buffer from ever taking the process
//! down. The view borrows the bytes: frames are never copied in the per-frame path.

mod format;
mod size;

pub use format::{PixelFormat, UnknownFormat};
pub use size::{FrameSize, SizeError};

use core::fmt;

/// Bytes per pixel in packed YUYV.
pub const YUYV_BYTES_PER_PIXEL: usize = 2;

/// Why a byte buffer is not a valid frame of the stated geometry.
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
                "row stride of {stride_bytes} bytes is shorter than one row of {row_bytes} bytes"
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

/// One frame, borrowed from a dump buffer or a V4L2 mmap buffer.
#[derive(Debug, Clone, Copy)]
pub struct Frame<'a> {
    bytes: &'a [u8],
    size: FrameSize,
    stride_bytes: usize,
    format: PixelFormat,
}

impl<'a> Frame<'a> {
    /// A YUYV frame: see [`Frame::new_checked_as`].
    pub fn new_checked(
        bytes: &'a [u8],
        size: FrameSize,
        stride_bytes: usize,
    ) -> Result<Self, FrameError> {
        Self::new_checked_as(bytes, size, stride_bytes, PixelFormat::Yuyv)
    }

    /// Checks that `bytes` holds `size.height_px` rows of `format` pixels `stride_bytes`
    /// apart, each at least `width × bytes per pixel` long. The last row need not carry its
    /// padding.
    pub fn new_checked_as(
        bytes: &'a [u8],
        size: FrameSize,
        stride_bytes: usize,
        format: PixelFormat,
    ) -> Result<Self, FrameError> {
        let row_bytes = size.row_bytes_as(format);
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
            format,
        })
    }

    /// The pixel format.
    pub fn format(&self) -> PixelFormat {
        self.format
    }

    /// Bytes from one pixel's luma to the next in a row: 2 for YUYV and UYVY, 1 for GREY.
    #[inline]
    pub fn luma_step(&self) -> usize {
        self.format.bytes_per_pixel()
    }

    /// The frame's size in pixels.
    pub fn size(&self) -> FrameSize {
        self.size
    }

    /// Bytes from the start of one row to the next.
    pub fn stride_bytes(&self) -> usize {
        self.stride_bytes
    }

    /// The packed bytes of row `y` as the camera sent them, exactly `width × bytes per pixel`
    /// long, or `None` past the last row.
    #[inline]
    pub fn row(&self, y: usize) -> Option<&'a [u8]> {
        if y >= self.size.height() {
            return None;
        }
        let start = y * self.stride_bytes;
        self.bytes
            .get(start..start + self.size.row_bytes_as(self.format))
    }

    /// All rows, top to bottom, each exactly `width × bytes per pixel` long.
    pub fn rows(&self) -> impl ExactSizeIterator<Item = &'a [u8]> + 'a {
        let row_bytes = self.size.row_bytes_as(self.format);
        let bytes = self.bytes;
        let stride = self.stride_bytes;
        (0..self.size.height()).map(move |y| {
            // In range by the check in `new_checked_as`; an empty row is never reached.
            bytes.get(y * stride..y * stride + row_bytes).unwrap_or(&[])
        })
    }

    /// Row `y` from its first luma byte to its last: pixel `x`'s luma is byte
    /// `x * luma_step()`. `None` past the last row.
    #[inline]
    pub fn luma_row(&self, y: usize) -> Option<&'a [u8]> {
        let row = self.row(y)?;
        row.get(self.format.luma_offset()..self.luma_row_len() + self.format.luma_offset())
    }

    /// Every row's luma span (as [`Frame::luma_row`]), top to bottom.
    pub fn luma_rows(&self) -> impl ExactSizeIterator<Item = &'a [u8]> + 'a {
        let (offset, len) = (self.format.luma_offset(), self.luma_row_len());
        self.rows()
            .map(move |row| row.get(offset..offset + len).unwrap_or(&[]))
    }

    /// Bytes from a row's first luma byte to its last, inclusive.
    fn luma_row_len(&self) -> usize {
        (self.size.width() - 1) * self.luma_step() + 1
    }

    /// The luma of pixel `(x, y)`, or `None` outside the frame.
    #[inline]
    pub fn luma(&self, x: usize, y: usize) -> Option<u8> {
        if x >= self.size.width() {
            return None;
        }
        self.luma_row(y)?.get(x * self.luma_step()).copied()
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
    fn luma_is_found_in_every_format() {
        // 2x2 pixels with lumas 10, 11 / 20, 21, stride padded by two bytes.
        let yuyv = [10, 1, 11, 2, 0xEE, 0xEE, 20, 3, 21, 4];
        let uyvy = [1, 10, 2, 11, 0xEE, 0xEE, 3, 20, 4, 21];
        let grey = [10, 11, 0xEE, 0xEE, 20, 21];
        for (bytes, format, stride) in [
            (&yuyv[..], PixelFormat::Yuyv, 6),
            (&uyvy[..], PixelFormat::Uyvy, 6),
            (&grey[..], PixelFormat::Grey, 4),
        ] {
            let frame = Frame::new_checked_as(bytes, size(2, 2), stride, format).unwrap();
            let lumas: Vec<_> = (0..2)
                .flat_map(|y| (0..2).map(move |x| (x, y)))
                .map(|(x, y)| frame.luma(x, y))
                .collect();
            assert_eq!(lumas, [Some(10), Some(11), Some(20), Some(21)], "{format}");
            let step = frame.luma_step();
            let from_rows: Vec<u8> = frame
                .luma_rows()
                .flat_map(|row| row.iter().step_by(step).copied())
                .collect();
            assert_eq!(from_rows, [10, 11, 20, 21], "{format}");
            assert_eq!(frame.row(1).map(<[u8]>::len), Some(2 * step));
        }
        assert_eq!(
            Frame::new_checked_as(&grey, size(2, 2), 1, PixelFormat::Grey).err(),
            Some(FrameError::StrideTooSmall {
                stride_bytes: 1,
                row_bytes: 2
            })
        );
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
