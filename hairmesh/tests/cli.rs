//! The `hairmesh` command as a user runs it.

use std::path::Path;
use std::process::Command;

fn hairmesh(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_hairmesh")).args(args).output().expect("run hairmesh");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn repo(path: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path).display().to_string()
}

#[test]
fn the_committed_head_cap_is_what_the_generator_writes() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("cap.gltf");
    let (ok, _, stderr) = hairmesh(&["head-cap", "-o", out.to_str().expect("utf-8")]);
    assert!(ok, "{stderr}");
    let committed = std::fs::read(repo("assets/head_cap.gltf")).expect("assets/head_cap.gltf");
    assert_eq!(
        std::fs::read(&out).expect("written"),
        committed,
        "regenerate with `hairmesh head-cap -o assets/head_cap.gltf`"
    );
}

#[test]
fn convert_and_info_on_the_readme_examples() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("lee");
    let lee = repo("tests/data/heads/LeePerrySmith/LeePerrySmith.glb");
    let (ok, stdout, stderr) = hairmesh(&[
        "convert",
        &lee,
        "-o",
        out.to_str().expect("utf-8"),
        "--scalp",
        "above:0,1,0,1.5",
        "--strands",
        "5000",
        "--f16",
    ]);
    assert!(ok, "{stderr}");
    for field in ["bundles:", "layers:", "strands:", "bytes on the GPU"] {
        assert!(stdout.contains(field), "{field} missing: {stdout}");
    }
    assert!(stderr.contains("importing") && stderr.contains("writing"), "progress: {stderr}");
    let (ok, stdout, stderr) = hairmesh(&["info", out.to_str().expect("utf-8")]);
    assert!(ok, "{stderr}");
    assert!(stdout.contains("square set 0") && stdout.contains("F16"), "{stdout}");
    // The README's hairline and draped long hair on the same head; `info` names the provenance.
    let draped = dir.path().join("lee_draped");
    let (ok, _, stderr) = hairmesh(&[
        "convert",
        &lee,
        "-o",
        draped.to_str().expect("utf-8"),
        "--scalp",
        "above:0,0.8192,-0.5735,1.3435",
        "--drape",
        "0,1.9,-0.2",
        "--comb",
        "0,0,-2.5",
        "--layers",
        "6",
        "--length",
        "4.5",
        "--strands",
        "3000",
    ]);
    assert!(ok, "{stderr}");
    let (ok, stdout, stderr) = hairmesh(&["info", draped.to_str().expect("utf-8")]);
    assert!(ok, "{stderr}");
    assert!(stdout.contains("draped around") && stdout.contains("above:0,0.8192"), "{stdout}");
    let (ok, stdout, _) = hairmesh(&["info", &repo("tests/data/strands/tressfx/v4/Ratboy_mohawk.tfx")]);
    assert!(ok && stdout.contains("2228"), "{stdout}");
    let (ok, stdout, _) = hairmesh(&["info", &repo("tests/data/strands/tressfx/v4/Ratboy_mohawk.tfxbone")]);
    assert!(ok && stdout.contains("bones:"), "{stdout}");
}

#[test]
fn bad_input_is_refused_and_writes_nothing() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("asset");
    let o = out.to_str().expect("utf-8");
    let cap = repo("assets/head_cap.gltf");
    for (args, expected) in [
        (vec!["convert", "missing.glb", "-o", o], "missing.glb"),
        (vec!["convert", &cap, "-o", o, "--scalp", "above:1,2"], "scalp selector"),
        (vec!["convert", &cap, "-o", o, "--scalp", "sphere:0,50,0,0.1"], "no triangles"),
        (vec!["convert", &cap, "-o", o, "--layers", "0"], "0 layers"),
        (vec!["convert", &cap, "-o", o, "--length", "NaN"], "length"),
        (vec!["convert", &cap, "-o", o, "--strands", "0"], "strands"),
        (vec!["convert", &cap, "-o", o, "--density", "1", "--strands", "5"], "cannot be used with"),
        (vec!["convert", &cap, "-o", o, "--morph-layers"], "no morph targets"),
        (vec!["convert", &cap, "-o", o, "--drape", "0,1.6"], "three finite numbers"),
        (vec!["convert", &cap, "-o", o, "--drape", "0,1.6,0", "--comb", "0,1,0"], "no direction"),
        (vec!["info", "nothing.txt"], "nothing.txt"),
    ] {
        let (ok, _, stderr) = hairmesh(&args);
        assert!(!ok, "{args:?} should fail");
        assert!(stderr.contains(expected), "{args:?}: `{stderr}` should mention `{expected}`");
        assert!(!out.exists(), "{args:?} wrote output");
    }
    let style = dir.path().join("style.json");
    std::fs::write(&style, r#"{"curl": {"radius": 0.01, "speed": 3}}"#).expect("write");
    let (ok, _, stderr) = hairmesh(&["convert", &cap, "-o", o, "--style", style.to_str().expect("utf-8")]);
    assert!(
        !ok && stderr.contains("style.json")
            && stderr.contains("unknown field `speed`")
            && stderr.contains("line 1"),
        "{stderr}"
    );
    assert!(!out.exists());
}
