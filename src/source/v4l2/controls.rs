//! Camera controls: what a camera exposes, and setting the few that matter for LED tracking
//! (a short manual exposure makes the LED the only saturated thing and shortens its streaks)
//! plus any other by name, with a report of what was set and what the camera refused.

use core::fmt;
use core::str::FromStr;
use std::io;
use std::os::raw::c_int;

use v4l::v4l_sys::{
    V4L2_CID_AUTO_WHITE_BALANCE, V4L2_CID_EXPOSURE_ABSOLUTE, V4L2_CID_EXPOSURE_AUTO, V4L2_CID_GAIN,
    V4L2_CID_POWER_LINE_FREQUENCY, V4L2_CTRL_FLAG_DISABLED, V4L2_CTRL_FLAG_READ_ONLY,
};

use super::sys::{self, ControlDesc};

/// V4L2's `exposure_time_absolute` counts in units of 100 µs.
pub const EXPOSURE_UNIT_US: u32 = 100;

/// `V4L2_CTRL_TYPE_*` values glint can set.
const TYPE_INTEGER: u32 = 1;
const TYPE_BOOLEAN: u32 = 2;
const TYPE_MENU: u32 = 3;
const TYPE_CTRL_CLASS: u32 = 6;
const TYPE_INTEGER_MENU: u32 = 9;

/// `V4L2_EXPOSURE_*` menu items of `auto_exposure`, in the order "auto on" tries them: full
/// auto, then aperture priority (what most UVC webcams call auto), then shutter priority.
const EXPOSURE_AUTO_MODES: [i64; 3] = [0, 3, 2];
const EXPOSURE_MANUAL: i64 = 1;

/// Menus longer than this are not listed item by item.
const MAX_MENU_ITEMS: i64 = 64;

/// The mains frequency the camera should filter flicker of.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PowerLine {
    Disabled,
    Hz50,
    Hz60,
    Auto,
}

impl PowerLine {
    /// The `V4L2_CID_POWER_LINE_FREQUENCY_*` menu index.
    fn menu_index(self) -> i64 {
        match self {
            PowerLine::Disabled => 0,
            PowerLine::Hz50 => 1,
            PowerLine::Hz60 => 2,
            PowerLine::Auto => 3,
        }
    }
}

impl FromStr for PowerLine {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "off" | "disabled" | "0" => Ok(PowerLine::Disabled),
            "50" | "50hz" => Ok(PowerLine::Hz50),
            "60" | "60hz" => Ok(PowerLine::Hz60),
            "auto" => Ok(PowerLine::Auto),
            _ => Err(format!(
                "power-line frequency {s:?} is not one of off, 50, 60, auto"
            )),
        }
    }
}

/// `NAME=VALUE` for any control, by its name as `v4l2-ctl` prints it (`white_balance_automatic`).
/// The value is a number, a boolean word (`on`, `off`, `true`, `false`) or a menu item's name.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NamedControl {
    pub name: String,
    pub value: String,
}

impl FromStr for NamedControl {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.split_once('=') {
            Some((name, value)) if !name.trim().is_empty() && !value.trim().is_empty() => {
                Ok(NamedControl {
                    name: control_key(name.trim()),
                    value: value.trim().to_string(),
                })
            }
            _ => Err(format!("control {s:?} is not NAME=VALUE")),
        }
    }
}

/// The controls to set when a camera is opened (and again whenever it is reopened).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ControlRequest {
    /// Manual exposure time; implies auto exposure off unless `auto_exposure` says otherwise.
    pub exposure_us: Option<u32>,
    pub gain: Option<i64>,
    pub auto_exposure: Option<bool>,
    pub auto_white_balance: Option<bool>,
    pub power_line: Option<PowerLine>,
    pub named: Vec<NamedControl>,
}

impl ControlRequest {
    /// Whether nothing is asked for.
    pub fn is_empty(&self) -> bool {
        *self == ControlRequest::default()
    }
}

/// Why a camera did not take a control.
#[derive(Debug)]
pub enum Refusal {
    /// The camera has no such control.
    Missing,
    /// The control exists but cannot be written (read-only or disabled).
    NotWritable,
    /// The value is outside the control's range.
    OutOfRange { minimum: i64, maximum: i64 },
    /// The value names no item of the control's menu.
    NotInMenu { items: Vec<String> },
    /// The value is not a number, boolean or menu item.
    BadValue,
    /// Only integer, boolean and menu controls can be set.
    UnsupportedType(u32),
    /// The driver returned an error.
    Driver(io::Error),
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refusal::Missing => write!(f, "the camera has no such control"),
            Refusal::NotWritable => write!(f, "the control is read-only or disabled"),
            Refusal::OutOfRange { minimum, maximum } => {
                write!(f, "out of range {minimum}..={maximum}")
            }
            Refusal::NotInMenu { items } => write!(f, "not one of {}", items.join(", ")),
            Refusal::BadValue => write!(f, "not a number, boolean or menu item"),
            Refusal::UnsupportedType(t) => write!(f, "controls of V4L2 type {t} cannot be set"),
            Refusal::Driver(e) => write!(f, "the driver refused: {e}"),
        }
    }
}

/// What happened to one requested control.
#[derive(Debug)]
pub struct ControlOutcome {
    /// The control's key, e.g. `exposure_time_absolute`.
    pub name: String,
    /// What was asked, as the user wrote it (with units where glint converted).
    pub requested: String,
    /// The value the camera reports after setting it, or why it refused.
    pub result: Result<i64, Refusal>,
}

/// Which requested controls a camera took and which it refused.
#[derive(Debug, Default)]
pub struct ControlReport {
    pub outcomes: Vec<ControlOutcome>,
}

impl ControlReport {
    /// The outcomes the camera refused.
    pub fn refused(&self) -> impl Iterator<Item = &ControlOutcome> {
        self.outcomes.iter().filter(|o| o.result.is_err())
    }
}

impl fmt::Display for ControlReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, outcome) in self.outcomes.iter().enumerate() {
            if i > 0 {
                write!(f, "; ")?;
            }
            match &outcome.result {
                Ok(now) => write!(
                    f,
                    "set {} = {} (now {now})",
                    outcome.name, outcome.requested
                )?,
                Err(why) => write!(f, "refused {} = {}: {why}", outcome.name, outcome.requested)?,
            }
        }
        Ok(())
    }
}

/// One control as listed by `glint devices`.
#[derive(Debug, Clone)]
pub struct ControlInfo {
    /// The key used in `--control NAME=VALUE`.
    pub key: String,
    pub desc: ControlDesc,
    /// `(index, name)` of each menu item the driver lists.
    pub menu: Vec<(i64, String)>,
    /// The current value, when it can be read as a 32-bit value.
    pub value: Option<i32>,
}

impl fmt::Display for ControlInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let d = &self.desc;
        write!(f, "{} ({}", self.key, type_name(d.kind))?;
        if matches!(d.kind, TYPE_INTEGER) {
            write!(f, " {}..={} step {}", d.minimum, d.maximum, d.step)?;
        }
        write!(f, ", default {}", d.default)?;
        if let Some(v) = self.value {
            write!(f, ", now {v}")?;
        }
        if d.flags & V4L2_CTRL_FLAG_READ_ONLY != 0 {
            write!(f, ", read-only")?;
        }
        write!(f, ")")?;
        if !self.menu.is_empty() {
            let items: Vec<String> = self.menu.iter().map(|(i, n)| format!("{i}={n}")).collect();
            write!(f, " [{}]", items.join(", "))?;
        }
        Ok(())
    }
}

fn type_name(kind: u32) -> &'static str {
    match kind {
        TYPE_INTEGER => "int",
        TYPE_BOOLEAN => "bool",
        TYPE_MENU => "menu",
        TYPE_INTEGER_MENU => "intmenu",
        4 => "button",
        5 => "int64",
        7 => "string",
        8 => "bitmask",
        _ => "compound",
    }
}

/// A control's name as a key: lower case, runs of other characters turned into one `_`, the
/// way `v4l2-ctl` names them ("Exposure Time, Absolute" → `exposure_time_absolute`).
pub fn control_key(name: &str) -> String {
    let mut key = String::with_capacity(name.len());
    let mut pending_underscore = false;
    for c in name.chars() {
        if c.is_ascii_alphanumeric() {
            if pending_underscore {
                key.push('_');
            }
            pending_underscore = false;
            key.push(c.to_ascii_lowercase());
        } else if !key.is_empty() {
            pending_underscore = true;
        }
    }
    key
}

/// Every control of the node, with menu items and current values (class headings skipped).
pub fn list_controls(fd: c_int) -> io::Result<Vec<ControlInfo>> {
    let descs = sys::query_controls(fd)?;
    Ok(descs
        .into_iter()
        .filter(|d| d.kind != TYPE_CTRL_CLASS)
        .map(|desc| {
            let menu = menu_items(fd, &desc);
            let value = if matches!(
                desc.kind,
                TYPE_INTEGER | TYPE_BOOLEAN | TYPE_MENU | TYPE_INTEGER_MENU
            ) && desc.flags & V4L2_CTRL_FLAG_DISABLED == 0
            {
                sys::get_control(fd, desc.id).ok()
            } else {
                None
            };
            ControlInfo {
                key: control_key(&desc.name),
                desc,
                menu,
                value,
            }
        })
        .collect())
}

fn menu_items(fd: c_int, desc: &ControlDesc) -> Vec<(i64, String)> {
    if !matches!(desc.kind, TYPE_MENU | TYPE_INTEGER_MENU)
        || desc.minimum < 0
        || desc.maximum.saturating_sub(desc.minimum) > MAX_MENU_ITEMS
    {
        return Vec::new();
    }
    (desc.minimum..=desc.maximum)
        .filter_map(|index| {
            let name = sys::query_menu_item(
                fd,
                desc.id,
                u32::try_from(index).ok()?,
                desc.kind == TYPE_INTEGER_MENU,
            )?;
            Some((index, name))
        })
        .collect()
}

/// Sets the requested controls, in an order that lets each take effect (auto exposure off
/// before the exposure time), and reports each outcome. Never fails as a whole: a camera that
/// refuses a control still captures.
pub fn apply_controls(fd: c_int, request: &ControlRequest) -> ControlReport {
    let controls = match list_controls(fd) {
        Ok(controls) => controls,
        Err(e) => {
            log::warn!("cannot list the camera's controls: {e}");
            Vec::new()
        }
    };
    let by_id = |id: u32| controls.iter().find(|c| c.desc.id == id);
    let mut report = ControlReport::default();
    let mut push = |name: &str, requested: String, result| {
        report.outcomes.push(ControlOutcome {
            name: name.to_string(),
            requested,
            result,
        })
    };

    let auto_exposure = request.auto_exposure.or(request.exposure_us.map(|_| false));
    if let Some(on) = auto_exposure {
        let result = match by_id(V4L2_CID_EXPOSURE_AUTO) {
            None => Err(Refusal::Missing),
            Some(c) if on => {
                let mode = EXPOSURE_AUTO_MODES
                    .iter()
                    .find(|&&m| c.menu.iter().any(|(i, _)| *i == m));
                match mode {
                    Some(&m) => set_value(fd, c, m),
                    None => Err(Refusal::NotInMenu {
                        items: c.menu.iter().map(|(_, n)| n.clone()).collect(),
                    }),
                }
            }
            Some(c) => set_value(fd, c, EXPOSURE_MANUAL),
        };
        push(
            "auto_exposure",
            if on { "on" } else { "off" }.into(),
            result,
        );
    }
    if let Some(exposure_us) = request.exposure_us {
        let units = i64::from(exposure_us.saturating_add(EXPOSURE_UNIT_US / 2) / EXPOSURE_UNIT_US);
        let result = match by_id(V4L2_CID_EXPOSURE_ABSOLUTE) {
            None => Err(Refusal::Missing),
            Some(c) => set_value(fd, c, units),
        };
        push(
            "exposure_time_absolute",
            format!("{units} ({exposure_us} µs in 100 µs units)"),
            result,
        );
    }
    if let Some(gain) = request.gain {
        let result = by_id(V4L2_CID_GAIN).map_or(Err(Refusal::Missing), |c| set_value(fd, c, gain));
        push("gain", gain.to_string(), result);
    }
    if let Some(on) = request.auto_white_balance {
        let result = by_id(V4L2_CID_AUTO_WHITE_BALANCE)
            .map_or(Err(Refusal::Missing), |c| set_value(fd, c, i64::from(on)));
        push(
            "white_balance_automatic",
            if on { "on" } else { "off" }.into(),
            result,
        );
    }
    if let Some(freq) = request.power_line {
        let result = by_id(V4L2_CID_POWER_LINE_FREQUENCY).map_or(Err(Refusal::Missing), |c| {
            set_value(fd, c, freq.menu_index())
        });
        push("power_line_frequency", format!("{freq:?}"), result);
    }
    for named in &request.named {
        let result = match controls.iter().find(|c| c.key == named.name) {
            None => Err(Refusal::Missing),
            Some(c) => parse_value(c, &named.value).and_then(|v| set_value(fd, c, v)),
        };
        push(&named.name, named.value.clone(), result);
    }
    report
}

/// A `--control` value for this control: a number, a boolean word, or a menu item's name.
fn parse_value(control: &ControlInfo, text: &str) -> Result<i64, Refusal> {
    if let Ok(v) = text.parse::<i64>() {
        return Ok(v);
    }
    match text.to_ascii_lowercase().as_str() {
        "on" | "true" | "yes" => return Ok(1),
        "off" | "false" | "no" => return Ok(0),
        _ => {}
    }
    let wanted = control_key(text);
    match control
        .menu
        .iter()
        .find(|(_, name)| control_key(name) == wanted)
    {
        Some((index, _)) => Ok(*index),
        None if control.menu.is_empty() => Err(Refusal::BadValue),
        None => Err(Refusal::NotInMenu {
            items: control.menu.iter().map(|(_, n)| n.clone()).collect(),
        }),
    }
}

/// Checks `value` against what the control declares, sets it and reads back what it became.
fn set_value(fd: c_int, control: &ControlInfo, value: i64) -> Result<i64, Refusal> {
    let d = &control.desc;
    if !matches!(
        d.kind,
        TYPE_INTEGER | TYPE_BOOLEAN | TYPE_MENU | TYPE_INTEGER_MENU
    ) {
        return Err(Refusal::UnsupportedType(d.kind));
    }
    if d.flags & (V4L2_CTRL_FLAG_READ_ONLY | V4L2_CTRL_FLAG_DISABLED) != 0 {
        return Err(Refusal::NotWritable);
    }
    if value < d.minimum || value > d.maximum {
        return Err(Refusal::OutOfRange {
            minimum: d.minimum,
            maximum: d.maximum,
        });
    }
    if matches!(d.kind, TYPE_MENU | TYPE_INTEGER_MENU)
        && !control.menu.iter().any(|(i, _)| *i == value)
    {
        return Err(Refusal::NotInMenu {
            items: control
                .menu
                .iter()
                .map(|(i, n)| format!("{i}={n}"))
                .collect(),
        });
    }
    let value32 = i32::try_from(value).map_err(|_| Refusal::OutOfRange {
        minimum: i64::from(i32::MIN),
        maximum: i64::from(i32::MAX),
    })?;
    sys::set_control(fd, d.id, value32).map_err(Refusal::Driver)?;
    sys::get_control(fd, d.id)
        .map(i64::from)
        .map_err(Refusal::Driver)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_names_become_v4l2_ctl_keys() {
        assert_eq!(
            control_key("Exposure Time, Absolute"),
            "exposure_time_absolute"
        );
        assert_eq!(
            control_key("White Balance, Automatic"),
            "white_balance_automatic"
        );
        assert_eq!(control_key("  Gain  "), "gain");
        assert_eq!(control_key("Power Line Frequency"), "power_line_frequency");
    }

    #[test]
    fn named_controls_parse_and_normalise() {
        let c: NamedControl = "Brightness=128".parse().unwrap();
        assert_eq!((c.name.as_str(), c.value.as_str()), ("brightness", "128"));
        assert!("brightness".parse::<NamedControl>().is_err());
        assert!("=3".parse::<NamedControl>().is_err());
        assert!("gain=".parse::<NamedControl>().is_err());
    }

    #[test]
    fn power_line_words() {
        assert_eq!("50".parse(), Ok(PowerLine::Hz50));
        assert_eq!("60Hz".parse(), Ok(PowerLine::Hz60));
        assert_eq!("off".parse(), Ok(PowerLine::Disabled));
        assert!("55".parse::<PowerLine>().is_err());
    }

    fn menu_control() -> ControlInfo {
        ControlInfo {
            key: "power_line_frequency".into(),
            desc: ControlDesc {
                id: V4L2_CID_POWER_LINE_FREQUENCY,
                kind: TYPE_MENU,
                name: "Power Line Frequency".into(),
                minimum: 0,
                maximum: 2,
                step: 1,
                default: 1,
                flags: 0,
            },
            menu: vec![
                (0, "Disabled".into()),
                (1, "50 Hz".into()),
                (2, "60 Hz".into()),
            ],
            value: Some(1),
        }
    }

    #[test]
    fn values_parse_as_numbers_words_or_menu_items() {
        let c = menu_control();
        assert_eq!(parse_value(&c, "2").ok(), Some(2));
        assert_eq!(parse_value(&c, "on").ok(), Some(1));
        assert_eq!(parse_value(&c, "60 hz").ok(), Some(2));
        assert!(matches!(
            parse_value(&c, "70 Hz"),
            Err(Refusal::NotInMenu { .. })
        ));
    }

    #[test]
    fn out_of_range_and_read_only_values_are_refused_before_the_driver() {
        let mut c = menu_control();
        // fd -1: reaching the driver would fail with EBADF, so these refusals come first.
        assert!(matches!(
            set_value(-1, &c, 5),
            Err(Refusal::OutOfRange {
                minimum: 0,
                maximum: 2
            })
        ));
        c.desc.flags = V4L2_CTRL_FLAG_READ_ONLY;
        assert!(matches!(set_value(-1, &c, 1), Err(Refusal::NotWritable)));
        c.desc.flags = 0;
        assert!(matches!(set_value(-1, &c, 1), Err(Refusal::Driver(_))));
    }
}
