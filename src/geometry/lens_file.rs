//! Reading a lens calibrated elsewhere (`glint calibrate --lens FILE`): OpenCV's camera YAML
//! (what `calibrateCamera` tools write through `FileStorage`, starting `%YAML:1.0`, matrices
//! tagged `!!opencv-matrix`) and ROS's `camera_info` YAML (`distortion_model: plumb_bob`).
//!
//! Both are a small, fixed subset of YAML: top-level `key: value` lines and, under a matrix
//! key, indented `rows`, `cols`, `dt` and `data: [ ... ]` (the list may run over several
//! lines). That subset is parsed here by hand with strict checks rather than pulling in a YAML
//! library: anything outside it is refused with the line, and so is a lens that cannot be right
//! for the frames (another image size, a skewed or non-finite matrix, absurd coefficients, a
//! distortion model other than OpenCV's five-coefficient one).

use core::fmt;

use super::camera::{CameraError, Lens};
use crate::frame::FrameSize;

/// Longest file accepted: a camera_info file is under 2 kB.
pub const MAX_LENS_FILE_BYTES: usize = 64 * 1024;
/// Most top-level keys kept (camera_info has eight).
const MAX_KEYS: usize = 32;

/// Why a lens file cannot be used.
#[derive(Debug, Clone, PartialEq)]
pub enum LensFileError {
    /// Larger than [`MAX_LENS_FILE_BYTES`].
    TooLarge,
    /// A line outside the YAML subset these files use. `line` is 1-based.
    Syntax { line: usize, message: &'static str },
    /// A required key is missing.
    Missing(&'static str),
    /// A value is not a number (or a list of numbers).
    NotANumber(&'static str),
    /// A matrix has the wrong shape.
    Shape(&'static str),
    /// The camera matrix has skew or a last row other than `0 0 1`.
    NotACameraMatrix,
    /// The distortion model is not OpenCV's `plumb_bob` (k1 k2 p1 p2 k3).
    Model(String),
    /// The file is for another image size.
    OtherSize { file: (u32, u32), frames: FrameSize },
    /// The lens itself cannot be used.
    Lens(CameraError),
}

impl fmt::Display for LensFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LensFileError::TooLarge => write!(
                f,
                "larger than {} kB: not a camera YAML",
                MAX_LENS_FILE_BYTES / 1024
            ),
            LensFileError::Syntax { line, message } => write!(f, "line {line}: {message}"),
            LensFileError::Missing(key) => write!(f, "no {key}"),
            LensFileError::NotANumber(key) => write!(f, "{key}: not a list of numbers"),
            LensFileError::Shape(key) => write!(f, "{key}: wrong number of rows, cols or data"),
            LensFileError::NotACameraMatrix => write!(
                f,
                "camera_matrix is not [fx 0 cx; 0 fy cy; 0 0 1] (skew is not supported)"
            ),
            LensFileError::Model(m) => write!(
                f,
                "distortion_model {m:?}: only plumb_bob (OpenCV's k1 k2 p1 p2 k3) is supported"
            ),
            LensFileError::OtherSize { file, frames } => write!(
                f,
                "made for {}x{} images, but the frames are {frames}",
                file.0, file.1
            ),
            LensFileError::Lens(e) => write!(f, "{e}"),
        }
    }
}

impl core::error::Error for LensFileError {}

/// One top-level entry: a scalar, or a block of indented `key: value` pairs.
#[derive(Debug, Default)]
struct Entry<'a> {
    key: &'a str,
    value: &'a str,
    fields: Vec<(&'a str, String)>,
}

/// Splits the file into entries.
fn entries(text: &str) -> Result<Vec<Entry<'_>>, LensFileError> {
    let mut out: Vec<Entry<'_>> = Vec::new();
    // An open `data: [` list continuing over lines: (entry, field) and the text so far.
    let mut open_list: Option<String> = None;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.split('#').next().unwrap_or("").trim_end();
        if let Some(list) = open_list.as_mut() {
            if line.contains(':') {
                return Err(LensFileError::Syntax {
                    line: line_no,
                    message: "a key inside a list: the list above is not closed with `]`",
                });
            }
            list.push(' ');
            list.push_str(line.trim());
            if line.contains(']') {
                let done = open_list.take().unwrap_or_default();
                let field = out.last_mut().and_then(|e| e.fields.last_mut()).ok_or(
                    LensFileError::Syntax {
                        line: line_no,
                        message: "a list outside a matrix",
                    },
                )?;
                field.1 = done;
            }
            continue;
        }
        let trimmed = line.trim();
        if trimmed.is_empty() || trimmed.starts_with("%YAML") || trimmed == "---" {
            continue;
        }
        let Some((key, value)) = trimmed.split_once(':') else {
            return Err(LensFileError::Syntax {
                line: line_no,
                message: "expected `key: value`",
            });
        };
        let (key, value) = (key.trim(), value.trim());
        let nested = line.starts_with([' ', '\t']);
        if nested {
            let entry = out.last_mut().ok_or(LensFileError::Syntax {
                line: line_no,
                message: "an indented line before any key",
            })?;
            if value.starts_with('[') && !value.contains(']') {
                open_list = Some(value.to_owned());
            }
            entry.fields.push((key, value.to_owned()));
        } else {
            if out.len() >= MAX_KEYS {
                return Err(LensFileError::Syntax {
                    line: line_no,
                    message: "too many keys for a camera YAML",
                });
            }
            out.push(Entry {
                key,
                value,
                fields: Vec::new(),
            });
        }
    }
    if open_list.is_some() {
        return Err(LensFileError::Syntax {
            line: text.lines().count(),
            message: "a list is not closed with `]`",
        });
    }
    Ok(out)
}

fn numbers(list: &str, key: &'static str) -> Result<Vec<f64>, LensFileError> {
    let inner = list
        .trim()
        .strip_prefix('[')
        .and_then(|l| l.strip_suffix(']'))
        .ok_or(LensFileError::NotANumber(key))?;
    inner
        .split(',')
        .map(str::trim)
        .filter(|v| !v.is_empty())
        .map(|v| v.parse::<f64>().map_err(|_| LensFileError::NotANumber(key)))
        .collect()
}

/// A matrix entry's data, checked against its rows and cols.
fn matrix(entries: &[Entry<'_>], key: &'static str) -> Result<Vec<f64>, LensFileError> {
    let entry = entries
        .iter()
        .find(|e| e.key == key)
        .ok_or(LensFileError::Missing(key))?;
    let field = |name: &str| {
        entry
            .fields
            .iter()
            .find(|(k, _)| *k == name)
            .map(|(_, v)| v.as_str())
    };
    let data = numbers(field("data").ok_or(LensFileError::Shape(key))?, key)?;
    let dim = |name: &str| -> Result<usize, LensFileError> {
        field(name)
            .ok_or(LensFileError::Shape(key))?
            .parse()
            .map_err(|_| LensFileError::Shape(key))
    };
    if dim("rows")?.checked_mul(dim("cols")?) != Some(data.len()) {
        return Err(LensFileError::Shape(key));
    }
    if data.iter().any(|v| !v.is_finite()) {
        return Err(LensFileError::Lens(CameraError::NonFinite));
    }
    Ok(data)
}

/// Parses and checks a lens file's text for frames of `size`.
pub fn parse(text: &str, size: FrameSize) -> Result<Lens, LensFileError> {
    if text.len() > MAX_LENS_FILE_BYTES {
        return Err(LensFileError::TooLarge);
    }
    let entries = entries(text)?;
    let scalar = |key: &str| entries.iter().find(|e| e.key == key).map(|e| e.value);
    if let (Some(w), Some(h)) = (scalar("image_width"), scalar("image_height")) {
        let (w, h): (u32, u32) = (
            w.parse()
                .map_err(|_| LensFileError::NotANumber("image_width"))?,
            h.parse()
                .map_err(|_| LensFileError::NotANumber("image_height"))?,
        );
        if (w as usize, h as usize) != (size.width(), size.height()) {
            return Err(LensFileError::OtherSize {
                file: (w, h),
                frames: size,
            });
        }
    }
    if let Some(model) = scalar("distortion_model") {
        if model != "plumb_bob" {
            return Err(LensFileError::Model(model.to_owned()));
        }
    }
    let k = matrix(&entries, "camera_matrix")?;
    let [fx, skew, cx, zero, fy, cy, z0, z1, one] =
        <[f64; 9]>::try_from(k.as_slice()).map_err(|_| LensFileError::Shape("camera_matrix"))?;
    if skew != 0.0 || zero != 0.0 || z0 != 0.0 || z1 != 0.0 || one != 1.0 {
        return Err(LensFileError::NotACameraMatrix);
    }
    let d = matrix(&entries, "distortion_coefficients")?;
    // OpenCV writes 4, 5, 8, 12 or 14 coefficients; beyond k3 only zeros mean plumb_bob.
    let (first, rest) = d.split_at(d.len().min(5));
    if first.len() < 4 || rest.iter().any(|&v| v != 0.0) {
        return Err(LensFileError::Shape("distortion_coefficients"));
    }
    let at = |i: usize| first.get(i).copied().unwrap_or(0.0);
    let lens = Lens {
        fx,
        fy,
        cx,
        cy,
        k1: at(0),
        k2: at(1),
        p1: at(2),
        p2: at(3),
        k3: at(4),
    };
    lens.check(size).map_err(LensFileError::Lens)?;
    Ok(lens)
}

#[cfg(test)]
mod tests {
    use super::*;

    const OPENCV: &str = "%YAML:1.0
---
calibration_time: \"Mon Dec  1 17:00:00 2026\"
image_width: 640
image_height: 480
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 4.6e+02, 0., 3.195e+02, 0., 4.62e+02,
       2.395e+02, 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix
   rows: 1
   cols: 5
   dt: d
   data: [ -3.0e-01, 9.0e-02, 1.0e-03, -5.0e-04, 0. ]
avg_reprojection_error: 0.21
";

    const ROS: &str = "image_width: 640
image_height: 480
camera_name: webcam
camera_matrix:
  rows: 3
  cols: 3
  data: [460.0, 0.0, 319.5, 0.0, 462.0, 239.5, 0.0, 0.0, 1.0]
distortion_model: plumb_bob
distortion_coefficients:
  rows: 1
  cols: 5
  data: [-0.3, 0.09, 0.001, -0.0005, 0.0]
rectification_matrix:
  rows: 3
  cols: 3
  data: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
projection_matrix:
  rows: 3
  cols: 4
  data: [460.0, 0.0, 319.5, 0.0, 0.0, 462.0, 239.5, 0.0, 0.0, 0.0, 1.0, 0.0]
";

    fn vga() -> FrameSize {
        FrameSize::new(640, 480).unwrap()
    }

    #[test]
    fn opencv_and_ros_files_give_the_same_lens() {
        let a = parse(OPENCV, vga()).unwrap();
        let b = parse(ROS, vga()).unwrap();
        assert_eq!(a, b);
        assert_eq!((a.fx, a.fy, a.cx, a.cy), (460.0, 462.0, 319.5, 239.5));
        assert_eq!(a.coefficients(), [-0.3, 0.09, 0.001, -0.0005, 0.0]);
    }

    #[test]
    fn bad_files_are_refused_by_name() {
        let other = FrameSize::new(1280, 720).unwrap();
        assert_eq!(
            parse(ROS, other).unwrap_err().to_string(),
            "made for 640x480 images, but the frames are 1280x720"
        );
        let nan = ROS.replace("[-0.3, 0.09", "[nan, 0.09");
        assert_eq!(
            parse(&nan, vga()),
            Err(LensFileError::Lens(CameraError::NonFinite))
        );
        let absurd = ROS.replace("[-0.3, 0.09", "[-3000.0, 0.09");
        assert_eq!(
            parse(&absurd, vga()),
            Err(LensFileError::Lens(CameraError::AbsurdCoefficient))
        );
        let fisheye = ROS.replace("plumb_bob", "equidistant");
        assert!(parse(&fisheye, vga())
            .unwrap_err()
            .to_string()
            .contains("equidistant"));
        let short = ROS.replace(
            "cols: 5\n  data: [-0.3, 0.09, 0.001, -0.0005, 0.0]",
            "cols: 5\n  data: [-0.3, 0.09]",
        );
        assert_eq!(
            parse(&short, vga()),
            Err(LensFileError::Shape("distortion_coefficients"))
        );
        let skew = ROS.replace("[460.0, 0.0, 319.5", "[460.0, 3.0, 319.5");
        assert_eq!(parse(&skew, vga()), Err(LensFileError::NotACameraMatrix));
        let open = OPENCV.replace("0., 0., 1. ]", "0., 0., 1.");
        assert!(matches!(
            parse(&open, vga()),
            Err(LensFileError::Syntax { .. })
        ));
        assert!(matches!(
            parse("just some text\n", vga()),
            Err(LensFileError::Syntax { line: 1, .. })
        ));
        assert_eq!(
            parse("image_width: 640\n", vga()),
            Err(LensFileError::Missing("camera_matrix"))
        );
        let huge = "#".repeat(MAX_LENS_FILE_BYTES + 1);
        assert_eq!(parse(&huge, vga()), Err(LensFileError::TooLarge));
    }
}
