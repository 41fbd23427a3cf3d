//! The `glint track` options for floor coordinates (`--calib`) and for following a marker
//! instead of an LED (`--detector aruco --marker ID [--dict NAME]`), and the pipeline they build.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;

use glint::frame::FrameSize;
use glint::geometry::aruco::{DetectorConfig, Dictionary};
use glint::geometry::CalibrationFile;
use glint::pipeline::{Pipeline, PipelineConfig};
use glint::small_file;
use glint::track::MarkerTracker;

/// Options of `glint track` that this module handles.
#[derive(Debug, Args)]
pub struct FloorArgs {
    /// A calibration written by `glint calibrate`: adds floor coordinates (`floor_x`,
    /// `floor_y`, and the floor velocity when known) to every found frame. A regular file of
    /// at most 1 MB.
    #[arg(long, value_name = "FILE", overrides_with = "no_calib")]
    pub calib: Option<PathBuf>,

    /// No floor coordinates, whatever a --calib before it (or the settings file's `calib`)
    /// says: try a Pi's settings on a machine without its calibration.
    #[arg(long, overrides_with = "calib")]
    no_calib: bool,

    /// With `--detector aruco`: the id of the marker the robot carries.
    #[arg(long, value_name = "ID")]
    marker: Option<u16>,

    /// With `--detector aruco`: the marker dictionary (OpenCV's name, e.g. DICT_6X6_250 or
    /// APRILTAG_36h11) [default: DICT_6X6_250].
    #[arg(long, value_name = "NAME")]
    dict: Option<Dictionary>,
}

impl FloorArgs {
    /// The longest border the marker detector will trace, which sizes its scratch.
    pub fn max_perimeter_px(&self) -> usize {
        DetectorConfig::new(self.dictionary()).max_perimeter_px
    }

    fn dictionary(&self) -> Dictionary {
        self.dict.unwrap_or(Dictionary::Aruco6x6_250)
    }
}

/// The pipeline for these options: an LED pipeline with `config`, or a marker pipeline when
/// `aruco`, either with the floor stage when a calibration is given.
pub fn build_pipeline(
    args: &FloorArgs,
    size: FrameSize,
    aruco: bool,
    config: PipelineConfig,
) -> Result<Pipeline> {
    let pipeline = match (aruco, args.marker) {
        (true, Some(id)) => Pipeline::marker(MarkerTracker::new(size, args.dictionary(), id)?),
        (true, None) => bail!("--detector aruco needs --marker ID, the id the robot carries"),
        (false, Some(_)) => bail!("--marker goes with --detector aruco"),
        (false, None) if args.dict.is_some() => bail!("--dict goes with --detector aruco"),
        (false, None) => Pipeline::new(size, config)?,
    };
    match &args.calib {
        Some(path) => Ok(pipeline.with_floor(load_calibration(path, size)?.floor)),
        None => Ok(pipeline),
    }
}

/// Reads and checks a calibration file for frames of `size`.
fn load_calibration(path: &Path, size: FrameSize) -> Result<CalibrationFile> {
    let text = small_file::read_text(path, small_file::MAX_SETTINGS_BYTES)
        .with_context(|| format!("cannot read calibration {}", path.display()))?;
    let calibration = CalibrationFile::parse(&text, size)
        .with_context(|| format!("calibration {}", path.display()))?;
    log::info!(
        "floor coordinates in {} from {} (corner residuals up to {:.3} px)",
        calibration.floor.unit(),
        path.display(),
        calibration.max_residual_px
    );
    Ok(calibration)
}
