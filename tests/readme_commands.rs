//! Every `glint ...` command shown in the READMEs (the project's, `board/`'s, the Pi's and
//! `tools/`') parses with glint's own command line (the binary's `cli` module, compiled in
//! here from its source, not a copy), and so does every `cargo run ... --bin glint-TOOL -- ...`
//! with that tool's own parser: a README cannot name an option that does not exist or drop one
//! that is required.
//!
//! Commands are taken from the README's fenced code blocks: lines starting with `glint `, with
//! `\`-continued lines joined, `# comments` and redirections cut, and output lines
//! (`glint demo: ...`) left out. Synopsis syntax is read as a user would:
//! `[...]` marks optional parts (kept, so that they are checked too), `a|b` offers choices (the
//! first is taken), `...` means "more of the same" (dropped), and upper-case placeholders get the
//! example values the README uses elsewhere. A settings file is spliced in as `glint run`
//! does, from this repository's copy of the file the README names.

// The binaries' argument parsing, compiled into this test: their `main` and helpers are not
// called here.
#[allow(dead_code)]
#[path = "../src/cli/mod.rs"]
mod cli;
#[allow(dead_code)]
#[path = "../tools/src/bin/glint-demo.rs"]
mod glint_demo;
#[allow(dead_code)]
#[path = "../tools/src/bin/glint-loop.rs"]
mod glint_loop;
#[allow(dead_code)]
#[path = "../tools/src/bin/glint-plot.rs"]
mod glint_plot;
#[allow(dead_code)]
#[path = "../tools/src/bin/glint-scene.rs"]
mod glint_scene;
#[allow(dead_code)]
#[path = "../tools/src/bin/glint-view.rs"]
mod glint_view;

use std::ffi::OsString;

use clap::{CommandFactory, Parser};

/// Example values for the README's placeholders.
const PLACEHOLDERS: [(&str, &str); 12] = [
    ("PATH", "run.yuv"),
    ("WxH", "640x480"),
    ("F", "30"),
    ("N", "1"),
    ("US", "2000"),
    ("ROW_US", "40"),
    ("PORT", "/dev/ttyUSB0"),
    ("SECONDS", "10"),
    ("NAME=VALUE", "sharpness=0"),
    ("MB", "256"),
    ("BAUD", "115200"),
    ("S", "7"),
];

/// Words that end a command on a shell line.
const SHELL_OPERATORS: [&str; 7] = [">", ">>", "<", "|", "&&", ";", "2>"];

/// The READMEs whose commands are checked.
const READMES: [&str; 4] = [
    include_str!("../README.md"),
    include_str!("../board/README.md"),
    include_str!("../board/raspberry-pi/README.md"),
    include_str!("../tools/README.md"),
];

/// Settings files the README names, and the file of this repository installed there.
const INSTALLED: [(&str, &str); 1] = [("/etc/glint/glint.toml", "board/raspberry-pi/glint.toml")];

/// The `glint` command lines in the fenced code blocks of `markdown`, each as its words.
fn commands(markdown: &str) -> Vec<Vec<String>> {
    let mut found = Vec::new();
    let mut in_block = false;
    let mut pending = String::new();
    for line in markdown.lines() {
        if line.trim_start().starts_with("```") {
            in_block = !in_block;
            pending.clear();
            continue;
        }
        if !in_block {
            continue;
        }
        let line = match line.find(" #") {
            Some(at) => &line[..at],
            None => line,
        };
        pending.push_str(line.trim());
        if let Some(joined) = pending.strip_suffix('\\') {
            pending = format!("{} ", joined.trim_end());
            continue;
        }
        let logical = std::mem::take(&mut pending);
        // `glint demo: scene ...` is output shown in a block, not a command.
        let is_output = logical
            .split_whitespace()
            .nth(1)
            .is_some_and(|w| w.ends_with(':'));
        if logical.starts_with("glint ") && !is_output {
            found.push(words(&logical));
        } else if let Some(tool) = tool_command(&logical) {
            found.push(words(&tool));
        }
    }
    found
}

/// A tool run through cargo (`cargo run ... --bin glint-view -- ARGS`) as the tool's own
/// command line (`glint-view ARGS`).
fn tool_command(line: &str) -> Option<String> {
    let cargo = &line[line.find("cargo run ")?..];
    let (before, args) = cargo.split_once(" -- ").unwrap_or((cargo, ""));
    let bin = before
        .split_whitespace()
        .skip_while(|w| *w != "--bin")
        .nth(1)?;
    Some(format!("{bin} {args}"))
}

/// The words of a synopsis line, read as the module documentation says.
fn words(line: &str) -> Vec<String> {
    line.split_whitespace()
        // The shell's redirections and pipes end the command.
        .take_while(|w| !SHELL_OPERATORS.contains(w))
        .map(|w| w.trim_matches(['[', ']']))
        .filter(|w| !w.is_empty() && *w != "...")
        .map(|w| {
            let first = w.split('|').next().unwrap_or(w);
            PLACEHOLDERS
                .iter()
                .find(|(name, _)| *name == first)
                .map_or(first, |(_, value)| value)
                .to_string()
        })
        .collect()
}

/// Parses `argv` as its program does (`glint`: the settings file spliced in first).
fn parse(argv: &[String]) -> Result<(), String> {
    let argv: Vec<OsString> = argv
        .iter()
        .map(|w| {
            let installed = INSTALLED.iter().find(|(path, _)| path == w);
            OsString::from(installed.map_or(w.as_str(), |(_, copy)| copy))
        })
        .collect();
    let render = |e: clap::Error| e.render().to_string();
    match argv.first().and_then(|a| a.to_str()) {
        Some("glint-demo") => glint_demo::Args::try_parse_from(&argv)
            .map(drop)
            .map_err(render),
        Some("glint-plot") => glint_plot::Args::try_parse_from(&argv)
            .map(drop)
            .map_err(render),
        Some("glint-scene") => glint_scene::Args::try_parse_from(&argv)
            .map(drop)
            .map_err(render),
        Some("glint-view") => glint_view::Args::try_parse_from(&argv)
            .map(drop)
            .map_err(render),
        Some("glint-loop") => glint_loop::Args::try_parse_from(&argv)
            .map(drop)
            .map_err(render),
        _ => {
            let spliced = cli::run_config::splice(argv, &cli::Cli::command())?;
            cli::Cli::try_parse_from(&spliced.argv)
                .map(drop)
                .map_err(render)
        }
    }
}

#[test]
fn every_readme_command_parses() {
    let commands: Vec<Vec<String>> = READMES.iter().flat_map(|r| commands(r)).collect();
    for tool in ["glint-demo", "glint-plot", "glint-scene", "glint-view"] {
        assert!(
            commands.iter().any(|c| c[0] == tool),
            "no {tool} command found"
        );
    }
    assert!(
        commands.len() >= 12,
        "found only {} commands: {commands:?}",
        commands.len()
    );
    let mut failures = Vec::new();
    for argv in &commands {
        if let Err(e) = parse(argv) {
            failures.push(format!("{}\n    {e}", argv.join(" ")));
        }
    }
    assert!(
        failures.is_empty(),
        "README commands that do not parse:\n{}",
        failures.join("\n")
    );
}

/// The extraction itself: continued lines, comments, options, choices and placeholders; and a
/// command with an unknown option is caught.
#[test]
fn synopses_are_read_as_a_user_reads_them() {
    let markdown = "text glint track --no\n```sh\nglint track --input PATH|- \\\n  \
                    --size WxH [--fps F] > t.jsonl  # comment\nglint: info: a log line\n\
                    glint demo: some output\n\
                    glint track --input x --size 2x2 --frobnicate [--control NAME=VALUE ...]\n\
                    ```\nglint track --outside\n";
    let found = commands(markdown);
    assert_eq!(
        found,
        vec![
            vec!["glint", "track", "--input", "run.yuv", "--size", "640x480", "--fps", "30"],
            vec![
                "glint",
                "track",
                "--input",
                "x",
                "--size",
                "2x2",
                "--frobnicate",
                "--control",
                "sharpness=0"
            ],
        ]
    );
    assert!(parse(&found[0]).is_ok());
    assert!(parse(&found[1]).is_err());
    let demo = "x && cargo run --release -p glint-tools --bin glint-demo";
    assert_eq!(words(&tool_command(demo).unwrap()), ["glint-demo"]);
    let view = "cargo run -p glint-tools --bin glint-view -- --input a.yuv --size WxH --frame 1";
    let view = words(&tool_command(view).unwrap());
    assert!(parse(&view).is_err(), "--out is required: {view:?}");
    let mut view = view;
    view.extend(["--out".into(), "a.png".into()]);
    assert!(parse(&view).is_ok(), "{view:?}");
}
