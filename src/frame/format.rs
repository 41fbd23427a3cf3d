//! The packed pixel formats glint reads luma from.
//!
//! All three carry luma as one byte per pixel at a fixed place in a row: `YUYV` (`Y0 U Y1 V`,
//! luma at even bytes), `UYVY` (`U Y0 V Y1`, luma at odd bytes), and `GREY` (8-bit luma only,
//! as global-shutter mono cameras such as the OV9281 deliver). A frame view therefore needs
//! only the luma's byte offset in a row and the step from one pixel's luma to the next.

use core::fmt;
use core::str::FromStr;

/// A pixel format of the frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum PixelFormat {
    /// Packed YUV 4:2:2, `Y0 U Y1 V` (the default: what most UVC webcams deliver).
    #[default]
    Yuyv,
    /// Packed YUV 4:2:2, `U Y0 V Y1`.
    Uyvy,
    /// 8-bit luma only.
    Grey,
}

/// A format name that is not one of glint's.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnknownFormat(pub String);

impl fmt::Display for UnknownFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "pixel format {:?} is not one of yuyv, uyvy, grey",
            self.0
        )
    }
}

impl std::error::Error for UnknownFormat {}

impl PixelFormat {
    /// Every format, in the order the CLI lists them.
    pub const ALL: [PixelFormat; 3] = [PixelFormat::Yuyv, PixelFormat::Uyvy, PixelFormat::Grey];

    /// Bytes one pixel takes in a row.
    pub const fn bytes_per_pixel(self) -> usize {
        match self {
            PixelFormat::Yuyv | PixelFormat::Uyvy => 2,
            PixelFormat::Grey => 1,
        }
    }

    /// Where the first pixel's luma sits in a row.
    pub const fn luma_offset(self) -> usize {
        match self {
            PixelFormat::Uyvy => 1,
            PixelFormat::Yuyv | PixelFormat::Grey => 0,
        }
    }

    /// The lower-case name used on the command line and in sidecars.
    pub const fn name(self) -> &'static str {
        match self {
            PixelFormat::Yuyv => "yuyv",
            PixelFormat::Uyvy => "uyvy",
            PixelFormat::Grey => "grey",
        }
    }

    /// The V4L2 four-character code.
    pub const fn fourcc(self) -> [u8; 4] {
        match self {
            PixelFormat::Yuyv => *b"YUYV",
            PixelFormat::Uyvy => *b"UYVY",
            PixelFormat::Grey => *b"GREY",
        }
    }

    /// The format of a V4L2 four-character code, if glint reads it.
    pub fn from_fourcc(fourcc: [u8; 4]) -> Option<Self> {
        Self::ALL.into_iter().find(|f| f.fourcc() == fourcc)
    }
}

impl fmt::Display for PixelFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for PixelFormat {
    type Err = UnknownFormat;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let lower = s.trim().to_ascii_lowercase();
        // V4L2 spells it GREY; "gray" is the other spelling people type.
        let name = if lower == "gray" { "grey" } else { &lower };
        Self::ALL
            .into_iter()
            .find(|f| f.name() == name)
            .ok_or_else(|| UnknownFormat(s.to_owned()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_fourccs_round_trip() {
        for format in PixelFormat::ALL {
            assert_eq!(format.name().parse::<PixelFormat>(), Ok(format));
            assert_eq!(PixelFormat::from_fourcc(format.fourcc()), Some(format));
        }
        assert_eq!("GRAY".parse::<PixelFormat>(), Ok(PixelFormat::Grey));
        assert!("nv12".parse::<PixelFormat>().is_err());
        assert_eq!(PixelFormat::from_fourcc(*b"MJPG"), None);
    }
}
