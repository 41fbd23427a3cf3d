//! The publisher thread: takes reports off the queue, formats each in its forms and puts them
//! on the Zenoh session, each sent at once (`express`) rather than batched.
//!
//! Puts use congestion control `block`: when a link cannot take more, this thread waits (Zenoh
//! closes a link that stays blocked, 5 s by default, and reconnects), the queue before it fills,
//! and the tracking thread drops, and counts, the reports that do not fit. So every report lost
//! to a slow network is counted in one place; with `drop`, Zenoh would discard samples silently
//! whenever its own short queue is full, which a loaded machine does even on the loopback.

use std::sync::atomic::Ordering;
use std::sync::mpsc::Receiver;
use std::time::{SystemTime, UNIX_EPOCH};

use zenoh::bytes::Encoding;
use zenoh::config::EndPoint;
use zenoh::pubsub::Publisher;
use zenoh::qos::CongestionControl;
use zenoh::{Config, Session, Wait};

use super::outbox::Counters;
use super::ros::{self, POINT_STAMPED_BYTES};
use super::wire::{self, WireReport};
use super::{PublishConfig, PublishError};
use crate::geometry::FloorFix;
use crate::report::FrameReport;
use crate::sink::mavlink::estimate::metres_per_unit;
use crate::sink::{JsonLinesSink, Sink};
use crate::source::clock::monotonic_now_us;

/// The schema named in the binary form's encoding.
pub const BINARY_SCHEMA: &str = "glint.report.1";

/// Room for one JSON line; the buffer grows if a line is longer.
const LINE_BYTES: usize = 1024;

/// The session and one publisher per form.
pub struct Publishers {
    session: Session,
    json: Publisher<'static>,
    binary: Publisher<'static>,
    bridge_point: Publisher<'static>,
    rmw_point: Publisher<'static>,
    /// Appended to each JSON line: `,"camera":"CAM"`.
    camera_field: String,
    /// rmw_zenoh's publisher id: the session's.
    gid: [u8; 16],
}

impl Publishers {
    /// Opens the session (peer mode) and declares the publishers.
    pub fn open(config: &PublishConfig) -> Result<Publishers, PublishError> {
        let session = open_session(&config.connect, &config.listen)?;
        let declare = |key: &str, encoding: Encoding| {
            session
                .declare_publisher(key.to_owned())
                .encoding(encoding)
                .congestion_control(CongestionControl::Block)
                .express(true)
                .wait()
                .map_err(|e| PublishError::Open(format!("publisher on {key}: {e}")))
        };
        let keys = &config.keys;
        let json = declare(&keys.json, Encoding::APPLICATION_JSON)?;
        let binary = declare(
            &keys.binary,
            Encoding::APPLICATION_OCTET_STREAM.with_schema(BINARY_SCHEMA),
        )?;
        let bridge_point = declare(&keys.bridge_point, Encoding::APPLICATION_CDR)?;
        let rmw_point = declare(&keys.rmw_point, Encoding::APPLICATION_CDR)?;
        let gid = session.zid().to_le_bytes();
        Ok(Publishers {
            session,
            json,
            binary,
            bridge_point,
            rmw_point,
            camera_field: format!(",\"camera\":\"{}\"", keys.camera),
            gid,
        })
    }

    /// Publishes every report the queue delivers until the tracking side hangs up, then
    /// closes the session.
    pub fn run(self, reports: Receiver<FrameReport>, counters: &Counters) {
        let mut line = Vec::with_capacity(LINE_BYTES);
        let mut ros_sequence = 0i64;
        for report in reports {
            let unix_us = capture_unix_us(&report);
            let mut ok = self.put_json(&mut line, &report, unix_us);
            ok &= self.put_binary(&report, unix_us);
            if let Some(FloorFix::Mapped(f)) = report.floor {
                let scale = metres_per_unit(f.unit);
                let point = ros::point_stamped(f.position.x * scale, f.position.y * scale, unix_us);
                ros_sequence += 1;
                ok &= self.put_points(&point, ros_sequence, unix_us);
            }
            let counter = if ok { &counters.sent } else { &counters.failed };
            counter.fetch_add(1, Ordering::Relaxed);
            // For the status line: whether anyone listens (a peer that went away, or an
            // endpoint nobody serves, shows there rather than in Zenoh's own log).
            let subscribed = self
                .json
                .matching_status()
                .wait()
                .is_ok_and(|m| m.matching());
            counters.subscribed.store(subscribed, Ordering::Relaxed);
        }
        if let Err(e) = self.session.close().wait() {
            log::warn!("publish: closing the zenoh session: {e}");
        }
    }

    /// glint's JSON line, without its newline, with `camera` and `unix_us` added.
    fn put_json(&self, line: &mut Vec<u8>, report: &FrameReport, unix_us: u64) -> bool {
        line.clear();
        if JsonLinesSink::new(&mut *line, false).write(report).is_err() {
            return false;
        }
        // The line ends "}\n": reopen the object to add the fields.
        line.truncate(line.len().saturating_sub(2));
        line.extend_from_slice(self.camera_field.as_bytes());
        line.extend_from_slice(format!(",\"unix_us\":{unix_us}}}").as_bytes());
        self.json.put(line.as_slice()).wait().is_ok()
    }

    fn put_binary(&self, report: &FrameReport, unix_us: u64) -> bool {
        let mut buf = [0u8; wire::MAX_BYTES];
        match WireReport::new(report, unix_us).encode(&mut buf) {
            Ok(bytes) => self.binary.put(bytes).wait().is_ok(),
            Err(_) => false,
        }
    }

    fn put_points(&self, point: &[u8; POINT_STAMPED_BYTES], sequence: i64, unix_us: u64) -> bool {
        let bridged = self.bridge_point.put(point.as_slice()).wait().is_ok();
        let attachment = ros::attachment(sequence, unix_us, &self.gid);
        let rmw = self
            .rmw_point
            .put(point.as_slice())
            .attachment(attachment.as_slice())
            .wait()
            .is_ok();
        bridged && rmw
    }
}

/// A Zenoh session in peer mode (see `zenoh_config`); the subscriber opens its own the same
/// way.
pub fn open_session(connect: &[String], listen: &[String]) -> Result<Session, PublishError> {
    zenoh::open(zenoh_config(connect, listen)?)
        .wait()
        .map_err(|e| PublishError::Open(e.to_string()))
}

/// Zenoh's configuration: peer mode, and with endpoints given, exactly those links and no
/// multicast scouting; without, Zenoh's defaults (scouting, a listener on a free TCP port).
fn zenoh_config(connect: &[String], listen: &[String]) -> Result<Config, PublishError> {
    for endpoint in connect.iter().chain(listen) {
        check_endpoint(endpoint)?;
    }
    let mut zenoh = Config::default();
    let mut set = |key: &str, value: String| {
        zenoh
            .insert_json5(key, &value)
            .map_err(|e| PublishError::Config(format!("{key} = {value}: {e}")))
    };
    set("mode", "\"peer\"".into())?;
    if !connect.is_empty() || !listen.is_empty() {
        set("scouting/multicast/enabled", "false".into())?;
        set("connect/endpoints", json_list(connect))?;
        set("listen/endpoints", json_list(listen))?;
    }
    Ok(zenoh)
}

/// An endpoint this build can use: `tcp/` and an address with a port, which Zenoh then parses
/// (its own message names source files; this one names the form).
fn check_endpoint(endpoint: &str) -> Result<(), PublishError> {
    let address = endpoint.strip_prefix("tcp/").unwrap_or_default();
    let port = address.rsplit_once(':').map(|(_, port)| port);
    let host_ok = address
        .split_once(':')
        .is_some_and(|(host, _)| !host.is_empty());
    match port.map(str::parse::<u16>) {
        Some(Ok(_)) if host_ok && endpoint.parse::<EndPoint>().is_ok() => Ok(()),
        _ => Err(PublishError::Endpoint(endpoint.to_owned())),
    }
}

fn json_list(items: &[String]) -> String {
    serde_json::to_string(items).unwrap_or_else(|_| "[]".into())
}

/// The report's capture time on the wall clock: now, less how long ago on the monotonic clock
/// the frame was captured (for a file, read).
fn capture_unix_us(report: &FrameReport) -> u64 {
    let age_us = monotonic_now_us().saturating_sub(report.meta.monotonic_us);
    let now_us = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| u64::try_from(d.as_micros()).unwrap_or(u64::MAX))
        .unwrap_or(0);
    now_us.saturating_sub(age_us)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::net::Keys;

    #[test]
    fn endpoints_replace_scouting_and_a_bad_one_is_refused() {
        let mut config = PublishConfig {
            keys: Keys::new("glint", "cam", 0).unwrap(),
            connect: vec!["tcp/127.0.0.1:7447".into()],
            listen: Vec::new(),
        };
        let zenoh = zenoh_config(&config.connect, &config.listen).unwrap();
        assert_eq!(
            zenoh.get_json("scouting/multicast/enabled").unwrap(),
            "false"
        );
        assert_eq!(zenoh.get_json("listen/endpoints").unwrap(), "[]");
        for bad in [
            "nonsense",
            "udp/1.2.3.4:5",
            "tcp/1.2.3.4",
            "tcp/:7447",
            "tcp/h:99999",
        ] {
            config.connect = vec![bad.into()];
            let e = zenoh_config(&config.connect, &config.listen)
                .unwrap_err()
                .to_string();
            assert!(
                e.starts_with(&format!("endpoint {bad:?}: write tcp/")),
                "{e}"
            );
        }
        for good in ["tcp/[::1]:7447", "tcp/0.0.0.0:0", "tcp/pi.local:7447"] {
            config.listen = vec![good.into()];
            config.connect = Vec::new();
            assert!(
                zenoh_config(&config.connect, &config.listen).is_ok(),
                "{good}"
            );
        }
    }
}
