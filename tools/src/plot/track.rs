//! Reading a JSON-lines track (`glint track --format jsonl`) into positions and speeds.

use std::fmt;
use std::io::BufRead;

use serde::Deserialize;

/// The units the positions of a track are in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Units {
    /// Image pixels (`x`, `y`): y grows downwards.
    Pixels,
    /// Floor units of the calibration (`floor_x`, `floor_y`, in the records' `floor_unit`,
    /// usually cm): y grows upwards, as on a map of the floor.
    Floor,
}

/// One frame of the track: its time, and the position when the LED was found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Seconds since the start of the track (the `t` field).
    pub t_s: f64,
    /// Position in the track's [`Units`]; `None` when not found (or not on the floor).
    pub position: Option<(f64, f64)>,
}

/// A whole track, in one kind of units.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    pub units: Units,
    /// The records' `floor_unit` (`cm`, `mm`, ...) when the track is in floor units.
    pub floor_unit: Option<String>,
    pub samples: Vec<Sample>,
}

/// Why a track cannot be plotted.
#[derive(Debug, Clone, PartialEq)]
pub enum TrackError {
    /// Reading the input failed.
    Read(String),
    /// A line is not a frame record; `line` counts from 1.
    Line { line: usize, message: String },
    /// The input holds no records at all.
    Empty,
    /// No frame has a position: nothing to draw.
    NoPositions { frames: usize },
    /// Found frames name different floor units: one axis cannot carry both.
    MixedUnits { first: String, other: String },
}

impl fmt::Display for TrackError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TrackError::Read(e) => write!(f, "cannot read the track: {e}"),
            TrackError::Line { line, message } => write!(f, "line {line}: {message}"),
            TrackError::Empty => write!(f, "the track is empty (no JSON lines)"),
            TrackError::NoPositions { frames } => {
                write!(
                    f,
                    "none of the {frames} frames has a position (found: false in all)"
                )
            }
            TrackError::MixedUnits { first, other } => write!(
                f,
                "the track mixes floor units ({first} and {other}): plot one calibration at a time"
            ),
        }
    }
}

impl std::error::Error for TrackError {}

/// The fields of a record that the plot uses; others are ignored.
#[derive(Debug, Deserialize)]
struct Record {
    t: f64,
    found: bool,
    x: Option<f64>,
    y: Option<f64>,
    floor_x: Option<f64>,
    floor_y: Option<f64>,
    floor_unit: Option<String>,
}

impl Track {
    /// Reads a JSON-lines track. Blank lines are skipped; any other line must be a frame
    /// record with a number `t` that never decreases and a boolean `found`, and a found frame
    /// must carry `x` and `y`. The track is in floor units when any found frame carries
    /// `floor_x` and `floor_y`; frames found without them then have no floor position.
    pub fn from_jsonl<R: BufRead>(input: R) -> Result<Self, TrackError> {
        let mut records = Vec::new();
        let mut last_t_s = f64::NEG_INFINITY;
        for (index, line) in input.lines().enumerate() {
            let line_number = index + 1;
            let line = line.map_err(|e| TrackError::Read(e.to_string()))?;
            if line.trim().is_empty() {
                continue;
            }
            let bad = |message: String| TrackError::Line {
                line: line_number,
                message,
            };
            let record: Record = serde_json::from_str(&line)
                .map_err(|e| bad(format!("not a glint track record: {e}")))?;
            if record.t < last_t_s {
                return Err(bad(format!(
                    "t goes backwards ({} after {last_t_s})",
                    record.t
                )));
            }
            last_t_s = record.t;
            if record.found && (record.x.is_none() || record.y.is_none()) {
                return Err(bad("found, but x or y is missing".into()));
            }
            records.push(record);
        }
        if records.is_empty() {
            return Err(TrackError::Empty);
        }
        let floor = records
            .iter()
            .any(|r| r.found && r.floor_x.is_some() && r.floor_y.is_some());
        let units = if floor { Units::Floor } else { Units::Pixels };
        let mut floor_unit: Option<String> = None;
        if floor {
            for unit in records
                .iter()
                .filter(|r| r.found)
                .filter_map(|r| r.floor_unit.as_ref())
            {
                match &floor_unit {
                    None => floor_unit = Some(unit.clone()),
                    Some(first) if first != unit => {
                        return Err(TrackError::MixedUnits {
                            first: first.clone(),
                            other: unit.clone(),
                        })
                    }
                    Some(_) => {}
                }
            }
        }
        let samples: Vec<Sample> = records
            .iter()
            .map(|r| {
                let (x, y) = match units {
                    Units::Pixels => (r.x, r.y),
                    Units::Floor => (r.floor_x, r.floor_y),
                };
                Sample {
                    t_s: r.t,
                    position: x.zip(y).filter(|_| r.found),
                }
            })
            .collect();
        if samples.iter().all(|s| s.position.is_none()) {
            return Err(TrackError::NoPositions {
                frames: samples.len(),
            });
        }
        Ok(Track {
            units,
            floor_unit,
            samples,
        })
    }

    /// The name of a length in the track's units, for axis labels: `px`, or the calibration's
    /// floor unit (`cm`, ...); "floor units" only when the records do not name it.
    pub fn length_name(&self) -> &str {
        match self.units {
            Units::Pixels => "px",
            Units::Floor => self.floor_unit.as_deref().unwrap_or("floor units"),
        }
    }

    /// The positions, as runs of consecutive frames that all have one (a lost frame ends a
    /// run, so the trajectory is not drawn across it).
    pub fn runs(&self) -> impl Iterator<Item = Vec<(f64, f64)>> + '_ {
        self.samples
            .split(|s| s.position.is_none())
            .filter(|run| !run.is_empty())
            .map(|run| run.iter().filter_map(|s| s.position).collect())
    }

    /// The speed between consecutive frames that both have a position, in track units per
    /// second, at the time of the later frame: `(t_s, speed)`, in runs like [`Track::runs`].
    /// Frames with the same `t` give no speed.
    pub fn speed_runs(&self) -> Vec<Vec<(f64, f64)>> {
        let mut runs = Vec::new();
        let mut run: Vec<(f64, f64)> = Vec::new();
        for pair in self.samples.windows(2) {
            let speed = match pair {
                [a, b] => a.position.zip(b.position).and_then(|(p, q)| {
                    let dt_s = b.t_s - a.t_s;
                    (dt_s > 0.0).then(|| (q.0 - p.0).hypot(q.1 - p.1) / dt_s)
                }),
                _ => None,
            };
            match (speed, pair.get(1)) {
                (Some(v), Some(b)) => run.push((b.t_s, v)),
                _ if !run.is_empty() => runs.push(std::mem::take(&mut run)),
                _ => {}
            }
        }
        if !run.is_empty() {
            runs.push(run);
        }
        runs
    }

    /// How many frames have a position.
    pub fn found_count(&self) -> usize {
        self.samples.iter().filter(|s| s.position.is_some()).count()
    }
}
