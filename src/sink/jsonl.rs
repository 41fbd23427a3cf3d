//! One JSON object per frame, one per line.
//!
//! Keys: `frame`, `t` (s), `found`; when found `x`, `y`, `mid_x`, `mid_y` (px), `pos_method`,
//! and when known `vx`, `vy` (px/s), `v_method`; for a tracked marker `heading_deg` (screen).
//! With a calibration, found frames get `floor_x`, `floor_y` and `floor_unit`, and when the
//! velocity is known `floor_vx`, `floor_vy`, `floor_speed` (units/s), for a marker
//! `floor_heading_deg`; a position on or beyond the floor's horizon gets `beyond_horizon: true`
//! and no floor numbers. When the calibration's markers are re-checked, every line says which
//! calibration it used, `"calib":{"age_s":…,"residual_px":…}` (seconds since markers last
//! confirmed the pose, and their rms residual then), and floor numbers get `floor_stale: true`
//! once no marker has been seen for a while (the camera may have moved). Headings are degrees
//! from +x towards +y of their coordinates ([`crate::geometry::marker_heading_deg`]). With
//! `--predict arrival`, a found frame with a known velocity gets `predicted`: `{"x", "y" (px),
//! "ahead_ms"}`, the position extrapolated to the moment the line is written, `ahead_ms` after
//! the end of the exposure (see [`super::predict`]). Then the detection's diagnostics, among
//! them, where the streak's path was read, `path_px`: its length from this frame alone (px),
//! before the tracker's offset and weighing (a `streak` velocity is this exposure's path,
//! weighed with the middles'; `path_px` is the frame's own measurement), with
//! `--streak-model fit`, `fit_px`: one standard deviation of the fitted path's ends
//! (px), and `fit_floor`: `learned`, `partly` or `flat`, whether the floor under the fitted
//! pixels was learned or (where no floor was learned yet) one fitted flat floor; and
//! `cut_by_edge: true` where the light reaches the frame's edge (an LED driving into or out of
//! view), whose middle and `path_px` are the visible part's, not its path's (on a track its
//! velocity is then the track's, and its head carried along the track where the edge cut it:
//! see `Tracker::update`).
//!
//! With several robots (`--robots N`, N > 1) the line holds the frame's own fields (`frame`,
//! `t`, `found`: any robot found, `calib`, `seq`, `dropped`, `blobs`, `threshold`, `learning`,
//! `blinded`, `overflow`) and `tracks`: one object per robot, `id`, `provisional`,
//! `id_source`, `state` (`searching`, `tracking`, `coasting`), `merged`, then that robot's
//! `found` and the fields above with their meanings. `--predict arrival` extrapolates a single
//! robot only.

use std::io::{self, Write};

use super::predict::{Predictor, Reference};
use super::Sink;
use crate::report::{Blob, Estimate, FloorFix, FrameReport, Streak};
use crate::source::clock::monotonic_now_us;

/// Writes reports as JSON lines; flushes after each line when `live`, so a consumer reading a
/// pipe sees every frame as it happens.
pub struct JsonLinesSink<W: Write> {
    out: W,
    live: bool,
    /// With `--predict arrival`.
    predictor: Option<Predictor>,
}

impl<W: Write> JsonLinesSink<W> {
    /// A sink on `out`.
    pub fn new(out: W, live: bool) -> Self {
        JsonLinesSink {
            out,
            live,
            predictor: None,
        }
    }

    /// Adds the position extrapolated to the moment each line is written (`--predict arrival`).
    pub fn predicting(mut self) -> Self {
        self.predictor = Some(Predictor::new());
        self
    }
}

impl<W: Write> Sink for JsonLinesSink<W> {
    fn write(&mut self, r: &FrameReport) -> io::Result<()> {
        let d = &r.detection;
        let out = &mut self.out;
        write!(
            out,
            "{{\"frame\":{},\"t\":{:.6},\"found\":{}",
            r.meta.index,
            r.t_s(),
            r.tracks.iter().any(|t| t.estimate.is_some())
        )?;
        if r.several() {
            return self.write_several(r);
        }
        write_position(out, r.position)?;
        if let Some(predictor) = self.predictor.as_mut() {
            let velocity = r.position.and_then(|p| p.velocity_px_s);
            let motion = predictor.observe(r.meta.timestamp_us, Reference::Pixels, velocity);
            if let (Some(motion), Some(p)) = (motion, r.position) {
                let ahead_us = monotonic_now_us().saturating_sub(r.meta.monotonic_us);
                let ahead_s = ahead_us as f32 * 1e-6;
                let (x, y) = motion.extrapolate(p.position_px, ahead_s);
                write!(
                    out,
                    ",\"predicted\":{{\"x\":{x:.3},\"y\":{y:.3},\"ahead_ms\":{:.3}}}",
                    ahead_us as f64 * 1e-3
                )?;
            }
        }
        if let Some(m) = r.marker {
            write!(out, ",\"heading_deg\":{:.2}", m.heading_deg)?;
        }
        write_floor(out, r.floor)?;
        write_calib(out, r)?;
        if let Some(c) = r.calib {
            if c.stale && r.floor.is_some() {
                write!(out, ",\"floor_stale\":true")?;
            }
        }
        write_blob(out, d.best.filter(|_| r.position.is_some()))?;
        write_frame_tail(out, r)?;
        if r.ambiguous {
            write!(out, ",\"ambiguous\":true")?;
        }
        if r.markers_capped {
            write!(out, ",\"markers_capped\":true")?;
        }
        if d.blinded {
            write!(out, ",\"blinded\":true")?;
        }
        if d.overflow.any() {
            write!(out, ",\"overflow\":true")?;
        }
        self.end_line()
    }

    fn finish(&mut self) -> io::Result<()> {
        self.out.flush()
    }
}

impl<W: Write> JsonLinesSink<W> {
    /// With several robots: the frame's own fields, then `tracks`, one object per robot with
    /// the single-robot line's fields and meanings (`found`, `x`, `y`, `mid_x`, `mid_y`,
    /// `pos_method`, `vx`, `vy`, `v_method`, the floor's, `area_px`, `len_px`, `path_px`, `fit_px`)
    /// after its `id`, `provisional`, `id_source`, `state` and `merged`.
    fn write_several(&mut self, r: &FrameReport) -> io::Result<()> {
        let out = &mut self.out;
        let d = &r.detection;
        write_calib(out, r)?;
        write_frame_tail(out, r)?;
        if d.blinded {
            write!(out, ",\"blinded\":true")?;
        }
        if d.overflow.any() {
            write!(out, ",\"overflow\":true")?;
        }
        write!(out, ",\"tracks\":[")?;
        for (i, t) in r.tracks.iter().enumerate() {
            let separator = if i == 0 { "" } else { "," };
            write!(
                out,
                "{separator}{{\"id\":{},\"provisional\":{},\"id_source\":\"{}\",\
                 \"state\":\"{}\",\"merged\":{},\"found\":{}",
                t.id,
                t.provisional,
                t.id_source.name(),
                t.state.name(),
                t.merged,
                t.estimate.is_some()
            )?;
            write_position(out, t.estimate)?;
            write_floor(out, t.floor)?;
            if r.calib.is_some_and(|c| c.stale) && t.floor.is_some() {
                write!(out, ",\"floor_stale\":true")?;
            }
            write_blob(out, t.blob.filter(|_| t.estimate.is_some()))?;
            write!(out, "}}")?;
        }
        write!(out, "]")?;
        self.end_line()
    }

    fn end_line(&mut self) -> io::Result<()> {
        writeln!(self.out, "}}")?;
        if self.live {
            self.out.flush()?;
        }
        Ok(())
    }
}

/// `x`, `y`, `mid_x`, `mid_y`, `pos_method` and, when known, `vx`, `vy`, `v_method`.
fn write_position(out: &mut impl Write, position: Option<Estimate>) -> io::Result<()> {
    if let Some(p) = position {
        write!(
            out,
            ",\"x\":{:.3},\"y\":{:.3},\"mid_x\":{:.3},\"mid_y\":{:.3},\"pos_method\":\"{}\"",
            p.position_px.0,
            p.position_px.1,
            p.mid_px.0,
            p.mid_px.1,
            p.position_method.name()
        )?;
        if let Some(((vx, vy), method)) = p.velocity_px_s {
            write!(
                out,
                ",\"vx\":{vx:.2},\"vy\":{vy:.2},\"v_method\":\"{}\"",
                method.name()
            )?;
        }
    }
    Ok(())
}

/// The floor's numbers, or `beyond_horizon`.
fn write_floor(out: &mut impl Write, floor: Option<FloorFix>) -> io::Result<()> {
    match floor {
        Some(FloorFix::Mapped(f)) => {
            write!(
                out,
                ",\"floor_x\":{:.3},\"floor_y\":{:.3},\"floor_unit\":\"{}\"",
                f.position.x, f.position.y, f.unit
            )?;
            if let Some(v) = f.velocity_per_s {
                write!(
                    out,
                    ",\"floor_vx\":{:.3},\"floor_vy\":{:.3},\"floor_speed\":{:.3}",
                    v.x,
                    v.y,
                    v.norm()
                )?;
            }
            if let Some(h) = f.heading_deg {
                write!(out, ",\"floor_heading_deg\":{h:.2}")?;
            }
        }
        Some(FloorFix::BeyondHorizon) => write!(out, ",\"beyond_horizon\":true")?,
        None => {}
    }
    Ok(())
}

/// `area_px`, `len_px`, where the streak's path was read `path_px` (its length from this
/// frame alone, before the tracker's learned offset and weighing) and, with a fitted model,
/// `fit_px` and `fit_floor` of the light's blob, and `cut_by_edge` where it reaches the
/// frame's edge.
fn write_blob(out: &mut impl Write, blob: Option<(Blob, Streak)>) -> io::Result<()> {
    if let Some((blob, streak)) = blob {
        write!(
            out,
            ",\"area_px\":{},\"len_px\":{}",
            blob.area_px, streak.skeleton_length_px
        )?;
        if let Some(path) = streak.path {
            write!(out, ",\"path_px\":{:.3}", path.path_length_px)?;
        }
        if let Some(fit_px) = streak.path.and_then(|p| p.fit_px) {
            write!(out, ",\"fit_px\":{fit_px:.3}")?;
        }
        if let Some(floor) = streak.path.and_then(|p| p.fit_floor) {
            write!(out, ",\"fit_floor\":\"{}\"", floor.name())?;
        }
        if streak.cut_by_edge() {
            write!(out, ",\"cut_by_edge\":true")?;
        }
    }
    Ok(())
}

/// Which calibration the floor numbers used, when its markers are re-checked.
fn write_calib(out: &mut impl Write, r: &FrameReport) -> io::Result<()> {
    if let Some(c) = r.calib {
        write!(
            out,
            ",\"calib\":{{\"age_s\":{:.3},\"residual_px\":{:.3}}}",
            c.age_s, c.residual_px
        )?;
    }
    Ok(())
}

/// The frame's counters: `seq`, `dropped`, `blobs`, `threshold`, `learning`.
fn write_frame_tail(out: &mut impl Write, r: &FrameReport) -> io::Result<()> {
    let d = &r.detection;
    write!(
        out,
        ",\"seq\":{},\"dropped\":{},\"blobs\":{}",
        r.meta.sequence, r.meta.dropped, d.blob_count
    )?;
    if let Some(level) = d.levels.threshold_luma {
        write!(out, ",\"threshold\":{level}")?;
    }
    if d.learning {
        write!(out, ",\"learning\":true")?;
    }
    Ok(())
}
