//! `glint fuse --subscribe KEY`: the cameras' JSON lines live over Zenoh
//! (`glint::net::subscriber`), fused as they arrive.
//!
//! Each line names its camera (`camera`, else its key's last chunk) and its capture time on
//! the wall clock (`unix_us`, which `--publish` adds): the cameras' clocks are assumed synced
//! (NTP/PTP), and their own `t` restarts per camera, so `unix_us` is the time fused on.
//!
//! Lines of different cameras arrive in any order within the network's delay, while the
//! fuser takes them in capture-time order (a report earlier than a step already written is
//! left out). So arrivals are held for [`HOLD_US`] of capture time, in order, before they are
//! fused: a camera up to that far behind the others loses nothing. When nothing arrives for as
//! long, what is held is fused at once.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::RecvTimeoutError;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use serde::Deserialize;

use glint::fuse::{FuseConfig, Fuser};
use glint::net::subscriber::{Message, Subscription};

use super::fuse::{Emitter, FuseArgs, Fused, BAD_LINES_SHOWN, MAX_CAMERAS};
use super::logger;
use super::signals::stop_on_signals;

/// How long a line is held (µs of capture time) before it is fused.
const HOLD_US: i64 = 100_000;
/// How often the stop flag and the deadline are checked when nothing arrives.
const POLL: Duration = Duration::from_millis(20);

/// The fields `--publish` adds to a camera's line.
#[derive(Debug, Deserialize)]
struct Envelope {
    camera: Option<String>,
    unix_us: Option<u64>,
}

/// A line waiting its turn: capture time, arrival order, camera, the line.
type Held = Reverse<(i64, u64, usize, String)>;

/// The live state: the cameras seen so far and what each sent that was not used.
struct Cameras {
    names: Vec<String>,
    bad: Vec<u64>,
    refused: Vec<u64>,
    /// Lines of cameras beyond [`MAX_CAMERAS`], left out.
    beyond: u64,
    /// Lines whose camera could not be told, left out.
    unnamed: u64,
}

impl Cameras {
    /// The camera's index, seen now for the first time or before; `None` past the limit.
    fn index(&mut self, name: &str) -> Option<usize> {
        if let Some(k) = self.names.iter().position(|n| n == name) {
            return Some(k);
        }
        if self.names.len() >= MAX_CAMERAS {
            self.beyond += 1;
            if self.beyond == 1 {
                log::warn!(
                    "camera {name:?}: more than the {MAX_CAMERAS} cameras glint fuse takes, \
                     its lines left out"
                );
            }
            return None;
        }
        log::info!("camera {name} reports");
        self.names.push(name.to_owned());
        self.bad.push(0);
        self.refused.push(0);
        Some(self.names.len() - 1)
    }

    /// Counts a bad line of camera `k`, and shows the first few.
    fn bad_line(&mut self, k: usize, why: &dyn std::fmt::Display) {
        if let Some(n) = self.bad.get_mut(k) {
            *n += 1;
            if *n <= BAD_LINES_SHOWN {
                let name = self.names.get(k).map_or("?", String::as_str);
                log::warn!("camera {name}: {why}, skipped");
            }
        }
    }
}

/// Subscribes on `session` and fuses until a signal, `--seconds`, or a write error.
pub fn run(
    args: &FuseArgs,
    config: FuseConfig,
    session: &zenoh::Session,
    emitter: &mut Emitter,
) -> Result<Fused> {
    let key = args.subscribe.as_deref().unwrap_or_default();
    let stop = Arc::new(AtomicBool::new(false));
    stop_on_signals(&stop)?;
    let (subscription, messages) =
        Subscription::on(session, key).with_context(|| format!("--subscribe {key}"))?;
    logger::write_line(format_args!("glint: fuse: subscribed to {key}/*"));
    let deadline = args
        .seconds
        .map(|s| Instant::now() + Duration::from_secs_f64(s));
    let mut fuser = Fuser::new(MAX_CAMERAS, config);
    let mut cameras = Cameras {
        names: Vec::new(),
        bad: Vec::new(),
        refused: Vec::new(),
        beyond: 0,
        unnamed: 0,
    };
    let mut held: BinaryHeap<Held> = BinaryHeap::new();
    let mut arrivals = 0u64;
    let mut newest_us = i64::MIN;
    let mut last_arrival = Instant::now();
    while !stop.load(Ordering::Relaxed)
        && deadline.is_none_or(|d| Instant::now() < d)
        && emitter.error.is_none()
    {
        match messages.recv_timeout(POLL) {
            Ok(message) => {
                last_arrival = Instant::now();
                if let Some((capture_us, camera)) = admit(&message, &mut cameras) {
                    arrivals += 1;
                    newest_us = newest_us.max(capture_us);
                    held.push(Reverse((capture_us, arrivals, camera, message.line)));
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
        let quiet = last_arrival.elapsed() >= Duration::from_micros(HOLD_US as u64);
        while let Some(Reverse((capture_us, ..))) = held.peek() {
            if !quiet && *capture_us > newest_us.saturating_sub(HOLD_US) {
                break;
            }
            if let Some(Reverse(line)) = held.pop() {
                fuse(&mut fuser, &mut cameras, line, emitter);
            }
        }
    }
    while let Some(Reverse(line)) = held.pop() {
        fuse(&mut fuser, &mut cameras, line, emitter);
    }
    let names = &cameras.names;
    fuser.finish(&mut |step| emitter.emit(step, names));
    let (received, dropped, not_text) = subscription.counts();
    subscription.close();
    logger::write_line(format_args!(
        "glint: fuse: {received} lines received, {dropped} dropped by a full queue, {not_text} \
         not text, {} of unknown cameras, {} beyond {MAX_CAMERAS} cameras",
        cameras.unnamed, cameras.beyond
    ));
    let origins = names.iter().map(|n| format!("{key}/{n}")).collect();
    Ok((fuser, cameras.names, origins, cameras.bad, cameras.refused))
}

/// The message's capture time and camera index, or `None` (counted) when it has none.
fn admit(message: &Message, cameras: &mut Cameras) -> Option<(i64, usize)> {
    let envelope = serde_json::from_str::<Envelope>(&message.line);
    let name = match &envelope {
        Ok(Envelope {
            camera: Some(name), ..
        }) if !name.is_empty() => name.as_str(),
        _ if !message.key_camera.is_empty() => message.key_camera.as_str(),
        _ => {
            cameras.unnamed += 1;
            return None;
        }
    };
    let k = cameras.index(name)?;
    match envelope {
        Err(e) => {
            cameras.bad_line(k, &format_args!("not a JSON report ({e})"));
            None
        }
        Ok(Envelope { unix_us: None, .. }) => {
            cameras.bad_line(
                k,
                &"a line without `unix_us` (not from glint --publish): no capture time on the \
                  shared clock",
            );
            None
        }
        Ok(Envelope {
            unix_us: Some(t), ..
        }) => match i64::try_from(t) {
            Ok(t) => Some((t, k)),
            Err(_) => {
                cameras.bad_line(k, &format_args!("`unix_us` {t} is not a time"));
                None
            }
        },
    }
}

/// Fuses one held line.
fn fuse(
    fuser: &mut Fuser,
    cameras: &mut Cameras,
    (capture_us, _, camera, line): (i64, u64, usize, String),
    emitter: &mut Emitter,
) {
    let names = &cameras.names;
    let pushed = fuser.push_line(camera, Some(capture_us), &line, &mut |step| {
        emitter.emit(step, names)
    });
    if let Err(e) = pushed {
        match e {
            glint::fuse::MessageError::Line(e) => cameras.bad_line(camera, &e),
            glint::fuse::MessageError::Push(e) => {
                if let Some(n) = cameras.refused.get_mut(camera) {
                    *n += 1;
                    if *n <= BAD_LINES_SHOWN {
                        let name = cameras.names.get(camera).map_or("?", String::as_str);
                        log::warn!("camera {name}: {e}");
                    }
                }
            }
        }
    }
}
