//! The lines the firmware writes to the rig on its UART1 (see board/firmware/src/bin/mps2.rs),
//! parsed. Every line is checked: a garbled one is counted, never trusted.

/// One wheel command, as the firmware sent it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Command {
    /// The position update it answers.
    pub seq: u8,
    /// That update's frame time, µs (glint's frame clock: frame index × period).
    pub timestamp_us: u32,
    /// The light was in view.
    pub steering: bool,
    /// Wheel speeds, mm/s.
    pub left_mm_s: i32,
    pub right_mm_s: i32,
    /// The position's age as the firmware reckoned it when writing the line, µs.
    pub age_us: Option<u32>,
    /// The firmware's clock when it reckoned the age (qemu's virtual clock, which runs with the
    /// host's monotonic clock), µs, wrapping at 2³².
    pub clock_us: u32,
    /// The firmware's clock when its link read the age frame (with an age), µs.
    pub received_us: Option<u32>,
}

/// A line from the firmware.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Line {
    /// `W seq timestamp_us steering left right age|- clock_us received_us|-`
    Wheels(Command),
    /// `L 0|1 clock_us`: the LED switched, at that moment of the firmware's clock.
    Led { on: bool, clock_us: u32 },
    /// `ready compensate=…` (also at start) or anything else the rig does not act on.
    Other,
}

/// Parses one line (without its newline); `None` when it is garbled.
pub fn parse(line: &str) -> Option<Line> {
    let mut words = line.split_ascii_whitespace();
    match words.next()? {
        "W" => {
            let mut next = || words.next();
            let seq = next()?.parse().ok()?;
            let timestamp_us = next()?.parse().ok()?;
            let steering = match next()? {
                "0" => false,
                "1" => true,
                _ => return None,
            };
            let left_mm_s = next()?.parse().ok()?;
            let right_mm_s = next()?.parse().ok()?;
            let age_us = match next()? {
                "-" => None,
                age => Some(age.parse().ok()?),
            };
            let clock_us = next()?.parse().ok()?;
            let received_us = match next()? {
                "-" => None,
                at => Some(at.parse().ok()?),
            };
            if next().is_some() || age_us.is_some() != received_us.is_some() {
                return None;
            }
            Some(Line::Wheels(Command {
                seq,
                timestamp_us,
                steering,
                left_mm_s,
                right_mm_s,
                age_us,
                clock_us,
                received_us,
            }))
        }
        "L" => {
            let on = match words.next()? {
                "0" => false,
                "1" => true,
                _ => return None,
            };
            let clock_us = words.next()?.parse().ok()?;
            words.next().is_none().then_some(Line::Led { on, clock_us })
        }
        "ready" => Some(Line::Other),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_firmwares_lines_parse_and_garbage_does_not() {
        assert_eq!(
            parse("W 7 233333 1 512 -488 5775 4000000000 3999999100"),
            Some(Line::Wheels(Command {
                seq: 7,
                timestamp_us: 233_333,
                steering: true,
                left_mm_s: 512,
                right_mm_s: -488,
                age_us: Some(5_775),
                clock_us: 4_000_000_000,
                received_us: Some(3_999_999_100),
            }))
        );
        assert!(matches!(
            parse("W 7 0 0 0 0 - 12 -"),
            Some(Line::Wheels(Command { age_us: None, .. }))
        ));
        assert_eq!(
            parse("L 0 17"),
            Some(Line::Led {
                on: false,
                clock_us: 17
            })
        );
        assert_eq!(parse("ready compensate=1"), Some(Line::Other));
        for bad in [
            "",
            "W",
            "W 7 0 2 0 0 - 1 -",
            "W 300 0 1 0 0 - 1 -",
            "W 7 0 1 0 0 5 1",
            "W 7 0 1 0 0 5 1 1 extra",
            "W 7 0 1 0 0 5 1 -",
            "W 7 0 1 0 0 - 1 1",
            "W 7 0 1 x 0 - 1 -",
            "W 7 0 1 0 0 - 4294967296 -",
            "L 2 1",
            "L 1",
            "L 1 1 1",
            "Q",
        ] {
            assert_eq!(parse(bad), None, "{bad:?}");
        }
    }
}
