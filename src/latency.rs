//! `glint latency`: the whole loop's latency, measured by the robot's own LED.
//!
//! glint asks the robot over the serial link to switch its LED off (a protocol version 2 LED
//! request), at random moments, and watches for the first frame in which the LED is gone. The
//! time from the request to that frame covers the line time, the robot's reaction, the wait for
//! the next exposure, the exposure, the transfer from the camera and the processing.
//!
//! Times are on the frame clock (the positions' timestamps: the driver's clock for a camera):
//! the request's moment is the frame time at which its last byte left the host (the LED
//! request's `at_us`) plus the delay it asks the robot to wait, the dark frame's is the end of
//! its exposure; the delivery and processing of that frame are measured on the monotonic clock
//! from its capture (a camera, a stamped pipe) or arrival (a pipe) until it is read and until
//! the report is out. Each wait is bounded in frame time, so a robot that does not answer is
//! reported, never waited for.
//!
//! The first dark frame comes up to a frame period after the LED went dark: the wait for the
//! next exposure. Each request asks for a random delay within a frame period, so the moments
//! the LED goes dark fall at every phase of the frame clock, and the frames before and after
//! each bracket that moment; [`reaction_from_phases`] finds the moment the brackets share, the
//! latency without the wait.
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
    /// From the moment the robot was asked to switch its LED off (the request's last byte
    /// leaving the host, and the delay asked for) to the end of the first dark frame's
    /// exposure (frame clock), µs.
    pub to_capture_us: u64,
    /// From that moment to the end of the exposure of the last frame that still saw the LED,
    /// µs (negative when that exposure ended before): with `to_capture_us`, it brackets the
    /// moment the LED went dark.
    pub last_lit_us: Option<i64>,
    /// From that frame's capture to its delivery to glint (a camera's readout, transfer and
    /// driver; nil for a pipe without capture times), µs.
    pub delivery_us: u64,
    /// From that frame's capture (or arrival) to its report (monotonic clock), µs.
    pub processing_us: u64,
}

/// The moment the LED went dark after its request, found from the frames' phases: each answered
/// request brackets it between the last frame that saw the LED and the first that did not
/// (their exposures' middles). Requests ask for the LED to go dark at random moments of the frame
/// clock, so the brackets fall at every phase, and the moment inside all of them is the reaction
/// without the wait for the next exposure. A reaction that jitters leaves no moment inside all:
/// the estimate is then the moment nearest to the brackets in all (the least sum of distances
/// to them, zero inside one), a median of the reactions that a late answer or two cannot drag.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PhaseEstimate {
    /// From the moment the robot was asked for to the LED going dark, µs: the middle of the
    /// moments nearest to the brackets.
    pub reaction_us: i64,
    /// How wide that set of moments is, µs: with a steady reaction, the estimate is good to
    /// half of it.
    pub span_us: i64,
    /// Brackets holding the estimate, of `brackets`.
    pub agreeing: usize,
    /// Brackets there were (answered requests with a lit frame before the dark one).
    pub brackets: usize,
}

/// The [`PhaseEstimate`] of `measured`, with the frames' moments at their exposures' middles
/// (`exposure_us` before their ends; 0 takes the ends). `None` without a bracket.
pub fn reaction_from_phases(measured: &[Measurement], exposure_us: u64) -> Option<PhaseEstimate> {
    let half = i64::try_from(exposure_us / 2).unwrap_or(i64::MAX);
    let brackets: Vec<(i64, i64)> = measured
        .iter()
        .filter_map(|m| {
            let dark = i64::try_from(m.to_capture_us).ok()?;
            Some((
                m.last_lit_us?.saturating_sub(half),
                dark.saturating_sub(half),
            ))
        })
        .collect();
    // The sum of distances is convex and piecewise linear with its corners at the brackets'
    // ends: its least value is taken at ends, and between the outermost of them.
    let distance = |t: i64| -> i128 {
        brackets
            .iter()
            .map(|&(lo, hi)| i128::from((lo - t).max(0) + (t - hi).max(0)))
            .sum()
    };
    let ends = brackets.iter().flat_map(|&(lo, hi)| [lo, hi]);
    let least = ends.clone().map(distance).min()?;
    let nearest = ends.filter(|&t| distance(t) == least);
    let (lo, hi) = nearest.fold((i64::MAX, i64::MIN), |(a, b), t| (a.min(t), b.max(t)));
    let reaction_us = lo + (hi - lo) / 2;
    Some(PhaseEstimate {
        reaction_us,
        span_us: hi - lo,
        agreeing: brackets
            .iter()
            .filter(|&&(a, b)| a <= reaction_us && reaction_us <= b)
            .count(),
        brackets: brackets.len(),
    })
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

/// How long a frame took to reach glint and to be processed, monotonic clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FrameTimes {
    /// From its capture to its delivery, µs.
    pub delivery_us: u64,
    /// From its capture to its report, µs.
    pub processing_us: u64,
}

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
    Posted {
        request: u8,
        posted_at_us: u64,
        delay_us: u32,
    },
    /// Sent: waiting for the first dark frame after the moment asked for (frame time).
    Sent { asked_us: u64 },
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
    /// Frame time of the last frame that saw the LED.
    last_lit_at_us: Option<u64>,
    /// Frame time of the last frame, and the period before it.
    last_frame_us: Option<u64>,
    frame_period_us: Option<u64>,
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
            last_lit_at_us: None,
            last_frame_us: None,
            frame_period_us: None,
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

    /// The next random number (xorshift64*).
    fn random(&mut self) -> u64 {
        self.rng ^= self.rng >> 12;
        self.rng ^= self.rng << 25;
        self.rng ^= self.rng >> 27;
        self.rng.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// A random wait before the next request: between one and three off periods.
    fn random_gap_us(&mut self) -> u64 {
        let off = u64::from(self.config.off_us.max(1));
        off + self.random() % (2 * off)
    }

    /// The delay to ask the robot for, before it switches its LED off: random within a frame
    /// period. Requests go out just after a frame is processed, always at about the same phase
    /// of the frame clock (the camera's delay and the processing fix it); the delay spreads the
    /// moments the LED goes dark over every phase, so that the frames' phases can tell the
    /// reaction from the wait for the next exposure ([`reaction_from_phases`]).
    pub fn request_delay_us(&mut self) -> u32 {
        let period_us = self.frame_period_us.unwrap_or(0);
        if period_us == 0 {
            return 0;
        }
        u32::try_from(self.random() % period_us).unwrap_or(0)
    }

    /// Takes one processed frame: its time `t_us`, whether the LED was found, how long it took
    /// from capture to report, and the last LED request the link sent. After [`Step::Request`]
    /// the command posts a request and says so with [`LatencyTest::posted`].
    pub fn on_frame(
        &mut self,
        t_us: u64,
        found: bool,
        times: FrameTimes,
        sent: Option<SentLed>,
    ) -> Result<Step, LatencyError> {
        let step = self.step(t_us, found, times, sent);
        if found {
            self.last_lit_at_us = Some(t_us);
        }
        if let Some(before) = self.last_frame_us.replace(t_us) {
            self.frame_period_us = Some(t_us.saturating_sub(before)).filter(|&p| p > 0);
        }
        step
    }

    fn step(
        &mut self,
        t_us: u64,
        found: bool,
        times: FrameTimes,
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
                delay_us,
            } => {
                match sent.filter(|s| s.request == request) {
                    Some(sent) => {
                        let asked_us = sent.at_frame_us + u64::from(delay_us);
                        self.phase = Phase::Sent { asked_us };
                        // This very frame may already be the dark one.
                        return self.step(t_us, found, times, Some(sent));
                    }
                    // Never sent (the port is down, the line is stuck): unanswered.
                    None if t_us.saturating_sub(posted_at_us) > self.config.answer_us => {
                        return self.give_up();
                    }
                    None => {}
                }
                Ok(Step::Continue)
            }
            Phase::Sent { asked_us } => {
                if t_us >= asked_us && !found {
                    let since_request =
                        |at: u64| i64::try_from(i128::from(at) - i128::from(asked_us)).ok();
                    self.measurements.push(Measurement {
                        to_capture_us: t_us - asked_us,
                        last_lit_us: self.last_lit_at_us.and_then(since_request),
                        delivery_us: times.delivery_us,
                        processing_us: times.processing_us,
                    });
                    self.unanswered_in_a_row = 0;
                    self.phase = Phase::Dark { since_us: t_us };
                } else if t_us.saturating_sub(asked_us) > self.config.answer_us {
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

    /// Records that request number `request` was posted at frame time `t_us`, asking the robot
    /// to switch its LED off `delay_us` after it arrives.
    pub fn posted(&mut self, request: u8, t_us: u64, delay_us: u32) {
        self.requests += 1;
        self.phase = Phase::Posted {
            request,
            posted_at_us: t_us,
            delay_us,
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
            let times = FrameTimes {
                delivery_us: 700,
                processing_us: 1_000,
            };
            last = test.on_frame(t, found, times, sent);
            match last {
                Ok(Step::Request) => {
                    test.posted(request, t, 0);
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
                    last_lit_us: Some(18_000),
                    delivery_us: 700,
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
            last = test.on_frame(i * FRAME_US, false, FrameTimes::default(), None);
            if last.is_err() {
                break;
            }
        }
        assert!(matches!(last, Err(LatencyError::NoLed { .. })));
    }

    /// The brackets of a robot going dark `reaction_us` after each request, seen by frames every
    /// `FRAME_US` sampled at their exposure's middle, requests at phases spread over a frame.
    fn brackets(reaction_us: &[i64], exposure_us: i64) -> Vec<Measurement> {
        let frame = FRAME_US as i64;
        reaction_us
            .iter()
            .enumerate()
            .map(|(i, &r)| {
                // The request at phase p of the frame clock; frames end at multiples of FRAME_US.
                let p = (i as i64 * 3_700) % frame;
                let off = p + r;
                // The first frame whose exposure's middle is at or after the LED went dark.
                let dark_end = ((off + exposure_us / 2 + frame - 1) / frame) * frame;
                Measurement {
                    to_capture_us: (dark_end - p) as u64,
                    last_lit_us: Some(dark_end - frame - p),
                    delivery_us: 0,
                    processing_us: 0,
                }
            })
            .collect()
    }

    #[test]
    fn the_frames_phases_give_the_reaction_without_the_wait_for_the_next_exposure() {
        let exposure_us = 4_000;
        let constant = brackets(&[12_345; 30], exposure_us);
        let e = reaction_from_phases(&constant, exposure_us as u64).unwrap();
        assert_eq!((e.agreeing, e.brackets), (30, 30));
        assert!((e.reaction_us - 12_345).abs() <= e.span_us / 2 + 1, "{e:?}");
        assert!(e.span_us <= 1_000, "{e:?}");
        // The first dark frame alone is late by up to a frame (and by half the exposure).
        let mean_to_capture = constant.iter().map(|m| m.to_capture_us).sum::<u64>() / 30;
        assert!(mean_to_capture > 12_345 + 2_000, "{mean_to_capture}");

        // A reaction that jitters by ±1 ms, and two requests answered late: the most
        // brackets still share the moment.
        let mut jittery: Vec<i64> = (0..30)
            .map(|i| 20_000 + (i * 677) % 2_000 - 1_000)
            .collect();
        jittery[3] = 60_000;
        jittery[17] = 45_000;
        let e = reaction_from_phases(&brackets(&jittery, exposure_us), exposure_us as u64).unwrap();
        assert!((e.reaction_us - 20_000).abs() <= 1_000, "{e:?}");
        assert!(e.agreeing < 30 && e.agreeing >= 20, "{e:?}");

        // Without a lit frame before the dark one there is no bracket.
        let none = [Measurement {
            to_capture_us: 5_000,
            last_lit_us: None,
            delivery_us: 0,
            processing_us: 0,
        }];
        assert_eq!(reaction_from_phases(&none, 0), None);
    }

    #[test]
    fn the_delays_asked_for_spread_over_the_measured_frame_period() {
        let mut test = LatencyTest::new(config());
        assert_eq!(test.request_delay_us(), 0, "no frame period known yet");
        for i in 0..3 {
            let _ = test.on_frame(i * FRAME_US, true, FrameTimes::default(), None);
        }
        let delays: Vec<u32> = (0..200).map(|_| test.request_delay_us()).collect();
        assert!(
            delays.iter().all(|&d| u64::from(d) < FRAME_US),
            "{delays:?}"
        );
        let quarters = |q: u32| {
            delays
                .iter()
                .filter(|&&d| d * 4 / FRAME_US as u32 == q)
                .count()
        };
        assert!((0..4).all(|q| quarters(q) > 20), "{delays:?}");
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
