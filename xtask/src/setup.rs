//! System packages: detect what is missing and, as root on Debian, install it.
//!
//! Mesa's software Vulkan driver (lavapipe) gained VK_EXT_mesh_shader long after Debian 12's
//! Mesa 22.3, so on bookworm the driver comes from `bookworm-backports` (Mesa 25.x), added from
//! the Debian mirror the machine already uses. A second run finds everything installed, asks
//! `dpkg-query` once and returns in milliseconds.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail};

/// Packages installed from the release's default suite.
/// `fonts-dejavu-core`: the font of the benchmark plots. The editor's window test: `xvfb`
/// and `xauth` (a virtual X display, `xvfb-run`), `x11-apps` (`xwd`, a screenshot taken from
/// outside the app), and the X libraries winit loads at run time.
const BASE_PACKAGES: &[&str] = &[
    "libvulkan1",
    "vulkan-validationlayers",
    "glslang-tools",
    "spirv-tools",
    "fonts-dejavu-core",
    "xvfb",
    "xauth",
    "x11-apps",
    "libxkbcommon-x11-0",
    "libxcursor1",
    "libxrandr2",
    "libxi6",
    "libx11-xcb1",
];
/// The driver: lavapipe, with VK_EXT_mesh_shader from this Mesa major version on.
const DRIVER_PACKAGE: &str = "mesa-vulkan-drivers";
const MIN_MESA_MAJOR: u32 = 24;
const BACKPORTS_SOURCE: &str = "/etc/apt/sources.list.d/hairkit-bookworm-backports.sources";
const ICD_DIR: &str = "/usr/share/vulkan/icd.d";

/// What the machine has once set-up is done.
#[derive(Debug)]
pub struct Machine {
    /// The lavapipe ICD manifest, pinned so results do not depend on other drivers present.
    pub lavapipe_icd: PathBuf,
    /// Whether this Mesa's lavapipe exposes VK_EXT_mesh_shader.
    pub mesa_has_mesh_shader: bool,
    /// The venv interpreter with the export tests' clients ([`crate::python`]).
    pub python: Option<PathBuf>,
}

impl Machine {
    /// Environment for tests: lavapipe only, validation on, and a missing device or (with a
    /// new enough Mesa) a missing mesh-shader extension is a failure rather than a skip, so a
    /// broken set-up can never pass CI by skipping.
    pub fn test_env(&self) -> Vec<(String, String)> {
        let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap_or(Path::new("."));
        let mut env = vec![
            ("VK_DRIVER_FILES".into(), self.lavapipe_icd.display().to_string()),
            ("HAIRKIT_VALIDATION".into(), "1".into()),
            ("HAIRKIT_REQUIRE_GPU".into(), "1".into()),
            (
                "MESA_SHADER_CACHE_DIR".into(),
                workspace.join("target/mesa-shader-cache").display().to_string(),
            ),
        ];
        if self.mesa_has_mesh_shader {
            env.push(("HAIRKIT_REQUIRE_MESH_SHADER".into(), "1".into()));
        }
        // With the clients installed, a test that cannot run one fails instead of being ignored.
        if let Some(python) = &self.python {
            env.push(("HAIRKIT_PYTHON".into(), python.display().to_string()));
            env.push(("HAIRKIT_REQUIRE_CLIENTS".into(), "1".into()));
        }
        env
    }
}

pub fn ensure_system_packages() -> Result<Machine> {
    let installed = query_installed()?;
    let mut missing: Vec<&str> =
        BASE_PACKAGES.iter().copied().filter(|p| !installed.iter().any(|(name, _)| name == p)).collect();
    let mesa = installed.iter().find(|(name, _)| name == DRIVER_PACKAGE);
    let mesa_ok = mesa.is_some_and(|(_, v)| mesa_major(v) >= MIN_MESA_MAJOR);
    if !missing.is_empty() || !mesa_ok {
        if !mesa_ok {
            missing.push(DRIVER_PACKAGE);
        }
        install(&missing, mesa.map(|(_, v)| v.as_str()))?;
    }
    let installed = query_installed()?;
    let mesa_version = installed
        .iter()
        .find(|(name, _)| name == DRIVER_PACKAGE)
        .map(|(_, v)| v.clone())
        .context("mesa-vulkan-drivers is still not installed after set-up")?;
    let lavapipe_icd = find_lavapipe_icd()?;
    eprintln!("xtask: system packages present; lavapipe from Mesa {mesa_version}");
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap_or(Path::new("."));
    let python = match crate::python::ensure_clients(workspace) {
        Ok(p) => Some(p),
        Err(e) => {
            eprintln!(
                "xtask: the export tests' Python clients are not installed ({e:#}): those tests will be ignored"
            );
            None
        }
    };
    Ok(Machine { mesa_has_mesh_shader: mesa_major(&mesa_version) >= MIN_MESA_MAJOR, lavapipe_icd, python })
}

/// `(package, version)` for every one of our packages that dpkg reports as installed.
fn query_installed() -> Result<Vec<(String, String)>> {
    if which("dpkg-query").is_none() {
        return Ok(Vec::new());
    }
    let mut all: Vec<&str> = BASE_PACKAGES.to_vec();
    all.push(DRIVER_PACKAGE);
    let out = Command::new("dpkg-query")
        .arg("-W")
        .arg("-f=${Package} ${db:Status-Abbrev} ${Version}\n")
        .args(&all)
        .output()
        .context("could not run dpkg-query")?;
    // dpkg-query exits 1 when some package is unknown; the listing is still valid.
    let text = String::from_utf8_lossy(&out.stdout);
    Ok(text
        .lines()
        .filter_map(|line| {
            let mut parts = line.split_whitespace();
            let name = parts.next()?;
            let status = parts.next()?;
            let version = parts.next()?;
            (status == "ii").then(|| (name.split(':').next().unwrap_or(name).to_owned(), version.to_owned()))
        })
        .collect())
}

/// `25.0.7-2~bpo12+1` → 25; an epoch (`1:25.0`) is skipped.
fn mesa_major(version: &str) -> u32 {
    let v = version.split_once(':').map_or(version, |(_, rest)| rest);
    v.split('.').next().and_then(|m| m.parse().ok()).unwrap_or(0)
}

fn os_release() -> (String, String) {
    let text = std::fs::read_to_string("/etc/os-release").unwrap_or_default();
    let field = |key: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(key).and_then(|r| r.strip_prefix('=')))
            .map(|v| v.trim_matches('"').to_owned())
            .unwrap_or_default()
    };
    (field("ID"), field("VERSION_CODENAME"))
}

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
        .unwrap_or(false)
}

fn install(missing: &[&str], old_mesa: Option<&str>) -> Result<()> {
    let (id, codename) = os_release();
    let by_hand = format!(
        "hairkit needs these system packages: {all} (Mesa {MIN_MESA_MAJOR}+ for lavapipe with \
         VK_EXT_mesh_shader; on Debian 12 take mesa-vulkan-drivers from bookworm-backports).\n\
         Missing or too old here: {missing}{old}.\n\
         On Debian 12 as root:\n  \
         echo 'deb http://deb.debian.org/debian bookworm-backports main' > /etc/apt/sources.list.d/backports.list\n  \
         apt-get update\n  \
         apt-get install -y {base}\n  \
         apt-get install -y -t bookworm-backports {DRIVER_PACKAGE}",
        all = [BASE_PACKAGES, &[DRIVER_PACKAGE]].concat().join(" "),
        missing = missing.join(" "),
        old = old_mesa.map(|v| format!(" (installed Mesa: {v})")).unwrap_or_default(),
        base = BASE_PACKAGES.join(" "),
    );
    if id != "debian" || which("apt-get").is_none() {
        bail!("this is not a Debian machine, so set-up cannot install packages itself.\n{by_hand}");
    }
    if !is_root() {
        bail!("set-up must run as root to install packages.\n{by_hand}");
    }
    eprintln!("xtask: installing system packages: {}", missing.join(" "));
    let use_backports = codename == "bookworm";
    if use_backports {
        ensure_backports_source()?;
    }
    apt(&["update"])?;
    let base: Vec<&str> = missing.iter().copied().filter(|p| *p != DRIVER_PACKAGE).collect();
    if !base.is_empty() {
        let mut args = vec!["install", "-y", "--no-install-recommends"];
        args.extend(base);
        apt(&args)?;
    }
    if missing.contains(&DRIVER_PACKAGE) {
        let mut args = vec!["install", "-y", "--no-install-recommends"];
        if use_backports {
            args.extend(["-t", "bookworm-backports"]);
        }
        args.push(DRIVER_PACKAGE);
        apt(&args)?;
    }
    Ok(())
}

fn apt(args: &[&str]) -> Result<()> {
    eprintln!("xtask: apt-get {}", args.join(" "));
    let status = Command::new("apt-get")
        .args(args)
        .env("DEBIAN_FRONTEND", "noninteractive")
        .status()
        .context("could not run apt-get")?;
    if !status.success() {
        bail!("`apt-get {}` failed ({status})", args.join(" "));
    }
    Ok(())
}

/// Adds `bookworm-backports` from the mirror the machine already uses, unless some source
/// already lists that suite.
fn ensure_backports_source() -> Result<()> {
    let mut sources = vec![PathBuf::from("/etc/apt/sources.list")];
    if let Ok(dir) = std::fs::read_dir("/etc/apt/sources.list.d") {
        sources.extend(dir.filter_map(|e| e.ok().map(|e| e.path())));
    }
    let texts: Vec<String> = sources
        .iter()
        .filter(|p| {
            p.extension().is_some_and(|e| e == "list" || e == "sources") || p.ends_with("sources.list")
        })
        .filter_map(|p| std::fs::read_to_string(p).ok())
        .collect();
    if texts
        .iter()
        .any(|t| t.lines().any(|l| !l.trim_start().starts_with('#') && l.contains("bookworm-backports")))
    {
        return Ok(());
    }
    let mirror = texts
        .iter()
        .find_map(|t| debian_mirror(t))
        .unwrap_or_else(|| "http://deb.debian.org/debian".to_owned());
    let entry = format!(
        "# Added by `cargo xtask setup` (hairkit): Mesa with VK_EXT_mesh_shader for lavapipe.\n\
         Types: deb\nURIs: {mirror}\nSuites: bookworm-backports\nComponents: main\n\
         Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg\n"
    );
    eprintln!("xtask: adding bookworm-backports ({mirror}) as {BACKPORTS_SOURCE}");
    std::fs::write(BACKPORTS_SOURCE, entry).with_context(|| format!("could not write {BACKPORTS_SOURCE}"))
}

/// The URI of the main Debian archive in a one-line or deb822 source file.
fn debian_mirror(text: &str) -> Option<String> {
    let lines: Vec<&str> = text.lines().map(str::trim).filter(|l| !l.starts_with('#')).collect();
    for l in &lines {
        let mut words = l.split_whitespace();
        if words.next() == Some("deb") {
            let uri = words.find(|w| !w.starts_with('['))?;
            if uri.ends_with("/debian") || uri.ends_with("/debian/") {
                return Some(uri.trim_end_matches('/').to_owned());
            }
        }
        if let Some(uris) = l.strip_prefix("URIs:") {
            let uri = uris.split_whitespace().next()?;
            if uri.ends_with("/debian") || uri.ends_with("/debian/") {
                return Some(uri.trim_end_matches('/').to_owned());
            }
        }
    }
    None
}

fn find_lavapipe_icd() -> Result<PathBuf> {
    let entries =
        std::fs::read_dir(ICD_DIR).with_context(|| format!("no Vulkan driver manifests in {ICD_DIR}"))?;
    entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("lvp_icd") && n.ends_with(".json"))
        })
        .with_context(|| format!("mesa-vulkan-drivers is installed but {ICD_DIR} has no lvp_icd*.json"))
}

fn which(program: &str) -> Option<PathBuf> {
    std::env::var_os("PATH")
        .and_then(|paths| std::env::split_paths(&paths).map(|dir| dir.join(program)).find(|p| p.is_file()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mesa_versions() {
        assert_eq!(mesa_major("25.0.7-2~bpo12+1"), 25);
        assert_eq!(mesa_major("22.3.6-1+deb12u1"), 22);
        assert_eq!(mesa_major("1:24.2"), 24);
        assert_eq!(mesa_major("garbage"), 0);
    }

    #[test]
    fn mirrors() {
        let deb822 = "Types: deb\n# http://snapshot\nURIs: http://deb.debian.org/debian\nSuites: bookworm\n";
        assert_eq!(debian_mirror(deb822).as_deref(), Some("http://deb.debian.org/debian"));
        let one_line = "deb [arch=amd64] http://ftp.de.debian.org/debian/ bookworm main\n";
        assert_eq!(debian_mirror(one_line).as_deref(), Some("http://ftp.de.debian.org/debian"));
        assert_eq!(debian_mirror("deb https://packages.cloud.google.com/apt x main"), None);
    }

    /// docs/testing.md lists exactly what the set-up installs.
    #[test]
    fn the_docs_list_every_package_the_set_up_installs() {
        let page = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/testing.md");
        let text = std::fs::read_to_string(&page).expect("docs/testing.md");
        let table: String = text
            .split("## What the set-up installs")
            .nth(1)
            .and_then(|rest| rest.split("\n## ").next())
            .expect("docs/testing.md has a section on what the set-up installs")
            .to_owned();
        let listed: Vec<&str> = table
            .lines()
            .filter(|l| l.starts_with("| `"))
            .flat_map(|l| l.split('|').nth(1).unwrap_or_default().split(','))
            .map(|p| p.trim().trim_matches('`').split('`').next().unwrap_or_default())
            .collect();
        let mut installed: Vec<&str> = BASE_PACKAGES.iter().copied().chain([DRIVER_PACKAGE]).collect();
        let mut documented = listed.clone();
        installed.sort_unstable();
        documented.sort_unstable();
        assert_eq!(
            documented, installed,
            "docs/testing.md's package table against BASE_PACKAGES + DRIVER_PACKAGE"
        );
    }
}
