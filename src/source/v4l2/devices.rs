//! Finding cameras: every `/dev/video*` node that captures video, with what it offers.

use core::fmt;
use std::io;
use std::path::{Path, PathBuf};

use super::controls::{self, ControlInfo};
use super::negotiate::{self, Offer};
use super::{open_device, sys, V4l2Error};

/// Where device nodes live.
const DEV_DIR: &str = "/dev";
const NODE_PREFIX: &str = "video";

/// One capture node and everything it offers.
#[derive(Debug, Clone)]
pub struct DeviceInfo {
    pub path: PathBuf,
    pub driver: String,
    pub card: String,
    pub bus_info: String,
    pub offer: Offer,
    pub controls: Vec<ControlInfo>,
}

impl fmt::Display for DeviceInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{}: {} (driver {}, {})",
            self.path.display(),
            self.card,
            self.driver,
            self.bus_info
        )?;
        writeln!(f, " formats:")?;
        writeln!(f, "{}", self.offer)?;
        write!(f, " controls:")?;
        if self.controls.is_empty() {
            write!(f, " none")?;
        }
        for control in &self.controls {
            write!(f, "\n  {control}")?;
        }
        Ok(())
    }
}

/// The `/dev/videoN` nodes present, by number.
pub fn video_nodes() -> io::Result<Vec<PathBuf>> {
    let mut nodes: Vec<(u32, PathBuf)> = std::fs::read_dir(DEV_DIR)?
        .filter_map(Result::ok)
        .filter_map(|entry| {
            let name = entry.file_name();
            let number = name.to_str()?.strip_prefix(NODE_PREFIX)?.parse().ok()?;
            Some((number, entry.path()))
        })
        .collect();
    nodes.sort();
    Ok(nodes.into_iter().map(|(_, path)| path).collect())
}

/// Describes one node; `Ok(None)` when it does not capture video (output, metadata, radio...).
pub fn describe(path: &Path) -> Result<Option<DeviceInfo>, V4l2Error> {
    let device = open_device(path)?;
    let fd = device.handle().fd();
    let caps = sys::query_capability(fd).map_err(|e| V4l2Error::io(path, "VIDIOC_QUERYCAP", e))?;
    if !caps.is_video_capture() {
        return Ok(None);
    }
    let offer =
        negotiate::query_offer(&device).map_err(|e| V4l2Error::io(path, "VIDIOC_ENUM_FMT", e))?;
    let controls = controls::list_controls(fd).unwrap_or_default();
    Ok(Some(DeviceInfo {
        path: path.to_path_buf(),
        driver: caps.driver,
        card: caps.card,
        bus_info: caps.bus_info,
        offer,
        controls,
    }))
}

/// Every capture device. A node that cannot be opened (busy elsewhere, no permission) is
/// listed as an error beside the others rather than hiding them.
pub fn list_devices() -> io::Result<Vec<Result<DeviceInfo, V4l2Error>>> {
    Ok(video_nodes()?
        .iter()
        .filter_map(|path| describe(path).transpose())
        .collect())
}
