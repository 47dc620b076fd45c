//! The repository stands alone: nothing it builds, tests or benchmarks reads a path outside it
//! except through the data set's resolver.
//!
//! A clone must build and test by itself plus the third-party data set, which lives beside the
//! repository (or where `HAIRKIT_DATA` points, or in the user cache) and is found only by
//! `data-set/src/lib.rs`. So every source, build script, manifest and scene is scanned for
//! references that climb out of the repository root (`../../` from a crate folder, or the
//! shared folder beside the checkout), and the repository holds no third-party data.

use std::path::{Path, PathBuf};

fn repository_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The one source allowed to name the folder beside the checkout.
const RESOLVER: &str = "data-set/src/lib.rs";

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
        // Build output and git internals.
        if name == "target" || name == ".git" {
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
    let escapes = [
        ["../", "sha", "red/"].concat(),
        ["sha", "red/", "testdata"].concat(),
        ["\"", "sha", "red", "\""].concat(),
        ["\"../", "../"].concat(),
        ["tests", "/data/"].concat(),
        ["\"data", "/heads"].concat(),
    ];
    let mut offenders = Vec::new();
    for file in &files {
        if file.ends_with(RESOLVER) {
            continue;
        }
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
fn the_resolver_is_what_names_the_folder_beside_the_checkout() {
    // Its exemption above must stay meaningful: the file exists and does name that folder.
    let text = std::fs::read_to_string(repository_root().join(RESOLVER)).expect("the resolver's source");
    let names_it = [".join(\"", "sha", "red\").join(\"testdata\")"].concat();
    assert!(text.contains(&names_it), "{RESOLVER} no longer names the folder beside the checkout");
}

#[test]
fn no_third_party_data_is_in_the_repository() {
    let root = repository_root();
    // The old place of the data set is gone (tracked or not).
    assert!(
        !root.join("tests/data").exists(),
        "tests/data is back: third-party files belong in the data set"
    );
    // No file of the data set's list is anywhere in the tree under its own name.
    let listed: Vec<String> = data_set::sources()
        .expect("the sources list reads")
        .into_iter()
        .filter_map(|s| s.path.rsplit('/').next().map(str::to_owned))
        .filter(|name| !["LICENSE", "LICENSE.md", "README.md", "metadata.json"].contains(&name.as_str()))
        .collect();
    let mut files = Vec::new();
    fn all(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
            let path = entry.path();
            let name = entry.file_name();
            if name == "target" || name == ".git" {
                continue;
            }
            if path.is_dir() { all(&path, out) } else { out.push(path) }
        }
    }
    all(&root, &mut files);
    let copies: Vec<String> = files
        .iter()
        .filter(|f| f.file_name().and_then(|n| n.to_str()).is_some_and(|n| listed.iter().any(|l| l == n)))
        .map(|f| f.display().to_string())
        .collect();
    assert!(copies.is_empty(), "files of the third-party data set inside the repository: {copies:?}");
}
