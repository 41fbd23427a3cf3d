//! The fused steps as JSON lines, one per step:
//!
//! ```json
//! {"t":10.033333,"tracks":[{"id":1,"found":true,"floor_x":12.345,"floor_y":-70.000,
//!  "floor_unit":"cm","floor_sigma":0.061,"floor_vx":60.000,"floor_vy":0.000,
//!  "cameras":["a","b"],"weights":[0.712,0.288]}]}
//! ```
//!
//! `t` is the step's capture time (s, the cameras' shared clock); per robot `id`, `found`, and
//! when found the floor position and its unit (the cameras' `floor_unit`, cm with glint's
//! calibrations), its standard deviation `floor_sigma` (same unit; once every contributing
//! camera has measured its floor length of a pixel, see [`super::FusedTrack::sigma`]), the
//! floor velocity when known (units/s), and the cameras that contributed with their weights.
//! Numbers are written as the cameras' own lines write them (3 decimals, `t` 6), so one camera
//! fused alone gives back its own numbers.

use std::io::{self, Write};

use super::FusedStep;

/// Writes one step; `names` are the cameras' names, by index.
pub fn write_step(out: &mut impl Write, step: &FusedStep, names: &[String]) -> io::Result<()> {
    write!(out, "{{\"t\":{:.6},\"tracks\":[", step.t_us as f64 * 1e-6)?;
    for (k, track) in step.tracks.iter().enumerate() {
        if k > 0 {
            write!(out, ",")?;
        }
        write!(out, "{{\"id\":{},\"found\":{}", track.id, track.found)?;
        if let Some(p) = track.floor {
            write!(out, ",\"floor_x\":{:.3},\"floor_y\":{:.3}", p.x, p.y)?;
            if let Some(unit) = step.unit {
                write!(out, ",\"floor_unit\":\"{}\"", unit.name())?;
            }
            if let Some(sigma) = track.sigma {
                write!(out, ",\"floor_sigma\":{sigma:.3}")?;
            }
        }
        if let Some(v) = track.velocity {
            write!(out, ",\"floor_vx\":{:.3},\"floor_vy\":{:.3}", v.x, v.y)?;
        }
        write!(out, ",\"cameras\":[")?;
        for (i, (camera, _)) in track.cameras.iter().enumerate() {
            let name = names.get(*camera).map_or("?", String::as_str);
            let quoted = serde_json::to_string(name).map_err(io::Error::other)?;
            write!(out, "{}{quoted}", if i > 0 { "," } else { "" })?;
        }
        write!(out, "],\"weights\":[")?;
        for (i, (_, w)) in track.cameras.iter().enumerate() {
            write!(out, "{}{w:.3}", if i > 0 { "," } else { "" })?;
        }
        write!(out, "]}}")?;
    }
    writeln!(out, "]}}")
}
