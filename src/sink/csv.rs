//! The same columns as the JSON lines, as CSV with a header; empty cells where unknown.
//!
//! With several robots, one row per robot and frame, under the same header with five more
//! columns at its end: `id`, `provisional`, `id_source`, `state` and `merged` ([`CSV_TRACK_COLUMNS`]);
//! each row's position, velocity, blob and floor columns are that robot's, `found` whether it
//! was found.
//!
//! With `--predict arrival` (one robot), three more columns at the end, as the JSON lines'
//! `predicted`: `predicted_x`, `predicted_y` (px), the position extrapolated to the moment the row
//! is written, and `predicted_ahead_ms`, how far ahead of the exposure's end that is
//! ([`CSV_PREDICTED_COLUMNS`]); empty when the frame has no position or no velocity yet.

use std::io::{self, Write};

use super::predict::{Predictor, Reference};
use super::Sink;
use crate::report::{Blob, Estimate, FloorFix, FrameReport, Streak};
use crate::source::clock::monotonic_now_us;

/// The header line.
pub const CSV_HEADER: &str = "frame,t,found,x,y,mid_x,mid_y,pos_method,vx,vy,v_method,area_px,\
len_px,seq,dropped,blobs,threshold,ambiguous,blinded,overflow,heading_deg,floor_x,floor_y,\
floor_vx,floor_vy,floor_speed,floor_heading_deg,floor_unit,beyond_horizon,fit_px,path_px";

/// The columns added after [`CSV_HEADER`] when several robots are followed.
pub const CSV_TRACK_COLUMNS: &str = "id,provisional,id_source,state,merged";

/// The columns added after [`CSV_HEADER`] with `--predict arrival`.
pub const CSV_PREDICTED_COLUMNS: &str = "predicted_x,predicted_y,predicted_ahead_ms";

/// Writes reports as CSV rows under a header line naming the columns.
pub struct CsvSink<W: Write> {
    out: W,
    live: bool,
    header_written: bool,
    /// With `--predict arrival`.
    predictor: Option<Predictor>,
}

impl<W: Write> CsvSink<W> {
    /// A sink on `out`; flushes after each row when `live`.
    pub fn new(out: W, live: bool) -> Self {
        CsvSink {
            out,
            live,
            header_written: false,
            predictor: None,
        }
    }

    /// Adds the position extrapolated to the moment each row is written (`--predict arrival`).
    pub fn predicting(mut self) -> Self {
        self.predictor = Some(Predictor::new());
        self
    }
}

impl<W: Write> Sink for CsvSink<W> {
    fn write(&mut self, r: &FrameReport) -> io::Result<()> {
        let out = &mut self.out;
        if !self.header_written {
            if r.several() {
                writeln!(out, "{CSV_HEADER},{CSV_TRACK_COLUMNS}")?;
            } else if self.predictor.is_some() {
                writeln!(out, "{CSV_HEADER},{CSV_PREDICTED_COLUMNS}")?;
            } else {
                writeln!(out, "{CSV_HEADER}")?;
            }
            self.header_written = true;
        }
        if r.several() {
            for t in &r.tracks {
                write_row(out, r, t.estimate, t.floor, t.blob)?;
                writeln!(
                    out,
                    ",{},{},{},{},{}",
                    t.id,
                    t.provisional,
                    t.id_source.name(),
                    t.state.name(),
                    t.merged
                )?;
            }
        } else {
            write_row(out, r, r.position, r.floor, r.detection.best)?;
            if let Some(predictor) = self.predictor.as_mut() {
                write_predicted(out, predictor, r)?;
            }
            writeln!(out)?;
        }
        if self.live {
            out.flush()?;
        }
        Ok(())
    }

    fn finish(&mut self) -> io::Result<()> {
        if !self.header_written {
            if self.predictor.is_some() {
                writeln!(self.out, "{CSV_HEADER},{CSV_PREDICTED_COLUMNS}")?;
            } else {
                writeln!(self.out, "{CSV_HEADER}")?;
            }
            self.header_written = true;
        }
        self.out.flush()
    }
}

/// The cells of [`CSV_PREDICTED_COLUMNS`]: the position extrapolated to now, as the JSON lines'
/// `predicted`.
fn write_predicted(
    out: &mut impl Write,
    predictor: &mut Predictor,
    r: &FrameReport,
) -> io::Result<()> {
    let velocity = r.position.and_then(|p| p.velocity_px_s);
    let motion = predictor.observe(r.meta.timestamp_us, Reference::Pixels, velocity);
    match (motion, r.position) {
        (Some(motion), Some(p)) => {
            let ahead_us = monotonic_now_us().saturating_sub(r.meta.monotonic_us);
            let (x, y) = motion.extrapolate(p.position_px, ahead_us as f32 * 1e-6);
            write!(out, ",{x:.3},{y:.3},{:.3}", ahead_us as f64 * 1e-3)
        }
        _ => write!(out, ",,,"),
    }
}

/// The columns of [`CSV_HEADER`] for one light (the frame's one robot, or one of several),
/// without the line's end.
fn write_row(
    out: &mut impl Write,
    r: &FrameReport,
    position: Option<Estimate>,
    floor: Option<FloorFix>,
    blob: Option<(Blob, Streak)>,
) -> io::Result<()> {
    let d = &r.detection;
    let blob = blob.filter(|_| position.is_some());
    write!(
        out,
        "{},{:.6},{}",
        r.meta.index,
        r.t_s(),
        position.is_some()
    )?;
    match position {
        Some(p) => write!(
            out,
            ",{:.3},{:.3},{:.3},{:.3},{}",
            p.position_px.0,
            p.position_px.1,
            p.mid_px.0,
            p.mid_px.1,
            p.position_method.name()
        )?,
        None => write!(out, ",,,,,")?,
    }
    match position.and_then(|p| p.velocity_px_s) {
        Some(((vx, vy), method)) => write!(out, ",{vx:.2},{vy:.2},{}", method.name())?,
        None => write!(out, ",,,")?,
    }
    match blob {
        Some((blob, streak)) => write!(out, ",{},{}", blob.area_px, streak.skeleton_length_px)?,
        None => write!(out, ",,")?,
    }
    write!(
        out,
        ",{},{},{},",
        r.meta.sequence, r.meta.dropped, d.blob_count
    )?;
    if let Some(level) = d.levels.threshold_luma {
        write!(out, "{level}")?;
    }
    write!(out, ",{},{},{}", r.ambiguous, d.blinded, d.overflow.any())?;
    match r.marker {
        Some(m) => write!(out, ",{:.2}", m.heading_deg)?,
        None => write!(out, ",")?,
    }
    match floor {
        Some(FloorFix::Mapped(f)) => {
            write!(out, ",{:.3},{:.3}", f.position.x, f.position.y)?;
            match f.velocity_per_s {
                Some(v) => write!(out, ",{:.3},{:.3},{:.3}", v.x, v.y, v.norm())?,
                None => write!(out, ",,,")?,
            }
            match f.heading_deg {
                Some(h) => write!(out, ",{h:.2}")?,
                None => write!(out, ",")?,
            }
            write!(out, ",{},false", f.unit)?;
        }
        Some(FloorFix::BeyondHorizon) => write!(out, ",,,,,,,,true")?,
        None => write!(out, ",,,,,,,,false")?,
    }
    match blob.and_then(|(_, streak)| streak.path?.fit_px) {
        Some(fit_px) => write!(out, ",{fit_px:.3}")?,
        None => write!(out, ",")?,
    }
    match blob.and_then(|(_, streak)| streak.path) {
        Some(path) => write!(out, ",{:.3}", path.path_length_px),
        None => write!(out, ","),
    }
}
