//! Camera options shared by `glint track --device` and `glint record`, and opening the camera:
//! a reopening V4L2 source whose stop flag Ctrl-C and SIGTERM set.

use std::path::Path;

use anyhow::Result;
use clap::{Args, ValueEnum};

use glint::frame::{FrameSize, PixelFormat};
use glint::source::v4l2::{
    CaptureConfig, ControlRequest, NamedControl, PowerLine, ReopeningSource, DEFAULT_BUFFER_COUNT,
};

/// Most mmap buffers accepted; drivers cap far lower (UVC at 32).
const MAX_BUFFERS: i64 = 32;

/// What the camera is asked for beyond size and frame rate.
#[derive(Debug, Args)]
pub struct CameraArgs {
    /// mmap buffers to ask the driver for, 1 to 32 (each holds one frame).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_BUFFER_COUNT,
          allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(1..=MAX_BUFFERS))]
    buffers: u32,

    /// Manual exposure time in microseconds (turns auto exposure off unless
    /// --auto-exposure on). A short exposure leaves the LED the only saturated thing. The
    /// tracker uses it too: the streak's length over it is the speed within one frame; so for
    /// a recording, give the exposure it was made with. 1 to 10000000.
    #[arg(long, value_name = "MICROSECONDS", allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(1..=10_000_000))]
    exposure_us: Option<u32>,

    /// Sensor gain, in the camera's own units (see `glint devices`).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    gain: Option<i64>,

    /// Automatic exposure.
    #[arg(long, value_enum)]
    auto_exposure: Option<OnOff>,

    /// Automatic white balance.
    #[arg(long, value_enum)]
    awb: Option<OnOff>,

    /// Mains frequency whose flicker the camera filters.
    #[arg(long, value_name = "off|50|60|auto")]
    power_line: Option<PowerLine>,

    /// Any other control, by the name `glint devices` lists (repeatable).
    #[arg(long = "control", value_name = "NAME=VALUE")]
    controls: Vec<NamedControl>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum OnOff {
    On,
    Off,
}

impl OnOff {
    fn is_on(self) -> bool {
        self == OnOff::On
    }
}

impl CameraArgs {
    /// Whether any option that only a camera can take was given (`--exposure-us` also
    /// describes a recording, so it does not count).
    pub fn any_given(&self) -> bool {
        let request = ControlRequest {
            exposure_us: None,
            ..self.request()
        };
        self.buffers != DEFAULT_BUFFER_COUNT || !request.is_empty()
    }

    /// The mmap buffers asked for.
    pub fn buffers(&self) -> u32 {
        self.buffers
    }

    /// The exposure time given, in microseconds.
    pub fn exposure_us(&self) -> Option<u32> {
        self.exposure_us
    }

    /// The controls to set at every open of the camera.
    fn request(&self) -> ControlRequest {
        ControlRequest {
            exposure_us: self.exposure_us,
            gain: self.gain,
            auto_exposure: self.auto_exposure.map(OnOff::is_on),
            auto_white_balance: self.awb.map(OnOff::is_on),
            power_line: self.power_line,
            named: self.controls.clone(),
        }
    }
}

/// Opens the camera at `path` for `format` frames of `size` (at `fps` when given), sets the
/// controls (the report goes to the log), and arranges for Ctrl-C and SIGTERM to end the stream
/// cleanly. Live runs log at info level at least, so the control report and the periodic
/// summary show by default.
pub fn open(
    path: &Path,
    size: FrameSize,
    fps: Option<u32>,
    format: PixelFormat,
    camera: &CameraArgs,
) -> Result<ReopeningSource> {
    if log::max_level() < log::LevelFilter::Info {
        log::set_max_level(log::LevelFilter::Info);
    }
    let mut config = CaptureConfig::new(path, size, fps);
    config.buffer_count = camera.buffers;
    config.format = format;
    let source = ReopeningSource::open(config, camera.request())?;
    if let Some(inner) = source.current() {
        let n = inner.negotiated();
        log::info!(
            "{}: {} {} with rows {} bytes apart, {}, {} mmap buffers",
            path.display(),
            String::from_utf8_lossy(&n.format.fourcc()),
            n.size,
            n.stride_bytes,
            n.fps
                .map_or("the camera's frame rate".to_string(), |f| format!(
                    "{f:.3} fps"
                )),
            inner.buffer_count()
        );
    }
    super::signals::stop_on_signals(&source.stop_flag())?;
    Ok(source)
}

/// A `--fps` for a camera: V4L2 frame intervals are asked for in whole frames per second.
pub fn whole_fps(fps: Option<f64>) -> Result<Option<u32>> {
    match fps {
        None => Ok(None),
        Some(f) if f.fract() == 0.0 && f >= 1.0 && f <= f64::from(u32::MAX) => Ok(Some(f as u32)),
        Some(f) => {
            anyhow::bail!("--fps {f} for a camera must be a whole number of frames per second")
        }
    }
}
