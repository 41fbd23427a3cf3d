//! Example firmware entry point for a Cortex-M4F robot controller (thumbv7em-none-eabihf).
//!
//! It wires a UART to glint's decoder and a control-loop stub. The UART here is a replay of
//! recorded frames so the example builds without a particular HAL: replace `Replay::new(..)` with
//! your HAL's UART (anything implementing `embedded_io::Read`), and `HoldPosition` with your
//! motor control. Built by `board/firmware/check.sh`.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(target_os = "none")]
mod target {
    use cortex_m_rt::entry;
    use glint_firmware::demo::{Replay, DEMO_STREAM};
    use glint_firmware::{HoldPosition, Link};
    use panic_halt as _;

    /// Where the stub steers to, in floor mm.
    const HOME_MM: (i32, i32) = (1000, 500);

    #[entry]
    fn main() -> ! {
        let mut link = Link::new(Replay::new(DEMO_STREAM));
        let mut control = HoldPosition::new(HOME_MM);
        loop {
            // `Replay` cannot fail; a real UART's overrun or framing error has already been
            // counted and its partial frame dropped by `poll`, so carry on reading.
            let _ = link.poll(&mut control);
            core::hint::black_box(&control.command_mm_per_s);
        }
    }
}

/// On a host the firmware has nothing to drive; its logic is tested with `cargo test`.
#[cfg(not(target_os = "none"))]
fn main() {
    println!("glint-firmware runs on a microcontroller: build it with board/firmware/check.sh");
}
