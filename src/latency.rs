//! `glint latency`: the whole loop's latency, measured by the robot's own LED.
//!
//! glint asks the robot over the serial link to switch its LED off (a protocol version 2 LED
//! request), at random moments, and watches for the first frame in which the LED is gone. The
//! time from the request to that frame covers the line time, the robot's reaction, the wait for
//! the next exposure, the exposure, the transfer from the camera and the processing.
//!
//! Times are on the frame clock (the positions' timestamps: the driver's clock for a camera):
//! the request's moment is the frame time at which its last byte left the host (the LED
//! request's `at_us`), the dark frame's is the end of its exposure; the processing of that frame
//! is measured on the monotonic clock from its capture (a camera) or arrival (a pipe) until the
//! report is out. Each wait is bounded in frame time, so a robot that does not answer is
//! reported, never waited for.
//!
//! The state machine here sees one frame at a time and says when to send a request; the command
//! (`src/cli/latency.rs`) owns the source, the pipeline and the serial link.

use core::fmt;

use crate::sink::serial::SentLed;

/// Consecutive frames with the LED in view before a request: a single frame could be a
/// reflection, and the dark frame must follow a lit one.
pub const LIT_FRAMES: u32 = 3;

/// Frame time without the LED at the start after which the test gives up.
pub const NO_LED_LIMIT_US: u64 = 3_000_000;

/// Requests unanswered in a row after which the robot is taken not to answer at all.
pub const UNANSWERED_IN_A_ROW: u32 = 3;

/// Settings of one run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LatencyConfig {
    /// Requests to send.
    pub trials: u32,
    /// How long the robot is asked to keep its LED off, µs.
    pub off_us: u32,
    /// How long after a request (frame time) a dark frame may come before the request counts
    /// as unanswered, µs.
    pub answer_us: u64,
    /// Seed of the random moments.
    pub seed: u64,
}

/// One answered request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Measurement {
    /// From the request's last byte leaving the host to the end of the first dark frame's
    /// exposure (frame clock), µs.
    pub to_capture_us: u64,
    /// From that frame's capture (or arrival) to its report (monotonic clock), µs.
    pub processing_us: u64,
}

/// Why the test could not finish.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LatencyError {
    /// The LED was not in view at the start.
    NoLed {
        /// Frame time waited, µs.
        waited_us: u64,
    },
    /// Several requests in a row went unanswered.
    NoAnswer {
        /// Requests unanswered in a row.
        requests: u32,
        /// Frame time waited for each, µs.
        answer_us: u64,
    },
    /// After going dark, the LED did not come back on.
    LedStayedOff {
        /// Frame time waited, µs.
        waited_us: u64,
    },
}

impl fmt::Display for LatencyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LatencyError::NoLed { waited_us } => write!(
                f,
                "no LED in view after {:.1} s of frames: point the camera at the robot",
                *waited_us as f64 * 1e-6
            ),
            LatencyError::NoAnswer {
                requests,
                answer_us,
            } => write!(
                f,
                "robot did not answer: its LED stayed on after {requests} requests in a row \
                 (waited {:.0} ms of frames for each); does its firmware know LED requests \
                 (protocol version 2), and is it listening on this port?",
                *answer_us as f64 * 1e-3
            ),
            LatencyError::LedStayedOff { waited_us } => write!(
                f,
                "the robot's LED did not come back on within {:.0} ms of frames",
                *waited_us as f64 * 1e-3
            ),
        }
    }
}

impl std::error::Error for LatencyError {}

/// What the command does after a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// Go on with the next frame.
    Continue,
    /// Send a LED request now, then go on.
    Request,
    /// Every request was sent and answered (or given up).
    Done,
}

/// Where the test stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// Waiting for the LED to be lit for [`LIT_FRAMES`], then for the random moment.
    Lit {
        lit_frames: u32,
        request_at_us: Option<u64>,
    },
    /// A request was posted; waiting for the writer to send it.
    Posted { request: u8, posted_at_us: u64 },
    /// Sent: waiting for the first dark frame after it.
    Sent { sent: SentLed },
    /// Answered: waiting for the LED to come back.
    Dark { since_us: u64 },
}

/// The test's state across frames.
#[derive(Debug)]
pub struct LatencyTest {
    config: LatencyConfig,
    phase: Phase,
    rng: u64,
    /// Frame time of the first frame seen.
    first_us: Option<u64>,
    /// Whether the LED has been seen at all.
    seen_led: bool,
    requests: u32,
    unanswered: u32,
    unanswered_in_a_row: u32,
    measurements: Vec<Measurement>,
}

impl LatencyTest {
    /// A test that will send `config.trials` requests.
    pub fn new(config: LatencyConfig) -> Self {
        LatencyTest {
            config,
            phase: Phase::Lit {
                lit_frames: 0,
                request_at_us: None,
            },
            rng: config.seed | 1,
            first_us: None,
            seen_led: false,
            requests: 0,
            unanswered: 0,
            unanswered_in_a_row: 0,
            measurements: Vec::with_capacity(config.trials as usize),
        }
    }

    /// The answered requests so far.
    pub fn measurements(&self) -> &[Measurement] {
        &self.measurements
    }

    /// Requests sent so far, and how many went unanswered.
    pub fn requests(&self) -> (u32, u32) {
        (self.requests, self.unanswered)
    }

    /// A random wait before the next request: between one and three off periods, so that
    /// requests fall at every phase of the frame clock.
    fn random_gap_us(&mut self) -> u64 {
        // xorshift64*
        self.rng ^= self.rng >> 12;
        self.rng ^= self.rng << 25;
        self.rng ^= self.rng >> 27;
        let r = self.rng.wrapping_mul(0x2545_F491_4F6C_DD1D);
        let off = u64::from(self.config.off_us.max(1));
        off + r % (2 * off)
    }

    /// Takes one processed frame: its time `t_us`, whether the LED was found, how long it took
    /// from capture to report, and the last LED request the link sent. After [`Step::Request`]
    /// the command posts a request and says so with [`LatencyTest::posted`].
    pub fn on_frame(
        &mut self,
        t_us: u64,
        found: bool,
        processing_us: u64,
        sent: Option<SentLed>,
    ) -> Result<Step, LatencyError> {
        let first_us = *self.first_us.get_or_insert(t_us);
        self.seen_led |= found;
        match self.phase {
            Phase::Lit {
                lit_frames,
                request_at_us,
            } => {
                if !self.seen_led && t_us.saturating_sub(first_us) > NO_LED_LIMIT_US {
                    return Err(LatencyError::NoLed {
                        waited_us: t_us - first_us,
                    });
                }
                let lit_frames = if found { lit_frames + 1 } else { 0 };
                let request_at_us = match request_at_us {
                    None if lit_frames >= LIT_FRAMES => Some(t_us + self.random_gap_us()),
                    other => other,
                };
                self.phase = Phase::Lit {
                    lit_frames,
                    request_at_us,
                };
                if self.requests >= self.config.trials {
                    return Ok(Step::Done);
                }
                if lit_frames >= LIT_FRAMES && request_at_us.is_some_and(|at| t_us >= at) {
                    return Ok(Step::Request);
                }
                Ok(Step::Continue)
            }
            Phase::Posted {
                request,
                posted_at_us,
            } => {
                match sent.filter(|s| s.request == request) {
                    Some(sent) => {
                        self.phase = Phase::Sent { sent };
                        // This very frame may already be the dark one.
                        return self.on_frame(t_us, found, processing_us, Some(sent));
                    }
                    // Never sent (the port is down, the line is stuck): unanswered.
                    None if t_us.saturating_sub(posted_at_us) > self.config.answer_us => {
                        return self.give_up();
                    }
                    None => {}
                }
                Ok(Step::Continue)
            }
            Phase::Sent { sent } => {
                if t_us >= sent.at_frame_us && !found {
                    self.measurements.push(Measurement {
                        to_capture_us: t_us - sent.at_frame_us,
                        processing_us,
                    });
                    self.unanswered_in_a_row = 0;
                    self.phase = Phase::Dark { since_us: t_us };
                } else if t_us.saturating_sub(sent.at_frame_us) > self.config.answer_us {
                    return self.give_up();
                }
                Ok(Step::Continue)
            }
            Phase::Dark { since_us } => {
                if found {
                    self.phase = Phase::Lit {
                        lit_frames: 1,
                        request_at_us: None,
                    };
                } else {
                    let limit_us = u64::from(self.config.off_us) + self.config.answer_us;
                    let waited_us = t_us.saturating_sub(since_us);
                    if waited_us > limit_us {
                        return Err(LatencyError::LedStayedOff { waited_us });
                    }
                }
                Ok(Step::Continue)
            }
        }
    }

    /// Records that request number `request` was posted at frame time `t_us`.
    pub fn posted(&mut self, request: u8, t_us: u64) {
        self.requests += 1;
        self.phase = Phase::Posted {
            request,
            posted_at_us: t_us,
        };
    }

    fn give_up(&mut self) -> Result<Step, LatencyError> {
        self.unanswered += 1;
        self.unanswered_in_a_row += 1;
        if self.unanswered_in_a_row >= UNANSWERED_IN_A_ROW {
            return Err(LatencyError::NoAnswer {
                requests: self.unanswered_in_a_row,
                answer_us: self.config.answer_us,
            });
        }
        self.phase = Phase::Lit {
            lit_frames: 0,
            request_at_us: None,
        };
        Ok(Step::Continue)
    }
}

/// The value at quantile `q` (0..=1) of `values` (sorted here), nearest rank.
pub fn quantile_us(values: &mut [u64], q: f64) -> u64 {
    values.sort_unstable();
    let rank = ((values.len() as f64 * q).ceil() as usize).saturating_sub(1);
    values
        .get(rank.min(values.len().saturating_sub(1)))
        .copied()
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    const FRAME_US: u64 = 10_000;

    fn config() -> LatencyConfig {
        LatencyConfig {
            trials: 3,
            off_us: 50_000,
            answer_us: 200_000,
            seed: 7,
        }
    }

    /// Runs the test against a robot that goes dark `reaction_us` after each request's
    /// `at_frame_us` for `off_us`, or never when `None`.
    fn run(reaction_us: Option<u64>, frames: u64) -> (LatencyTest, Result<Step, LatencyError>) {
        let mut test = LatencyTest::new(config());
        let mut sent: Option<SentLed> = None;
        let mut dark_from = u64::MAX;
        let mut request = 0u8;
        let mut last = Ok(Step::Continue);
        for i in 0..frames {
            let t = i * FRAME_US;
            let found = !(t >= dark_from && t < dark_from + 50_000);
            last = test.on_frame(t, found, 1_000, sent);
            match last {
                Ok(Step::Request) => {
                    test.posted(request, t);
                    // Sent 2 ms into the next frame interval.
                    let at = t + 2_000;
                    sent = Some(SentLed {
                        request,
                        at_frame_us: at,
                    });
                    if let Some(r) = reaction_us {
                        dark_from = at + r;
                    }
                    request = request.wrapping_add(1);
                }
                Ok(Step::Done) | Err(_) => break,
                Ok(Step::Continue) => {}
            }
        }
        (test, last)
    }

    #[test]
    fn every_request_is_measured_to_the_first_dark_frame() {
        let (test, last) = run(Some(25_000), 1_000);
        assert_eq!(last, Ok(Step::Done));
        assert_eq!(test.requests(), (3, 0));
        // Dark from at + 25 ms; frames every 10 ms, at 2 ms past a frame: the first dark
        // frame ends 28 ms after the request.
        for m in test.measurements() {
            assert_eq!(
                *m,
                Measurement {
                    to_capture_us: 28_000,
                    processing_us: 1_000
                }
            );
        }
        assert_eq!(test.measurements().len(), 3);
    }

    #[test]
    fn a_robot_that_never_answers_is_reported_within_the_bound() {
        let (test, last) = run(None, 10_000);
        assert_eq!(
            last,
            Err(LatencyError::NoAnswer {
                requests: UNANSWERED_IN_A_ROW,
                answer_us: 200_000
            })
        );
        assert!(test.measurements().is_empty());
        assert!(last
            .unwrap_err()
            .to_string()
            .starts_with("robot did not answer"));
    }

    #[test]
    fn no_led_at_the_start_is_an_error_not_a_wait() {
        let mut test = LatencyTest::new(config());
        let mut last = Ok(Step::Continue);
        for i in 0..1_000 {
            last = test.on_frame(i * FRAME_US, false, 0, None);
            if last.is_err() {
                break;
            }
        }
        assert!(matches!(last, Err(LatencyError::NoLed { .. })));
    }

    #[test]
    fn quantiles_by_nearest_rank() {
        let mut v = [5, 1, 4, 2, 3];
        assert_eq!(quantile_us(&mut v, 0.5), 3);
        assert_eq!(quantile_us(&mut v, 0.95), 5);
        assert_eq!(quantile_us(&mut v, 1.0), 5);
        assert_eq!(quantile_us(&mut [], 0.5), 0);
    }
}
