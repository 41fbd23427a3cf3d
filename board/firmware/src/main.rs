//! Example firmware entry point for a Cortex-M4F robot controller (thumbv7em-none-eabihf).
//!
//! It wires a UART to glint's decoder, a control-loop stub and a LED that answers glint's
//! requests. The UART here is a replay of recorded frames and the LED a stand-in, so the example
//! builds without a particular HAL: replace `Replay::new(..)` with your HAL's UART (anything
//! implementing `embedded_io::Read`), `DemoLed` with your LED pin, and `HoldPosition` with your
//! motor control. The clock is the core's cycle counter. Built by `board/firmware/check.sh`.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(target_os = "none")]
mod target {
    use cortex_m::peripheral::DWT;
    use cortex_m_rt::entry;
    use glint_firmware::demo::{DemoLed, Replay, DEMO_STREAM};
    use glint_firmware::{HoldPosition, Link, WithLed};
    use panic_halt as _;

    /// Where the stub steers to, in floor mm.
    const HOME_MM: (i32, i32) = (1000, 500);
    /// This robot's id, for its position updates on a shared line and for LED requests.
    const ROBOT_ID: u8 = 1;
    /// Core clock in MHz (an STM32F4 after reset runs on its 16 MHz internal oscillator).
    const CORE_MHZ: u32 = 16;

    /// Microseconds from the cycle counter (wraps every 2³² cycles, 4.5 min at 16 MHz: the
    /// link only takes differences of a few frames).
    fn now_us() -> u32 {
        DWT::cycle_count() / CORE_MHZ
    }

    #[entry]
    fn main() -> ! {
        if let Some(mut core) = cortex_m::Peripherals::take() {
            core.DCB.enable_trace();
            core.DWT.enable_cycle_counter();
        }
        // `for_robot`: on a line shared by several robots, take only this robot's updates.
        let mut link = Link::new(Replay::new(DEMO_STREAM), now_us).for_robot(ROBOT_ID);
        let mut robot = WithLed::new(HoldPosition::new(HOME_MM), DemoLed::default(), ROBOT_ID);
        loop {
            // `Replay` cannot fail; a real UART's overrun or framing error has already been
            // counted and its partial frame dropped by `poll`, so carry on reading.
            let _ = link.poll(&mut robot);
            robot.tick(now_us());
            core::hint::black_box(&robot.control.command_mm_per_s);
        }
    }
}

/// On a host the firmware has nothing to drive; its logic is tested with `cargo test`.
#[cfg(not(target_os = "none"))]
fn main() {
    println!("glint-firmware runs on a microcontroller: build it with board/firmware/check.sh");
}
