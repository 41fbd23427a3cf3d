//! Agreeing on a capture format with the camera: packed YUYV at the requested size and frame
//! rate, and the row stride the driver chose. When the camera cannot do it, the error lists
//! what it does offer, so the user can pick a size and rate that work.

use core::fmt;
use std::io;
use std::os::raw::c_int;

use v4l::frameinterval::FrameIntervalEnum;
use v4l::framesize::FrameSizeEnum;
use v4l::parameters::Capabilities;
use v4l::video::Capture;
use v4l::{Device, Fraction};

use super::sys::{self, FormatDesc};
use crate::frame::{FrameSize, PixelFormat};

/// The four-character code of packed YUYV 4:2:2.
pub const YUYV: [u8; 4] = *b"YUYV";

/// A frame rate may come back this far (relative) from the one asked for, for cameras that
/// express 30 fps as 1001/30000 s and the like.
const FPS_TOLERANCE: f64 = 0.01;

/// Stepwise frame sizes are not expanded; intervals are listed for at most this many sizes
/// per format, which covers real webcams (a dozen sizes at most).
const MAX_SIZES_WITH_INTERVALS: usize = 32;

/// What a camera says it can capture.
#[derive(Debug, Clone, Default)]
pub struct Offer {
    pub formats: Vec<OfferedFormat>,
}

/// One pixel format and its sizes.
#[derive(Debug, Clone)]
pub struct OfferedFormat {
    pub fourcc: [u8; 4],
    pub description: String,
    pub sizes: Vec<OfferedSize>,
}

/// A frame size, or a range of them, and the frame intervals offered at it.
#[derive(Debug, Clone)]
pub struct OfferedSize {
    pub size: SizeRange,
    pub intervals: Vec<IntervalRange>,
}

/// Frame sizes as the driver lists them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SizeRange {
    Discrete {
        width_px: u32,
        height_px: u32,
    },
    Stepwise {
        min: (u32, u32),
        max: (u32, u32),
        step: (u32, u32),
    },
}

/// Frame intervals (seconds per frame, as fractions) as the driver lists them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IntervalRange {
    Discrete(u32, u32),
    Stepwise { min: (u32, u32), max: (u32, u32) },
}

/// Frames per second of an interval `num/den` seconds, or `None` for a zero interval.
fn fps_of(num: u32, den: u32) -> Option<f64> {
    (num != 0).then(|| f64::from(den) / f64::from(num))
}

impl fmt::Display for IntervalRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let show = |f: &mut fmt::Formatter<'_>, (num, den): (u32, u32)| match fps_of(num, den) {
            Some(fps) => write!(f, "{}", (fps * 100.0).round() / 100.0),
            None => write!(f, "?"),
        };
        match *self {
            IntervalRange::Discrete(num, den) => show(f, (num, den)),
            // The longest interval is the lowest rate.
            IntervalRange::Stepwise { min, max } => {
                show(f, max)?;
                write!(f, "-")?;
                show(f, min)
            }
        }
    }
}

impl fmt::Display for SizeRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            SizeRange::Discrete {
                width_px,
                height_px,
            } => write!(f, "{width_px}x{height_px}"),
            SizeRange::Stepwise { min, max, step } => write!(
                f,
                "{}x{} to {}x{} in steps of {}x{}",
                min.0, min.1, max.0, max.1, step.0, step.1
            ),
        }
    }
}

impl fmt::Display for OfferedSize {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.size)?;
        if !self.intervals.is_empty() {
            write!(f, " @ ")?;
            for (i, interval) in self.intervals.iter().enumerate() {
                if i > 0 {
                    write!(f, ", ")?;
                }
                write!(f, "{interval}")?;
            }
            write!(f, " fps")?;
        }
        Ok(())
    }
}

impl fmt::Display for OfferedFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} ({}):",
            String::from_utf8_lossy(&self.fourcc),
            self.description
        )?;
        if self.sizes.is_empty() {
            write!(f, " no sizes listed")?;
        }
        for (i, size) in self.sizes.iter().enumerate() {
            write!(f, "{}{size}", if i == 0 { " " } else { "; " })?;
        }
        Ok(())
    }
}

impl fmt::Display for Offer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.formats.is_empty() {
            return write!(f, "  (no capture formats)");
        }
        for (i, format) in self.formats.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "  {format}")?;
        }
        Ok(())
    }
}

/// Lists the formats, sizes and frame intervals of a capture node. Parts the driver does not
/// enumerate are left empty rather than failing the listing.
pub fn query_offer(device: &Device) -> io::Result<Offer> {
    let fd = device.handle().fd();
    let formats = sys::enum_formats(fd)?;
    Ok(Offer {
        formats: formats
            .into_iter()
            .map(|format| offered_format(device, format))
            .collect(),
    })
}

fn offered_format(device: &Device, format: FormatDesc) -> OfferedFormat {
    let fourcc = v4l::FourCC::new(&format.fourcc);
    let sizes = device.enum_framesizes(fourcc).unwrap_or_default();
    let sizes = sizes
        .into_iter()
        .enumerate()
        .map(|(i, s)| {
            let size = match s.size {
                FrameSizeEnum::Discrete(d) => SizeRange::Discrete {
                    width_px: d.width,
                    height_px: d.height,
                },
                FrameSizeEnum::Stepwise(s) => SizeRange::Stepwise {
                    min: (s.min_width, s.min_height),
                    max: (s.max_width, s.max_height),
                    step: (s.step_width, s.step_height),
                },
            };
            let intervals = match size {
                SizeRange::Discrete {
                    width_px,
                    height_px,
                } if i < MAX_SIZES_WITH_INTERVALS => device
                    .enum_frameintervals(fourcc, width_px, height_px)
                    .unwrap_or_default()
                    .into_iter()
                    .map(|iv| match iv.interval {
                        FrameIntervalEnum::Discrete(fr) => {
                            IntervalRange::Discrete(fr.numerator, fr.denominator)
                        }
                        FrameIntervalEnum::Stepwise(s) => IntervalRange::Stepwise {
                            min: (s.min.numerator, s.min.denominator),
                            max: (s.max.numerator, s.max.denominator),
                        },
                    })
                    .collect(),
                _ => Vec::new(),
            };
            OfferedSize { size, intervals }
        })
        .collect();
    OfferedFormat {
        fourcc: format.fourcc,
        description: format.description,
        sizes,
    }
}

/// The format both sides agreed on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Negotiated {
    pub size: FrameSize,
    /// The pixel format agreed (the one asked for: glint does not convert).
    pub format: PixelFormat,
    /// Bytes from one row to the next, as the driver lays buffers out (may exceed 2 × width).
    pub stride_bytes: usize,
    /// Frames per second the camera reports it will deliver, when it says.
    pub fps: Option<f64>,
}

/// Why the camera and glint could not agree.
#[derive(Debug)]
pub enum NegotiationError {
    /// The camera cannot deliver what was asked; `offer` is what it can.
    Unsupported {
        wanted: String,
        problem: String,
        offer: Offer,
    },
    /// An ioctl failed outright.
    Io(&'static str, io::Error),
}

impl fmt::Display for NegotiationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NegotiationError::Unsupported {
                wanted,
                problem,
                offer,
            } => write!(
                f,
                "cannot capture {wanted}: {problem}. The camera offers:\n{offer}"
            ),
            NegotiationError::Io(op, e) => write!(f, "{op} failed: {e}"),
        }
    }
}

impl std::error::Error for NegotiationError {}

/// Sets `format` (YUYV, UYVY or GREY) at `size` and, when given, `fps` frames per second, and
/// returns what was agreed. A camera without that format is refused with the list of what it
/// offers, so that the user can pick `--format-in` from it.
pub fn negotiate(
    device: &Device,
    size: FrameSize,
    fps: Option<u32>,
    format: PixelFormat,
) -> Result<Negotiated, NegotiationError> {
    let fd: c_int = device.handle().fd();
    let fourcc = format.fourcc();
    let name = String::from_utf8_lossy(&fourcc).into_owned();
    let wanted = match fps {
        Some(fps) => format!("{name} {}x{} at {fps} fps", size.width(), size.height()),
        None => format!("{name} {}x{}", size.width(), size.height()),
    };
    let unsupported = |problem: String| {
        let offer = query_offer(device).unwrap_or_default();
        NegotiationError::Unsupported {
            wanted: wanted.clone(),
            problem,
            offer,
        }
    };

    let formats = sys::enum_formats(fd).map_err(|e| NegotiationError::Io("VIDIOC_ENUM_FMT", e))?;
    if !formats.iter().any(|f| f.fourcc == fourcc) {
        return Err(unsupported(format!(
            "it has no {name} format (--format-in picks another)"
        )));
    }
    let (width_px, height_px) = (size.width() as u32, size.height() as u32);
    let got = sys::set_format(fd, width_px, height_px, fourcc)
        .map_err(|e| NegotiationError::Io("VIDIOC_S_FMT", e))?;
    if got.fourcc != fourcc || got.width_px != width_px || got.height_px != height_px {
        return Err(unsupported(format!(
            "the driver answered {} {}x{}",
            String::from_utf8_lossy(&got.fourcc),
            got.width_px,
            got.height_px
        )));
    }
    let row_bytes = size.row_bytes_as(format);
    // Some drivers leave bytesperline 0 for packed formats, meaning rows are not padded.
    let stride_bytes = match got.bytes_per_line as usize {
        0 => row_bytes,
        stride if stride >= row_bytes => stride,
        stride => {
            return Err(unsupported(format!(
                "the driver reports {stride} bytes per line, less than one {name} row ({row_bytes})"
            )))
        }
    };

    let fps = match fps {
        Some(fps) => Some(set_frame_rate(device, fps).map_err(unsupported)?),
        None => device
            .params()
            .ok()
            .and_then(|p| fps_of(p.interval.numerator, p.interval.denominator)),
    };
    Ok(Negotiated {
        size,
        format,
        stride_bytes,
        fps,
    })
}

/// Sets the frame interval to 1/`fps` s and checks the camera took it; the error text says why
/// not.
fn set_frame_rate(device: &Device, fps: u32) -> Result<f64, String> {
    let current = device
        .params()
        .map_err(|e| format!("it does not report its frame rate ({e})"))?;
    if !current.capabilities.contains(Capabilities::TIME_PER_FRAME) {
        return Err("its frame rate cannot be set".into());
    }
    let mut wanted = current;
    wanted.interval = Fraction::new(1, fps);
    let got = device
        .set_params(&wanted)
        .map_err(|e| format!("setting the frame rate failed ({e})"))?;
    let got_fps = fps_of(got.interval.numerator, got.interval.denominator)
        .ok_or_else(|| "the driver answered a zero frame interval".to_string())?;
    if (got_fps - f64::from(fps)).abs() > f64::from(fps) * FPS_TOLERANCE {
        return Err(format!("the driver answered {got_fps:.2} fps"));
    }
    Ok(got_fps)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_offer_reads_as_formats_sizes_and_rates() {
        let offer = Offer {
            formats: vec![OfferedFormat {
                fourcc: *b"YUYV",
                description: "YUYV 4:2:2".into(),
                sizes: vec![
                    OfferedSize {
                        size: SizeRange::Discrete {
                            width_px: 640,
                            height_px: 480,
                        },
                        intervals: vec![
                            IntervalRange::Discrete(1, 30),
                            IntervalRange::Discrete(1001, 30000),
                        ],
                    },
                    OfferedSize {
                        size: SizeRange::Stepwise {
                            min: (16, 16),
                            max: (1920, 1080),
                            step: (2, 2),
                        },
                        intervals: vec![],
                    },
                ],
            }],
        };
        assert_eq!(
            offer.to_string(),
            "  YUYV (YUYV 4:2:2): 640x480 @ 30, 29.97 fps; 16x16 to 1920x1080 in steps of 2x2"
        );
    }
}
