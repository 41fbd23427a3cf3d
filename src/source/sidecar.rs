//! The sidecar of a recorded dump (`FILE.yuv.json` beside `FILE.yuv`): the frame size, format
//! and row strides, and each frame's sequence number and time, so that a replay on another
//! machine reproduces the real frame times and drops of the capture.
//!
//! ```json
//! {"version":1,"format":"YUYV","width":640,"height":480,"stride":1280,"driver_stride":1280,
//!  "fps":30.0,"device":"/dev/video0","frames":[{"seq":0,"t_us":0},{"seq":2,"t_us":66671}]}
//! ```
//!
//! `format` is the V4L2 code of the pixels (`YUYV`, `UYVY` or `GREY`); `stride` is the dump's
//! own row stride, always `width × bytes per pixel` (rows are written unpadded);
//! `driver_stride` is what the camera used. `seq` is the capture's 64-bit sequence number (gaps
//! are dropped frames) and `t_us` the driver timestamp in microseconds since the first frame.
//! [`ReplaySource`] replays a dump with its sidecar's timing. A sidecar is checked before use:
//! it must agree with itself and with the dump beside it, or the replay refuses to start.

use core::fmt;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::dump::{DumpError, DumpSource};
use super::{FrameMeta, FrameSource};
use crate::frame::{Frame, FrameSize, PixelFormat, SizeError};
use crate::small_file::{self, SmallFileError};

/// The sidecar layout written by this version of glint.
pub const SIDECAR_VERSION: u32 = 1;
/// Appended to the dump's file name.
pub const SIDECAR_SUFFIX: &str = ".json";
/// The pixel format of dumps recorded before the sidecar named others.
pub const FORMAT_YUYV: &str = "YUYV";
/// Bytes a sidecar may spend per frame (a frame's entry is about 30), and on its header: a
/// sidecar larger than that for its dump is refused before it is read into memory.
const MAX_SIDECAR_BYTES_PER_FRAME: u64 = 128;
const MAX_SIDECAR_HEADER_BYTES: u64 = 64 * 1024;
/// The frame rate handed to the dump reader under a replay; never used, since every frame's
/// time comes from the sidecar.
const UNUSED_NOMINAL_FPS: f64 = 1.0;

/// One frame's place on the capture's timeline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct FrameTiming {
    /// Sequence number; a step of more than one means frames were dropped.
    pub seq: u64,
    /// Capture time in microseconds since the first frame.
    pub t_us: u64,
}

/// What a sidecar says about its dump.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Sidecar {
    pub version: u32,
    pub format: String,
    #[serde(rename = "width")]
    pub width_px: u32,
    #[serde(rename = "height")]
    pub height_px: u32,
    /// Bytes from one row to the next in the dump.
    #[serde(rename = "stride")]
    pub stride_bytes: usize,
    /// Bytes from one row to the next in the camera's buffers.
    #[serde(rename = "driver_stride")]
    pub driver_stride_bytes: usize,
    /// The frame rate the camera agreed to, when it said.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fps: Option<f64>,
    /// The device the frames came from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub device: Option<String>,
    pub frames: Vec<FrameTiming>,
}

/// Why a sidecar cannot be used.
#[derive(Debug)]
pub enum SidecarError {
    /// Reading or writing it failed.
    Io(io::Error),
    /// It is not a regular file, or not readable as one.
    File(SmallFileError),
    /// It is far larger than its dump could need.
    TooLarge { bytes: u64, limit_bytes: u64 },
    /// It is not the JSON described in the module documentation.
    Parse(serde_json::Error),
    /// It was written by a newer glint (or claims the version 0, which none wrote).
    Version(u32),
    /// The frames are not YUYV.
    Format(String),
    /// The size is not a usable frame size.
    Size(SizeError),
    /// The dump's rows are not `2 × width` apart.
    Stride {
        stride_bytes: usize,
        row_bytes: usize,
    },
    /// Sequence numbers must increase from one frame to the next.
    Sequence {
        frame: usize,
        previous: u64,
        seq: u64,
    },
    /// Times must not decrease from one frame to the next.
    Time {
        frame: usize,
        previous_us: u64,
        t_us: u64,
    },
    /// The sidecar is for frames of another size than the replay was asked for.
    SizeMismatch {
        sidecar: FrameSize,
        given: FrameSize,
    },
    /// The dump holds another number of frames than the sidecar lists.
    FrameCount {
        sidecar_frames: usize,
        dump_bytes: u64,
        frame_bytes: usize,
    },
}

impl fmt::Display for SidecarError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SidecarError::Io(e) => write!(f, "{e}"),
            SidecarError::File(e) => write!(f, "{e}"),
            SidecarError::TooLarge { bytes, limit_bytes } => write!(
                f,
                "{bytes} bytes is too large for the sidecar of this dump (at most {limit_bytes})"
            ),
            SidecarError::Parse(e) => write!(f, "not a glint sidecar: {e}"),
            SidecarError::Version(0) => write!(
                f,
                "sidecar version 0 does not exist (this glint reads version {SIDECAR_VERSION})"
            ),
            SidecarError::Version(v) => write!(
                f,
                "sidecar version {v} is newer than this glint reads ({SIDECAR_VERSION})"
            ),
            SidecarError::Format(format) => {
                write!(f, "frames are {format:?}, but glint reads YUYV, UYVY and GREY only")
            }
            SidecarError::Size(e) => write!(f, "{e}"),
            SidecarError::Stride {
                stride_bytes,
                row_bytes,
            } => write!(
                f,
                "the dump's rows are {stride_bytes} bytes apart, but replay reads unpadded rows \
                 of {row_bytes} bytes"
            ),
            SidecarError::Sequence {
                frame,
                previous,
                seq,
            } => write!(
                f,
                "frame {frame}: sequence number {seq} does not follow {previous}"
            ),
            SidecarError::Time {
                frame,
                previous_us,
                t_us,
            } => write!(
                f,
                "frame {frame}: time {t_us} µs is earlier than the previous frame's {previous_us} µs"
            ),
            SidecarError::SizeMismatch { sidecar, given } => write!(
                f,
                "the sidecar says the frames are {sidecar}, but --size is {given}"
            ),
            SidecarError::FrameCount {
                sidecar_frames,
                dump_bytes,
                frame_bytes,
            } => {
                write!(
                    f,
                    "the sidecar lists {sidecar_frames} frames but the dump holds {} frames",
                    dump_bytes / *frame_bytes as u64
                )?;
                let trailing = dump_bytes % *frame_bytes as u64;
                if trailing > 0 {
                    write!(f, " and {trailing} trailing bytes")?;
                }
                write!(f, " of {frame_bytes} bytes")
            }
        }
    }
}

// The messages include their cause's text, so no cause is given as a source as well: an
// error chain printed whole (`{:#}`) would repeat it.
impl std::error::Error for SidecarError {}

impl Sidecar {
    /// The sidecar of unpadded YUYV frames of `size` that a camera laid out `driver_stride_bytes`
    /// apart, with their timing.
    pub fn new(size: FrameSize, driver_stride_bytes: usize, frames: Vec<FrameTiming>) -> Self {
        Sidecar {
            version: SIDECAR_VERSION,
            format: FORMAT_YUYV.to_string(),
            width_px: size.width() as u32,
            height_px: size.height() as u32,
            stride_bytes: size.row_bytes(),
            driver_stride_bytes,
            fps: None,
            device: None,
            frames,
        }
    }

    /// The same sidecar for frames of `format` (unpadded rows of that format).
    pub fn with_format(mut self, format: PixelFormat) -> Self {
        self.format = String::from_utf8_lossy(&format.fourcc()).into_owned();
        self.stride_bytes = self
            .size()
            .map_or(self.stride_bytes, |s| s.row_bytes_as(format));
        self
    }

    /// The pixel format it states (its V4L2 four-character code).
    pub fn pixel_format(&self) -> Result<PixelFormat, SidecarError> {
        let fourcc: [u8; 4] = self
            .format
            .as_bytes()
            .try_into()
            .map_err(|_| SidecarError::Format(self.format.clone()))?;
        PixelFormat::from_fourcc(fourcc).ok_or_else(|| SidecarError::Format(self.format.clone()))
    }

    /// Where the sidecar of `dump` lives: the dump's name with [`SIDECAR_SUFFIX`] appended.
    pub fn path_for(dump: &Path) -> PathBuf {
        let mut name = dump.as_os_str().to_os_string();
        name.push(SIDECAR_SUFFIX);
        PathBuf::from(name)
    }

    /// Frames lost between the first and the last one listed (by their sequence numbers).
    pub fn dropped(&self) -> u64 {
        match (self.frames.first(), self.frames.last()) {
            (Some(first), Some(last)) => last
                .seq
                .saturating_sub(first.seq)
                .saturating_add(1)
                .saturating_sub(self.frames.len() as u64),
            _ => 0,
        }
    }

    /// The frame size it states.
    pub fn size(&self) -> Result<FrameSize, SidecarError> {
        FrameSize::new(self.width_px, self.height_px).map_err(SidecarError::Size)
    }

    /// Reads and checks the sidecar at `path` for a dump of `dump_bytes` bytes of `size`
    /// frames. Errors say what disagrees; `Io` with `NotFound` means there is no sidecar.
    /// The sidecar must be a regular file (a FIFO or a device is refused without waiting).
    pub fn load_for(path: &Path, size: FrameSize, dump_bytes: u64) -> Result<Self, SidecarError> {
        // The smallest frame (GREY) bounds the frame count for every format.
        let frames_in_dump = dump_bytes / size.frame_bytes_as(PixelFormat::Grey).max(1) as u64;
        let limit_bytes = MAX_SIDECAR_HEADER_BYTES
            .saturating_add(frames_in_dump.saturating_mul(MAX_SIDECAR_BYTES_PER_FRAME));
        let bytes = small_file::read_bytes(path, limit_bytes).map_err(|e| match e {
            SmallFileError::Open(e) => SidecarError::Io(e),
            SmallFileError::TooLarge { bytes, .. } => SidecarError::TooLarge {
                bytes: bytes.unwrap_or(limit_bytes.saturating_add(1)),
                limit_bytes,
            },
            e => SidecarError::File(e),
        })?;
        let sidecar = Self::read(&bytes[..])?;
        sidecar.check_against(size, dump_bytes)?;
        Ok(sidecar)
    }

    /// Parses a sidecar and checks that it agrees with itself.
    pub fn read(reader: impl Read) -> Result<Self, SidecarError> {
        let sidecar: Sidecar = serde_json::from_reader(reader).map_err(SidecarError::Parse)?;
        sidecar.validate()?;
        Ok(sidecar)
    }

    /// Writes the sidecar as one line of JSON.
    pub fn write(&self, mut out: impl Write) -> Result<(), SidecarError> {
        serde_json::to_writer(&mut out, self).map_err(SidecarError::Parse)?;
        writeln!(out)
            .and_then(|()| out.flush())
            .map_err(SidecarError::Io)
    }

    /// Checks version, format, size, stride and that the timeline runs forward.
    pub fn validate(&self) -> Result<(), SidecarError> {
        if self.version > SIDECAR_VERSION || self.version == 0 {
            return Err(SidecarError::Version(self.version));
        }
        let format = self.pixel_format()?;
        let size = self.size()?;
        if self.stride_bytes != size.row_bytes_as(format) {
            return Err(SidecarError::Stride {
                stride_bytes: self.stride_bytes,
                row_bytes: size.row_bytes_as(format),
            });
        }
        for (i, pair) in self.frames.windows(2).enumerate() {
            let (a, b) = match pair {
                [a, b] => (a, b),
                _ => continue,
            };
            if b.seq <= a.seq {
                return Err(SidecarError::Sequence {
                    frame: i + 1,
                    previous: a.seq,
                    seq: b.seq,
                });
            }
            if b.t_us < a.t_us {
                return Err(SidecarError::Time {
                    frame: i + 1,
                    previous_us: a.t_us,
                    t_us: b.t_us,
                });
            }
        }
        Ok(())
    }

    /// Checks that the sidecar describes a dump of `dump_bytes` bytes of `size` frames.
    pub fn check_against(&self, size: FrameSize, dump_bytes: u64) -> Result<(), SidecarError> {
        let sidecar = self.size()?;
        if sidecar != size {
            return Err(SidecarError::SizeMismatch {
                sidecar,
                given: size,
            });
        }
        let frame_bytes = size.frame_bytes_as(self.pixel_format()?);
        let expected = (self.frames.len() as u64).checked_mul(frame_bytes as u64);
        if expected != Some(dump_bytes) {
            return Err(SidecarError::FrameCount {
                sidecar_frames: self.frames.len(),
                dump_bytes,
                frame_bytes,
            });
        }
        Ok(())
    }
}

/// Why a replay with a sidecar stopped.
#[derive(Debug)]
pub enum ReplayError {
    /// Reading the dump failed.
    Dump(DumpError),
    /// The dump goes on past the frames the sidecar lists (a growing file, or a pipe).
    PastSidecar { frame: u64, sidecar_frames: usize },
}

impl fmt::Display for ReplayError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReplayError::Dump(e) => write!(f, "{e}"),
            ReplayError::PastSidecar {
                frame,
                sidecar_frames,
            } => write!(
                f,
                "frame {frame} is past the {sidecar_frames} frames the sidecar lists"
            ),
        }
    }
}

impl std::error::Error for ReplayError {}

/// A dump replayed with the frame times and sequence numbers of its recording: the reports
/// carry the same `t`, `seq` and `dropped` as the live run would have.
pub struct ReplaySource<R> {
    dump: DumpSource<R>,
    frames: Vec<FrameTiming>,
    previous_seq: Option<u64>,
}

impl<R: Read> ReplaySource<R> {
    /// Replays `reader`, a dump of `size` frames in the sidecar's pixel format, with
    /// `sidecar`'s timing. The sidecar is assumed checked ([`Sidecar::load_for`]).
    pub fn new(reader: R, size: FrameSize, sidecar: Sidecar) -> Self {
        let format = sidecar.pixel_format().unwrap_or_default();
        let dump = DumpSource::with_format(reader, size, UNUSED_NOMINAL_FPS, format);
        Self::from_dump(dump, sidecar)
    }

    /// [`ReplaySource::new`] over a dump source already opened in the sidecar's pixel format
    /// (with [`DumpSource::try_with_format`], say); its nominal frame rate is not used.
    pub fn from_dump(dump: DumpSource<R>, sidecar: Sidecar) -> Self {
        ReplaySource {
            dump,
            frames: sidecar.frames,
            previous_seq: None,
        }
    }
}

impl<R: Read> FrameSource for ReplaySource<R> {
    type Error = ReplayError;

    fn next_frame(&mut self) -> Result<Option<(Frame<'_>, FrameMeta)>, ReplayError> {
        let Some((frame, meta)) = self.dump.next_frame().map_err(ReplayError::Dump)? else {
            return Ok(None);
        };
        let timing = usize::try_from(meta.index)
            .ok()
            .and_then(|i| self.frames.get(i))
            .ok_or(ReplayError::PastSidecar {
                frame: meta.index,
                sidecar_frames: self.frames.len(),
            })?;
        let dropped = match self.previous_seq {
            Some(previous) => timing.seq.saturating_sub(previous).saturating_sub(1),
            None => 0,
        };
        self.previous_seq = Some(timing.seq);
        let meta = FrameMeta {
            index: meta.index,
            sequence: timing.seq,
            dropped,
            timestamp_us: timing.t_us,
            monotonic_us: meta.monotonic_us,
        };
        Ok(Some((frame, meta)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn size() -> FrameSize {
        FrameSize::new(4, 2).unwrap()
    }

    fn timing(seq: u64, t_us: u64) -> FrameTiming {
        FrameTiming { seq, t_us }
    }

    fn sidecar(frames: Vec<FrameTiming>) -> Sidecar {
        Sidecar::new(size(), 16, frames)
    }

    #[test]
    fn written_sidecars_read_back_equal() {
        let mut s = sidecar(vec![timing(5, 0), timing(6, 33_000), timing(9, 133_000)]);
        s.fps = Some(30.0);
        s.device = Some("/dev/video0 \"cam\"".into());
        let mut bytes = Vec::new();
        s.write(&mut bytes).unwrap();
        assert_eq!(bytes.iter().filter(|&&b| b == b'\n').count(), 1, "one line");
        assert_eq!(Sidecar::read(&bytes[..]).unwrap(), s);
        assert_eq!(s.dropped(), 2);
        assert_eq!(sidecar(vec![]).dropped(), 0);
    }

    #[test]
    fn the_path_appends_to_the_dump_name() {
        assert_eq!(
            Sidecar::path_for(Path::new("/tmp/run.yuv")),
            PathBuf::from("/tmp/run.yuv.json")
        );
    }

    #[test]
    fn inconsistent_sidecars_are_refused() {
        let backwards_seq = sidecar(vec![timing(5, 0), timing(5, 10)]);
        assert!(matches!(
            backwards_seq.validate(),
            Err(SidecarError::Sequence { frame: 1, .. })
        ));
        let backwards_time = sidecar(vec![timing(1, 50), timing(2, 10)]);
        assert!(matches!(
            backwards_time.validate(),
            Err(SidecarError::Time { frame: 1, .. })
        ));
        let mut padded = sidecar(vec![]);
        padded.stride_bytes = 16;
        assert!(matches!(
            padded.validate(),
            Err(SidecarError::Stride {
                stride_bytes: 16,
                row_bytes: 8
            })
        ));
        let mut odd = sidecar(vec![]);
        odd.width_px = 3;
        assert!(matches!(odd.validate(), Err(SidecarError::Size(_))));
        let mut future = sidecar(vec![]);
        future.version = SIDECAR_VERSION + 1;
        let e = future.validate().unwrap_err();
        assert!(e.to_string().contains("is newer"), "{e}");
        future.version = 0;
        let e = future.validate().unwrap_err();
        assert!(matches!(e, SidecarError::Version(0)));
        assert!(!e.to_string().contains("newer"), "{e}");
        let mut mjpeg = sidecar(vec![]);
        mjpeg.format = "MJPG".into();
        assert!(matches!(mjpeg.validate(), Err(SidecarError::Format(_))));
        assert!(matches!(
            Sidecar::read(&b"{\"version\":1}"[..]),
            Err(SidecarError::Parse(_))
        ));
    }

    #[test]
    fn a_sidecar_must_match_its_dump() {
        let s = sidecar(vec![timing(0, 0), timing(1, 10)]);
        let frame_bytes = size().frame_bytes() as u64;
        assert!(s.check_against(size(), 2 * frame_bytes).is_ok());
        let e = s.check_against(size(), 3 * frame_bytes + 5).unwrap_err();
        assert_eq!(
            e.to_string(),
            "the sidecar lists 2 frames but the dump holds 3 frames and 5 trailing bytes of 16 bytes"
        );
        let other = FrameSize::new(2, 4).unwrap();
        let e = s.check_against(other, 2 * frame_bytes).unwrap_err();
        assert_eq!(
            e.to_string(),
            "the sidecar says the frames are 4x2, but --size is 2x4"
        );
    }

    #[test]
    fn replay_reproduces_sequence_drops_and_times() {
        let bytes: Vec<u8> = (0..48).collect();
        let s = sidecar(vec![timing(10, 0), timing(11, 33_000), timing(14, 140_000)]);
        let mut source = ReplaySource::new(&bytes[..], size(), s);
        let mut metas = Vec::new();
        while let Some((frame, meta)) = source.next_frame().unwrap() {
            metas.push((meta, frame.luma(0, 0).unwrap()));
        }
        let got: Vec<_> = metas
            .iter()
            .map(|(m, y)| (m.index, m.sequence, m.dropped, m.timestamp_us, *y))
            .collect();
        assert_eq!(
            got,
            vec![
                (0, 10, 0, 0, 0),
                (1, 11, 0, 33_000, 16),
                (2, 14, 2, 140_000, 32)
            ]
        );
    }

    #[test]
    fn a_dump_longer_than_its_sidecar_stops_with_an_error() {
        let bytes = [0u8; 32];
        let mut source = ReplaySource::new(&bytes[..], size(), sidecar(vec![timing(0, 0)]));
        assert!(source.next_frame().unwrap().is_some());
        assert!(matches!(
            source.next_frame(),
            Err(ReplayError::PastSidecar {
                frame: 1,
                sidecar_frames: 1
            })
        ));
    }

    #[test]
    fn an_oversized_sidecar_is_not_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.yuv.json");
        std::fs::write(&path, vec![b' '; 200 * 1024]).unwrap();
        let e = Sidecar::load_for(&path, size(), 16).unwrap_err();
        assert!(matches!(e, SidecarError::TooLarge { .. }), "{e}");
    }
}
