//! `glint latency`: asks the robot to switch its LED off at random moments and measures how long
//! until glint sees it gone (see `glint::latency`).

use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::Args;

use super::serial_ports::SerialPlan;
use super::track::{self, Opened, TrackSettings};

use glint::latency::{
    quantile_us, reaction_from_phases, FrameTimes, LatencyConfig, LatencyTest, Measurement, Step,
};
use glint::sink::serial::line_time;
use glint::sink::Sink;
use glint::source::clock::monotonic_now_us;
use glint::source::FrameSource;
use glint_protocol::{encode, LedRequest, Message, MAX_LED_WIRE_LEN};

/// Percent per unit.
const PERCENT: f64 = 100.0;

#[derive(Debug, Args)]
pub struct LatencyArgs {
    #[command(flatten)]
    pub settings: TrackSettings,

    /// Requests to send.
    #[arg(long, default_value_t = 30, value_parser = clap::value_parser!(u32).range(1..=1000))]
    trials: u32,

    /// The robot to ask, by its id; 0 asks every robot on the line.
    #[arg(long, default_value_t = 0)]
    robot: u8,

    /// How long the robot keeps its LED off per request, ms.
    #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u32).range(5..=10_000))]
    off_ms: u32,

    /// How long to wait (in frame time) for the LED to go dark after a request before it
    /// counts as unanswered, ms; after 3 unanswered in a row the test stops.
    #[arg(long, default_value_t = 1_000, value_parser = clap::value_parser!(u32).range(10..=60_000))]
    answer_ms: u32,

    /// Seed of the random moments (default: from the clock).
    #[arg(long)]
    seed: Option<u64>,
}

pub fn run(args: LatencyArgs) -> Result<ExitCode> {
    let port = match args.settings.serial_plan()? {
        SerialPlan::Shared(port) => port,
        SerialPlan::None => bail!(
            "glint latency needs a link to the robot: give --serial PORT (the robot switches \
             its LED off when glint asks over it)"
        ),
        SerialPlan::PerRobot(_) => bail!(
            "glint latency asks over one line: give --serial PORT (and --robot ID), not ID=PORT"
        ),
    };
    if args.settings.publish.publish.is_some() {
        bail!("glint latency measures the serial link alone: drop --publish");
    }
    let Opened {
        mut source,
        mut pipeline,
        serial,
        ..
    } = track::open(&args.settings, &args.settings.memory_plan())?;
    let (glint_link, mavlink) = serial.into_parts();
    // A line per robot is refused above: the first part is the one shared line, if any.
    let (serial, _) = glint_link.into_parts();
    if mavlink.is_some() {
        bail!("glint latency asks the robot in glint's own protocol: drop --mavlink");
    }
    let mut serial = serial.with_context(|| format!("no serial link on {port}"))?;
    let off_us = args.off_ms * 1_000;
    let mut test = LatencyTest::new(LatencyConfig {
        trials: args.trials,
        off_us,
        answer_us: u64::from(args.answer_ms) * 1_000,
        seed: args.seed.unwrap_or_else(monotonic_now_us),
    });
    let outcome = loop {
        let (frame, meta) = match source.next_frame() {
            Ok(Some(next)) => next,
            Ok(None) => {
                let (sent, _) = test.requests();
                break Err(anyhow::anyhow!(
                    "the input ended after {sent} of {} requests",
                    args.trials
                ));
            }
            Err(e) => break Err(anyhow::Error::new(e).context("reading frames")),
        };
        // Delivered now: a camera's driver stamps the exposure, a stamped pipe carries it.
        let delivered_us = monotonic_now_us();
        let report = pipeline.process(&frame, meta);
        serial.write(&report)?;
        let times = FrameTimes {
            delivery_us: delivered_us.saturating_sub(meta.monotonic_us),
            processing_us: monotonic_now_us().saturating_sub(meta.monotonic_us),
        };
        // The robot stands still while it is measured: its LED lit is reported as found when
        // it comes on (it appeared), then as a candidate not yet told from glare (it stands
        // still). Either is "lit".
        let found = report.position.is_some() || report.ambiguous;
        match test.on_frame(meta.timestamp_us, found, times, serial.last_led_sent()) {
            Ok(Step::Continue) => {}
            Ok(Step::Request) => {
                let delay_us = test.request_delay_us();
                let request = serial.request_led(args.robot, delay_us, off_us);
                test.posted(request, meta.timestamp_us, delay_us);
            }
            Ok(Step::Done) => break Ok(()),
            Err(e) => break Err(e.into()),
        }
    };
    serial.finish()?;
    outcome?;
    let (requests, unanswered) = test.requests();
    print_summary(&args, test.measurements(), requests, unanswered);
    Ok(ExitCode::SUCCESS)
}

/// Milliseconds from µs.
fn ms(us: u64) -> f64 {
    us as f64 * 1e-3
}

fn print_summary(args: &LatencyArgs, measured: &[Measurement], requests: u32, unanswered: u32) {
    let line_us = request_line_us(args);
    let mut total: Vec<u64> = measured
        .iter()
        .map(|m| line_us + m.to_capture_us + m.processing_us)
        .collect();
    let mut to_capture: Vec<u64> = measured.iter().map(|m| m.to_capture_us).collect();
    let mut delivery: Vec<u64> = measured.iter().map(|m| m.delivery_us).collect();
    let mut processing: Vec<u64> = measured
        .iter()
        .map(|m| m.processing_us.saturating_sub(m.delivery_us))
        .collect();
    println!(
        "latency: {} of {requests} requests answered ({unanswered} unanswered)",
        measured.len()
    );
    let stats = |v: &mut [u64]| {
        (
            quantile_us(v, 0.5),
            quantile_us(v, 0.95),
            quantile_us(v, 1.0),
        )
    };
    let (p50, p95, max) = stats(&mut total);
    println!(
        "latency: request written to dark frame processed: p50 {:.1} ms, p95 {:.1} ms, max {:.1} ms",
        ms(p50),
        ms(p95),
        ms(max)
    );
    let (c50, c95, cmax) = stats(&mut to_capture);
    println!(
        "latency: request on the robot's side to dark frame captured: p50 {:.1} ms, p95 {:.1} \
         ms, max {:.1} ms",
        ms(c50),
        ms(c95),
        ms(cmax)
    );
    let exposure_us = args.settings.input.exposure_us().map(u64::from);
    let half_exposure_us = exposure_us.unwrap_or(0) / 2;
    let estimate = reaction_from_phases(measured, exposure_us.unwrap_or(0));
    // From the request written to the LED dark: the line time, then the robot's reaction.
    let dark_after_write_us = estimate.map(|e| e.reaction_us + line_us as i64);
    match estimate {
        Some(e) => println!(
            "latency: request written to the LED going dark (line time and the robot's \
             reaction), from the frames' phases: {:.1} ms (±{:.1} ms; {} of {} requests' frames \
             agree)",
            e.reaction_us as f64 * 1e-3 + ms(line_us),
            e.span_us as f64 * 0.5e-3,
            e.agreeing,
            e.brackets
        ),
        None => println!(
            "latency: request written to the LED going dark: no request had a lit frame before \
             its dark one"
        ),
    }
    let (d50, d95, _) = stats(&mut delivery);
    let (e50, e95, _) = stats(&mut processing);
    println!(
        "latency: capture to delivered (the camera's readout, transfer and driver): p50 {:.1} ms, \
         p95 {:.1} ms; delivered to processed: p50 {:.1} ms, p95 {:.1} ms",
        ms(d50),
        ms(d95),
        ms(e50),
        ms(e95)
    );
    // The wait for the next exposure to see the LED dark: what is left of each request's
    // time to the dark frame once the robot's reaction and half the exposure are taken out.
    let mut phase: Vec<u64> = match estimate {
        Some(e) => measured
            .iter()
            .map(|m| {
                (m.to_capture_us as i64 - e.reaction_us - half_exposure_us as i64).max(0) as u64
            })
            .collect(),
        None => Vec::new(),
    };
    let phase_p50 = quantile_us(&mut phase, 0.5);
    let share = |us: u64| us as f64 * PERCENT / (p50.max(1) as f64);
    let part = |name: &str, us: u64| format!("{name} {:.1} ms ({:.0} %)", ms(us), share(us));
    let exposure = match exposure_us {
        Some(_) => part("half the exposure", half_exposure_us),
        None => "exposure unknown (give --exposure-us; the frames' moments are then their \
                 exposures' ends)"
            .to_string(),
    };
    let reaction = match estimate {
        Some(e) => part("the robot's reaction", e.reaction_us.max(0) as u64),
        None => "the robot's reaction unknown".to_string(),
    };
    println!(
        "latency: parts of the p50: {}, {reaction}, {}, {exposure}, {}, {}",
        part("line time", line_us),
        part("the wait for the next exposure", phase_p50),
        part("capture to delivered", d50),
        part("delivered to processed", e50),
    );
    if let Some(dark_us) = dark_after_write_us {
        let loop_us = dark_us.max(0) as u64 + half_exposure_us + d50 + e50;
        println!(
            "latency: without the wait for the next exposure: {:.1} ms (request written to the \
             LED dark, half the exposure, capture to processed)",
            ms(loop_us)
        );
    }
}

/// Line time of one LED request at the link's baud.
fn request_line_us(args: &LatencyArgs) -> u64 {
    let request = LedRequest {
        robot: args.robot,
        request: 0,
        at_us: 0,
        delay_us: 0,
        off_us: args.off_ms * 1_000,
    };
    let mut out = [0u8; MAX_LED_WIRE_LEN];
    let bytes = encode(&Message::Led(request), &mut out).map_or(MAX_LED_WIRE_LEN, <[u8]>::len);
    line_time(bytes as u64, args.settings.baud).as_micros() as u64
}
