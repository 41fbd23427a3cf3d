//! One JSON object per frame, one per line.

use std::io::{self, Write};

use super::Sink;
use crate::pipeline::FrameReport;

/// Writes reports as JSON lines; flushes after each line when `live`, so a consumer reading a
/// pipe sees every frame as it happens.
pub struct JsonLinesSink<W: Write> {
    out: W,
    live: bool,
}

impl<W: Write> JsonLinesSink<W> {
    /// A sink on `out`.
    pub fn new(out: W, live: bool) -> Self {
        JsonLinesSink { out, live }
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
            r.position.is_some()
        )?;
        if let Some(p) = r.position {
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
        if let Some((blob, streak)) = d.best.filter(|_| r.position.is_some()) {
            write!(
                out,
                ",\"area_px\":{},\"len_px\":{}",
                blob.area_px, streak.skeleton_length_px
            )?;
        }
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
        if r.ambiguous {
            write!(out, ",\"ambiguous\":true")?;
        }
        if d.blinded {
            write!(out, ",\"blinded\":true")?;
        }
        if d.overflow.any() {
            write!(out, ",\"overflow\":true")?;
        }
        writeln!(out, "}}")?;
        if self.live {
            out.flush()?;
        }
        Ok(())
    }

    fn finish(&mut self) -> io::Result<()> {
        self.out.flush()
    }
}
