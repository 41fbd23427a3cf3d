//! One camera's report line, read back: today's single-LED line (one robot, id 1) or the
//! several-robots line with `"tracks":[{"id":..,...}]`, whose track objects carry the same
//! fields as the single-LED line plus `id`.
//!
//! Every line is hostile until checked: a truncated or garbage line, a number that is not
//! finite, a floor x without its y, a found track without its pixel position or the same id
//! twice is refused with a [`LineError`] naming the field, never read as a wrong number.

use core::fmt;

use serde_json::{Map, Value};

use crate::geometry::{FloorUnit, Point};

/// Longest line accepted, bytes: a report with 64 tracks is under 32 kB.
pub const MAX_LINE_BYTES: usize = 64 * 1024;
/// Most tracks one line may hold.
pub const MAX_TRACKS_PER_LINE: usize = 64;

/// What one camera said about one robot at one capture time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sighting {
    /// The robot's id (1 for the single-LED line).
    pub id: u32,
    /// Whether the camera found it.
    pub found: bool,
    /// Position in the picture (the streak's head), px.
    pub position_px: Option<Point>,
    /// The streak's middle, px.
    pub mid_px: Option<Point>,
    /// Whether the position is the head (`pos_method: head`) or only the middle.
    pub head: bool,
    /// Floor position, floor units (cm with glint's calibrations).
    pub floor: Option<Point>,
    /// The floor numbers' unit (`floor_unit`), when the line says.
    pub unit: Option<FloorUnit>,
    /// Floor velocity, units/s.
    pub floor_velocity: Option<Point>,
    /// Picture velocity, px/s.
    pub velocity_px_s: Option<Point>,
    /// The blob's area and the streak's skeleton length, px.
    pub area_px: Option<f64>,
    pub len_px: Option<f64>,
    /// The streak fit's standard deviation (`--streak-model fit`), px.
    pub fit_px: Option<f64>,
    /// The calibration's marker residual when last checked, px.
    pub calib_residual_px: Option<f64>,
    /// The floor numbers may be stale (no calibration marker seen for a while).
    pub floor_stale: bool,
    /// Found on or beyond the floor's horizon: no floor numbers, on purpose.
    pub beyond_horizon: bool,
}

/// One parsed report line: its capture time and what it says about each robot.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// Capture time (end of the exposure), µs on the cameras' shared clock.
    pub t_us: i64,
    /// One per robot the line mentions.
    pub sightings: Vec<Sighting>,
}

/// Why a report line was refused.
#[derive(Debug, Clone, PartialEq)]
pub enum LineError {
    /// Longer than [`MAX_LINE_BYTES`].
    TooLong(usize),
    /// Not JSON (garbage, or a line cut short).
    NotJson(String),
    /// JSON, but not an object.
    NotAnObject,
    /// A field is missing, of the wrong type, or out of range.
    Field {
        /// The field's name.
        field: &'static str,
        /// What is wrong with it.
        why: &'static str,
    },
    /// The same robot id twice in one line.
    DuplicateId(u32),
    /// More tracks than [`MAX_TRACKS_PER_LINE`].
    TooManyTracks(usize),
}

impl fmt::Display for LineError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LineError::TooLong(n) => {
                write!(
                    f,
                    "a line of {n} bytes, longer than a report (at most {MAX_LINE_BYTES})"
                )
            }
            LineError::NotJson(e) => write!(f, "not a JSON report (cut short or garbage): {e}"),
            LineError::NotAnObject => write!(f, "not a report: a JSON value but not an object"),
            LineError::Field { field, why } => write!(f, "field `{field}` {why}"),
            LineError::DuplicateId(id) => write!(f, "robot id {id} twice in one line"),
            LineError::TooManyTracks(n) => {
                write!(f, "{n} tracks in one line, more than {MAX_TRACKS_PER_LINE}")
            }
        }
    }
}

impl std::error::Error for LineError {}

fn field(field: &'static str, why: &'static str) -> LineError {
    LineError::Field { field, why }
}

/// A finite number, if the key is present; an error if it is present but not one.
fn number(obj: &Map<String, Value>, key: &'static str) -> Result<Option<f64>, LineError> {
    match obj.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(v) => match v.as_f64() {
            Some(x) if x.is_finite() => Ok(Some(x)),
            _ => Err(field(key, "is not a finite number")),
        },
    }
}

/// A point from two keys that come together or not at all.
fn pair(
    obj: &Map<String, Value>,
    kx: &'static str,
    ky: &'static str,
) -> Result<Option<Point>, LineError> {
    match (number(obj, kx)?, number(obj, ky)?) {
        (Some(x), Some(y)) => Ok(Some(Point::new(x, y))),
        (None, None) => Ok(None),
        (Some(_), None) => Err(field(ky, "is missing beside its x")),
        (None, Some(_)) => Err(field(kx, "is missing beside its y")),
    }
}

fn flag(obj: &Map<String, Value>, key: &'static str) -> Result<bool, LineError> {
    match obj.get(key) {
        None | Some(Value::Null) => Ok(false),
        Some(Value::Bool(b)) => Ok(*b),
        Some(_) => Err(field(key, "is not true or false")),
    }
}

/// Reads one track object (the line itself for the single-LED line).
fn sighting(obj: &Map<String, Value>, id: u32) -> Result<Sighting, LineError> {
    let found = match obj.get("found") {
        Some(Value::Bool(b)) => *b,
        None => return Err(field("found", "is missing")),
        Some(_) => return Err(field("found", "is not true or false")),
    };
    let position_px = pair(obj, "x", "y")?;
    if found && position_px.is_none() {
        return Err(field("x", "is missing from a found track"));
    }
    let head = match obj.get("pos_method") {
        None | Some(Value::Null) => true,
        Some(Value::String(s)) if s == "head" => true,
        Some(Value::String(s)) if s == "mid" => false,
        Some(_) => return Err(field("pos_method", "is not \"head\" or \"mid\"")),
    };
    let calib_residual_px = match obj.get("calib") {
        None | Some(Value::Null) => None,
        Some(Value::Object(c)) => number(c, "residual_px")?,
        Some(_) => return Err(field("calib", "is not an object")),
    };
    let non_negative = |key: &'static str| -> Result<Option<f64>, LineError> {
        match number(obj, key)? {
            Some(v) if v < 0.0 => Err(field(key, "is negative")),
            v => Ok(v),
        }
    };
    Ok(Sighting {
        id,
        found,
        position_px,
        mid_px: pair(obj, "mid_x", "mid_y")?,
        head,
        floor: pair(obj, "floor_x", "floor_y")?,
        unit: match obj.get("floor_unit") {
            None | Some(Value::Null) => None,
            Some(Value::String(u)) => Some(
                u.parse()
                    .map_err(|_| field("floor_unit", "is not mm, cm, m or in"))?,
            ),
            Some(_) => return Err(field("floor_unit", "is not a unit's name")),
        },
        floor_velocity: pair(obj, "floor_vx", "floor_vy")?,
        velocity_px_s: pair(obj, "vx", "vy")?,
        area_px: non_negative("area_px")?,
        len_px: non_negative("len_px")?,
        fit_px: non_negative("fit_px")?,
        calib_residual_px: calib_residual_px.filter(|r| *r >= 0.0),
        floor_stale: flag(obj, "floor_stale")?,
        beyond_horizon: flag(obj, "beyond_horizon")?,
    })
}

/// Parses one report line. Its capture time is `capture_us` when the transport gave one, else
/// the line's own `t` (seconds on the camera's clock).
pub fn parse(line: &str, capture_us: Option<i64>) -> Result<Report, LineError> {
    if line.len() > MAX_LINE_BYTES {
        return Err(LineError::TooLong(line.len()));
    }
    let value: Value = serde_json::from_str(line).map_err(|e| LineError::NotJson(e.to_string()))?;
    let Value::Object(obj) = value else {
        return Err(LineError::NotAnObject);
    };
    let t_us = match capture_us {
        Some(t) => t,
        None => {
            let t_s = number(&obj, "t")?.ok_or(field("t", "is missing"))?;
            // i64 µs hold ±292 000 years; anything beyond a century is not a clock.
            if t_s.abs() > 3.2e9 {
                return Err(field("t", "is not a capture time in seconds"));
            }
            (t_s * 1e6).round() as i64
        }
    };
    let mut sightings = Vec::new();
    match obj.get("tracks") {
        None | Some(Value::Null) => sightings.push(sighting(&obj, 1)?),
        Some(Value::Array(tracks)) => {
            if tracks.len() > MAX_TRACKS_PER_LINE {
                return Err(LineError::TooManyTracks(tracks.len()));
            }
            for track in tracks {
                let Value::Object(track) = track else {
                    return Err(field("tracks", "holds something other than objects"));
                };
                let id = match track.get("id").and_then(Value::as_u64) {
                    Some(id) if id >= 1 && id <= u64::from(u32::MAX) => id as u32,
                    _ => return Err(field("id", "is not a robot id (a whole number from 1)")),
                };
                if sightings.iter().any(|s: &Sighting| s.id == id) {
                    return Err(LineError::DuplicateId(id));
                }
                sightings.push(sighting(track, id)?);
            }
        }
        Some(_) => return Err(field("tracks", "is not a list")),
    }
    Ok(Report { t_us, sightings })
}

#[cfg(test)]
mod tests {
    use super::*;

    const SINGLE: &str = r#"{"frame":3,"t":0.100000,"found":true,"x":10.5,"y":20.25,"mid_x":10.0,"mid_y":20.0,"pos_method":"head","vx":3.0,"vy":-1.0,"v_method":"frames","floor_x":12.345,"floor_y":-6.5,"floor_unit":"cm","floor_vx":1.5,"floor_vy":0.25,"floor_speed":1.52,"calib":{"age_s":0.3,"residual_px":0.25},"area_px":50,"len_px":2,"seq":3,"dropped":0,"blobs":1,"threshold":240}"#;

    #[test]
    fn the_single_led_line_is_robot_one() {
        let r = parse(SINGLE, None).unwrap();
        assert_eq!(r.t_us, 100_000);
        let [s] = r.sightings.as_slice() else {
            panic!()
        };
        assert_eq!(s.id, 1);
        assert!(s.found && s.head);
        assert_eq!(s.floor, Some(Point::new(12.345, -6.5)));
        assert_eq!(s.unit, Some(FloorUnit::Cm));
        assert_eq!(s.floor_velocity, Some(Point::new(1.5, 0.25)));
        assert_eq!(s.position_px, Some(Point::new(10.5, 20.25)));
        assert_eq!(s.calib_residual_px, Some(0.25));
        assert_eq!(s.area_px, Some(50.0));
    }

    #[test]
    fn the_several_robots_line_gives_each_id() {
        let line = r#"{"frame":0,"t":2.5,"tracks":[{"id":2,"found":false},{"id":7,"found":true,"x":1,"y":2,"floor_x":3,"floor_y":4}]}"#;
        let r = parse(line, Some(42)).unwrap();
        assert_eq!(r.t_us, 42, "the transport's time wins over the line's");
        assert_eq!(r.sightings.len(), 2);
        assert_eq!((r.sightings[0].id, r.sightings[0].found), (2, false));
        assert_eq!(r.sightings[1].floor, Some(Point::new(3.0, 4.0)));
    }

    #[test]
    fn hostile_lines_are_refused_naming_what_is_wrong() {
        let cut = &SINGLE[..SINGLE.len() / 2];
        let cases: [(&str, &str); 10] = [
            (
                r#"{"t":1,"found":true,"x":1,"y":2,"floor_x":5,"floor_y":6,"floor_unit":"ft"}"#,
                "`floor_unit`",
            ),
            (cut, "cut short"),
            ("\u{1}\u{2}garbage", "not a JSON"),
            ("[1,2]", "not an object"),
            (r#"{"found":true,"x":1,"y":2}"#, "`t` is missing"),
            (
                r#"{"t":1,"found":true,"x":1,"y":2,"floor_x":5}"#,
                "`floor_y` is missing",
            ),
            (r#"{"t":1,"found":true}"#, "`x` is missing"),
            (
                r#"{"t":"soon","found":false}"#,
                "`t` is not a finite number",
            ),
            (
                r#"{"t":1,"tracks":[{"id":1,"found":false},{"id":1,"found":false}]}"#,
                "twice",
            ),
            (r#"{"t":1,"tracks":[{"id":0,"found":false}]}"#, "`id`"),
        ];
        for (line, says) in cases {
            let e = parse(line, None).unwrap_err().to_string();
            assert!(e.contains(says), "{line:?}: {e}");
        }
        assert!(matches!(
            parse(&" ".repeat(MAX_LINE_BYTES + 1), None),
            Err(LineError::TooLong(_))
        ));
    }
}
