//! The Python clients the export tests open hairkit's files with (Pixar's USD library), in a
//! project-local venv (`target/python`) made from `xtask/python-requirements.txt`: versions and
//! hashes pinned, installed again only when that file changes.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context as _, Result, bail};

const REQUIREMENTS: &str = include_str!("../python-requirements.txt");

/// The venv's interpreter with the clients installed, or why there is none (no Python 3, no
/// network): the tests that need it then say so.
pub fn ensure_clients(workspace: &Path) -> Result<PathBuf> {
    let venv = workspace.join("target/python");
    let python = venv.join("bin/python");
    let marker = venv.join(".requirements");
    if std::fs::read_to_string(&marker).is_ok_and(|m| m == REQUIREMENTS) && python.is_file() {
        return Ok(python);
    }
    let system = ["python3", "python"]
        .into_iter()
        .find(|p| Command::new(p).arg("--version").output().is_ok_and(|o| o.status.success()))
        .context("no python3 on the PATH")?;
    eprintln!("xtask: installing the Python clients (USD) into {}", venv.display());
    run(Command::new(system).args(["-m", "venv", "--clear"]).arg(&venv))?;
    let requirements = venv.join("requirements.txt");
    std::fs::write(&requirements, REQUIREMENTS)?;
    run(Command::new(&python)
        .args(["-m", "pip", "install", "--quiet", "--disable-pip-version-check", "--require-hashes", "-r"])
        .arg(&requirements))?;
    std::fs::write(&marker, REQUIREMENTS)?;
    Ok(python)
}

fn run(command: &mut Command) -> Result<()> {
    let out = command.output().with_context(|| format!("running {command:?}"))?;
    if !out.status.success() {
        bail!(
            "{command:?} failed ({}): {}{}",
            out.status,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    Ok(())
}
