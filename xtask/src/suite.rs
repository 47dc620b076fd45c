//! `cargo xtask test`: formatting, clippy and the whole test suite, each step timed, with a
//! table at the end that shows where the minutes went.
//!
//! The tests run under `cargo nextest` when it is installed: every test in its own process, as
//! many at a time as the machine has cores, so the GPU tests of one binary (which share one
//! device and its validation log inside a process) run side by side on lavapipe, and one slow
//! binary no longer holds the others back. Doc tests, which nextest does not run, follow with
//! `cargo test --doc`. Without nextest the suite falls back on `cargo test` (the same tests,
//! one binary at a time).

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

use anyhow::{Context as _, Result, bail};

/// The packages a test area can name (`cargo xtask test render`).
pub const AREAS: &[(&str, &str)] = &[
    ("data-set", "data-set"),
    ("hairmesh", "hairmesh"),
    ("gen-gpu", "gen-gpu"),
    ("render", "render"),
    ("cli", "hairkit-cli"),
    ("editor", "editor"),
    ("tests", "hairkit-tests"),
    ("xtask", "xtask"),
    ("shader-build", "shader-build"),
];

/// What `cargo xtask test` was asked to do.
#[derive(Debug, Default)]
pub struct Options {
    pub lint: bool,
    /// Packages to test; empty: the whole workspace.
    pub packages: Vec<&'static str>,
    /// Arguments for the test runner (a filter, `--no-capture`, …).
    pub passthrough: Vec<String>,
}

impl Options {
    pub fn parse(own: &[String], passthrough: Vec<String>) -> Result<Options> {
        let mut options = Options { lint: true, passthrough, ..Options::default() };
        for a in own {
            match a.as_str() {
                "--no-lint" => options.lint = false,
                area => match AREAS.iter().find(|(name, package)| area == *name || area == *package) {
                    Some((_, package)) => options.packages.push(package),
                    None => bail!(
                        "unknown test area `{area}`: expected --no-lint or one of {}",
                        AREAS.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
                    ),
                },
            }
        }
        Ok(options)
    }

    fn package_args(&self) -> Vec<String> {
        if self.packages.is_empty() {
            vec!["--workspace".into()]
        } else {
            self.packages.iter().flat_map(|p| ["-p".to_owned(), (*p).to_owned()]).collect()
        }
    }
}

/// One timed step.
#[derive(Debug)]
struct Step {
    name: String,
    seconds: f64,
    ok: bool,
}

/// The steps run so far; printed as a table however the run ends.
#[derive(Debug, Default)]
pub struct Timeline {
    steps: Vec<Step>,
    binaries: Vec<BinaryTime>,
    started: Option<Instant>,
}

impl Timeline {
    pub fn new() -> Self {
        Timeline { started: Some(Instant::now()), ..Timeline::default() }
    }

    /// Runs `f` as the step `name`.
    pub fn step<T>(&mut self, name: &str, f: impl FnOnce() -> Result<T>) -> Result<T> {
        let start = Instant::now();
        let result = f();
        self.steps.push(Step {
            name: name.into(),
            seconds: start.elapsed().as_secs_f64(),
            ok: result.is_ok(),
        });
        result
    }

    /// The table: every step's wall time, then each test binary's tests and summed test time.
    pub fn table(&self) -> String {
        let mut out = String::from("\n| step | wall | result |\n|---|---:|---|\n");
        for s in &self.steps {
            out.push_str(&format!(
                "| {} | {} | {} |\n",
                s.name,
                minutes(s.seconds),
                if s.ok { "ok" } else { "FAILED" }
            ));
        }
        if let Some(start) = self.started {
            out.push_str(&format!("| **total** | **{}** | |\n", minutes(start.elapsed().as_secs_f64())));
        }
        if !self.binaries.is_empty() {
            out.push_str(
                "\n| test binary | tests | failed | skipped | test time (summed; runs in parallel) |\n|---|---:|---:|---:|---:|\n",
            );
            let mut binaries: Vec<&BinaryTime> = self.binaries.iter().collect();
            binaries.sort_by(|a, b| b.seconds.total_cmp(&a.seconds));
            for b in binaries {
                out.push_str(&format!(
                    "| {} | {} | {} | {} | {} |\n",
                    b.name,
                    b.tests,
                    b.failures,
                    b.skipped,
                    minutes(b.seconds)
                ));
            }
        }
        out
    }
}

fn minutes(seconds: f64) -> String {
    if seconds >= 60.0 {
        format!("{}m {:02.0}s", (seconds / 60.0).floor(), seconds % 60.0)
    } else {
        format!("{seconds:.1}s")
    }
}

/// Runs the suite: fmt and clippy (unless `--no-lint`), the tests' build, the tests, doc tests.
///
/// With nextest and clippy's driver at hand, clippy does not compile the workspace a second
/// time: the tests are built with `clippy-driver` as the workspace's compiler wrapper (what
/// `cargo clippy` does, but producing real artifacts), so the project's crates are linted while
/// they are compiled and the dependencies are built once; benches and examples are built (and
/// linted) in the same build, as `clippy --all-targets` would check them.
pub fn run(options: &Options, env: &[(String, String)], timeline: &mut Timeline) -> Result<()> {
    if options.lint {
        timeline.step("cargo fmt --check", || cargo(&["fmt", "--all", "--check"], env))?;
    }
    let packages = options.package_args();
    let packages: Vec<&str> = packages.iter().map(String::as_str).collect();
    let passthrough: Vec<&str> = options.passthrough.iter().map(String::as_str).collect();
    let mut env = env.to_vec();
    if options.packages.is_empty() {
        // The whole workspace's build makes every tool fresh (its bins are built for the
        // integration tests and by --all-targets): the tests of the docs' commands use them
        // as they are instead of running cargo again.
        env.push(("HAIRKIT_TOOLS_BUILT".into(), "1".into()));
    }
    if !has_nextest() {
        eprintln!(
            "xtask: cargo-nextest is not installed: running the tests one binary at a time with `cargo test`"
        );
        if options.lint {
            timeline.step("cargo clippy", || cargo(&CLIPPY, &env))?;
        }
        return timeline
            .step("cargo test", || cargo(&[&["test"], &packages[..], &passthrough[..]].concat(), &env));
    }
    let driver = if options.lint { clippy_driver() } else { None };
    match &driver {
        Some(driver) => {
            // Every later cargo call gets the same wrapper, or it would compile the crates again.
            env.push(("RUSTC_WORKSPACE_WRAPPER".into(), driver.clone()));
            env.push((
                "CLIPPY_ARGS".into(),
                ["-D", "warnings"].join("__CLIPPY_HACKERY__") + "__CLIPPY_HACKERY__",
            ));
            // `cargo test --no-run`, not nextest's: nextest lists every binary it builds, and a
            // criterion bench asked to list itself runs instead.
            timeline.step("build the tests and benches, clippy on the project's crates", || {
                cargo(&[&["test", "--no-run", "--quiet", "--all-targets"], &packages[..]].concat(), &env)
            })?;
        }
        None => {
            if options.lint {
                timeline.step("cargo clippy", || cargo(&CLIPPY, &env))?;
            }
            timeline.step("build the tests", || {
                cargo(&[&["nextest", "run", "--no-run", "--cargo-quiet"], &packages[..]].concat(), &env)
            })?;
        }
    }
    let env = &env[..];
    // nextest writes its reports under the target folder, wherever CARGO_TARGET_DIR puts it.
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../target"), std::path::PathBuf::from);
    let junit = target.join("nextest/xtask/junit.xml");
    let _ = std::fs::remove_file(&junit);
    let tests = timeline.step("run the tests (nextest)", || {
        cargo(
            &[
                &["nextest", "run", "--profile", "xtask", "--cargo-quiet", "--no-fail-fast"],
                &packages[..],
                &passthrough[..],
            ]
            .concat(),
            env,
        )
    });
    if let Ok(xml) = std::fs::read_to_string(&junit) {
        timeline.binaries = binary_times(&xml);
    }
    // Doc tests (nextest does not run them); a filter after `--` is for the test binaries.
    let docs = if passthrough.is_empty() {
        timeline.step("doc tests", || cargo(&[&["test", "--doc", "--quiet"], &packages[..]].concat(), env))
    } else {
        Ok(())
    };
    tests.and(docs)
}

/// `cargo clippy` as the fallback runs it.
const CLIPPY: [&str; 7] = ["clippy", "--workspace", "--all-targets", "--quiet", "--", "-D", "warnings"];

/// Clippy's driver beside cargo (rustup installs both), if it runs.
fn clippy_driver() -> Option<String> {
    let cargo = cargo_program();
    let beside = Path::new(&cargo).parent().map(|dir| dir.join("clippy-driver"));
    let candidates = beside.into_iter().map(|p| p.display().to_string()).chain(["clippy-driver".to_owned()]);
    candidates
        .into_iter()
        .find(|c| Command::new(c).arg("--version").output().is_ok_and(|o| o.status.success()))
}

fn has_nextest() -> bool {
    Command::new(cargo_program()).args(["nextest", "--version"]).output().is_ok_and(|o| o.status.success())
}

fn cargo_program() -> String {
    std::env::var("CARGO").unwrap_or_else(|_| "cargo".into())
}

pub fn cargo(args: &[&str], env: &[(String, String)]) -> Result<()> {
    let cargo = cargo_program();
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

/// One test binary's share of a nextest run, from its JUnit report.
#[derive(Debug, Default, PartialEq)]
pub struct BinaryTime {
    pub name: String,
    pub tests: u32,
    pub failures: u32,
    pub skipped: u32,
    /// The sum of its tests' wall times.
    pub seconds: f64,
}

/// Per binary (`<testsuite name="crate::binary" …>` with one `<testcase … time="s">` per test),
/// the number of tests, failures, skipped tests and the summed test time.
pub fn binary_times(junit: &str) -> Vec<BinaryTime> {
    let mut by_name: BTreeMap<String, BinaryTime> = BTreeMap::new();
    let mut current: Option<String> = None;
    for element in junit.split('<').skip(1) {
        let tag = element.split(['>', ' ', '/', '\n']).next().unwrap_or("");
        match tag {
            "testsuite" => {
                let name = attribute(element, "name").unwrap_or_default();
                by_name
                    .entry(name.clone())
                    .or_insert_with(|| BinaryTime { name: name.clone(), ..BinaryTime::default() });
                current = Some(name);
            }
            "testcase" => {
                if let Some(b) = current.as_ref().and_then(|n| by_name.get_mut(n)) {
                    b.tests += 1;
                    b.seconds += attribute(element, "time").and_then(|t| t.parse().ok()).unwrap_or(0.0);
                }
            }
            "failure" | "error" => {
                if let Some(b) = current.as_ref().and_then(|n| by_name.get_mut(n)) {
                    b.failures += 1;
                }
            }
            "skipped" => {
                if let Some(b) = current.as_ref().and_then(|n| by_name.get_mut(n)) {
                    b.skipped += 1;
                }
            }
            _ => {}
        }
    }
    by_name.into_values().collect()
}

/// The value of `name="…"` in an element's text.
fn attribute(element: &str, name: &str) -> Option<String> {
    let head = element.split('>').next()?;
    let start = head.find(&format!(" {name}=\""))? + name.len() + 3;
    let len = head[start..].find('"')?;
    Some(
        head[start..start + len]
            .replace("&quot;", "\"")
            .replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&amp;", "&"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn junit_reports_become_per_binary_times() {
        let xml = r#"<?xml version="1.0" encoding="UTF-8"?>
<testsuites name="nextest-run" tests="4" failures="1" errors="0" uuid="x" timestamp="t" time="9.5">
    <testsuite name="render::scenes" tests="2" disabled="0" errors="0" failures="1">
        <testcase name="a_golden" classname="render::scenes" timestamp="t" time="3.25">
            <failure type="test failure">boom</failure>
        </testcase>
        <testcase name="b" classname="render::scenes" timestamp="t" time="1.75"/>
    </testsuite>
    <testsuite name="hairmesh::cli" tests="2" disabled="0" errors="0" failures="0">
        <testcase name="x" classname="hairmesh::cli" timestamp="t" time="4.5"/>
        <testcase name="y" classname="hairmesh::cli" timestamp="t" time="0">
            <skipped/>
        </testcase>
    </testsuite>
</testsuites>"#;
        let times = binary_times(xml);
        assert_eq!(
            times,
            [
                BinaryTime { name: "hairmesh::cli".into(), tests: 2, failures: 0, skipped: 1, seconds: 4.5 },
                BinaryTime { name: "render::scenes".into(), tests: 2, failures: 1, skipped: 0, seconds: 5.0 },
            ]
        );
    }

    #[test]
    fn areas_name_packages_and_unknown_ones_are_refused() {
        let o = Options::parse(&["render".into(), "--no-lint".into(), "cli".into()], vec![]).expect("parses");
        assert!(!o.lint);
        assert_eq!(o.package_args(), ["-p", "render", "-p", "hairkit-cli"]);
        assert_eq!(Options::parse(&[], vec![]).expect("parses").package_args(), ["--workspace"]);
        let err = Options::parse(&["renderer".into()], vec![]).expect_err("unknown").to_string();
        assert!(err.contains("renderer") && err.contains("render, cli"), "{err}");
    }

    #[test]
    fn the_table_lists_steps_and_binaries() {
        let mut t = Timeline::new();
        t.step("cargo fmt --check", || Ok(())).expect("ok");
        let _ = t.step("cargo clippy", || -> Result<()> { bail!("no") });
        t.binaries = vec![BinaryTime {
            name: "render::scenes".into(),
            tests: 3,
            failures: 0,
            skipped: 0,
            seconds: 75.0,
        }];
        let table = t.table();
        assert!(table.contains("| cargo clippy |") && table.contains("| FAILED |"), "{table}");
        assert!(table.contains("| render::scenes | 3 | 0 | 0 | 1m 15s |"), "{table}");
    }
}
