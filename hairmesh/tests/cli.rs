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

/// A file of the third-party data set (see `data_set`).
fn data(path: &str) -> String {
    data_set::require(path).display().to_string()
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
    let lee = data("heads/LeePerrySmith/LeePerrySmith.glb");
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
    // An asset of bundles of different lengths says how many end where.
    let (ok, stdout, _) = hairmesh(&["info", &repo("assets/hair/short_front_long_back")]);
    assert!(
        ok && stdout.contains("bundles end at different layers: ") && stdout.contains("at layer 1"),
        "{stdout}"
    );
    let (ok, stdout, _) = hairmesh(&["info", &data("strands/tressfx/v4/Ratboy_mohawk.tfx")]);
    assert!(ok && stdout.contains("2228"), "{stdout}");
    let (ok, stdout, _) = hairmesh(&["info", &data("strands/tressfx/v4/Ratboy_mohawk.tfxbone")]);
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

/// The README's commands for the example assets (`-o target/hair/NAME`) write exactly the
/// committed `assets/hair/NAME`, so the assets follow every change to conversion (root sets
/// included) and the README stays true.
#[test]
fn the_committed_example_assets_are_what_the_readme_commands_write() {
    let readme = std::fs::read_to_string(repo("README.md")).expect("README.md");
    let commands: Vec<&str> = readme
        .lines()
        .filter_map(|l| l.strip_prefix("$ "))
        .filter(|l| l.starts_with("hairmesh convert assets/head_cap.gltf -o target/hair/"))
        .collect();
    assert_eq!(commands.len(), 2, "the README lists the two example assets' commands");
    let dir = tempfile::tempdir().expect("temp dir");
    // Run where the README's paths are relative to (the asset records them as given); only the
    // output goes to the temp dir.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    for command in commands {
        let mut args: Vec<String> = command.split_whitespace().skip(1).map(str::to_owned).collect();
        let out_at = args.iter().position(|a| a == "-o").expect("-o") + 1;
        let name = Path::new(&args[out_at]).file_name().expect("folder name").to_owned();
        let committed = root.join("assets/hair").join(&name);
        let written = dir.path().join(&name);
        args[out_at] = written.display().to_string();
        let out = Command::new(env!("CARGO_BIN_EXE_hairmesh"))
            .args(&args)
            .current_dir(&root)
            .output()
            .expect("run");
        assert!(out.status.success(), "{command}: {}", String::from_utf8_lossy(&out.stderr));
        for file in ["hair.json", "hair_mesh.exr", "uv.exr", "w.exr", "u.exr", "v.exr", "preview.png"] {
            let fresh = std::fs::read(written.join(file)).expect("written");
            let kept = std::fs::read(committed.join(file)).unwrap_or_default();
            assert!(
                fresh == kept,
                "{} differs from what `{command}` writes: run that command and copy its output there",
                committed.join(file).display()
            );
        }
    }
}

/// `cargo run --release -p hairmesh --example blue_noise -- COUNT SEED --png OUT` (the README's
/// picture command), run on the example binary `cargo test` builds beside this test.
#[test]
fn the_blue_noise_example_reports_quality_and_draws_its_picture() {
    let test_exe = std::env::current_exe().expect("test executable");
    let examples = test_exe.parent().and_then(Path::parent).expect("target/<profile>").join("examples");
    let example = examples.join(format!("blue_noise{}", std::env::consts::EXE_SUFFIX));
    assert!(
        example.exists(),
        "{} is missing: `cargo test` builds the examples, `--test cli` alone does not",
        example.display()
    );
    let dir = tempfile::tempdir().expect("temp dir");
    let png = dir.path().join("blue-noise.png");
    let out = Command::new(&example)
        .args(["512", "3", "--png", png.to_str().expect("utf-8")])
        .output()
        .expect("run");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}{}", String::from_utf8_lossy(&out.stderr));
    for domain in ["Square:", "Triangle:"] {
        let line =
            stdout.lines().find(|l| l.starts_with(domain)).unwrap_or_else(|| panic!("{domain} {stdout}"));
        let worst: f64 = line.rsplit(' ').next().and_then(|w| w.parse().ok()).expect("worst prefix ρ");
        assert!(worst >= 0.65, "{line}");
    }
    assert!(stdout.contains("edge bands"), "{stdout}");
    let decoder =
        png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&png).expect("picture written")));
    let reader = decoder.read_info().expect("a PNG");
    assert_eq!((reader.info().width, reader.info().height), (4 * 256 + 12, 2 * 256 + 4));
    let bad = Command::new(&example).args(["512", "3", "--png"]).output().expect("run");
    assert!(
        !bad.status.success() && String::from_utf8_lossy(&bad.stderr).contains("--png needs a file name")
    );
}

/// Numbers far outside any sensible range used to make assets hairkit could not read back (an
/// overflowing length written as `null`) or hair that vanished: refused, with the range, and
/// nothing written.
#[test]
fn numbers_outside_their_ranges_are_refused_and_nothing_is_written() {
    let dir = tempfile::tempdir().expect("temp dir");
    let cap = repo("assets/head_cap.gltf");
    let style = dir.path().join("style.json");
    std::fs::write(&style, r#"{"curl": {"radius": 1e300}}"#).expect("write");
    let out = dir.path().join("out");
    let out_text = out.to_str().expect("utf-8");
    for (args, expected) in [
        (vec!["--length", "1e308"], "invalid length: 1e308"),
        (vec!["--length", "1e-12"], "invalid length"),
        (vec!["--droop", "1e300"], "invalid droop: 1e300 (expected -10..=10)"),
        (vec!["--drape", "0,1.6,0", "--lift", "1e300"], "invalid lift"),
        (vec!["--drape", "0,1.6,0", "--comb", "1e300,0,0"], "invalid comb"),
        (vec!["--style", style.to_str().expect("utf-8")], "curl.radius: 1e300 is outside 0..=10000"),
        (vec!["--density", "nan"], "density"),
    ] {
        let mut all = vec!["convert", cap.as_str(), "-o", out_text];
        all.extend(&args);
        let (ok, _, stderr) = hairmesh(&all);
        assert!(!ok && stderr.contains(expected), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert!(!out.exists(), "{args:?}: wrote an output");
    }
}

/// `hairmesh check` counts the strands that enter the head: none for the head cap's hair (its
/// conversion keeps the hair mesh outside), and the tips pushed into the skull are found, with
/// exit status 1.
#[test]
fn check_finds_strands_inside_the_head() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("cap");
    let out_text = out.to_str().expect("utf-8");
    let cap = repo("assets/head_cap.gltf");
    // Without the head field: what `check` finds is the hair mesh's doing alone.
    let (ok, _, stderr) = hairmesh(&["convert", &cap, "-o", out_text, "--strands", "2000", "--no-collision"]);
    assert!(ok, "{stderr}");
    let (ok, stdout, stderr) = hairmesh(&["check", out_text]);
    assert!(ok && stdout.contains("strands entering the head: 0 (0.00 %)"), "{stdout}{stderr}");
    assert!(stdout.contains("collision:                none"), "{stdout}");
    assert!(stdout.contains("head frame:") && stdout.contains("strands over the face:"), "{stdout}");
    // Pull every tip to the middle of the head (the cap is centred at y = 1.6).
    let (mut asset, _) = hairmesh::asset_io::read_asset(&out).expect("asset");
    let tip = asset.mesh().layers.len() - 1;
    let moves: Vec<hairmesh::asset::VertexMove> = (0..asset.mesh().vertex_count() as u32)
        .map(|v| hairmesh::asset::VertexMove {
            layer: tip as u32,
            vertex: v,
            position: glam::DVec3::new(0.0, 1.62, 0.0),
        })
        .collect();
    asset.move_vertices(&moves).expect("move");
    let inside = dir.path().join("inside");
    hairmesh::asset_io::write_asset(&inside, &asset, Default::default(), "metres", Some(&cap))
        .expect("write");
    let (ok, stdout, stderr) = hairmesh(&["check", inside.to_str().expect("utf-8"), "--head", &cap]);
    assert!(!ok && stderr.contains("strands enter the head"), "{stdout}{stderr}");
    let entering: u64 = stdout
        .lines()
        .find_map(|l| l.strip_prefix("strands entering the head: "))
        .and_then(|l| l.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .expect("a count");
    assert!(entering > 1000, "{stdout}");
    assert!(stdout.contains("hair-mesh vertices inside:"), "{stdout}");
    // The same pull on hair converted with its head field: the strands are pushed out of the
    // cap wherever they cross it, so check finds next to none (the tips themselves sit inside).
    let with_field = dir.path().join("field");
    let (ok, _, stderr) =
        hairmesh(&["convert", &cap, "-o", with_field.to_str().expect("utf-8"), "--strands", "2000"]);
    assert!(ok, "{stderr}");
    let (mut asset, _) = hairmesh::asset_io::read_asset(&with_field).expect("asset");
    assert!(asset.head_field.is_some(), "no head field");
    asset.move_vertices(&moves).expect("move");
    let pulled = dir.path().join("pulled");
    hairmesh::asset_io::write_asset(&pulled, &asset, Default::default(), "metres", Some(&cap))
        .expect("write");
    let (_, stdout, _) = hairmesh(&["check", pulled.to_str().expect("utf-8"), "--head", &cap]);
    assert!(stdout.contains("collision:                head field of"), "{stdout}");
    let kept_out: u64 = stdout
        .lines()
        .find_map(|l| l.strip_prefix("strands entering the head: "))
        .and_then(|l| l.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .expect("a count");
    assert!(
        kept_out * 20 < entering,
        "{kept_out} strands enter with the field, {entering} without: {stdout}"
    );
}

/// Vector options take negative components as written (`--drape -0.1,…`, not `--drape=-0.1,…`).
#[test]
fn vector_options_take_negative_components() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("draped");
    let cap = repo("assets/head_cap.gltf");
    let args = ["convert", &cap, "-o", out.to_str().expect("utf-8"), "--strands", "500"];
    let vectors = ["--drape", "-0.001,1.57,-0.01", "--comb", "-0.5,0,-2", "--up", "-0.0,1,0"];
    let all: Vec<&str> = args.iter().chain(&vectors).copied().collect();
    let (ok, _, stderr) = hairmesh(&all);
    assert!(ok, "{stderr}");
    let (asset, _) = hairmesh::asset_io::read_asset(&out).expect("asset");
    let Some(hairmesh::asset::ScalpProvenance { layers: hairmesh::asset::LayerSource::Draped(d), .. }) =
        asset.provenance
    else {
        panic!("a draped asset")
    };
    assert_eq!(d.comb, glam::DVec3::new(-0.5, 0.0, -2.0));
}
