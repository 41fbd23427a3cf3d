//! The settings file of `glint run` (`--config FILE`, TOML): its keys are the command's own
//! long option names (`device = "/dev/video0"`, `exposure-us = 2000`, `stats = true`), so the
//! file, the command line and `glint run --help` can never drift apart.
//!
//! The file is turned into options and spliced in before those of the command line, which clap
//! then parses once, as if all had been typed: every value goes through the same checks as on
//! the command line, and a later option (the command line's) overrides an earlier one (the
//! file's). What clap cannot see is checked here: a key that is no option of `glint run`, and a
//! value of the wrong TOML type. Each message names the file and the key.
//!
//! Values: a string or a number is the option's value; `true` gives a switch (`stats = true`) or
//! an option whose value may be left out (`preview = true`), `false` leaves it off; a list gives a repeatable option once per item
//! (`control = ["sharpness=0", "contrast=32"]`).

use std::collections::BTreeSet;
use std::ffi::OsString;
use std::path::PathBuf;

use clap::error::{ContextKind, ContextValue};
use clap::{ArgAction, Command};
use glint::options::shortened;
use glint::small_file;
use toml::Value;

/// The subcommand that takes a settings file.
const RUN: &str = "run";
/// The option naming the settings file.
const CONFIG: &str = "config";
/// Options that make no sense inside the file.
const NOT_IN_FILE: [&str; 3] = [CONFIG, "help", "version"];

/// The command line with the settings file's options spliced in.
#[derive(Debug)]
pub struct Spliced {
    pub argv: Vec<OsString>,
    /// Where the file's options came from, for error messages.
    pub origin: Option<Origin>,
}

/// The settings file and the keys it set that the command line did not override.
#[derive(Debug)]
pub struct Origin {
    path: PathBuf,
    keys: BTreeSet<String>,
}

impl Spliced {
    /// Prefixes a command-line error about an option that came from the file with the file and
    /// the key, so `fps = -3` reads `glint.toml: key `fps`: invalid value ...`.
    pub fn attribute(&self, error: &clap::Error, message: String) -> String {
        let Some(origin) = &self.origin else {
            return message;
        };
        let Some(ContextValue::String(arg)) = error.get(ContextKind::InvalidArg) else {
            return message;
        };
        // "--fps <FPS>" → "fps"
        let key = arg
            .trim_start_matches("--")
            .split([' ', '='])
            .next()
            .unwrap_or_default();
        if origin.keys.contains(key) {
            format!("{}: key `{key}`: {message}", origin.path.display())
        } else {
            message
        }
    }
}

/// Splices the settings file named by `glint run --config FILE` into `argv`; any other command
/// line comes back unchanged. `cli` is the whole command, for `run`'s option names.
pub fn splice(argv: Vec<OsString>, cli: &Command) -> Result<Spliced, String> {
    let unchanged = |argv| Spliced { argv, origin: None };
    // Global switches (`-v`) come before the subcommand; none takes a value.
    let Some(run_at) = argv
        .iter()
        .skip(1)
        .position(|a| !a.to_string_lossy().starts_with('-'))
        .map(|i| i + 1)
    else {
        return Ok(unchanged(argv));
    };
    let Some(run) = cli.find_subcommand(RUN).filter(|_| argv[run_at] == RUN) else {
        return Ok(unchanged(argv));
    };
    let given = &argv[run_at + 1..];
    let Some(path) = config_path(given) else {
        return Ok(unchanged(argv));
    };
    let text = small_file::read_text(&path, small_file::MAX_SETTINGS_BYTES)
        .map_err(|e| format!("cannot read settings {}: {e}", path.display()))?;
    let settings = to_options(&text, run).map_err(|e| format!("{}: {e}", path.display()))?;
    let overridden = overridden_keys(given, run);
    let mut spliced = argv[..=run_at].to_vec();
    let mut keys = BTreeSet::new();
    for (key, options) in settings {
        if !overridden.contains(&key) {
            spliced.extend(options);
            keys.insert(key);
        }
    }
    spliced.extend_from_slice(given);
    Ok(Spliced {
        argv: spliced,
        origin: Some(Origin { path, keys }),
    })
}

/// The keys the command line overrides: the options it names, and the other members of a
/// one-of group it names one of (`--input` replaces the file's `device`).
fn overridden_keys(given: &[OsString], run: &Command) -> BTreeSet<String> {
    let mut keys = long_names(given);
    let long_of = |id: &clap::Id| {
        run.get_arguments()
            .find(|a| a.get_id() == id)
            .and_then(|a| a.get_long())
    };
    for group in run.get_groups() {
        let members: Vec<&str> = group.get_args().filter_map(long_of).collect();
        if !group.clone().is_multiple() && members.iter().any(|m| keys.contains(*m)) {
            keys.extend(members.iter().map(|m| (*m).to_owned()));
        }
    }
    keys
}

/// The value of `--config FILE` or `--config=FILE`.
fn config_path(args: &[OsString]) -> Option<PathBuf> {
    let flag = format!("--{CONFIG}");
    let with_eq = format!("--{CONFIG}=");
    args.iter().enumerate().find_map(|(i, a)| {
        let a = a.to_str()?;
        if a == flag {
            args.get(i + 1).map(PathBuf::from)
        } else {
            a.strip_prefix(&with_eq).map(PathBuf::from)
        }
    })
}

/// The long option names among `args` (`--fps 15`, `--fps=15`).
fn long_names(args: &[OsString]) -> BTreeSet<String> {
    args.iter()
        .filter_map(|a| a.to_str()?.strip_prefix("--"))
        .map(|a| a.split('=').next().unwrap_or_default().to_owned())
        .collect()
}

/// The file's settings as options of `run`, by key.
fn to_options(text: &str, run: &Command) -> Result<Vec<(String, Vec<OsString>)>, String> {
    let table: toml::Table = toml::from_str(text).map_err(|e| syntax_error(text, &e))?;
    let mut settings = Vec::new();
    for (key, value) in &table {
        let mut options = Vec::new();
        let arg = run
            .get_arguments()
            .find(|a| a.get_long() == Some(key.as_str()))
            .filter(|_| !NOT_IN_FILE.contains(&key.as_str()))
            .ok_or_else(|| {
                format!(
                    "unknown key `{}` (the keys are `glint run` options)",
                    shortened(key)
                )
            })?;
        let flag = || OsString::from(format!("--{key}"));
        let with_value = |v: &Value| scalar(v).map(|s| OsString::from(format!("--{key}={s}")));
        let wrong = |what: &str| format!("key `{key}`: {what}, not {}", describe(value));
        match (arg.get_action(), value) {
            (ArgAction::SetTrue, Value::Boolean(on)) => {
                if *on {
                    options.push(flag());
                }
            }
            (ArgAction::SetTrue, _) => return Err(wrong("a switch takes true or false")),
            // An option whose value may be left out (`--preview`): `true` is the option alone.
            (_, Value::Boolean(on)) if arg.get_num_args().is_some_and(|n| n.min_values() == 0) => {
                if *on {
                    options.push(flag());
                }
            }
            (ArgAction::Append, Value::Array(items)) => {
                for item in items {
                    options.push(with_value(item).ok_or_else(|| {
                        format!(
                            "key `{key}`: list items are strings or numbers, not {}",
                            describe(item)
                        )
                    })?);
                }
            }
            (_, v) => {
                options.push(with_value(v).ok_or_else(|| wrong("expected one string or number"))?)
            }
        }
        settings.push((key.clone(), options));
    }
    Ok(settings)
}

/// A string or number as an option value.
fn scalar(value: &Value) -> Option<String> {
    match value {
        Value::String(s) => Some(s.clone()),
        Value::Integer(i) => Some(i.to_string()),
        Value::Float(f) => Some(f.to_string()),
        _ => None,
    }
}

/// A value's kind, for messages.
fn describe(value: &Value) -> String {
    match value {
        Value::String(s) => format!("the string {:?}", shortened(s)),
        Value::Integer(i) => format!("the number {i}"),
        Value::Float(f) => format!("the number {f}"),
        Value::Boolean(b) => format!("{b}"),
        Value::Datetime(d) => format!("the date {d}"),
        Value::Array(_) => "a list".to_owned(),
        Value::Table(_) => "a table".to_owned(),
    }
}

/// A TOML syntax error on one line: `line 3: expected ...`.
fn syntax_error(text: &str, error: &toml::de::Error) -> String {
    let message = error.message().trim().replace('\n', " ");
    match error.span() {
        Some(span) => {
            let line = text
                .get(..span.start)
                .map_or(0, |before| before.matches('\n').count())
                + 1;
            format!("line {line}: {message}")
        }
        None => message,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    fn cli() -> Command {
        super::super::Cli::command()
    }

    fn splice_text(text: &str, cli_args: &[&str]) -> Result<Spliced, String> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("glint.toml");
        std::fs::write(&path, text).unwrap();
        let mut argv: Vec<OsString> = ["glint", "-v", "run", "--config"]
            .iter()
            .map(OsString::from)
            .collect();
        argv.push(path.into_os_string());
        argv.extend(cli_args.iter().map(OsString::from));
        splice(argv, &cli())
    }

    #[test]
    fn file_options_come_before_the_command_line_s() {
        let s = splice_text(
            "input = \"-\"\nsize = \"64x48\"\nfps = 12.5\nstats = true\nno-sidecar = false\n\
             gain = -3\ncontrol = [\"a=1\", \"b=2\"]\n",
            &["--fps", "20", "--device", "/dev/video9"],
        )
        .unwrap();
        let argv: Vec<&str> = s.argv.iter().map(|a| a.to_str().unwrap()).collect();
        let run = argv.iter().position(|a| *a == "run").unwrap();
        for option in [
            "--size=64x48",
            "--stats",
            "--gain=-3",
            "--control=a=1",
            "--control=b=2",
        ] {
            let at = argv.iter().position(|a| *a == option);
            let cli_fps = argv.iter().position(|a| *a == "20").unwrap();
            assert!(
                at.is_some_and(|at| run < at && at < cli_fps),
                "{option} in {argv:?}"
            );
        }
        assert!(!argv.iter().any(|a| a.contains("no-sidecar")), "{argv:?}");
        assert!(!argv.contains(&"--fps=12.5"), "overridden: {argv:?}");
        assert!(
            !argv.contains(&"--input=-"),
            "--device replaces input: {argv:?}"
        );
        let origin = s.origin.unwrap();
        assert!(origin.keys.contains("size"));
        assert!(
            !origin.keys.contains("fps"),
            "overridden on the command line"
        );
        assert_eq!(argv[0], "glint");
    }

    #[test]
    fn preview_takes_an_address_or_true() {
        let options = |text: &str| -> Vec<String> {
            let s = splice_text(text, &[]).unwrap();
            let argv = s.argv.iter().map(|a| a.to_string_lossy().into_owned());
            argv.filter(|a| a.starts_with("--preview")).collect()
        };
        assert_eq!(options("preview = true\n"), ["--preview"]);
        assert_eq!(options("preview = false\n"), Vec::<String>::new());
        assert_eq!(
            options("preview = \"0.0.0.0:9000\"\n"),
            ["--preview=0.0.0.0:9000"]
        );
        // A switch-less option without a missing value still wants one.
        assert!(splice_text("fps = true\n", &[]).is_err());
    }

    #[test]
    fn every_bad_file_names_its_key_or_line() {
        let cases = [
            ("devise = \"/dev/video0\"\n", "unknown key `devise`"),
            ("config = \"other.toml\"\n", "unknown key `config`"),
            (
                "stats = \"yes\"\n",
                "key `stats`: a switch takes true or false",
            ),
            (
                "size = [640, 480]\n",
                "key `size`: expected one string or number",
            ),
            (
                "fps = { a = 1 }\n",
                "key `fps`: expected one string or number, not a table",
            ),
            ("control = [[1]]\n", "key `control`: list items"),
            ("size = \"640x480\"\nfps = \n", "line 2: "),
        ];
        for (text, want) in cases {
            let e = splice_text(text, &[]).unwrap_err();
            assert!(e.contains(want), "{text:?}: {e}");
            assert!(e.contains("glint.toml: "), "{e}");
            assert!(!e.contains('\n'), "one line: {e:?}");
        }
    }

    #[test]
    fn other_commands_and_runs_without_a_file_are_left_alone() {
        for line in [
            &["glint", "track", "--config", "x"][..],
            &["glint", "run", "--size", "64x48"],
            &["glint"],
        ] {
            let argv: Vec<OsString> = line.iter().map(OsString::from).collect();
            let s = splice(argv.clone(), &cli()).unwrap();
            assert_eq!(s.argv, argv);
            assert!(s.origin.is_none());
        }
    }

    #[test]
    fn a_missing_file_is_an_error() {
        let argv: Vec<OsString> = ["glint", "run", "--config=/nonexistent/glint.toml"]
            .iter()
            .map(OsString::from)
            .collect();
        let e = splice(argv, &cli()).unwrap_err();
        assert!(
            e.contains("cannot read settings /nonexistent/glint.toml: "),
            "{e}"
        );
    }
}
