//! Shared by the integration tests: one text form for decoder events, used by the SPEC's test
//! vectors, by the C test program's output and by the Rust decoder's results, so all three are
//! compared as the same strings.
#![allow(dead_code)] // each test binary uses its own part of this module

use glint_protocol::{
    DecodeError, Heartbeat, LedRequest, Message, Position, PositionAge, Received, RobotPosition,
    Status, TrackerState, Units,
};

/// The text form of a position's fields (after the `position`/`robot-position` word).
fn position_fields(p: &Position) -> String {
    format!(
        "seq={} timestamp_us={} units={} x={} y={} vx_per_s={} vy_per_s={} status={} quality={}",
        p.seq,
        p.timestamp_us,
        match p.units {
            Units::Floor => "floor",
            Units::Pixels => "pixels",
        },
        p.x,
        p.y,
        p.vx_per_s,
        p.vy_per_s,
        match p.status {
            Status::Lost => "lost",
            Status::Found => "found",
            Status::Predicted => "predicted",
        },
        p.quality
    )
}

/// The text form of one decoder event.
pub fn describe(event: &Result<Received, DecodeError>) -> String {
    match event {
        Ok(Received::Message(Message::Position(p))) => format!("position {}", position_fields(p)),
        Ok(Received::Message(Message::RobotPosition(r))) => format!(
            "robot-position robot={} {}",
            r.robot,
            position_fields(&r.position)
        ),
        Ok(Received::Message(Message::Heartbeat(h))) => format!(
            "heartbeat protocol_version={} frame_rate_centihz={} dropped_frames={} tracker_state={}",
            h.protocol_version,
            h.frame_rate_centihz,
            h.dropped_frames,
            match h.tracker_state {
                TrackerState::Starting => "starting",
                TrackerState::Searching => "searching",
                TrackerState::Tracking => "tracking",
                TrackerState::Coasting => "coasting",
            }
        ),
        Ok(Received::Message(Message::Age(a))) => format!(
            "age seq={} age_us={} predicted={}",
            a.seq, a.age_us, a.predicted
        ),
        Ok(Received::Message(Message::Led(r))) => format!(
            "led robot={} request={} at_us={} delay_us={} off_us={}",
            r.robot, r.request, r.at_us, r.delay_us, r.off_us
        ),
        Ok(Received::Unknown { id }) => format!("unknown id={id:#04x}"),
        Err(DecodeError::Overflow) => "error overflow".to_string(),
        Err(DecodeError::Cobs) => "error cobs".to_string(),
        Err(DecodeError::TooShort) => "error short".to_string(),
        Err(DecodeError::Crc) => "error crc".to_string(),
        Err(DecodeError::Malformed { id }) => format!("error malformed id={id:#04x}"),
    }
}

/// Parses the text form of a message (the inverse of [`describe`] for messages).
pub fn parse_message(text: &str) -> Result<Message, String> {
    let mut words = text.split_whitespace();
    let kind = words.next().ok_or("empty message line")?;
    let fields: Vec<(&str, &str)> = words
        .map(|w| w.split_once('=').ok_or(format!("field without '=': {w}")))
        .collect::<Result<_, _>>()?;
    let get = |name: &str| -> Result<&str, String> {
        fields
            .iter()
            .find(|(k, _)| *k == name)
            .map(|(_, v)| *v)
            .ok_or(format!("{kind}: missing field {name}"))
    };
    fn num<T: std::str::FromStr>(s: &str) -> Result<T, String> {
        s.parse().map_err(|_| format!("bad number {s}"))
    }
    let position = || -> Result<Position, String> {
        Ok(Position {
            seq: num(get("seq")?)?,
            timestamp_us: num(get("timestamp_us")?)?,
            units: match get("units")? {
                "floor" => Units::Floor,
                "pixels" => Units::Pixels,
                other => return Err(format!("bad units {other}")),
            },
            x: num(get("x")?)?,
            y: num(get("y")?)?,
            vx_per_s: num(get("vx_per_s")?)?,
            vy_per_s: num(get("vy_per_s")?)?,
            status: match get("status")? {
                "lost" => Status::Lost,
                "found" => Status::Found,
                "predicted" => Status::Predicted,
                other => return Err(format!("bad status {other}")),
            },
            quality: num(get("quality")?)?,
        })
    };
    match kind {
        "position" => Ok(Message::Position(position()?)),
        "robot-position" => Ok(Message::RobotPosition(RobotPosition {
            robot: num(get("robot")?)?,
            position: position()?,
        })),
        "heartbeat" => Ok(Message::Heartbeat(Heartbeat {
            protocol_version: num(get("protocol_version")?)?,
            frame_rate_centihz: num(get("frame_rate_centihz")?)?,
            dropped_frames: num(get("dropped_frames")?)?,
            tracker_state: match get("tracker_state")? {
                "starting" => TrackerState::Starting,
                "searching" => TrackerState::Searching,
                "tracking" => TrackerState::Tracking,
                "coasting" => TrackerState::Coasting,
                other => return Err(format!("bad tracker state {other}")),
            },
        })),
        "age" => Ok(Message::Age(PositionAge {
            seq: num(get("seq")?)?,
            age_us: num(get("age_us")?)?,
            predicted: num(get("predicted")?)?,
        })),
        "led" => Ok(Message::Led(LedRequest {
            robot: num(get("robot")?)?,
            request: num(get("request")?)?,
            at_us: num(get("at_us")?)?,
            delay_us: num(get("delay_us")?)?,
            off_us: num(get("off_us")?)?,
        })),
        other => Err(format!("unknown message kind {other}")),
    }
}

/// Parses space-separated hex bytes ("0a ff 00").
pub fn parse_hex(text: &str) -> Result<Vec<u8>, String> {
    text.split_whitespace()
        .map(|h| u8::from_str_radix(h, 16).map_err(|_| format!("bad hex byte {h}")))
        .collect()
}

/// Formats bytes as space-separated lower-case hex.
pub fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// One test vector from SPEC.md.
#[derive(Debug, Clone)]
pub struct Vector {
    pub name: String,
    /// The message line, for vectors the encoder must produce.
    pub message: Option<String>,
    /// The payload before COBS (id, body, CRC), for encode vectors.
    pub payload: Option<Vec<u8>>,
    /// The bytes on the wire, delimiter included.
    pub wire: Vec<u8>,
    /// What a decoder reports for `wire`, one event per line.
    pub decodes: Vec<String>,
}

/// Reads the test vectors out of SPEC.md: the fenced blocks marked `test-vector`.
pub fn spec_vectors() -> Vec<Vector> {
    let spec_path = concat!(env!("CARGO_MANIFEST_DIR"), "/SPEC.md");
    let spec = std::fs::read_to_string(spec_path).unwrap_or_else(|e| panic!("{spec_path}: {e}"));
    let mut vectors = Vec::new();
    let mut block: Option<Vec<&str>> = None;
    for line in spec.lines() {
        match (&mut block, line.trim()) {
            (None, "```test-vector") => block = Some(Vec::new()),
            (Some(lines), "```") => {
                vectors.push(parse_vector(lines).unwrap_or_else(|e| panic!("SPEC.md vector: {e}")));
                block = None;
            }
            (Some(lines), l) => lines.push(l),
            (None, _) => {}
        }
    }
    assert!(block.is_none(), "SPEC.md: unterminated test-vector block");
    vectors
}

fn parse_vector(lines: &[&str]) -> Result<Vector, String> {
    let mut v = Vector {
        name: String::new(),
        message: None,
        payload: None,
        wire: Vec::new(),
        decodes: Vec::new(),
    };
    for line in lines {
        let (key, value) = line
            .split_once(':')
            .ok_or(format!("line without ':': {line}"))?;
        let value = value.trim();
        match key {
            "name" => v.name = value.to_string(),
            "message" => v.message = Some(value.to_string()),
            "payload" => v.payload = Some(parse_hex(value)?),
            "wire" => v.wire.extend(parse_hex(value)?),
            "decodes" => v.decodes.push(value.to_string()),
            other => return Err(format!("unknown key {other}")),
        }
    }
    if v.name.is_empty() || v.wire.is_empty() {
        return Err(format!("vector needs a name and wire bytes: {lines:?}"));
    }
    Ok(v)
}

/// A small deterministic generator (SplitMix64) so the corruption counts are reproducible.
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (n > 0; the modulo bias is irrelevant at these sizes).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }

    pub fn byte(&mut self) -> u8 {
        self.next_u64() as u8
    }

    /// A random message of any kind, each position followed by its age, as on the real link.
    pub fn message(&mut self) -> Message {
        let u32_field = |r: &mut Self| (r.next_u64() as u32) >> r.below(32);
        match self.below(8) {
            0 | 1 => {
                return Message::Age(PositionAge {
                    seq: self.byte(),
                    age_us: u32_field(self),
                    predicted: self.below(2) == 0,
                })
            }
            2 => {
                return Message::Led(LedRequest {
                    robot: self.byte(),
                    request: self.byte(),
                    at_us: self.next_u64() as u32,
                    delay_us: u32_field(self),
                    off_us: u32_field(self),
                })
            }
            _ => {}
        }
        if self.below(4) == 0 {
            Message::Heartbeat(Heartbeat {
                protocol_version: self.byte(),
                frame_rate_centihz: self.next_u64() as u16,
                dropped_frames: (self.next_u64() as u32) >> self.below(32),
                tracker_state: [
                    TrackerState::Starting,
                    TrackerState::Searching,
                    TrackerState::Tracking,
                    TrackerState::Coasting,
                ][self.below(4)],
            })
        } else {
            // Shift right by a random amount so every varint length occurs.
            let field = |r: &mut Self| (r.next_u64() as i16) >> r.below(16);
            let position = Position {
                seq: self.byte(),
                timestamp_us: self.next_u64() as u32,
                units: if self.below(2) == 0 {
                    Units::Floor
                } else {
                    Units::Pixels
                },
                x: field(self),
                y: field(self),
                vx_per_s: field(self),
                vy_per_s: field(self),
                status: [Status::Lost, Status::Found, Status::Predicted][self.below(3)],
                quality: self.byte(),
            };
            // A third of the updates addressed to one robot of several (version 3).
            if self.below(3) == 0 {
                Message::RobotPosition(RobotPosition {
                    robot: self.byte().max(1),
                    position,
                })
            } else {
                Message::Position(position)
            }
        }
    }
}
