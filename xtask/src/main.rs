//! `cargo xtask`: everything a fresh machine needs, behind the two README commands.
//!
//! * `cargo xtask setup` installs the system packages the toolkit needs (Debian, as root) or
//!   says exactly what to install.
//! * `cargo xtask test` sets up, then runs formatting and lint checks and the whole test suite
//!   on Mesa lavapipe with the Khronos validation layer.
//! * `cargo xtask demo` sets up, then runs the demo in release mode.
//! * `cargo xtask data` downloads the third-party data set into the user cache; `test` and
//!   `demo` call it when no folder holds the data set.

mod data;
mod python;
mod setup;
mod suite;

use std::process::ExitCode;

use anyhow::{Context, Result, bail};

const USAGE: &str = "\
usage: cargo xtask <command> [args]

commands:
  setup           install the system packages the toolkit needs (idempotent)
  test [--no-lint] [AREA ...] [-- <test runner args>]
                  set up, check formatting and clippy, run the whole test suite (or the tests
                  of the AREAs: data-set, hairmesh, gen-gpu, render, cli, editor, tests, xtask,
                  shader-build) under cargo nextest, and print each step's time
  demo [-- <demo args>]
                  set up, then run `hairkit demo` (release build)
  data            download the third-party data set (heads, grooms, glTF samples) into the
                  user cache, checking every file's SHA-256 (resumes an interrupted run)
  env             print the environment the tests run with (for running cargo by hand)
";

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let command = args.next().unwrap_or_default();
    let rest: Vec<String> = args.collect();
    match command.as_str() {
        "setup" => setup::ensure_system_packages().map(|_| ()),
        "test" => test(&rest),
        "demo" => demo(&rest),
        "data" => {
            if let Some(a) = rest.first() {
                bail!("unknown option `{a}` for `cargo xtask data`\n{USAGE}");
            }
            fetch_data()
        }
        "env" => {
            let machine = setup::ensure_system_packages()?;
            for (k, v) in machine.test_env() {
                println!("export {k}={v}");
            }
            Ok(())
        }
        "" | "help" | "-h" | "--help" => {
            print!("{USAGE}");
            Ok(())
        }
        other => bail!("unknown command `{other}`\n{USAGE}"),
    }
}

/// Downloads the data set into the user cache (`HAIRKIT_DATA`, when set, is the user's own
/// folder and is never written to).
fn fetch_data() -> Result<()> {
    if let Some(dir) = data_set::hairkit_data() {
        bail!(
            "{} is set ({}): the data set is read from there only, so downloading into the cache would not be used; \
             unset it to use the cache",
            data_set::ENV_VAR,
            dir.display()
        );
    }
    let cache = data_set::user_cache().context("no cache folder: set XDG_CACHE_HOME or HOME")?;
    let sources = data_set::sources()?;
    data::fetch_all(&data::agent(), &sources, &cache, &mut std::io::stdout().lock())
}

/// Where the data set is for this run: a complete folder if one is found, else a download into
/// the user cache (when `HAIRKIT_DATA` does not name another folder).
fn ensure_data() -> Result<()> {
    let set = data_set::DataSet::from_env();
    if let Some(root) = set.complete_root() {
        eprintln!("xtask: data set in {} ({})", root.path.display(), root.place);
        return Ok(());
    }
    if data_set::hairkit_data().is_some() {
        eprintln!(
            "xtask: warning: {} does not hold the whole data set; whatever needs a missing file will say which",
            data_set::ENV_VAR
        );
        return Ok(());
    }
    eprintln!("xtask: no folder holds the data set; downloading it");
    fetch_data()
}

fn split_passthrough(args: &[String]) -> (Vec<String>, Vec<String>) {
    match args.iter().position(|a| a == "--") {
        Some(i) => (args[..i].to_vec(), args[i + 1..].to_vec()),
        None => (args.to_vec(), Vec::new()),
    }
}

fn test(args: &[String]) -> Result<()> {
    let (own, passthrough) = split_passthrough(args);
    let options = suite::Options::parse(&own, passthrough)?;
    let mut timeline = suite::Timeline::new();
    let result = (|| {
        let machine = timeline.step("set-up", setup::ensure_system_packages)?;
        let env = machine.test_env();
        timeline.step("data set", ensure_data)?;
        suite::run(&options, &env, &mut timeline)
    })();
    eprintln!("{}", timeline.table());
    result
}

fn demo(args: &[String]) -> Result<()> {
    let (own, passthrough) = split_passthrough(args);
    if let Some(a) = own.first() {
        bail!("unknown option `{a}` for `cargo xtask demo` (demo options go after `--`)\n{USAGE}");
    }
    let machine = setup::ensure_system_packages()?;
    let mut env = machine.test_env();
    if let Err(e) = ensure_data() {
        // The demo falls back on the project's own head cap and says so.
        eprintln!("xtask: warning: {e:#}");
    }
    // The demo is for looking at, not for testing the driver: validation stays off so the
    // printed timings mean something.
    env.retain(|(k, _)| k != "HAIRKIT_VALIDATION");
    let mut run_args =
        vec!["run", "--release", "--quiet", "-p", "hairkit-cli", "--bin", "hairkit", "--", "demo"];
    run_args.extend(passthrough.iter().map(String::as_str));
    suite::cargo(&run_args, &env)
}
