//! Stand-ins for the example binary: a UART that replays recorded bytes and a LED that only
//! remembers its state, so the firmware builds and runs without a particular HAL. Replace them
//! with your board's UART driver and LED pin.

use core::convert::Infallible;

use embedded_io::{ErrorType, Read};

use crate::led::LedPin;

/// Frames from `board/protocol/SPEC.md`'s test vectors, preceded by the lone 0x00 a sender emits
/// when it opens the port: a position on the floor and its age (5.23 ms), a heartbeat, and a
/// request to every robot to switch its LED off at once for 200 ms.
pub const DEMO_STREAM: &[u8] = &[
    0x00, //
    0x06, 0x01, 0x01, 0x40, 0xe2, 0x01, 0x08, 0x05, 0xe0, 0x17, 0xeb, 0x04, 0xf4, 0x03, 0x04, 0xc8,
    0x92, 0xba, 0x00, //
    0x05, 0x03, 0x01, 0xee, 0x28, 0x03, 0x15, 0xbd, 0x00, //
    0x09, 0x02, 0x02, 0xb8, 0x17, 0x0c, 0x02, 0x1d, 0x16, 0x00, //
    0x02, 0x04, 0x05, 0x07, 0x40, 0xe2, 0x01, 0x01, 0x06, 0xc0, 0x9a, 0x0c, 0xc8, 0xef, 0x00,
];

/// A LED that only remembers whether it is on.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DemoLed {
    /// The state last set.
    pub on: bool,
}

impl LedPin for DemoLed {
    fn set_led(&mut self, on: bool) {
        self.on = on;
    }
}

/// An `embedded_io::Read` that replays a byte slice forever, a few bytes per read like a UART.
pub struct Replay {
    bytes: &'static [u8],
    pos: usize,
}

/// Bytes per read, as a UART's FIFO might deliver them.
const REPLAY_READ_LEN: usize = 5;

impl Replay {
    /// Replays `bytes` (which must not be empty to produce anything).
    pub const fn new(bytes: &'static [u8]) -> Self {
        Replay { bytes, pos: 0 }
    }
}

impl ErrorType for Replay {
    type Error = Infallible;
}

impl Read for Replay {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let rest = self.bytes.get(self.pos..).unwrap_or(&[]);
        let n = rest.len().min(buf.len()).min(REPLAY_READ_LEN);
        if let (Some(dst), Some(src)) = (buf.get_mut(..n), rest.get(..n)) {
            dst.copy_from_slice(src);
        }
        self.pos += n;
        if self.pos >= self.bytes.len() {
            self.pos = 0;
        }
        Ok(n)
    }
}
