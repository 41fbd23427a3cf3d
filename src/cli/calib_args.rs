//! The `glint track` options for floor coordinates (`--calib`) and for following a marker
//! instead of an LED (`--detector aruco --marker ID [--dict NAME]`), and the pipeline they build.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;

use glint::detect::aruco::{DetectorConfig, Dictionary};
use glint::frame::FrameSize;
use glint::geometry::recheck::MarkerRecheck;
use glint::geometry::CalibrationFile;
use glint::pipeline::{Pipeline, PipelineConfig};
use glint::small_file;
use glint::track::{MarkerTracker, MultiTracker};

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

    /// With --calib: the LED's height above the floor, in cm (0 to 1000). Floor positions and
    /// velocities are then those of the point on the floor under the LED. Needs a calibration
    /// with the camera's pose (written by this glint).
    #[arg(long, value_name = "CM", requires = "calib", value_parser = parse_height_cm,
          allow_hyphen_values = true)]
    pub led_height_cm: Option<f64>,

    /// With --calib: do not re-detect the calibration's markers while tracking. By default
    /// (with a calibration from this glint) they are re-checked twice a second, a knocked
    /// camera's pose is refitted, and JSON lines say which calibration they used.
    #[arg(long, requires = "calib")]
    pub no_recheck: bool,

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

/// Highest LED accepted, cm: a tracker's camera is a few metres up at most.
const MAX_LED_HEIGHT_CM: f64 = 1000.0;

fn parse_height_cm(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(h) if (0.0..=MAX_LED_HEIGHT_CM).contains(&h) => Ok(h),
        _ => Err(format!(
            "{s:?} is not a height between 0 and {MAX_LED_HEIGHT_CM} cm"
        )),
    }
}

/// The pipeline for these options: an LED pipeline with `config`, or a marker pipeline when
/// `aruco`, either with the floor stage when a calibration is given.
pub fn build_pipeline(
    args: &FloorArgs,
    size: FrameSize,
    aruco: bool,
    robots: usize,
    config: PipelineConfig,
) -> Result<Pipeline> {
    if robots > 1 && aruco {
        bail!("--robots {robots}: --detector aruco follows one marker; several robots need LEDs");
    }
    let pipeline = match (aruco, args.marker) {
        (true, Some(id)) => Pipeline::marker(MarkerTracker::new(size, args.dictionary(), id)?),
        (true, None) => bail!("--detector aruco needs --marker ID, the id the robot carries"),
        (false, Some(_)) => bail!("--marker goes with --detector aruco"),
        (false, None) if args.dict.is_some() => bail!("--dict goes with --detector aruco"),
        (false, None) if robots > 1 => {
            Pipeline::several(size, config, MultiTracker::new(robots, config.tracker)?)?
        }
        (false, None) => Pipeline::new(size, config)?,
    };
    let Some(path) = &args.calib else {
        return Ok(pipeline);
    };
    let (calibration, map) = load_calibration(path, size)?;
    let mut floor = calibration.floor;
    if let Some(height_cm) = args.led_height_cm {
        let camera_cm = floor.camera().map(|c| c.pose.height());
        if let Some(camera_cm) = camera_cm.filter(|&c| height_cm >= c) {
            bail!(
                "--led-height-cm {height_cm}: the LED must be below the camera, which is \
                 {camera_cm:.1} cm up"
            );
        }
        floor = floor
            .with_led_height(height_cm)
            .with_context(|| format!("--led-height-cm with calibration {}", path.display()))?;
    }
    let pipeline = pipeline.with_floor(floor);
    match calibration.dictionary {
        Some(dictionary) if floor.camera().is_some() && !args.no_recheck => Ok(pipeline
            .with_recheck(MarkerRecheck::new(
                size,
                dictionary,
                &map,
                calibration.rms_residual_px,
            )?)),
        _ => Ok(pipeline),
    }
}

/// Reads and checks a calibration file for frames of `size`; also its marker map.
fn load_calibration(
    path: &Path,
    size: FrameSize,
) -> Result<(CalibrationFile, Vec<glint::geometry::MarkerPlacement>)> {
    let text = small_file::read_text(path, small_file::MAX_SETTINGS_BYTES)
        .with_context(|| format!("cannot read calibration {}", path.display()))?;
    let calibration = CalibrationFile::parse(&text, size)
        .with_context(|| format!("calibration {}", path.display()))?;
    let model = match calibration.floor.camera() {
        Some(c) if c.lens.is_ideal() => format!("ideal lens, camera {:.1} cm up", c.pose.height()),
        Some(c) => format!("fitted lens, camera {:.1} cm up", c.pose.height()),
        None => "homography of an older calibration: ideal lens, LED on the floor".to_owned(),
    };
    log::info!(
        "floor coordinates in {} from {} ({model}; corner residuals up to {:.3} px)",
        calibration.floor.unit(),
        path.display(),
        calibration.max_residual_px
    );
    let map = CalibrationFile::marker_map(&text)
        .with_context(|| format!("calibration {}", path.display()))?;
    Ok((calibration, map))
}
