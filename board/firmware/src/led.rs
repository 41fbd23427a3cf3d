//! Glint's LED requests (protocol version 2): "switch your LED off for a while", for glint's
//! latency self-test and to tell robots apart. The robot's own code owns the LED; it gives
//! [`WithLed`] a [`LedPin`], and the firmware switches it at the requested moments.

use glint_protocol::{DecodeError, Heartbeat, LedRequest, Position, EVERY_ROBOT};

use crate::clock::reached;
use crate::control::{ArrivedAge, ControlLoop};

/// The robot's LED, as its own code drives it.
pub trait LedPin {
    /// Switches the LED on (`true`) or off.
    fn set_led(&mut self, on: bool);
}

/// An off period in the robot's clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct OffPeriod {
    from_us: u32,
    until_us: u32,
}

/// A control loop with a LED that answers glint's requests: positions, ages and heartbeats go
/// to the inner loop unchanged; LED requests for this robot (or every robot) are scheduled and
/// carried out by [`WithLed::tick`].
#[derive(Debug)]
pub struct WithLed<C, P> {
    /// The robot's control loop.
    pub control: C,
    pin: P,
    robot_id: u8,
    pending: Option<OffPeriod>,
    led_on: bool,
    /// Requests this robot answered.
    pub answered: u32,
}

impl<C: ControlLoop, P: LedPin> WithLed<C, P> {
    /// Wraps `control`; the LED on `pin` is switched on now and answers requests for
    /// `robot_id` and for every robot.
    pub fn new(control: C, mut pin: P, robot_id: u8) -> Self {
        pin.set_led(true);
        WithLed {
            control,
            pin,
            robot_id,
            pending: None,
            led_on: true,
            answered: 0,
        }
    }

    /// Whether the LED is on.
    pub fn led_on(&self) -> bool {
        self.led_on
    }

    /// Switches the LED when a requested moment has come; call it often (each loop turn).
    pub fn tick(&mut self, now_us: u32) {
        let Some(period) = self.pending else {
            return;
        };
        let on = !reached(now_us, period.from_us) || reached(now_us, period.until_us);
        if reached(now_us, period.until_us) {
            self.pending = None;
        }
        self.switch(on);
    }

    fn switch(&mut self, on: bool) {
        if on != self.led_on {
            self.pin.set_led(on);
            self.led_on = on;
        }
    }
}

impl<C: ControlLoop, P: LedPin> ControlLoop for WithLed<C, P> {
    fn on_position(&mut self, position: &Position) {
        self.control.on_position(position);
    }

    fn on_age(&mut self, age: &ArrivedAge) {
        self.control.on_age(age);
    }

    fn on_heartbeat(&mut self, heartbeat: &Heartbeat) {
        self.control.on_heartbeat(heartbeat);
    }

    fn on_link_error(&mut self, error: DecodeError) {
        self.control.on_link_error(error);
    }

    /// Schedules the off period in this robot's clock, counting the delay from the arrival of
    /// the request (this firmware does not follow glint's clock). A new request replaces a
    /// pending one; `off_us` 0 switches the LED back on at once.
    fn on_led(&mut self, request: &LedRequest, received_at_us: u32) {
        if request.robot != EVERY_ROBOT && request.robot != self.robot_id {
            return;
        }
        self.answered = self.answered.wrapping_add(1);
        if request.off_us == 0 {
            self.pending = None;
            self.switch(true);
            return;
        }
        let from_us = received_at_us.wrapping_add(request.delay_us);
        self.pending = Some(OffPeriod {
            from_us,
            until_us: from_us.wrapping_add(request.off_us),
        });
        self.tick(received_at_us);
    }
}
