//! The example firmware on Arm's MPS2 board with the AN386 image (a Cortex-M4), as
//! qemu-system-arm emulates it (`-M mps2-an386`): the robot of the rig in `tools/src/rig`.
//!
//! - UART0 carries glint's frames in (`-serial` 1): the link and the path follower
//!   ([`PurePursuit`]), with a LED that answers glint's requests.
//! - UART1 (`-serial` 2) carries text lines to and from the rig's simulated robot. In, once at
//!   start: `compensate on` or `compensate off`; the firmware answers `ready compensate=1|0`.
//!   Out: `W seq timestamp_us steering left_mm_s right_mm_s age_us clock_us received_us` per
//!   position update (`steering` 1 when the light was in view; `age_us` is `-` without an age
//!   frame, otherwise the position's age as this firmware reckons it when it writes the line;
//!   `clock_us` is this firmware's clock at that moment, so the rig can take the truth at the
//!   moment the age was reckoned rather than when it read the line; `received_us` is its clock
//!   when the link read the age frame, `-` without one, so the rig can tell how late the
//!   emulator handed the bytes on), and `L 0|1 clock_us` when
//!   the LED switches (at that moment of this firmware's clock).
//! - The clock is TIMER0, a 32-bit down counter at the board's 25 MHz, extended to 64 bits in
//!   software at every reading (readings come at least once per update; the counter wraps
//!   every 172 s).
//!
//! The UARTs' receive interrupts only wake the core from `wfi`; bytes are read in the main loop.
//! SysTick wakes it every 250 µs too, so that a LED switch glint asked for at a later moment
//! happens within 250 µs of it, whether or not bytes come.
//! qemu's CMSDK UART model has no FIFO and no line timing: a byte is there as soon as qemu has
//! it, and the next comes when the last is read.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(target_os = "none")]
mod target {
    use core::cell::Cell;
    use core::convert::Infallible;
    use core::fmt::Write as _;
    use core::ptr::{read_volatile, write_volatile};

    use cortex_m::interrupt::{self, Mutex};
    use cortex_m_rt::{entry, exception};
    use embedded_io::{ErrorType, Read};
    use glint_firmware::led::LedPin;
    use glint_firmware::pursuit::{FigureEight, PurePursuit, PursuitParams};
    use glint_firmware::{Link, WithLed};
    use panic_halt as _;

    /// The board's peripheral clock.
    const CLOCK_HZ: u32 = 25_000_000;
    const CLOCK_MHZ: u64 = 25;
    /// The UARTs' nominal baud rate (qemu does not time the line, but wants a valid divider).
    const BAUD: u32 = 115_200;
    const UART0: usize = 0x4000_4000;
    const UART1: usize = 0x4000_5000;
    const TIMER0: usize = 0x4000_0000;
    /// NVIC interrupt numbers of the UARTs' receive interrupts.
    const UART0_RX_IRQ: u32 = 0;
    const UART1_RX_IRQ: u32 = 2;
    /// CMSDK APB UART registers and bits.
    const DATA: usize = 0x00;
    const STATE: usize = 0x04;
    const CTRL: usize = 0x08;
    const INTCLEAR: usize = 0x0c;
    const BAUDDIV: usize = 0x10;
    const STATE_TX_FULL: u32 = 1 << 0;
    const STATE_RX_FULL: u32 = 1 << 1;
    const CTRL_TX_EN: u32 = 1 << 0;
    const CTRL_RX_EN: u32 = 1 << 1;
    const CTRL_RX_INTEN: u32 = 1 << 3;
    /// CMSDK APB timer registers.
    const TIMER_CTRL: usize = 0x00;
    const TIMER_VALUE: usize = 0x04;
    const TIMER_RELOAD: usize = 0x08;
    const TIMER_ENABLE: u32 = 1 << 0;

    /// The robot this firmware drives: the rig's figure-eight at 0.5 m/s on a 120 mm axle, its
    /// motors following commands with a 30 ms lag.
    const PARAMS: PursuitParams = PursuitParams {
        path: FigureEight::RIG,
        speed_mm_s: 500.0,
        wheel_base_mm: 120.0,
        lookahead_mm: 100.0,
        // The rig's robot's motors (tools/src/rig/run.rs, RIG_DRIVE).
        motor_lag_us: 30_000,
        compensate: true,
    };
    /// This robot's id for LED requests.
    const ROBOT_ID: u8 = 1;
    /// Longest line accepted from the rig.
    const LINE_LEN: usize = 32;

    fn read_reg(addr: usize) -> u32 {
        // SAFETY: only called with the addresses of the board's memory-mapped registers above.
        unsafe { read_volatile(addr as *const u32) }
    }

    fn write_reg(addr: usize, value: u32) {
        // SAFETY: as `read_reg`.
        unsafe { write_volatile(addr as *mut u32, value) }
    }

    /// One CMSDK UART, by its base address.
    #[derive(Clone, Copy)]
    struct Uart(usize);

    impl Uart {
        fn init(self) {
            write_reg(self.0 + BAUDDIV, CLOCK_HZ / BAUD);
            write_reg(self.0 + CTRL, CTRL_TX_EN | CTRL_RX_EN | CTRL_RX_INTEN);
        }

        fn rx_ready(self) -> bool {
            read_reg(self.0 + STATE) & STATE_RX_FULL != 0
        }

        fn try_read(self) -> Option<u8> {
            self.rx_ready().then(|| read_reg(self.0 + DATA) as u8)
        }

        /// Waits (asleep) for a byte.
        fn read_blocking(self) -> u8 {
            loop {
                if let Some(b) = self.try_read() {
                    return b;
                }
                sleep_unless(|| self.rx_ready());
            }
        }

        fn write_byte(self, byte: u8) {
            while read_reg(self.0 + STATE) & STATE_TX_FULL != 0 {}
            write_reg(self.0 + DATA, u32::from(byte));
        }
    }

    impl core::fmt::Write for Uart {
        fn write_str(&mut self, s: &str) -> core::fmt::Result {
            s.bytes().for_each(|b| self.write_byte(b));
            Ok(())
        }
    }

    /// Sleeps until an interrupt unless `ready` holds. Checked with interrupts masked, so a
    /// byte that arrives between the check and `wfi` still wakes the core (a pending interrupt
    /// ends `wfi` even while masked; its handler runs once they are unmasked).
    fn sleep_unless(ready: impl Fn() -> bool) {
        interrupt::free(|_| {
            if !ready() {
                cortex_m::asm::wfi();
            }
        });
    }

    /// UART0 as `embedded_io::Read`: blocks (asleep) until a byte, then takes what is there.
    struct Uart0Rx;

    impl ErrorType for Uart0Rx {
        type Error = Infallible;
    }

    impl Read for Uart0Rx {
        fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
            let uart = Uart(UART0);
            let Some((first, rest)) = buf.split_first_mut() else {
                return Ok(0);
            };
            *first = uart.read_blocking();
            let mut n = 1;
            for slot in rest {
                let Some(b) = uart.try_read() else { break };
                *slot = b;
                n += 1;
            }
            Ok(n)
        }
    }

    /// TIMER0's count at the last reading, and the cycles counted since start-up.
    static CLOCK: Mutex<Cell<(u32, u64)>> = Mutex::new(Cell::new((u32::MAX, 0)));

    fn start_clock() {
        write_reg(TIMER0 + TIMER_RELOAD, u32::MAX);
        write_reg(TIMER0 + TIMER_VALUE, u32::MAX);
        write_reg(TIMER0 + TIMER_CTRL, TIMER_ENABLE);
    }

    /// Microseconds since start-up, wrapping at 2³².
    fn now_us() -> u32 {
        interrupt::free(|cs| {
            let cell = CLOCK.borrow(cs);
            let (last, cycles) = cell.get();
            let count = read_reg(TIMER0 + TIMER_VALUE);
            // A down counter: the cycles elapsed are last − now, modulo the wrap.
            let cycles = cycles + u64::from(last.wrapping_sub(count));
            cell.set((count, cycles));
            (cycles / CLOCK_MHZ) as u32
        })
    }

    /// The LED, reported to the rig (which draws it) as it switches.
    struct RigLed;

    impl LedPin for RigLed {
        fn set_led(&mut self, on: bool) {
            let _ = writeln!(Uart(UART1), "L {} {}", u8::from(on), now_us());
        }
    }

    /// Waits for the rig's `compensate on|off` line and answers it.
    fn read_mode() -> bool {
        let uart = Uart(UART1);
        let mut line = [0u8; LINE_LEN];
        loop {
            let mut len = 0;
            loop {
                let b = uart.read_blocking();
                if b == b'\n' {
                    break;
                }
                if let Some(slot) = line.get_mut(len) {
                    *slot = b;
                    len += 1;
                }
            }
            let on = match line.get(..len) {
                Some(b"compensate on") => true,
                Some(b"compensate off") => false,
                _ => continue,
            };
            let _ = writeln!(Uart(UART1), "ready compensate={}", u8::from(on));
            return on;
        }
    }

    /// SysTick's reload for a tick every 250 µs at the core's clock.
    const SYSTICK_RELOAD: u32 = CLOCK_HZ / 4_000 - 1;

    /// Interrupts (and SysTick) only wake the core: clear the UARTs' so they do not fire again.
    #[exception]
    unsafe fn DefaultHandler(_irqn: i16) {
        write_reg(UART0 + INTCLEAR, 0xf);
        write_reg(UART1 + INTCLEAR, 0xf);
    }

    #[entry]
    fn main() -> ! {
        start_clock();
        Uart(UART0).init();
        Uart(UART1).init();
        // SAFETY: the handler above only clears the UARTs' interrupt flags.
        unsafe {
            (*cortex_m::peripheral::NVIC::PTR).iser[0]
                .write((1 << UART0_RX_IRQ) | (1 << UART1_RX_IRQ));
        }
        if let Some(mut core) = cortex_m::Peripherals::take() {
            core.SYST
                .set_clock_source(cortex_m::peripheral::syst::SystClkSource::Core);
            core.SYST.set_reload(SYSTICK_RELOAD);
            core.SYST.clear_current();
            core.SYST.enable_interrupt();
            core.SYST.enable_counter();
        }
        let compensate = read_mode();
        let mut control = PurePursuit::new(PARAMS);
        control.set_compensation(compensate);
        let mut robot = WithLed::new(control, RigLed, ROBOT_ID);
        let mut link = Link::new(Uart0Rx, now_us);
        loop {
            // Only when a byte is there: the link's read waits for one, and the LED must not.
            if Uart(UART0).rx_ready() {
                let Ok(_) = link.poll(&mut robot);
            }
            robot.tick(now_us());
            if let Some(cmd) = robot.control.take_command() {
                let mut out = Uart(UART1);
                let _ = write!(
                    out,
                    "W {} {} {} {} {} ",
                    cmd.seq,
                    cmd.timestamp_us,
                    u8::from(cmd.steering),
                    cmd.left_mm_s,
                    cmd.right_mm_s
                );
                // The age last, read as late as possible: the line's first bytes are out.
                let now = now_us();
                let _ = match cmd.age {
                    Some(age) => {
                        writeln!(out, "{} {now} {}", age.age_at_us(now), age.received_at_us)
                    }
                    None => writeln!(out, "- {now} -"),
                };
            }
            // Until a byte comes or the next tick.
            sleep_unless(|| Uart(UART0).rx_ready());
        }
    }
}

/// On a host the board has nothing to drive; its logic is tested with `cargo test`.
#[cfg(not(target_os = "none"))]
fn main() {
    println!("glint-firmware-mps2 runs in qemu-system-arm -M mps2-an386 (see tools/src/rig)");
}
