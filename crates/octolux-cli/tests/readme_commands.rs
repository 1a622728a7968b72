//! The README's front door, read from the README itself: the command that renders the default
//! scene works as written, and CI runs the test command it gives. A README and a project that
//! disagree fail here.
//!
//! The run command is `cargo run --release -- ARGS`. Building a release binary inside the test
//! suite would double CI's compile time, so the test splits the command in its two halves:
//! which binary `cargo run` picks in this workspace (cargo's rule, applied to
//! `cargo metadata`: the one `default-run` of the default members, else the one binary), and
//! that binary run with ARGS, from a fresh folder, writing what the README says.

use crate::common::{assert_succeeds, temp_dir};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn readme() -> String {
    std::fs::read_to_string(repo().join("README.md")).unwrap()
}

/// The one command line of the first ```sh block under `heading`.
fn command_under(readme: &str, heading: &str) -> Vec<String> {
    let section = readme
        .split_once(&format!("\n{heading}\n"))
        .unwrap_or_else(|| panic!("no '{heading}' in README.md"))
        .1;
    let block = section
        .split_once("```sh\n")
        .and_then(|(_, rest)| rest.split_once("```"))
        .unwrap_or_else(|| panic!("no sh block under '{heading}'"))
        .0;
    let lines: Vec<&str> = block.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "one command under '{heading}': {lines:?}");
    lines[0].split_whitespace().map(str::to_string).collect()
}

/// The binary `cargo run` (no `--bin`, `--example` or `-p`) runs in the workspace, by cargo's
/// rule; an error with cargo's words when it cannot decide.
fn binary_cargo_run_picks() -> Result<String, String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    let out = Command::new(cargo)
        .args([
            "metadata",
            "--no-deps",
            "--format-version",
            "1",
            "--offline",
        ])
        .current_dir(repo())
        .output()
        .expect("run cargo metadata");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let meta: Value = serde_json::from_slice(&out.stdout).unwrap();
    let members: Vec<&Value> = meta["workspace_default_members"]
        .as_array()
        .unwrap()
        .iter()
        .collect();
    let packages: Vec<&Value> = meta["packages"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|p| members.contains(&&p["id"]))
        .collect();
    let default_runs: Vec<&str> = packages
        .iter()
        .filter_map(|p| p["default_run"].as_str())
        .collect();
    if let [one] = default_runs[..] {
        return Ok(one.to_string());
    }
    let bins: Vec<&str> = packages
        .iter()
        .flat_map(|p| p["targets"].as_array().unwrap())
        .filter(|t| t["kind"].as_array().unwrap().iter().any(|k| k == "bin"))
        .map(|t| t["name"].as_str().unwrap())
        .collect();
    match bins[..] {
        [one] => Ok(one.to_string()),
        _ => Err(format!(
            "`cargo run` could not determine which binary to run; available binaries: {}",
            bins.join(", ")
        )),
    }
}

#[test]
fn the_run_command_renders_the_default_scene() {
    let readme = readme();
    let words = command_under(&readme, "## Render the default scene");
    let dashes = words
        .iter()
        .position(|w| w == "--")
        .expect("`cargo run ... -- ARGS`");
    assert_eq!(words[..2], ["cargo", "run"], "{words:?}");
    for flag in &words[2..dashes] {
        assert!(
            ["--release", "--locked"].contains(&flag.as_str()),
            "cargo flag '{flag}' that changes which binary runs: update this test"
        );
    }
    assert_eq!(binary_cargo_run_picks().as_deref(), Ok("octolux"));

    // The README says the command writes render.png.
    let section = readme.split_once("## Render the default scene").unwrap().1;
    assert!(
        section.contains("This writes `render.png`"),
        "the README's promise changed"
    );
    let tmp = temp_dir("readme-run");
    let out = Command::new(env!("CARGO_BIN_EXE_octolux"))
        .args(&words[dashes + 1..])
        .current_dir(tmp.path())
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .output()
        .unwrap();
    assert_succeeds(&out);
    let size = |flag: &str| -> u32 {
        let i = words.iter().position(|w| w == flag).unwrap();
        words[i + 1].parse().unwrap()
    };
    let image = image::open(tmp.path().join("render.png")).expect("render.png written");
    assert_eq!(
        (image.width(), image.height()),
        (size("--width"), size("--height"))
    );
}

#[test]
fn ci_runs_the_test_command() {
    let words = command_under(&readme(), "## Run the tests");
    let command = words.join(" ");
    let ci = std::fs::read_to_string(repo().join(".ci/run")).unwrap();
    assert!(
        ci.lines().any(|l| l.trim() == command),
        "`.ci/run` does not run the README's test command '{command}'"
    );
}
