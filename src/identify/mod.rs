//! Identification: which track is which robot, learned from the robot itself.
//!
//! Ids from continuity alone are only as good as the last time two tracks came close. With a
//! link to every robot, glint asks one robot at a time to switch its LED off for a few frames
//! (a [`BlinkRequest`], sent as the protocol's LED request) and watches which track goes dark in
//! exactly those frames (`observe`). That track is the robot: the slot is bound to its id.
//!
//! A binding holds until the picture can no longer vouch for it: its track is lost for
//! [`IdentifyConfig::lost_after_frames`] frames (whatever comes back may be another light), or
//! it comes within [`IdentifyConfig::close_px`] of another track (they may swap when they part).
//! Then the slot is unbound and identified again. Nothing is ever guessed: an attempt where no
//! track or several went dark, a watched track was lost or came close to another, or no frame
//! fell in the dark window, is retried; a robot that does not answer is asked again after a
//! back-off, and its track stays unbound. An unbound track has only a provisional id, and no
//! packet goes out under a robot's id for it.
//!
//! The core knows nothing of frames or sinks: per frame it takes the frame time and each track
//! slot's visibility and position, and answers with at most one LED request to send; the
//! bindings are read with [`Identifier::robot_of`].
//!
//! # Memory
//!
//! Fixed: one entry per track slot and per robot, `N` of each (a const generic). [`Identifier::step`]
//! allocates nothing.

mod observe;

use core::fmt;

use observe::{Observation, Verdict};

pub use crate::report::MAX_ROBOTS;

/// How identification asks and judges. Times are in µs of the frame clock (the clock of the
/// frames' capture timestamps, which the LED request's `at_us` also uses).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IdentifyConfig {
    /// Robots followed, ids 1..=`robots`.
    pub robots: u8,
    /// The robots with a link, bit `id − 1` per robot (all of them by default): only these are
    /// asked. A robot without one cannot answer; its track keeps a provisional id.
    pub linked: u32,
    /// The camera's frame period, until it is measured: identification counts in frames, and
    /// takes the period from the frames' own timestamps (the shortest of the last
    /// [`PERIOD_SAMPLES`] intervals: drops only lengthen an interval) once it has seen two.
    pub frame_period_us: u64,
    /// How far ahead of the request the LED goes off, in frames: the request must reach the
    /// robot first.
    pub lead_frames: u32,
    /// How long the LED stays off, in frames (F).
    pub off_frames: u32,
    /// The longest time from a frame's capture to the robot receiving a request sent on that
    /// frame (processing, queueing, line time, the robot's receive latency), in frames: the LED
    /// goes off between `lead` and `lead + send_allowance_frames` after the frame that asked.
    pub send_allowance_frames: u32,
    /// A bound track not seen for this many frames in a row is lost: whatever light it finds
    /// next is identified again.
    pub lost_after_frames: u32,
    /// Two visible tracks closer than this (px) may swap ids when they part: both are unbound,
    /// and neither is watched during an attempt.
    pub close_px: f32,
    /// Failed attempts on one robot in a row before it is left alone for `backoff_frames`.
    pub attempts_before_backoff: u32,
    /// How long a robot that did not answer is left alone, in frames.
    pub backoff_frames: u32,
}

impl IdentifyConfig {
    /// Defaults for `robots` robots at `frame_period_us`: the LED off for 5 frames, one frame
    /// ahead, with two frames allowed for the request to arrive (so 2 to 3 frames are surely
    /// dark); a track lost for 3 frames, or within 24 px of another, is identified again.
    pub fn new(robots: u8, frame_period_us: u64) -> Self {
        IdentifyConfig {
            robots,
            linked: u32::MAX,
            frame_period_us,
            lead_frames: 1,
            off_frames: 5,
            send_allowance_frames: 2,
            lost_after_frames: 3,
            close_px: 24.0,
            attempts_before_backoff: 3,
            backoff_frames: 60,
        }
    }

    /// The LED request's delay: `lead_frames` frame periods.
    pub fn delay_us(&self) -> u64 {
        self.frame_period_us
            .saturating_mul(u64::from(self.lead_frames))
    }

    /// The LED request's off time: `off_frames` frame periods.
    pub fn off_us(&self) -> u64 {
        self.frame_period_us
            .saturating_mul(u64::from(self.off_frames))
    }

    /// The send allowance: `send_allowance_frames` frame periods.
    pub fn send_allowance_us(&self) -> u64 {
        self.frame_period_us
            .saturating_mul(u64::from(self.send_allowance_frames))
    }
}

/// Frame intervals the period is measured over.
pub const PERIOD_SAMPLES: usize = 16;

/// The frame period, from the frames' timestamps.
#[derive(Debug, Clone, Copy)]
struct Period {
    last_us: Option<u64>,
    intervals_us: [u64; PERIOD_SAMPLES],
    next: usize,
}

impl Period {
    fn new() -> Self {
        Period {
            last_us: None,
            intervals_us: [0; PERIOD_SAMPLES],
            next: 0,
        }
    }

    fn frame(&mut self, now_us: u64) {
        if let Some(interval_us) = self.last_us.and_then(|last| now_us.checked_sub(last)) {
            if interval_us > 0 {
                if let Some(slot) = self.intervals_us.get_mut(self.next) {
                    *slot = interval_us;
                }
                self.next = (self.next + 1) % PERIOD_SAMPLES;
            }
        }
        self.last_us = Some(now_us);
    }

    /// The shortest interval seen lately, or `guess_us` before any.
    fn us(&self, guess_us: u64) -> u64 {
        self.intervals_us
            .iter()
            .copied()
            .filter(|&i| i > 0)
            .min()
            .unwrap_or(guess_us)
    }
}

/// Why an [`IdentifyConfig`] cannot work.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum IdentifyError {
    /// No robots, or more than the track table holds.
    Robots {
        /// Robots asked for.
        robots: u8,
        /// What the table holds.
        max: usize,
    },
    /// A frame period of 0.
    FramePeriod,
    /// The off time leaves no frame that is surely dark: it must cover the send allowance and
    /// two frame periods (a frame's exposure at each end).
    OffTooShort {
        /// The off time asked for.
        off_us: u64,
        /// The least that leaves one surely dark frame.
        needed_us: u64,
    },
    /// The delay or off time does not fit the LED request's 32-bit fields.
    TooLong,
}

impl fmt::Display for IdentifyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            IdentifyError::Robots { robots, max } => {
                write!(f, "identification needs 1 to {max} robots, not {robots}")
            }
            IdentifyError::FramePeriod => write!(f, "identification needs a frame period above 0"),
            IdentifyError::OffTooShort { off_us, needed_us } => write!(
                f,
                "a LED off for {off_us} µs leaves no frame surely dark: it needs at least \
                 {needed_us} µs (the send allowance and two frame periods)"
            ),
            IdentifyError::TooLong => {
                write!(f, "the LED request's delay or off time exceeds 2³² µs")
            }
        }
    }
}

impl std::error::Error for IdentifyError {}

/// One track slot as the tracker sees it in this frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TrackSeen {
    /// Its light was found in this frame.
    pub visible: bool,
    /// Where, in image pixels (meaningful when visible).
    pub x_px: f32,
    /// Where, in image pixels.
    pub y_px: f32,
}

/// "Robot `robot`, switch your LED off for `off_us`, `delay_us` from now": what to send, as the
/// protocol's LED request, on the frame that asked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BlinkRequest {
    /// The robot asked, 1..=robots.
    pub robot: u8,
    /// How long after the request arrives the LED goes off.
    pub delay_us: u32,
    /// How long it stays off.
    pub off_us: u32,
}

/// Why an attempt was not conclusive; it is retried.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Inconclusive {
    /// No watched track went dark (the robot did not answer, or its light is out of view).
    NoneWentDark,
    /// More than one watched track went dark.
    SeveralWentDark,
    /// A watched track was missing outside the dark frames, or stayed dark after them, or came
    /// close to another: the picture changed under the test.
    Disturbed,
    /// No frame fell in the window where the LED is surely off (frames dropped).
    NoDarkFrame,
}

impl Inconclusive {
    /// A short name for logs.
    pub fn name(self) -> &'static str {
        match self {
            Inconclusive::NoneWentDark => "none went dark",
            Inconclusive::SeveralWentDark => "several went dark",
            Inconclusive::Disturbed => "a watched track changed",
            Inconclusive::NoDarkFrame => "no frame in the dark window",
        }
    }
}

/// What one frame's step concluded, besides any request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Robot `robot` is the track in `slot`.
    Bound {
        /// The track slot.
        slot: usize,
        /// The robot id.
        robot: u8,
    },
    /// The attempt on `robot` told nothing; it will be asked again.
    Retry {
        /// The robot asked.
        robot: u8,
        /// Why.
        why: Inconclusive,
    },
}

/// What [`Identifier::step`] asks of the caller for one frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Step {
    /// A LED request to send now.
    pub request: Option<BlinkRequest>,
    /// An attempt that ended on this frame.
    pub outcome: Option<Outcome>,
}

/// Counts since start-up, for the log.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct IdentifyStats {
    /// LED requests asked for.
    pub requests: u64,
    /// Attempts that bound a robot.
    pub bound: u64,
    /// Attempts retried, for any [`Inconclusive`] reason.
    pub retried: u64,
    /// Bindings dropped because their track was lost or came close to another.
    pub unbound: u64,
}

/// One track slot's identification state.
#[derive(Debug, Clone, Copy, Default)]
struct Slot {
    robot: Option<u8>,
    /// Frames in a row this slot was not visible.
    unseen_frames: u32,
}

/// One robot's identification state.
#[derive(Debug, Clone, Copy, Default)]
struct Robot {
    /// Failed attempts in a row.
    failures: u32,
    /// Not asked before this frame time (back-off).
    resume_at_us: u64,
}

/// The identification state machine for up to `N` track slots and `N` robots.
#[derive(Debug)]
pub struct Identifier<const N: usize> {
    config: IdentifyConfig,
    slots: [Slot; N],
    robots: [Robot; N],
    /// The robot asked next, round robin over unbound ones (index: id − 1).
    next_robot: usize,
    asking: Option<Observation<N>>,
    period: Period,
    stats: IdentifyStats,
}

impl<const N: usize> Identifier<N> {
    /// Checks `config` and starts with every track unbound.
    pub fn new(config: IdentifyConfig) -> Result<Self, IdentifyError> {
        if config.robots == 0 || usize::from(config.robots) > N {
            return Err(IdentifyError::Robots {
                robots: config.robots,
                max: N,
            });
        }
        if config.frame_period_us == 0 {
            return Err(IdentifyError::FramePeriod);
        }
        let needed_us = config
            .send_allowance_us()
            .saturating_add(config.frame_period_us.saturating_mul(2));
        if config.off_us() < needed_us {
            return Err(IdentifyError::OffTooShort {
                off_us: config.off_us(),
                needed_us,
            });
        }
        if u32::try_from(config.delay_us()).is_err() || u32::try_from(config.off_us()).is_err() {
            return Err(IdentifyError::TooLong);
        }
        Ok(Identifier {
            config,
            slots: [Slot::default(); N],
            robots: [Robot::default(); N],
            next_robot: 0,
            asking: None,
            period: Period::new(),
            stats: IdentifyStats::default(),
        })
    }

    /// The robot bound to track `slot`, if any; `None` means the track's id is provisional.
    pub fn robot_of(&self, slot: usize) -> Option<u8> {
        self.slots.get(slot).and_then(|s| s.robot)
    }

    /// The track slot robot `robot` is bound to, if any.
    pub fn slot_of(&self, robot: u8) -> Option<usize> {
        self.slots.iter().position(|s| s.robot == Some(robot))
    }

    /// The robot being asked now, if an attempt is under way.
    pub fn asking(&self) -> Option<u8> {
        self.asking.as_ref().map(Observation::robot)
    }

    /// Counts since start-up.
    pub fn stats(&self) -> IdentifyStats {
        self.stats
    }

    /// One frame: `now_us` its capture time, `tracks` the slots as the tracker has them (slots
    /// past the end are not visible; past `N` are ignored). Updates the bindings and says what
    /// to send.
    pub fn step(&mut self, now_us: u64, tracks: &[TrackSeen]) -> Step {
        self.period.frame(now_us);
        let seen = |slot: usize| tracks.get(slot).copied().unwrap_or_default();
        let close = self.close_pairs(tracks);
        self.drop_doubtful_bindings(tracks, &close);

        let mut step = Step::default();
        if let Some(observation) = self.asking.as_mut() {
            match observation.frame(now_us, &seen, &close) {
                Verdict::Watching => return step,
                Verdict::Dark(slot) => {
                    let robot = observation.robot();
                    self.bind(slot, robot);
                    step.outcome = Some(Outcome::Bound { slot, robot });
                }
                Verdict::Inconclusive(why) => {
                    let robot = observation.robot();
                    self.failed(robot, now_us);
                    step.outcome = Some(Outcome::Retry { robot, why });
                }
            }
            self.asking = None;
        }
        step.request = self.ask(now_us, &seen, &close);
        step
    }

    /// For each slot, whether it is visible and within `close_px` of another visible slot.
    fn close_pairs(&self, tracks: &[TrackSeen]) -> [bool; N] {
        let mut close = [false; N];
        let limit_sq = self.config.close_px * self.config.close_px;
        for (i, a) in tracks.iter().enumerate().take(N) {
            for (j, b) in tracks.iter().enumerate().take(N).skip(i + 1) {
                let (dx, dy) = (a.x_px - b.x_px, a.y_px - b.y_px);
                if a.visible && b.visible && dx * dx + dy * dy < limit_sq {
                    if let Some(c) = close.get_mut(i) {
                        *c = true;
                    }
                    if let Some(c) = close.get_mut(j) {
                        *c = true;
                    }
                }
            }
        }
        close
    }

    /// Unbinds slots whose track came close to another, or came back after being lost.
    fn drop_doubtful_bindings(&mut self, tracks: &[TrackSeen], close: &[bool; N]) {
        for (slot, state) in self.slots.iter_mut().enumerate() {
            let visible = tracks.get(slot).is_some_and(|t| t.visible);
            let lost = state.unseen_frames >= self.config.lost_after_frames;
            let near = close.get(slot).copied().unwrap_or(false);
            if state.robot.is_some() && ((visible && lost) || near) {
                state.robot = None;
                self.stats.unbound += 1;
            }
            state.unseen_frames = if visible {
                0
            } else {
                state.unseen_frames.saturating_add(1)
            };
        }
    }

    fn bind(&mut self, slot: usize, robot: u8) {
        // A robot is one track: the slot it was bound to before (none, as only unbound robots
        // are asked) and the robot this slot was bound to lose their binding.
        for s in self.slots.iter_mut() {
            if s.robot == Some(robot) {
                s.robot = None;
            }
        }
        if let Some(s) = self.slots.get_mut(slot) {
            s.robot = Some(robot);
        }
        if let Some(r) = robot_index(robot).and_then(|i| self.robots.get_mut(i)) {
            r.failures = 0;
        }
        self.stats.bound += 1;
    }

    fn failed(&mut self, robot: u8, now_us: u64) {
        self.stats.retried += 1;
        let backoff_us = self
            .measured()
            .frame_period_us
            .saturating_mul(u64::from(self.config.backoff_frames));
        if let Some(r) = robot_index(robot).and_then(|i| self.robots.get_mut(i)) {
            r.failures += 1;
            if r.failures >= self.config.attempts_before_backoff {
                r.failures = 0;
                r.resume_at_us = now_us.saturating_add(backoff_us);
            }
        }
    }

    /// Starts an attempt if a visible track, apart from the others, has no robot, and an
    /// unbound robot may be asked.
    fn ask(
        &mut self,
        now_us: u64,
        seen: &impl Fn(usize) -> TrackSeen,
        close: &[bool; N],
    ) -> Option<BlinkRequest> {
        let watchable =
            |slot: usize| seen(slot).visible && !close.get(slot).copied().unwrap_or(true);
        let waiting = (0..N).any(|slot| watchable(slot) && self.robot_of(slot).is_none());
        if !waiting {
            return None;
        }
        let robots = usize::from(self.config.robots);
        let robot = (0..robots)
            .map(|k| (self.next_robot + k) % robots)
            .find(|&i| {
                let id = (i + 1) as u8;
                let linked = u32::try_from(i)
                    .ok()
                    .and_then(|bit| 1u32.checked_shl(bit))
                    .is_some_and(|mask| self.config.linked & mask != 0);
                linked
                    && self.slot_of(id).is_none()
                    && self.robots.get(i).is_some_and(|r| r.resume_at_us <= now_us)
            })?;
        self.next_robot = (robot + 1) % robots;
        let id = (robot + 1) as u8;
        let mut watched = [false; N];
        for (slot, w) in watched.iter_mut().enumerate() {
            *w = watchable(slot);
        }
        let config = self.measured();
        self.asking = Some(Observation::new(id, now_us, &config, watched));
        self.stats.requests += 1;
        Some(BlinkRequest {
            robot: id,
            delay_us: u32::try_from(config.delay_us()).unwrap_or(u32::MAX),
            off_us: u32::try_from(config.off_us()).unwrap_or(u32::MAX),
        })
    }

    /// The configuration at the measured frame period.
    fn measured(&self) -> IdentifyConfig {
        IdentifyConfig {
            frame_period_us: self.period.us(self.config.frame_period_us),
            ..self.config
        }
    }
}

/// A robot's index in the per-robot table: its id − 1 (ids start at 1; 0 addresses every robot).
fn robot_index(robot: u8) -> Option<usize> {
    usize::from(robot).checked_sub(1)
}

#[cfg(test)]
mod tests;
