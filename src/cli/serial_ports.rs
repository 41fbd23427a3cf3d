//! `--serial`: one line for every robot (`--serial PORT`: a UART, or a radio bridge that
//! reaches them all), or one line per robot (`--serial ID=PORT`, repeated). Parsed and checked
//! here, before anything is opened, so that a bad combination is one clear line.

use std::collections::BTreeMap;

use glint::identify::MAX_ROBOTS;

/// One `--serial` value.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SerialArg {
    /// `PORT`: a line every robot listens on.
    Shared(String),
    /// `ID=PORT`: robot `id`'s own line.
    Robot {
        /// The robot's id, 1..=[`MAX_ROBOTS`].
        id: u8,
        /// The port's path.
        port: String,
    },
}

/// The serial lines a run asks for, checked.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SerialPlan {
    /// No `--serial`.
    None,
    /// One line for every robot.
    Shared(String),
    /// One line per robot, by id (at least one; ids distinct, in order).
    PerRobot(BTreeMap<u8, String>),
}

/// Parses one `--serial` value: `ID=PORT` when what comes before the first `=` is a number,
/// `PORT` otherwise.
pub fn parse_serial(text: &str) -> Result<SerialArg, String> {
    let Some((id, port)) = text
        .split_once('=')
        .filter(|(id, _)| !id.is_empty() && id.bytes().all(|b| b.is_ascii_digit()))
    else {
        if text.is_empty() {
            return Err("an empty port name".to_string());
        }
        return Ok(SerialArg::Shared(text.to_string()));
    };
    let id = id
        .parse::<u8>()
        .ok()
        .filter(|&id| id >= 1 && usize::from(id) <= MAX_ROBOTS)
        .ok_or_else(|| {
            format!("robot id {id}: ids go from 1 to {MAX_ROBOTS} (the most robots glint follows)")
        })?;
    if port.is_empty() {
        return Err(format!("robot {id} has an empty port name"));
    }
    Ok(SerialArg::Robot {
        id,
        port: port.to_string(),
    })
}

/// Checks the `--serial` values together: one shared line, or distinct robots' own lines.
pub fn plan(args: &[SerialArg]) -> Result<SerialPlan, String> {
    let mut shared = None;
    let mut per_robot = BTreeMap::new();
    for arg in args {
        match arg {
            SerialArg::Shared(port) => {
                if let Some(first) = shared.replace(port) {
                    return Err(format!(
                        "--serial {first} and --serial {port}: one line serves every robot; for \
                         one line per robot give --serial ID=PORT for each"
                    ));
                }
            }
            SerialArg::Robot { id, port } => {
                if let Some(first) = per_robot.insert(*id, port.clone()) {
                    return Err(format!(
                        "robot {id} is given two serial ports (--serial {id}={first} and \
                         --serial {id}={port})"
                    ));
                }
            }
        }
    }
    match (shared, per_robot.is_empty()) {
        (None, true) => Ok(SerialPlan::None),
        (Some(port), true) => Ok(SerialPlan::Shared(port.clone())),
        (None, false) => Ok(SerialPlan::PerRobot(per_robot)),
        (Some(port), false) => Err(format!(
            "--serial {port} (one line for every robot) and --serial ID=PORT (a line per robot) \
             do not mix: give one or the other"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parsed(values: &[&str]) -> Result<SerialPlan, String> {
        let args: Vec<SerialArg> = values
            .iter()
            .map(|v| parse_serial(v))
            .collect::<Result<_, _>>()?;
        plan(&args)
    }

    #[test]
    fn a_port_and_robot_ports_parse() {
        assert_eq!(
            parse_serial("/dev/ttyAMA0"),
            Ok(SerialArg::Shared("/dev/ttyAMA0".into()))
        );
        assert_eq!(
            parse_serial("2=/dev/ttyUSB1"),
            Ok(SerialArg::Robot {
                id: 2,
                port: "/dev/ttyUSB1".into()
            })
        );
        // Only a number before the `=` makes it a robot's port.
        assert_eq!(
            parse_serial("/dev/serial/by-id/a=b"),
            Ok(SerialArg::Shared("/dev/serial/by-id/a=b".into()))
        );
        let plan = parsed(&["3=/dev/c", "1=/dev/a"]).expect("valid");
        let SerialPlan::PerRobot(ports) = plan else {
            panic!("{plan:?}")
        };
        assert_eq!(
            ports.into_iter().collect::<Vec<_>>(),
            [(1, "/dev/a".to_string()), (3, "/dev/c".to_string())]
        );
        assert_eq!(parsed(&[]), Ok(SerialPlan::None));
        assert_eq!(parsed(&["/dev/x"]), Ok(SerialPlan::Shared("/dev/x".into())));
    }

    #[test]
    fn bad_values_and_combinations_get_one_clear_line() {
        for (values, expected) in [
            (
                &["1=/dev/a", "1=/dev/b"][..],
                "robot 1 is given two serial ports",
            ),
            (&["/dev/a", "/dev/b"][..], "one line serves every robot"),
            (&["/dev/a", "2=/dev/b"][..], "do not mix"),
            (&["0=/dev/a"][..], "robot id 0: ids go from 1 to 16"),
            (&["17=/dev/a"][..], "robot id 17: ids go from 1 to 16"),
            (&["300=/dev/a"][..], "robot id 300"),
            (&["4="][..], "robot 4 has an empty port name"),
            (&[""][..], "an empty port name"),
        ] {
            let error = parsed(values).expect_err("refused");
            assert!(error.contains(expected), "{values:?}: {error}");
            assert!(!error.contains('\n'), "{error}");
        }
    }
}
