//! The repository stands alone: nothing it builds, tests or benchmarks reads a path outside it.
//!
//! A clone without sibling folders must pass its own test suite, so every source, build script,
//! manifest and scene is scanned for references that climb out of the repository root
//! (`../../` from a crate folder, or the steering folder that sits beside this project's own
//! checkouts). The real test data lives in `tests/data/` with its origins and licences.

use std::path::{Path, PathBuf};

fn repository_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Files whose contents decide what the build and the tests read.
fn is_checked(path: &Path) -> bool {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    matches!(ext, "rs" | "toml" | "json" | "glsl" | "comp" | "vert" | "frag" | "mesh" | "task" | "sh")
        || name == "run"
}

fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name();
        let name = name.to_string_lossy();
        // Build output, git internals and the vendored data itself (its files are inputs, not code).
        if name == "target" || name == ".git" || path.ends_with("tests/data") {
            continue;
        }
        if path.is_dir() {
            walk(&path, out);
        } else if is_checked(&path) {
            out.push(path);
        }
    }
}

#[test]
fn no_source_reads_outside_the_repository() {
    let root = repository_root();
    let mut files = Vec::new();
    walk(&root, &mut files);
    assert!(files.len() > 50, "the scan found only {} files under {}", files.len(), root.display());
    // Assembled at run time so this file does not match itself.
    let escapes = [format!("../{}/", "shared"), format!("{}/testdata", "shared"), format!("\"../{}", "../")];
    let mut offenders = Vec::new();
    for file in &files {
        let Ok(text) = std::fs::read_to_string(file) else { continue };
        for (number, line) in text.lines().enumerate() {
            if escapes.iter().any(|e| line.contains(e.as_str())) {
                offenders.push(format!("{}:{}: {}", file.display(), number + 1, line.trim()));
            }
        }
    }
    assert!(offenders.is_empty(), "paths that leave the repository:\n{}", offenders.join("\n"));
}

#[test]
fn the_test_data_is_in_the_repository_with_its_sources() {
    let data = repository_root().join("tests/data");
    let sources = std::fs::read_to_string(data.join("SOURCES.md")).expect("tests/data/SOURCES.md");
    let mut files = Vec::new();
    fn all(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).expect("readable test data").flatten() {
            let path = entry.path();
            if path.is_dir() { all(&path, out) } else { out.push(path) }
        }
    }
    all(&data, &mut files);
    let mut unlisted = Vec::new();
    for file in &files {
        let relative =
            file.strip_prefix(&data).expect("inside tests/data").to_string_lossy().replace('\\', "/");
        if relative == "SOURCES.md" || relative == "README.md" {
            continue;
        }
        // Every data file names its origin and licence in SOURCES.md.
        if !sources.contains(&format!("| {relative} |")) {
            unlisted.push(relative);
        }
    }
    assert!(files.len() > 20, "tests/data holds only {} files", files.len());
    assert!(
        unlisted.is_empty(),
        "files in tests/data without an origin and licence in SOURCES.md: {unlisted:?}"
    );
}
