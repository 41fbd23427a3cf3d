//! The serial line between glint and the emulated board, as a wire at a baud rate.
//!
//! glint writes to a pseudo-terminal, which delivers at once; qemu's UART model has no line
//! timing either. The wire forwards each byte to the board's UART when its last bit would have
//! arrived on a real line at the configured baud (10 bits a byte, back to back after the first),
//! so the line time glint adds to each position's age is a time that really passes.

use std::io::{self, Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread;
use std::time::Duration;

use glint::source::clock::monotonic_now_us;

/// Bits on the line per byte: start, 8 data, stop.
const BITS_PER_BYTE: u64 = 10;
/// How long a read waits before looking at the stop flag again.
pub const POLL: Duration = Duration::from_millis(50);
/// Sleeps shorter than this are spun instead: a sleep overshoots by tens of µs.
const SPIN_US: u64 = 60;

/// Nanoseconds one byte takes on the line at `baud`.
pub fn byte_time_ns(baud: u32) -> u64 {
    BITS_PER_BYTE * 1_000_000_000 / u64::from(baud.max(1))
}

/// Waits until the monotonic clock reads `t_us`.
fn wait_until_us(t_us: u64) {
    loop {
        let now = monotonic_now_us();
        if now >= t_us {
            return;
        }
        let left = t_us - now;
        if left > SPIN_US {
            thread::sleep(Duration::from_micros(left - SPIN_US));
        } else {
            std::hint::spin_loop();
        }
    }
}

/// Forwards `from` to `to` at `baud` until `stop` is set or `from` ends, showing `tap` each
/// chunk read and the moment it was read (monotonic µs). Returns the bytes forwarded.
pub fn forward(
    mut from: impl Read,
    mut to: impl Write,
    baud: u32,
    stop: &Arc<AtomicBool>,
    mut tap: impl FnMut(&[u8], u64),
) -> io::Result<u64> {
    let byte_ns = byte_time_ns(baud);
    let mut buf = [0u8; 256];
    // When the line is next free, ns of the monotonic clock.
    let mut free_ns = 0u64;
    let mut total = 0;
    while !stop.load(Ordering::Relaxed) {
        let n = match from.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::TimedOut | io::ErrorKind::Interrupted
                ) =>
            {
                continue
            }
            Err(e) => return Err(e),
        };
        let read_us = monotonic_now_us();
        let chunk = buf.get(..n).unwrap_or(&[]);
        tap(chunk, read_us);
        free_ns = free_ns.max(read_us * 1_000);
        for &byte in chunk {
            free_ns += byte_ns;
            wait_until_us(free_ns / 1_000);
            to.write_all(&[byte])?;
        }
        total += n as u64;
    }
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_byte_takes_ten_bit_times() {
        assert_eq!(byte_time_ns(115_200), 86_805);
        assert_eq!(byte_time_ns(1_000_000), 10_000);
    }

    #[test]
    fn bytes_arrive_no_sooner_than_the_line_allows() {
        // 100 bytes at 9600 baud: 104 ms on the line.
        let data = vec![0x55u8; 100];
        let stop = Arc::new(AtomicBool::new(false));
        let mut out = Vec::new();
        let start = monotonic_now_us();
        let mut tapped = 0;
        let n = forward(&data[..], &mut out, 9_600, &stop, |c, _| tapped += c.len()).unwrap();
        assert_eq!(tapped, 100);
        let took_us = monotonic_now_us() - start;
        assert_eq!(n, 100);
        assert_eq!(out, data);
        assert!(took_us >= 104_000, "{took_us}");
    }
}
