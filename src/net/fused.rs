//! Publishing `glint fuse`'s fused steps (`glint fuse --publish KEY`), on the session the fuser
//! opened (shared with `--subscribe`, so one `--zenoh-listen` serves both).
//!
//! | key expression | payload | encoding |
//! |---|---|---|
//! | `KEY/fused` | the fused JSON line (`crate::fuse::output`), without its newline | `application/json` |
//! | `KEY/fused/bin` | the compact binary form ([`WireFusedStep`]) | `application/octet-stream;glint.fused.1` |
//!
//! `fused` is no camera's name ([`super::keys`] refuses it), so a fuser subscribed to `KEY/*`
//! can tell the fused lines from the cameras' and leaves them out.
//!
//! # Threads
//!
//! As for a camera's reports ([`super::PublishSink`], through the same `outbox`): the
//! fusing thread hands each step's two forms to a bounded queue and returns; a full queue (a
//! slow network) drops the step and counts it; a thread of its own puts them on the session,
//! congestion control `block`. The fuser allocates per step anyway (see `crate::fuse`), so the
//! forms are built on its thread.
//!
//! # Binary form (version 1)
//!
//! postcard, as the report's binary form ([`super::wire`]): `version` (byte, 1), `t_us`
//! (varint, the step's capture time on the cameras' shared clock, µs), `unit` (byte: 0 mm,
//! 1 cm, 2 m, 3 in, 255 not named yet), then the tracks as a sequence (a varint count, then
//! each): `id` (varint), `found` (byte 0/1), `floor` (option of 2 × f32), `velocity` (option
//! of 2 × f32, units/s), `sigma` (option of f32, floor units), `cameras` (varint: how many
//! cameras contributed).

use std::sync::atomic::Ordering;
use std::sync::mpsc::Receiver;

use serde::{Deserialize, Serialize};
use zenoh::bytes::Encoding;
use zenoh::pubsub::Publisher;
use zenoh::qos::CongestionControl;
use zenoh::{Session, Wait};

use super::keys::{check_key, KeyError, FUSED_CHUNK};
use super::outbox::{Counters, Outbox};
use super::wire::unit_code;
use super::{PublishError, PublishStats};
use crate::fuse::{FusedStep, MAX_ROBOTS};

/// The schema named in the binary form's encoding.
pub const FUSED_SCHEMA: &str = "glint.fused.1";
/// The version of the binary form this module writes.
pub const FUSED_VERSION: u8 = 1;
/// The unit code of a step whose unit no report has named yet.
pub const UNIT_UNKNOWN: u8 = u8::MAX;
/// Longest binary form: version, `t_us`, unit, the count, and per track its longest encoding.
pub const MAX_FUSED_BYTES: usize = 1 + 10 + 1 + 5 + MAX_ROBOTS * (5 + 1 + 9 + 9 + 5 + 5);

/// The keys of the fused steps under `key`: JSON, binary.
pub fn fused_keys(key: &str) -> Result<(String, String), KeyError> {
    check_key(key)?;
    let json = format!("{key}/{FUSED_CHUNK}");
    let binary = format!("{json}/bin");
    Ok((json, binary))
}

/// One fused step in the binary form.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WireFusedStep {
    pub version: u8,
    pub t_us: u64,
    pub unit: u8,
    pub tracks: Vec<WireFusedTrack>,
}

/// One robot of a fused step in the binary form.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WireFusedTrack {
    pub id: u32,
    pub found: bool,
    pub floor: Option<(f32, f32)>,
    pub velocity: Option<(f32, f32)>,
    pub sigma: Option<f32>,
    pub cameras: u32,
}

impl WireFusedStep {
    /// The binary form of `step`.
    pub fn new(step: &FusedStep) -> WireFusedStep {
        WireFusedStep {
            version: FUSED_VERSION,
            t_us: u64::try_from(step.t_us).unwrap_or(0),
            unit: step.unit.map_or(UNIT_UNKNOWN, unit_code),
            tracks: step
                .tracks
                .iter()
                .map(|t| WireFusedTrack {
                    id: t.id,
                    found: t.found,
                    floor: t.floor.map(|p| (p.x as f32, p.y as f32)),
                    velocity: t.velocity.map(|v| (v.x as f32, v.y as f32)),
                    sigma: t.sigma.map(|s| s as f32),
                    cameras: u32::try_from(t.cameras.len()).unwrap_or(u32::MAX),
                })
                .collect(),
        }
    }

    /// Encodes into `out`, returning the bytes written.
    pub fn encode<'a>(&self, out: &'a mut [u8]) -> Result<&'a [u8], postcard::Error> {
        postcard::to_slice(self, out).map(|b| &*b)
    }
}

/// One step's forms, as queued.
struct Forms {
    json: Vec<u8>,
    binary: Vec<u8>,
}

/// The fusing thread's end of the fused steps' publisher.
pub struct FusedPublisher {
    outbox: Outbox<Forms>,
}

impl FusedPublisher {
    /// Declares the publishers of [`fused_keys`]`(key)` on `session` and starts the publisher
    /// thread.
    pub fn start(session: &Session, key: &str) -> Result<FusedPublisher, PublishError> {
        let (json_key, binary_key) =
            fused_keys(key).map_err(|e| PublishError::Open(e.to_string()))?;
        let declare = |key: String, encoding: Encoding| {
            session
                .declare_publisher(key.clone())
                .encoding(encoding)
                .congestion_control(CongestionControl::Block)
                .express(true)
                .wait()
                .map_err(|e| PublishError::Open(format!("publisher on {key}: {e}")))
        };
        let json = declare(json_key, Encoding::APPLICATION_JSON)?;
        let binary = declare(
            binary_key,
            Encoding::APPLICATION_OCTET_STREAM.with_schema(FUSED_SCHEMA),
        )?;
        let outbox = Outbox::start("glint-publish-fused", move |steps, counters| {
            run(&json, &binary, steps, counters)
        })
        .map_err(PublishError::Thread)?;
        Ok(FusedPublisher { outbox })
    }

    /// Queues one step: its JSON line (with or without its newline) and its binary form.
    /// Never waits: a full queue drops the step and counts it.
    pub fn publish(&mut self, json_line: &[u8], step: &FusedStep) {
        let mut buf = [0u8; MAX_FUSED_BYTES];
        let binary = match WireFusedStep::new(step).encode(&mut buf) {
            Ok(bytes) => bytes.to_vec(),
            // Cannot happen: the buffer holds the longest step of MAX_ROBOTS tracks.
            Err(_) => Vec::new(),
        };
        let json = json_line.strip_suffix(b"\n").unwrap_or(json_line).to_vec();
        self.outbox.offer(Forms { json, binary });
    }

    /// The counts so far; final once [`FusedPublisher::finish`] has returned.
    pub fn stats(&self) -> PublishStats {
        self.outbox.stats()
    }

    /// Lets the publisher thread send what is queued and waits for it.
    pub fn finish(&mut self) {
        self.outbox.close();
    }
}

/// The publisher thread: puts every queued step until the fuser hangs up.
fn run(
    json: &Publisher<'static>,
    binary: &Publisher<'static>,
    steps: Receiver<Forms>,
    counters: &Counters,
) {
    for forms in steps {
        let mut ok = json.put(forms.json).wait().is_ok();
        if !forms.binary.is_empty() {
            ok &= binary.put(forms.binary).wait().is_ok();
        }
        let counter = if ok { &counters.sent } else { &counters.failed };
        counter.fetch_add(1, Ordering::Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fuse::FusedTrack;
    use crate::geometry::{FloorUnit, Point};

    #[test]
    fn the_binary_form_is_laid_out_as_documented() {
        let step = FusedStep {
            t_us: 300,
            unit: Some(FloorUnit::Cm),
            tracks: vec![
                FusedTrack {
                    id: 1,
                    found: true,
                    floor: Some(Point::new(1.0, -2.0)),
                    velocity: None,
                    sigma: Some(0.5),
                    cameras: vec![(0, 0.25), (1, 0.75)],
                    head: true,
                },
                FusedTrack {
                    id: 2,
                    found: false,
                    floor: None,
                    velocity: None,
                    sigma: None,
                    cameras: Vec::new(),
                    head: false,
                },
            ],
        };
        let mut buf = [0u8; MAX_FUSED_BYTES];
        let bytes = WireFusedStep::new(&step).encode(&mut buf).unwrap();
        let mut expected = vec![1, 0xac, 0x02, 1, 2, 1, 1, 1];
        expected.extend(1.0f32.to_le_bytes());
        expected.extend((-2.0f32).to_le_bytes());
        expected.extend([0, 1]);
        expected.extend(0.5f32.to_le_bytes());
        expected.extend([2, 2, 0, 0, 0, 0, 0]);
        assert_eq!(bytes, expected.as_slice());
    }

    #[test]
    fn the_fused_keys_sit_beside_the_cameras() {
        assert_eq!(
            fused_keys("lab/glint").unwrap(),
            (
                "lab/glint/fused".to_owned(),
                "lab/glint/fused/bin".to_owned()
            )
        );
        assert!(fused_keys("lab/*").is_err());
    }
}
