//! `cargo xtask`: everything a fresh machine needs, behind the two README commands.
//!
//! * `cargo xtask setup` installs the system packages the toolkit needs (Debian, as root) or
//!   says exactly what to install.
//! * `cargo xtask test` sets up, then runs formatting and lint checks and the whole test suite
//!   on Mesa lavapipe with the Khronos validation layer.
//! * `cargo xtask demo` sets up, then runs the demo in release mode.

mod setup;

use std::process::{Command, ExitCode};

use anyhow::{Context, Result, bail};

const USAGE: &str = "\
usage: cargo xtask <command> [args]

commands:
  setup           install the system packages the toolkit needs (idempotent)
  test [--no-lint] [-- <cargo test args>]
                  set up, check formatting and clippy, run the whole test suite
  demo [-- <demo args>]
                  set up, then run `hairkit demo` (release build)
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

fn split_passthrough(args: &[String]) -> (Vec<String>, Vec<String>) {
    match args.iter().position(|a| a == "--") {
        Some(i) => (args[..i].to_vec(), args[i + 1..].to_vec()),
        None => (args.to_vec(), Vec::new()),
    }
}

fn test(args: &[String]) -> Result<()> {
    let (own, passthrough) = split_passthrough(args);
    let mut lint = true;
    for a in &own {
        match a.as_str() {
            "--no-lint" => lint = false,
            other => bail!("unknown option `{other}` for `cargo xtask test`\n{USAGE}"),
        }
    }
    let machine = setup::ensure_system_packages()?;
    let env = machine.test_env();
    if lint {
        cargo(&["fmt", "--all", "--check"], &env)?;
        cargo(&["clippy", "--workspace", "--all-targets", "--quiet", "--", "-D", "warnings"], &env)?;
    }
    let mut test_args = vec!["test", "--workspace"];
    test_args.extend(passthrough.iter().map(String::as_str));
    cargo(&test_args, &env)
}

fn demo(args: &[String]) -> Result<()> {
    let (own, passthrough) = split_passthrough(args);
    if let Some(a) = own.first() {
        bail!("unknown option `{a}` for `cargo xtask demo` (demo options go after `--`)\n{USAGE}");
    }
    let machine = setup::ensure_system_packages()?;
    let mut env = machine.test_env();
    // The demo is for looking at, not for testing the driver: validation stays off so the
    // printed timings mean something.
    env.retain(|(k, _)| k != "HAIRKIT_VALIDATION");
    let mut run_args =
        vec!["run", "--release", "--quiet", "-p", "hairkit-cli", "--bin", "hairkit", "--", "demo"];
    run_args.extend(passthrough.iter().map(String::as_str));
    cargo(&run_args, &env)
}

fn cargo(args: &[&str], env: &[(String, String)]) -> Result<()> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    eprintln!("xtask: cargo {}", args.join(" "));
    let status = Command::new(&cargo)
        .args(args)
        .envs(env.iter().map(|(k, v)| (k.as_str(), v.as_str())))
        .status()
        .with_context(|| format!("could not start `{cargo}`"))?;
    if !status.success() {
        bail!("`cargo {}` failed ({status})", args.join(" "));
    }
    Ok(())
}
