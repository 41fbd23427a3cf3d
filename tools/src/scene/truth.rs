//! Per-frame ground truth and its CSV form.
//!
//! Conventions: OpenCV pixel coordinates, (0, 0) the centre of the top-left pixel; a frame's
//! time `t` is the END of its exposure; velocities in px/s. Values that an image cannot show
//! (the LED is hidden) are `None`, written as empty CSV cells, never as made-up numbers.

use std::fmt;
use std::io::{self, BufRead, Write};

/// Whether the LED can be seen in a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Visibility {
    /// The whole disk is inside the frame and unoccluded for the whole exposure (CSV `1`).
    Visible,
    /// No part of the disk is visible at any time during the exposure (CSV `0`).
    Hidden,
    /// Anything in between: clipped by the frame edge or an occluder. Tests should ignore
    /// these frames (CSV `-1`).
    Partial,
}

impl Visibility {
    /// The CSV code: 1, 0 or -1.
    pub fn code(self) -> i8 {
        match self {
            Visibility::Visible => 1,
            Visibility::Hidden => 0,
            Visibility::Partial => -1,
        }
    }

    fn from_code(code: &str) -> Option<Self> {
        match code {
            "1" => Some(Visibility::Visible),
            "0" => Some(Visibility::Hidden),
            "-1" => Some(Visibility::Partial),
            _ => None,
        }
    }
}

/// Ground truth of one frame. With a rolling shutter (`SceneConfig::row_time_us`) "the
/// exposure" is the one the LED was seen in: from the start of the exposure of the row it was
/// in then to the end of the exposure of the row it was in then; `t_s` stays the frame's.
#[derive(Clone, Debug, PartialEq)]
pub struct Truth {
    /// 0-based frame index.
    pub frame: usize,
    /// `frame / fps`: the end of the exposure, in seconds.
    pub t_s: f64,
    /// Whether the LED can be seen.
    pub visible: Visibility,
    /// LED centre at the end of the exposure.
    pub x_px: Option<f64>,
    /// LED centre at the end of the exposure.
    pub y_px: Option<f64>,
    /// LED centre at the middle of the exposure: the middle of the streak.
    pub mid_x_px: Option<f64>,
    /// LED centre at the middle of the exposure: the middle of the streak.
    pub mid_y_px: Option<f64>,
    /// The point halfway along the path's length during the exposure: the streak's middle in
    /// space, which is what a single frame shows. At constant speed it is [`Truth::mid_x_px`];
    /// an LED speeding up spends the exposure's first half on less than half of the path.
    pub path_mid_x_px: Option<f64>,
    /// The point halfway along the path's length during the exposure (see
    /// [`Truth::path_mid_x_px`]).
    pub path_mid_y_px: Option<f64>,
    /// Velocity at the end of the exposure.
    pub vx_px_s: Option<f64>,
    /// Velocity at the end of the exposure.
    pub vy_px_s: Option<f64>,
    /// Length of the path travelled during the exposure (the streak's length, not counting
    /// the disk's own diameter).
    pub streak_px: Option<f64>,
}

/// The CSV header, also the column order.
pub const CSV_HEADER: &str =
    "frame,t,visible,x,y,mid_x,mid_y,vx,vy,streak_px,path_mid_x,path_mid_y";
const CSV_COLUMNS: usize = 12;

/// The header of truth files written before the path's middle was a column: still read, the
/// path's middle unknown.
const CSV_HEADER_WITHOUT_PATH_MIDDLE: &str = "frame,t,visible,x,y,mid_x,mid_y,vx,vy,streak_px";

/// Writes the header and one line per frame.
pub fn write_truth_csv<W: Write>(mut out: W, truths: &[Truth]) -> io::Result<()> {
    writeln!(out, "{CSV_HEADER}")?;
    for truth in truths {
        write!(
            out,
            "{},{:.6},{}",
            truth.frame,
            truth.t_s,
            truth.visible.code()
        )?;
        for value in [
            truth.x_px,
            truth.y_px,
            truth.mid_x_px,
            truth.mid_y_px,
            truth.vx_px_s,
            truth.vy_px_s,
            truth.streak_px,
            truth.path_mid_x_px,
            truth.path_mid_y_px,
        ] {
            match value {
                Some(v) => write!(out, ",{v:.6}")?,
                None => write!(out, ",")?,
            }
        }
        writeln!(out)?;
    }
    out.flush()
}

/// Why a truth CSV could not be read.
#[derive(Debug)]
pub enum TruthCsvError {
    /// Reading failed.
    Io(io::Error),
    /// The first line is not [`CSV_HEADER`].
    Header {
        /// What the first line held.
        found: String,
    },
    /// A line has the wrong number of cells.
    Columns {
        /// 1-based line number.
        line: usize,
        /// Cells found.
        found: usize,
    },
    /// A cell does not parse.
    Cell {
        /// 1-based line number.
        line: usize,
        /// Column name.
        column: &'static str,
        /// The cell's text.
        text: String,
    },
}

impl fmt::Display for TruthCsvError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TruthCsvError::Io(e) => write!(f, "cannot read truth CSV: {e}"),
            TruthCsvError::Header { found } => {
                write!(f, "truth CSV header is {found:?}, expected {CSV_HEADER:?}")
            }
            TruthCsvError::Columns { line, found } => {
                write!(
                    f,
                    "truth CSV line {line} has {found} cells, expected {CSV_COLUMNS}"
                )
            }
            TruthCsvError::Cell { line, column, text } => {
                write!(f, "truth CSV line {line}: bad {column} value {text:?}")
            }
        }
    }
}

impl std::error::Error for TruthCsvError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            TruthCsvError::Io(e) => Some(e),
            _ => None,
        }
    }
}

impl From<io::Error> for TruthCsvError {
    fn from(e: io::Error) -> Self {
        TruthCsvError::Io(e)
    }
}

/// Reads a CSV written by [`write_truth_csv`]. Blank lines are skipped.
pub fn read_truth_csv<R: BufRead>(input: R) -> Result<Vec<Truth>, TruthCsvError> {
    let mut lines = input.lines();
    let header = lines.next().transpose()?.unwrap_or_default();
    let with_path_middle = match header.trim() {
        CSV_HEADER => true,
        CSV_HEADER_WITHOUT_PATH_MIDDLE => false,
        _ => return Err(TruthCsvError::Header { found: header }),
    };
    let mut truths = Vec::new();
    for (index, line) in lines.enumerate() {
        let line = line?;
        if line.trim().is_empty() {
            continue;
        }
        truths.push(parse_line(index + 2, line.trim(), with_path_middle)?);
    }
    Ok(truths)
}

fn parse_line(line_no: usize, line: &str, with_path_middle: bool) -> Result<Truth, TruthCsvError> {
    let mut cells: Vec<&str> = line.split(',').collect();
    let columns = if with_path_middle {
        CSV_COLUMNS
    } else {
        CSV_COLUMNS - 2
    };
    if cells.len() != columns {
        return Err(TruthCsvError::Columns {
            line: line_no,
            found: cells.len(),
        });
    }
    // An old file's path middle: unknown, as an empty cell.
    cells.resize(CSV_COLUMNS, "");
    let &[frame, t, visible, x, y, mid_x, mid_y, vx, vy, streak, path_mid_x, path_mid_y] =
        cells.as_slice()
    else {
        return Err(TruthCsvError::Columns {
            line: line_no,
            found: cells.len(),
        });
    };
    let bad = |column: &'static str, text: &str| TruthCsvError::Cell {
        line: line_no,
        column,
        text: text.to_owned(),
    };
    let optional = |column: &'static str, text: &str| -> Result<Option<f64>, TruthCsvError> {
        if text.is_empty() {
            return Ok(None);
        }
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(Some(v)),
            _ => Err(bad(column, text)),
        }
    };
    Ok(Truth {
        frame: frame.parse().map_err(|_| bad("frame", frame))?,
        t_s: optional("t", t)?.ok_or_else(|| bad("t", t))?,
        visible: Visibility::from_code(visible).ok_or_else(|| bad("visible", visible))?,
        x_px: optional("x", x)?,
        y_px: optional("y", y)?,
        mid_x_px: optional("mid_x", mid_x)?,
        mid_y_px: optional("mid_y", mid_y)?,
        vx_px_s: optional("vx", vx)?,
        vy_px_s: optional("vy", vy)?,
        streak_px: optional("streak_px", streak)?,
        path_mid_x_px: optional("path_mid_x", path_mid_x)?,
        path_mid_y_px: optional("path_mid_y", path_mid_y)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Vec<Truth> {
        vec![
            Truth {
                frame: 0,
                t_s: 0.0,
                visible: Visibility::Visible,
                x_px: Some(10.25),
                y_px: Some(-3.5),
                mid_x_px: Some(10.0),
                mid_y_px: Some(-3.25),
                vx_px_s: Some(60.0),
                vy_px_s: Some(-1.125),
                streak_px: Some(0.5),
                path_mid_x_px: Some(10.125),
                path_mid_y_px: Some(-3.375),
            },
            Truth {
                frame: 1,
                t_s: 1.0 / 32.0,
                visible: Visibility::Hidden,
                x_px: None,
                y_px: None,
                mid_x_px: None,
                mid_y_px: None,
                vx_px_s: None,
                vy_px_s: None,
                streak_px: None,
                path_mid_x_px: None,
                path_mid_y_px: None,
            },
        ]
    }

    #[test]
    fn csv_round_trips_and_hidden_cells_are_empty() {
        let mut text = Vec::new();
        write_truth_csv(&mut text, &sample()).unwrap();
        let text = String::from_utf8(text).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], CSV_HEADER);
        assert_eq!(lines[2], "1,0.031250,0,,,,,,,,,");
        assert_eq!(read_truth_csv(text.as_bytes()).unwrap(), sample());
        // A file written before the path's middle was a column reads with it unknown.
        let old = format!(
            "{CSV_HEADER_WITHOUT_PATH_MIDDLE}\n0,0.0,1,10.25,-3.5,10,-3.25,60,-1.125,0.5\n"
        );
        let read = read_truth_csv(old.as_bytes()).unwrap();
        let mut expected = sample()[0].clone();
        (expected.path_mid_x_px, expected.path_mid_y_px) = (None, None);
        assert_eq!(read, vec![expected]);
        let short = format!("{CSV_HEADER}\n0,0.0,1,10.25,-3.5,10,-3.25,60,-1.125,0.5\n");
        assert!(read_truth_csv(short.as_bytes()).is_err(), "columns missing");
    }

    #[test]
    fn malformed_csv_is_reported_with_its_line() {
        let err = read_truth_csv("frame,t\n".as_bytes()).unwrap_err();
        assert!(matches!(err, TruthCsvError::Header { .. }), "{err}");
        let text = format!("{CSV_HEADER}\n0,0.0,1,1,2\n");
        let err = read_truth_csv(text.as_bytes()).unwrap_err();
        assert!(
            matches!(err, TruthCsvError::Columns { line: 2, found: 5 }),
            "{err}"
        );
        let text = format!("{CSV_HEADER}\n0,0.0,2,,,,,,,,,\n");
        let err = read_truth_csv(text.as_bytes()).unwrap_err();
        assert!(err.to_string().contains("visible"), "{err}");
        let text = format!("{CSV_HEADER}\n0,0.0,1,NaN,,,,,,,,\n");
        assert!(read_truth_csv(text.as_bytes()).is_err());
    }
}
