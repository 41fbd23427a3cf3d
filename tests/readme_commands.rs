//! Every `glint ...` command shown in the READMEs (the project's, `board/`'s, the Pi's and
//! `tools/`') parses with glint's own command line (the
//! binary's `cli` module, compiled in here from its source, not a copy), so the README cannot
//! name an option that does not exist or drop one that is required.
//!
//! Commands are taken from the README's fenced code blocks: lines starting with `glint `, with
//! `\`-continued lines joined, `# comments` and redirections cut, and output lines
//! (`glint demo: ...`) left out. Synopsis syntax is read as a user would:
//! `[...]` marks optional parts (kept, so that they are checked too), `a|b` offers choices (the
//! first is taken), `...` means "more of the same" (dropped), and upper-case placeholders get the
//! example values the README uses elsewhere. A settings file is spliced in as `glint run`
//! does, from this repository's copy of the file the README names.

// The binary's argument parsing, compiled into this test: its `main` and helpers are not
// called here.
#[allow(dead_code)]
#[path = "../src/cli/mod.rs"]
mod cli;

use std::ffi::OsString;

use clap::{CommandFactory, Parser};

/// Example values for the README's placeholders.
const PLACEHOLDERS: [(&str, &str); 10] = [
    ("PATH", "run.yuv"),
    ("WxH", "640x480"),
    ("F", "30"),
    ("N", "1"),
    ("US", "2000"),
    ("PORT", "/dev/ttyUSB0"),
    ("SECONDS", "10"),
    ("NAME=VALUE", "sharpness=0"),
    ("MB", "256"),
    ("BAUD", "115200"),
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
        }
    }
    found
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

/// Parses `argv` as `glint` does, the settings file spliced in first.
fn parse(argv: &[String]) -> Result<cli::Cli, String> {
    let argv: Vec<OsString> = argv
        .iter()
        .map(|w| {
            let installed = INSTALLED.iter().find(|(path, _)| path == w);
            OsString::from(installed.map_or(w.as_str(), |(_, copy)| copy))
        })
        .collect();
    let spliced = cli::run_config::splice(argv, &cli::Cli::command())?;
    cli::Cli::try_parse_from(&spliced.argv).map_err(|e| e.render().to_string())
}

#[test]
fn every_readme_command_parses() {
    let commands: Vec<Vec<String>> = READMES.iter().flat_map(|r| commands(r)).collect();
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
}
