//! One attempt: the frames after a LED request, judged against when the LED is surely on and
//! surely off.
//!
//! The request goes out on the frame that asked, at `asked_us`. The robot switches off `delay`
//! after it receives the request, which is at most `send_allowance` after `asked_us`, so the LED
//! is off from somewhere in `[asked + delay, asked + delay + allowance]` for `off`. A frame's
//! timestamp is the end of its exposure, and an exposure lasts at most a frame period `P`, so:
//!
//! - frames with `t < asked + delay` saw the LED on: every watched track must be visible;
//! - frames with `asked + delay + allowance + P ≤ t ≤ asked + delay + off` saw it off throughout:
//!   the robot's track is dark in all of them, every other watched track visible;
//! - the first frame with `t ≥ asked + delay + allowance + off + P` saw it on again: every
//!   watched track visible, and the attempt is judged on it.
//!
//! Frames in between may have caught the switch mid-exposure and are not judged.

use super::{IdentifyConfig, Inconclusive, TrackSeen};

/// What a frame of an attempt concluded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Verdict {
    /// Not over yet.
    Watching,
    /// The robot is the track in this slot.
    Dark(usize),
    /// Nothing can be concluded.
    Inconclusive(Inconclusive),
}

/// An attempt under way on one robot.
#[derive(Debug, Clone, Copy)]
pub(super) struct Observation<const N: usize> {
    robot: u8,
    /// Before this, the LED is surely on.
    on_until_us: u64,
    /// From this to `dark_until_us` (inclusive), it is surely off.
    dark_from_us: u64,
    dark_until_us: u64,
    /// From this on, it is surely on again.
    on_again_us: u64,
    /// The tracks watched: visible, and apart from the others, when the robot was asked.
    watched: [bool; N],
    /// Per watched slot, the surely-dark frames it was not visible in.
    dark_frames: [u32; N],
    /// Per watched slot: missing where the LED was surely on, or close to another track.
    disturbed: [bool; N],
    /// Frames that fell in the surely-dark window.
    window_frames: u32,
}

impl<const N: usize> Observation<N> {
    pub(super) fn new(
        robot: u8,
        asked_us: u64,
        config: &IdentifyConfig,
        watched: [bool; N],
    ) -> Self {
        let off_from_us = asked_us.saturating_add(config.delay_us());
        let latest_off_us = off_from_us.saturating_add(config.send_allowance_us());
        Observation {
            robot,
            on_until_us: off_from_us,
            dark_from_us: latest_off_us.saturating_add(config.frame_period_us),
            dark_until_us: off_from_us.saturating_add(config.off_us()),
            on_again_us: latest_off_us
                .saturating_add(config.off_us())
                .saturating_add(config.frame_period_us),
            watched,
            dark_frames: [0; N],
            disturbed: [false; N],
            window_frames: 0,
        }
    }

    /// The robot asked.
    pub(super) fn robot(&self) -> u8 {
        self.robot
    }

    /// Takes one frame at `now_us`; `seen` gives each slot, `close` the slots near another.
    pub(super) fn frame(
        &mut self,
        now_us: u64,
        seen: &impl Fn(usize) -> TrackSeen,
        close: &[bool; N],
    ) -> Verdict {
        let in_window = (self.dark_from_us..=self.dark_until_us).contains(&now_us);
        let surely_on = now_us < self.on_until_us || now_us >= self.on_again_us;
        if in_window {
            self.window_frames += 1;
        }
        for slot in 0..N {
            if !self.watched.get(slot).copied().unwrap_or(false) {
                continue;
            }
            let visible = seen(slot).visible;
            if close.get(slot).copied().unwrap_or(false) || (surely_on && !visible) {
                if let Some(d) = self.disturbed.get_mut(slot) {
                    *d = true;
                }
            }
            if in_window && !visible {
                if let Some(d) = self.dark_frames.get_mut(slot) {
                    *d += 1;
                }
            }
        }
        if now_us < self.on_again_us {
            return Verdict::Watching;
        }
        self.judge()
    }

    /// The verdict once the LED is surely on again.
    fn judge(&self) -> Verdict {
        if self.window_frames == 0 {
            return Verdict::Inconclusive(Inconclusive::NoDarkFrame);
        }
        let mut dark = None;
        let mut dark_count = 0;
        for slot in 0..N {
            if !self.watched.get(slot).copied().unwrap_or(false) {
                continue;
            }
            let dark_frames = self.dark_frames.get(slot).copied().unwrap_or(0);
            if self.disturbed.get(slot).copied().unwrap_or(true) {
                return Verdict::Inconclusive(Inconclusive::Disturbed);
            }
            if dark_frames == self.window_frames {
                dark = Some(slot);
                dark_count += 1;
            } else if dark_frames > 0 {
                // Dark in some surely-dark frames only: not this robot's switch.
                return Verdict::Inconclusive(Inconclusive::Disturbed);
            }
        }
        match (dark, dark_count) {
            (Some(slot), 1) => Verdict::Dark(slot),
            (_, 0) => Verdict::Inconclusive(Inconclusive::NoneWentDark),
            _ => Verdict::Inconclusive(Inconclusive::SeveralWentDark),
        }
    }
}
