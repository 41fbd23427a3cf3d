//! The identification state machine against a small simulated arena: robots whose LEDs answer
//! LED requests after a latency, seen by a camera whose frames expose for a while before their
//! timestamp, in track slots the test arranges (and swaps, as a tracker might).

use super::*;

const P_US: u64 = 33_333;
const SLOTS: usize = 8;

/// One robot in the arena.
#[derive(Clone, Copy)]
struct SimRobot {
    /// The id its firmware answers to (0: it has no link, and never answers).
    answers_to: u8,
    /// Where it is.
    x_px: f32,
    y_px: f32,
    /// In view at all.
    in_view: bool,
    /// Its LED is off during [from, until).
    off: Option<(u64, u64)>,
}

impl SimRobot {
    fn at(answers_to: u8, x_px: f32) -> Self {
        SimRobot {
            answers_to,
            x_px,
            y_px: 100.0,
            in_view: true,
            off: None,
        }
    }

    /// Seen in a frame exposed over [t − exposure, t]: its LED was on for at least half of it.
    fn seen(&self, t_us: u64, exposure_us: u64) -> bool {
        if !self.in_view {
            return false;
        }
        let Some((from, until)) = self.off else {
            return true;
        };
        let start = t_us.saturating_sub(exposure_us);
        let overlap = t_us.min(until).saturating_sub(start.max(from));
        overlap * 2 < exposure_us.max(1)
    }
}

/// The arena, the camera, the link and the identifier.
struct Sim {
    id: Identifier<SLOTS>,
    robots: Vec<SimRobot>,
    /// Slot → index into `robots` (the tracker's assignment), or None for an empty slot.
    slots: Vec<Option<usize>>,
    /// Extra lights (glare) in slots: slot → position.
    glare: Vec<(usize, f32)>,
    now_us: u64,
    /// Time from the frame that asked to the robot's receipt of the request.
    latency_us: u64,
    exposure_us: u64,
    /// Every outcome, in order.
    outcomes: Vec<Outcome>,
    requests: Vec<BlinkRequest>,
    /// Frames the camera drops (not handed to the identifier).
    drop_frames: std::ops::Range<u64>,
    frame_no: u64,
    /// The camera's real frame period.
    period_us: u64,
}

impl Sim {
    fn new(config: IdentifyConfig, robots: Vec<SimRobot>, slots: Vec<Option<usize>>) -> Self {
        Sim {
            id: Identifier::new(config).expect("valid config"),
            robots,
            slots,
            glare: Vec::new(),
            now_us: 1_000_000,
            latency_us: 12_000,
            exposure_us: P_US,
            outcomes: Vec::new(),
            requests: Vec::new(),
            drop_frames: 0..0,
            frame_no: 0,
            period_us: P_US,
        }
    }

    fn tracks(&self) -> Vec<TrackSeen> {
        let mut tracks: Vec<TrackSeen> = self
            .slots
            .iter()
            .map(|r| match r {
                Some(i) => {
                    let robot = &self.robots[*i];
                    TrackSeen {
                        visible: robot.seen(self.now_us, self.exposure_us),
                        x_px: robot.x_px,
                        y_px: robot.y_px,
                    }
                }
                None => TrackSeen::default(),
            })
            .collect();
        for &(slot, x_px) in &self.glare {
            tracks[slot] = TrackSeen {
                visible: true,
                x_px,
                y_px: 300.0,
            };
        }
        tracks
    }

    /// Runs `frames` frames; every request goes out to every robot that answers to its id.
    fn run(&mut self, frames: u32) {
        for _ in 0..frames {
            self.now_us += self.period_us;
            self.frame_no += 1;
            if self.drop_frames.contains(&self.frame_no) {
                continue;
            }
            let tracks = self.tracks();
            let step = self.id.step(self.now_us, &tracks);
            self.outcomes.extend(step.outcome);
            if let Some(r) = step.request {
                self.requests.push(r);
                let arrives = self.now_us + self.latency_us;
                for robot in self.robots.iter_mut().filter(|x| x.answers_to == r.robot) {
                    let from = arrives + u64::from(r.delay_us);
                    robot.off = Some((from, from + u64::from(r.off_us)));
                }
            }
        }
    }

    /// The robot id bound to each slot.
    fn bindings(&self) -> Vec<Option<u8>> {
        (0..self.slots.len()).map(|s| self.id.robot_of(s)).collect()
    }

    /// No binding ever named a robot other than the one in the slot at that moment.
    fn assert_never_wrong(&self) {
        for (slot, robot) in self.bindings().iter().enumerate() {
            if let (Some(robot), Some(Some(i))) = (robot, self.slots.get(slot)) {
                assert_eq!(
                    self.robots[*i].answers_to, *robot,
                    "slot {slot} bound to robot {robot}"
                );
            }
        }
    }

    fn retries(&self, why: Inconclusive) -> usize {
        self.outcomes
            .iter()
            .filter(|o| matches!(o, Outcome::Retry { why: w, .. } if *w == why))
            .count()
    }
}

fn config(robots: u8) -> IdentifyConfig {
    IdentifyConfig::new(robots, P_US)
}

/// Frames one attempt takes, at the defaults, with a margin.
const ATTEMPT_FRAMES: u32 = 12;

#[test]
fn every_robot_is_identified_at_start_in_whatever_slot_it_is() {
    let robots = vec![
        SimRobot::at(1, 100.0),
        SimRobot::at(2, 200.0),
        SimRobot::at(3, 300.0),
    ];
    // The tracker's slots do not follow the robot ids.
    let mut sim = Sim::new(config(3), robots, vec![Some(2), Some(0), Some(1)]);
    assert_eq!(sim.bindings(), [None, None, None]);
    // Before a binding, the id is provisional; one attempt at a time.
    sim.run(1);
    assert_eq!(sim.requests.len(), 1);
    assert_eq!(sim.id.asking(), Some(1));
    sim.run(3 * ATTEMPT_FRAMES);
    assert_eq!(sim.bindings(), [Some(3), Some(1), Some(2)]);
    assert_eq!(
        sim.requests.len(),
        3,
        "one request per robot: {:?}",
        sim.requests
    );
    assert_eq!(sim.id.stats().retried, 0);
    // All bound: nothing more is asked.
    sim.run(100);
    assert_eq!(sim.requests.len(), 3);
    sim.assert_never_wrong();
}

#[test]
fn the_request_is_off_for_f_frames_after_a_lead() {
    let mut sim = Sim::new(config(1), vec![SimRobot::at(1, 10.0)], vec![Some(0)]);
    sim.run(1);
    assert_eq!(
        sim.requests,
        [BlinkRequest {
            robot: 1,
            delay_us: 33_333,
            off_us: 5 * 33_333
        }]
    );
}

#[test]
fn any_latency_within_the_allowance_and_any_exposure_identify_correctly() {
    let allowance_us = config(2).send_allowance_us();
    for latency_us in (0..=allowance_us).step_by(5_000) {
        for exposure_us in [1_000, 8_000, 16_000, P_US] {
            let robots = vec![SimRobot::at(1, 100.0), SimRobot::at(2, 400.0)];
            let mut sim = Sim::new(config(2), robots, vec![Some(1), Some(0)]);
            sim.latency_us = latency_us;
            sim.exposure_us = exposure_us;
            sim.run(2 * ATTEMPT_FRAMES);
            assert_eq!(
                sim.bindings(),
                [Some(2), Some(1)],
                "latency {latency_us} µs, exposure {exposure_us} µs: {:?}",
                sim.outcomes
            );
        }
    }
}

#[test]
fn a_request_slower_than_the_allowance_is_never_bound_wrongly() {
    // Arriving after the allowance, the dark window no longer covers the LED's off time: an
    // attempt may fail, but must never bind a robot to the wrong track.
    for latency_us in [80_000, 120_000, 200_000, 400_000] {
        let robots = vec![SimRobot::at(1, 100.0), SimRobot::at(2, 400.0)];
        let mut sim = Sim::new(config(2), robots, vec![Some(1), Some(0)]);
        sim.latency_us = latency_us;
        for _ in 0..40 {
            sim.run(1);
            sim.assert_never_wrong();
        }
    }
}

#[test]
fn a_robot_that_never_answers_stays_unbound_and_is_asked_again_after_a_back_off() {
    // Robot 2's firmware does not answer (it answers to no id): its track keeps a provisional
    // id; robots 1 and 3 are identified.
    let robots = vec![
        SimRobot::at(1, 100.0),
        SimRobot::at(0, 200.0),
        SimRobot::at(3, 300.0),
    ];
    let mut sim = Sim::new(config(3), robots, vec![Some(0), Some(1), Some(2)]);
    sim.run(12 * ATTEMPT_FRAMES);
    assert_eq!(sim.bindings(), [Some(1), None, Some(3)]);
    sim.assert_never_wrong();
    let asked_2 = sim.requests.iter().filter(|r| r.robot == 2).count();
    // Three attempts, then left alone for 60 frames, then three more...
    assert!(asked_2 >= 3, "asked robot 2 {asked_2} times");
    let pending = usize::from(sim.id.asking() == Some(2));
    assert_eq!(sim.retries(Inconclusive::NoneWentDark), asked_2 - pending);
    // ... so over a long run, far fewer attempts than back-to-back asking would make.
    let before = sim.requests.len();
    sim.run(600);
    let per_600 = sim.requests.len() - before;
    assert!(
        per_600 <= 3 * (600 / 60 + 1) as usize,
        "{per_600} requests in 600 frames"
    );
    assert!(per_600 >= 3, "the silent robot is still asked now and then");
    assert_eq!(sim.bindings(), [Some(1), None, Some(3)]);
}

#[test]
fn a_robot_without_a_link_is_never_asked() {
    // Robot 2 has no line: only robots 1 and 3 are asked; robot 2's track stays provisional.
    let robots = vec![
        SimRobot::at(1, 100.0),
        SimRobot::at(2, 200.0),
        SimRobot::at(3, 300.0),
    ];
    let config = IdentifyConfig {
        linked: 0b101,
        ..config(3)
    };
    let mut sim = Sim::new(config, robots, vec![Some(0), Some(1), Some(2)]);
    sim.run(300);
    assert_eq!(sim.bindings(), [Some(1), None, Some(3)]);
    assert!(
        sim.requests.iter().all(|r| r.robot != 2),
        "{:?}",
        sim.requests
    );
    assert_eq!(sim.requests.len(), 2);
}

#[test]
fn two_robots_answering_the_same_id_are_never_bound() {
    // A misconfigured pair: both answer to 1. Two tracks go dark: retried, never guessed.
    let robots = vec![SimRobot::at(1, 100.0), SimRobot::at(1, 300.0)];
    let mut sim = Sim::new(config(2), robots, vec![Some(0), Some(1)]);
    sim.run(10 * ATTEMPT_FRAMES);
    assert_eq!(sim.id.slot_of(1), None);
    assert!(
        sim.retries(Inconclusive::SeveralWentDark) >= 1,
        "{:?}",
        sim.outcomes
    );
}

#[test]
fn a_track_lost_during_the_attempt_makes_it_inconclusive_then_it_is_retried() {
    let robots = vec![
        SimRobot::at(1, 100.0),
        SimRobot::at(2, 200.0),
        SimRobot::at(3, 300.0),
    ];
    let mut sim = Sim::new(config(3), robots, vec![Some(0), Some(1), Some(2)]);
    sim.run(2);
    assert_eq!(sim.id.asking(), Some(1));
    // Robot 3 leaves the view while robot 1 is asked.
    sim.robots[2].in_view = false;
    sim.run(ATTEMPT_FRAMES);
    assert_eq!(
        sim.retries(Inconclusive::Disturbed),
        1,
        "{:?}",
        sim.outcomes
    );
    assert_eq!(sim.id.slot_of(1), None);
    sim.robots[2].in_view = true;
    sim.run(4 * ATTEMPT_FRAMES);
    assert_eq!(sim.bindings(), [Some(1), Some(2), Some(3)]);
}

#[test]
fn a_coincidental_occlusion_of_another_track_in_the_dark_window_is_not_taken_for_an_answer() {
    // Robot 1 does not answer; while it is asked, robot 2's track is occluded over the whole
    // dark window. It went dark, but it stays dark after the LED would be back on: inconclusive,
    // not a binding of robot 1 to robot 2's track.
    let robots = vec![SimRobot::at(0, 100.0), SimRobot::at(2, 400.0)];
    let mut sim = Sim::new(config(2), robots, vec![Some(0), Some(1)]);
    sim.run(1);
    assert_eq!(sim.id.asking(), Some(1));
    let asked_us = sim.now_us;
    // Dark from just after the request until well after the LED would be back on.
    sim.robots[1].off = Some((asked_us + 1, asked_us + 14 * P_US));
    sim.run(ATTEMPT_FRAMES);
    assert_eq!(sim.id.slot_of(1), None, "{:?}", sim.outcomes);
    assert_eq!(
        sim.retries(Inconclusive::Disturbed),
        1,
        "{:?}",
        sim.outcomes
    );
}

#[test]
fn tracks_that_come_close_are_unbound_and_identified_again_when_they_part() {
    let robots = vec![SimRobot::at(1, 100.0), SimRobot::at(2, 400.0)];
    let mut sim = Sim::new(config(2), robots, vec![Some(0), Some(1)]);
    sim.run(2 * ATTEMPT_FRAMES);
    assert_eq!(sim.bindings(), [Some(1), Some(2)]);
    let requests = sim.requests.len();

    // They meet: both unbound at once, and nothing is asked while they touch.
    sim.robots[0].x_px = 250.0;
    sim.robots[1].x_px = 260.0;
    sim.run(1);
    assert_eq!(sim.bindings(), [None, None]);
    assert_eq!(sim.id.stats().unbound, 2);
    sim.run(30);
    assert_eq!(sim.requests.len(), requests, "asked while the tracks touch");

    // They part, and the tracker swapped their slots: identified again, the right way round.
    sim.slots = vec![Some(1), Some(0)];
    sim.robots[0].x_px = 100.0;
    sim.robots[1].x_px = 400.0;
    sim.run(2 * ATTEMPT_FRAMES);
    assert_eq!(sim.bindings(), [Some(2), Some(1)]);
    sim.assert_never_wrong();
}

#[test]
fn a_track_lost_and_found_again_is_identified_again() {
    let robots = vec![
        SimRobot::at(1, 100.0),
        SimRobot::at(2, 400.0),
        SimRobot::at(3, 600.0),
    ];
    let mut sim = Sim::new(config(3), robots, vec![Some(0), Some(1), None]);
    sim.run(2 * ATTEMPT_FRAMES);
    assert_eq!(sim.bindings(), [Some(1), Some(2), None]);

    // A short miss (fewer frames than lost_after_frames) keeps the binding.
    sim.robots[0].in_view = false;
    sim.run(2);
    sim.robots[0].in_view = true;
    sim.run(1);
    assert_eq!(sim.id.robot_of(0), Some(1));

    // Robot 1 leaves; the tracker gives its slot to robot 3 when that one comes into view.
    sim.robots[0].in_view = false;
    sim.run(5);
    assert_eq!(sim.id.robot_of(0), Some(1), "kept while unseen (coasting)");
    sim.slots[0] = Some(2);
    sim.run(1);
    assert_eq!(sim.id.robot_of(0), None, "found again: unbound");
    sim.run(3 * ATTEMPT_FRAMES);
    assert_eq!(sim.bindings(), [Some(3), Some(2), None]);
    sim.assert_never_wrong();
}

#[test]
fn glare_is_never_bound_and_asking_stays_bounded() {
    // Two robots and a glare spot in a slot of its own: the glare never goes dark.
    let robots = vec![SimRobot::at(1, 100.0), SimRobot::at(2, 400.0)];
    let mut sim = Sim::new(config(2), robots, vec![Some(0), Some(1), None]);
    sim.glare.push((2, 700.0));
    sim.run(600);
    assert_eq!(sim.bindings(), [Some(1), Some(2), None]);
    // Every robot is bound, so the glare's slot waits with no one to ask.
    assert_eq!(sim.requests.len(), 2);
}

#[test]
fn dropped_frames_over_the_dark_window_leave_the_attempt_inconclusive() {
    let mut sim = Sim::new(config(1), vec![SimRobot::at(1, 100.0)], vec![Some(0)]);
    // The first request goes out on frame 1; its surely-dark frames are frames 5 to 7.
    sim.drop_frames = 4..8;
    sim.run(ATTEMPT_FRAMES);
    assert_eq!(
        sim.retries(Inconclusive::NoDarkFrame),
        1,
        "{:?}",
        sim.outcomes
    );
    assert_eq!(sim.id.robot_of(0), None);
    sim.run(ATTEMPT_FRAMES);
    assert_eq!(sim.id.robot_of(0), Some(1));
}

#[test]
fn a_wrong_binding_is_corrected_by_the_robots_own_answer() {
    // Robot 2 sits in the slot bound to robot 1 (say, a wrong continuity guess before): when
    // robot 2 is asked, that slot goes dark, so it becomes robot 2's and robot 1 is unbound.
    let robots = vec![SimRobot::at(2, 100.0), SimRobot::at(1, 400.0)];
    let mut sim = Sim::new(config(2), robots, vec![Some(0), Some(1)]);
    sim.id.bind(0, 1);
    sim.run(3 * ATTEMPT_FRAMES);
    assert_eq!(sim.bindings(), [Some(2), Some(1)]);
}

#[test]
fn the_frame_period_is_measured_from_the_frames_whatever_was_configured() {
    // Configured for 30 fps; the camera runs at 15 and at 60 fps, with a dropped frame.
    for period_us in [66_667, 16_667] {
        let robots = vec![SimRobot::at(1, 100.0), SimRobot::at(2, 400.0)];
        let mut sim = Sim::new(config(2), robots, vec![Some(1), Some(0)]);
        sim.period_us = period_us;
        sim.drop_frames = 3..4;
        sim.run(3 * ATTEMPT_FRAMES);
        assert_eq!(
            sim.bindings(),
            [Some(2), Some(1)],
            "period {period_us} µs: {:?}",
            sim.outcomes
        );
        // The second request is sized in the measured frames: 5 frames off, one ahead.
        let last = sim.requests.last().expect("asked");
        assert_eq!(
            (last.delay_us, last.off_us),
            (period_us as u32, 5 * period_us as u32)
        );
    }
}

#[test]
fn configurations_that_cannot_work_are_refused() {
    assert!(matches!(
        Identifier::<4>::new(config(0)),
        Err(IdentifyError::Robots { robots: 0, max: 4 })
    ));
    assert!(matches!(
        Identifier::<4>::new(config(5)),
        Err(IdentifyError::Robots { robots: 5, max: 4 })
    ));
    assert_eq!(
        Identifier::<4>::new(IdentifyConfig::new(2, 0)).err(),
        Some(IdentifyError::FramePeriod)
    );
    let short = IdentifyConfig {
        off_frames: 3,
        ..config(2)
    };
    let err = Identifier::<4>::new(short).expect_err("refused");
    assert_eq!(
        err,
        IdentifyError::OffTooShort {
            off_us: 3 * P_US,
            needed_us: 4 * P_US
        }
    );
    assert!(err.to_string().contains("no frame surely dark"), "{err}");
    let long = IdentifyConfig {
        off_frames: 200_000,
        ..config(2)
    };
    assert_eq!(
        Identifier::<4>::new(long).err(),
        Some(IdentifyError::TooLong)
    );
}

#[test]
fn more_tracks_than_slots_are_ignored_and_fewer_are_not_visible() {
    let mut id = Identifier::<2>::new(config(2)).expect("valid");
    let lit = TrackSeen {
        visible: true,
        x_px: 0.0,
        y_px: 0.0,
    };
    let far = TrackSeen { x_px: 500.0, ..lit };
    // Four tracks into two slots, then none: no panic, and the first request still goes out.
    let step = id.step(0, &[lit, far, lit, far]);
    assert!(step.request.is_some());
    for t in 1..40 {
        let _ = id.step(t * P_US, &[]);
    }
    assert_eq!(
        (id.robot_of(0), id.robot_of(1), id.robot_of(7)),
        (None, None, None)
    );
}
