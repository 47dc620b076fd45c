//! The commands the README and `docs/*.md` show run as written.
//!
//! A `console` block is a test (trycmd's format): `$ COMMAND` lines, the exit status (`? 1`
//! when it is not success) and the output lines a user would see, with `...` for lines that vary
//! (timings, paths). Every markdown file's blocks run, in order, in a fresh copy of the checkout
//! (the tracked and the not-ignored files of the working tree, committed in a throwaway git
//! repository), with the tools from this build; afterwards `git status --porcelain` must be empty
//! there: a documented command never writes into the checkout. A command block in another
//! language (`sh`) is one a test cannot run as it stands (it builds the project, opens a window,
//! needs a cluster): each is listed below with the test that covers it instead, and a block that
//! is neither fails [`command_blocks_are_tested`].

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use anyhow::{Context as _, Result, bail, ensure};
use hairkit_tests::harness::{GpuTest, Requirements, run_gpu_tests};

/// The tools the docs name, the package that builds each, and what `cargo install` takes.
const TOOLS: &[(&str, &str)] = &[
    ("hairmesh", "hairmesh"),
    ("hairkit", "cli"),
    ("hair-render", "cli"),
    ("hair-bench", "cli"),
    ("hair-editor", "editor"),
];

/// `sh` blocks a test cannot run as written, by the start of their first command, with what
/// covers them instead.
const NOT_RUN_HERE: &[(&str, &str)] = &[
    (
        "cargo xtask demo",
        "builds the project; `demo_writes_images_and_timings` (cli/tests/cli.rs) runs `hairkit demo`",
    ),
    ("cargo xtask test", "is the test suite itself (`.ci/run` runs it)"),
    (
        "cargo install",
        "builds release binaries for minutes; `the_install_line_installs_every_tool` checks what it installs",
    ),
    (
        "eval $(cargo xtask env)",
        "sets up a shell; `cargo xtask test` runs every test under the same variables",
    ),
    ("HAIRKIT_FUZZ_CASES=", "the long fuzz run; the suite runs the same test with 96 cases per loader"),
    ("cargo bench", "criterion benchmarks; the suite builds them"),
    (
        "cargo run --release -p hairmesh --example blue_noise",
        "`the_blue_noise_example_reports_quality_and_draws_its_picture` (hairmesh/tests/cli.rs)",
    ),
    (
        "hair-editor HEAD",
        "opens a window; `real_window_under_xvfb_shows_hair` (editor/tests/ui.rs) does, under Xvfb",
    ),
    ("xvfb-run", "`real_window_under_xvfb_shows_hair` (editor/tests/ui.rs) runs it"),
    (
        "#!/bin/sh",
        "needs a Slurm cluster (issue 60); its hair-render commands run in docs/rendering.md's console blocks",
    ),
];

/// The repository's root.
fn repo() -> PathBuf {
    hairkit_tests::scenes::repo("")
}

/// The markdown files a user reads: the README and every page of `docs/`.
fn pages() -> Result<Vec<PathBuf>> {
    let mut pages = vec![PathBuf::from("README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(repo().join("docs"))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .filter_map(|p| p.strip_prefix(repo()).ok().map(Path::to_path_buf))
        .collect();
    docs.sort();
    pages.extend(docs);
    Ok(pages)
}

/// A fenced block: its language and its text.
struct Block {
    language: String,
    text: String,
    line: usize,
}

fn fenced_blocks(markdown: &str) -> Vec<Block> {
    let mut blocks = Vec::new();
    let mut open: Option<(String, usize, String)> = None;
    for (i, line) in markdown.lines().enumerate() {
        let trimmed = line.trim_start();
        match &mut open {
            None => {
                if let Some(info) = trimmed.strip_prefix("```") {
                    open = Some((info.trim().to_owned(), i + 1, String::new()));
                }
            }
            Some((language, start, text)) => {
                if trimmed.starts_with("```") {
                    blocks.push(Block { language: language.clone(), text: text.clone(), line: *start });
                    open = None;
                } else {
                    text.push_str(line);
                    text.push('\n');
                }
            }
        }
    }
    blocks
}

/// Where the build put its binaries (this test's executable is in `PROFILE/deps/`).
fn profile_dir() -> Result<PathBuf> {
    let exe = std::env::current_exe()?;
    exe.parent()
        .and_then(Path::parent)
        .map(Path::to_path_buf)
        .with_context(|| format!("{}: not inside a cargo target folder", exe.display()))
}

/// Builds the tools, unless `cargo xtask test` says its build of the whole workspace made them
/// (`HAIRKIT_TOOLS_BUILT=1`): a `cargo build` here would build them with other features than
/// the test build did, and rebuild much of the workspace.
fn build_tools() -> Result<()> {
    if std::env::var_os("HAIRKIT_TOOLS_BUILT").is_some_and(|v| v == "1") {
        return Ok(());
    }
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut command = Command::new(cargo);
    command.current_dir(repo()).args(["build", "--quiet", "--workspace", "--bins"]);
    if profile_dir()?.file_name().is_some_and(|n| n == "release") {
        command.arg("--release");
    }
    let status = command.status().context("running cargo build for the tools")?;
    ensure!(status.success(), "cargo build --bins failed ({status})");
    Ok(())
}

fn git(dir: &Path, args: &[&str]) -> Result<String> {
    let out = Command::new("git")
        .current_dir(dir)
        .args([
            "-c",
            "user.name=doc-commands",
            "-c",
            "user.email=doc-commands@invalid",
            "-c",
            "core.autocrlf=false",
        ])
        .args(args)
        .output()
        .context("running git")?;
    ensure!(out.status.success(), "git {}: {}", args.join(" "), String::from_utf8_lossy(&out.stderr));
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// A fresh copy of the checkout's working tree (tracked and not-ignored files), committed.
fn sandbox(name: &str) -> Result<PathBuf> {
    let dir = profile_dir()?.join("../tmp/doc-commands").join(name);
    if dir.exists() {
        std::fs::remove_dir_all(&dir).with_context(|| format!("clearing {}", dir.display()))?;
    }
    std::fs::create_dir_all(&dir)?;
    let files = git(&repo(), &["ls-files", "-z", "--cached", "--others", "--exclude-standard"])?;
    for file in files.split('\0').filter(|f| !f.is_empty()) {
        let from = repo().join(file);
        if !from.is_file() {
            continue; // deleted in the working tree
        }
        let to = dir.join(file);
        if let Some(parent) = to.parent() {
            std::fs::create_dir_all(parent)?;
        }
        std::fs::copy(&from, &to).with_context(|| format!("copying {file}"))?;
    }
    git(&dir, &["init", "--quiet"])?;
    git(&dir, &["add", "--all"])?;
    git(&dir, &["commit", "--quiet", "--message", "checkout"])?;
    Ok(dir)
}

/// Runs `page`'s console blocks in a fresh copy of the checkout; then nothing there may have
/// changed.
fn run_page(page: &Path) -> Result<()> {
    build_tools()?;
    let name = page.to_string_lossy().replace(['/', '.'], "_");
    let dir = sandbox(&name)?;
    let bins = profile_dir()?;
    for (tool, _) in TOOLS {
        ensure!(bins.join(tool).is_file(), "{}: not built", bins.join(tool).display());
    }
    let data = data_set::DataSet::from_env()
        .complete_root()
        .map(|root| root.path.clone())
        .context("the data set is missing (cargo xtask data)")?;
    std::env::set_current_dir(&dir)?;
    let cases = trycmd::TestCases::new();
    cases
        .case(dir.join(page))
        .timeout(Duration::from_secs(600))
        .env("HAIRKIT_DATA", data.display().to_string());
    for (tool, _) in TOOLS {
        cases.register_bin(*tool, bins.join(tool));
    }
    cases.run();
    let changed = git(&dir, &["status", "--porcelain", "--untracked-files=all"])?;
    ensure!(changed.is_empty(), "{}'s commands wrote into the checkout:\n{changed}", page.display());
    Ok(())
}

/// Every command block is a console block (run by this file's tests) or one [`NOT_RUN_HERE`]
/// lists; the `sh` ones are printed with what covers them.
fn command_blocks_are_tested() -> Result<()> {
    let mut unlisted = Vec::new();
    for page in pages()? {
        let text = std::fs::read_to_string(repo().join(&page))?;
        for block in fenced_blocks(&text) {
            if !matches!(block.language.as_str(), "sh" | "bash" | "shell") {
                continue;
            }
            let first = block.text.lines().map(str::trim).find(|l| !l.is_empty()).unwrap_or_default();
            match NOT_RUN_HERE.iter().find(|(start, _)| first.starts_with(start)) {
                Some((_, covered)) => eprintln!("{}:{}: `{first}` {covered}", page.display(), block.line),
                None => unlisted.push(format!("{}:{}: {first}", page.display(), block.line)),
            }
        }
    }
    if !unlisted.is_empty() {
        bail!(
            "command blocks no test runs (make them `console` blocks, or list them in NOT_RUN_HERE with the test that covers them):\n{}",
            unlisted.join("\n")
        );
    }
    Ok(())
}

/// The README's install line installs every tool a page names, from the package that builds it.
fn the_install_line_installs_every_tool() -> Result<()> {
    let readme = std::fs::read_to_string(repo().join("README.md"))?;
    for (tool, package) in TOOLS {
        let install = format!("cargo install --locked --path {package}");
        ensure!(readme.contains(&install), "the README does not say `{install}` (which installs {tool})");
        let manifest = std::fs::read_to_string(repo().join(package).join("Cargo.toml"))?;
        ensure!(
            manifest.contains(&format!("name = \"{tool}\"")),
            "{package}/Cargo.toml builds no binary named {tool}"
        );
    }
    Ok(())
}

fn main() -> std::process::ExitCode {
    let mut tests = vec![
        GpuTest::new("command_blocks_are_tested", Requirements::NONE, |_| command_blocks_are_tested()),
        GpuTest::new("the_install_line_installs_every_tool", Requirements::NONE, |_| {
            the_install_line_installs_every_tool()
        }),
    ];
    for page in pages().unwrap_or_default() {
        let text = std::fs::read_to_string(repo().join(&page)).unwrap_or_default();
        if !fenced_blocks(&text).iter().any(|b| b.language == "console") {
            continue;
        }
        let name = format!(
            "commands_in_{}_run_as_written",
            page.with_extension("").to_string_lossy().replace(['/', '-'], "_").to_lowercase()
        );
        tests.push(GpuTest::new(&name, Requirements::NONE, move |_| run_page(&page)));
    }
    run_gpu_tests(tests)
}
