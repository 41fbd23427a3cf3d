//! Frame dimensions, parsed from `WxH` and checked for what YUYV allows.

use core::fmt;
use core::str::FromStr;

use super::PixelFormat;

/// The largest side accepted, far above any webcam, so that sizes times strides never overflow
/// (what a size costs in memory is checked against `--max-memory-mb` separately).
pub const MAX_SIDE_PX: u32 = 16_384;

/// Width and height of a frame in pixels: both non-zero, the width even (YUYV pairs pixels).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FrameSize {
    width_px: u32,
    height_px: u32,
}

/// Why a size is not usable.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SizeError {
    /// Not of the form `WxH` with two whole numbers.
    Syntax(String),
    /// A zero side.
    Zero,
    /// YUYV and UYVY carry pixels in pairs (and every format is held to it).
    OddWidth(u32),
    /// Larger than `MAX_SIDE_PX`.
    TooLarge,
}

impl fmt::Display for SizeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SizeError::Syntax(s) => write!(f, "size {s:?} is not WIDTHxHEIGHT, e.g. 640x480"),
            SizeError::Zero => write!(f, "width and height must be greater than zero"),
            SizeError::OddWidth(w) => {
                // Said of every format: the size is read before the format is known, and a
                // GREY frame's width is held to the packed formats' pairs too.
                write!(
                    f,
                    "width {w} is odd: glint takes even widths only (YUYV and UYVY carry \
                     pixels in pairs)"
                )
            }
            SizeError::TooLarge => write!(f, "sides above {MAX_SIDE_PX} pixels are not supported"),
        }
    }
}

impl std::error::Error for SizeError {}

impl FrameSize {
    /// A checked size.
    pub fn new(width_px: u32, height_px: u32) -> Result<Self, SizeError> {
        if width_px == 0 || height_px == 0 {
            return Err(SizeError::Zero);
        }
        if width_px > MAX_SIDE_PX || height_px > MAX_SIDE_PX {
            return Err(SizeError::TooLarge);
        }
        if !width_px.is_multiple_of(2) {
            return Err(SizeError::OddWidth(width_px));
        }
        Ok(FrameSize {
            width_px,
            height_px,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width_px as usize
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height_px as usize
    }

    /// Pixels in the frame.
    pub fn pixels(&self) -> usize {
        self.width() * self.height()
    }

    /// Bytes of one unpadded YUYV row.
    pub fn row_bytes(&self) -> usize {
        self.row_bytes_as(PixelFormat::Yuyv)
    }

    /// Bytes of one unpadded YUYV frame, as raw dumps store it.
    pub fn frame_bytes(&self) -> usize {
        self.frame_bytes_as(PixelFormat::Yuyv)
    }

    /// Bytes of one unpadded row of `format`.
    pub fn row_bytes_as(&self, format: PixelFormat) -> usize {
        self.width() * format.bytes_per_pixel()
    }

    /// Bytes of one unpadded frame of `format`, as raw dumps store it.
    pub fn frame_bytes_as(&self, format: PixelFormat) -> usize {
        self.row_bytes_as(format) * self.height()
    }
}

impl fmt::Display for FrameSize {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}x{}", self.width_px, self.height_px)
    }
}

impl FromStr for FrameSize {
    type Err = SizeError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        // The text is quoted back in the message: at most its start.
        let syntax = || SizeError::Syntax(crate::options::shortened(s));
        let (w, h) = s.trim().split_once(['x', 'X']).ok_or_else(syntax)?;
        let w: u32 = w.trim().parse().map_err(|_| syntax())?;
        let h: u32 = h.trim().parse().map_err(|_| syntax())?;
        FrameSize::new(w, h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_refuses() {
        assert_eq!("640x480".parse::<FrameSize>().unwrap().pixels(), 307_200);
        assert_eq!(
            "641x480".parse::<FrameSize>(),
            Err(SizeError::OddWidth(641))
        );
        assert_eq!("0x480".parse::<FrameSize>(), Err(SizeError::Zero));
        assert!(matches!(
            "640*480".parse::<FrameSize>(),
            Err(SizeError::Syntax(_))
        ));
        assert!(matches!(
            "x480".parse::<FrameSize>(),
            Err(SizeError::Syntax(_))
        ));
        assert_eq!("99999x2".parse::<FrameSize>(), Err(SizeError::TooLarge));
    }
}
