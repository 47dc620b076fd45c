//! The `hairmesh` command against the file system: outputs that must not be replaced, glTF
//! references that leave their folder, special files, bounded reads, a closed pipe, a read-only
//! folder and a full disk. Every run has a time limit: a hang is a failure, not a stuck suite.
//!
//! The read-only and full-disk cases mount a small tmpfs, which needs root; elsewhere they are
//! listed as ignored with the reason.

use std::collections::BTreeMap;
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use libtest_mimic::{Arguments, Failed, Trial};

/// Longer than any of these runs takes; a run past it is a hang.
const TIME_LIMIT: Duration = Duration::from_secs(60);

struct Outcome {
    status: std::process::ExitStatus,
    stderr: String,
}

impl Outcome {
    fn ok(&self) -> bool {
        self.status.success()
    }
}

fn run_with(args: &[&str], env: &[(&str, &str)]) -> Result<Outcome, Failed> {
    let mut child = Command::new(env!("CARGO_BIN_EXE_hairmesh"))
        .args(args)
        .envs(env.iter().copied())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("run hairmesh: {e}"))?;
    // Read both pipes on threads so a chatty child never blocks on a full pipe.
    let mut out = child.stdout.take().ok_or("stdout")?;
    let mut err = child.stderr.take().ok_or("stderr")?;
    let out_reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = std::io::Read::read_to_string(&mut out, &mut s);
        s
    });
    let err_reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = std::io::Read::read_to_string(&mut err, &mut s);
        s
    });
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            break status;
        }
        if start.elapsed() > TIME_LIMIT {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!("hairmesh {args:?} hung (killed after {TIME_LIMIT:?})").into());
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    out_reader.join().map_err(|_| "stdout reader")?;
    let stderr = err_reader.join().map_err(|_| "stderr reader")?;
    if stderr.contains("panicked") {
        return Err(format!("hairmesh {args:?} panicked: {stderr}").into());
    }
    Ok(Outcome { status, stderr })
}

fn run(args: &[&str]) -> Result<Outcome, Failed> {
    run_with(args, &[])
}

fn text(path: &Path) -> &str {
    path.to_str().expect("temporary paths are UTF-8")
}

fn head_cap() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/head_cap.gltf")
}

/// Every file under `dir` with its bytes: to show a folder was left as it was.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut files = BTreeMap::new();
    let mut stack = vec![dir.to_owned()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).expect("list").flatten() {
            let path = entry.path();
            let kind = entry.file_type().expect("file type");
            if kind.is_dir() {
                stack.push(path);
            } else if kind.is_file() {
                files.insert(path.clone(), std::fs::read(&path).expect("read"));
            } else {
                files.insert(path, Vec::new());
            }
        }
    }
    files
}

fn ensure(condition: bool, message: impl FnOnce() -> String) -> Result<(), Failed> {
    if condition { Ok(()) } else { Err(message().into()) }
}

/// A one-triangle glTF in `dir` whose buffer is `uri`; the 36 bytes it needs are written to
/// `bin` when given.
fn triangle_gltf(dir: &Path, name: &str, uri: &str, bin: Option<&Path>) -> PathBuf {
    let positions: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let bytes: Vec<u8> = positions.iter().flat_map(|v| v.to_le_bytes()).collect();
    if let Some(bin) = bin {
        std::fs::write(bin, &bytes).expect("write the buffer");
    }
    let json = serde_json::json!({
        "asset": {"version": "2.0"},
        "buffers": [{"uri": uri, "byteLength": 36}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                        "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0
    });
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_vec(&json).expect("json")).expect("write the glTF");
    path
}

fn mkfifo(path: &Path) {
    let status = Command::new("mkfifo").arg(path).status().expect("mkfifo");
    assert!(status.success(), "mkfifo {}", path.display());
}

fn an_output_folder_holding_the_input_is_never_replaced() -> Result<(), Failed> {
    let dir = tempfile::tempdir()?;
    let input = dir.path().join("head.gltf");
    std::fs::copy(head_cap(), &input)?;
    std::fs::write(dir.path().join("notes.txt"), "mine")?;
    let before = snapshot(dir.path());
    for force in [false, true] {
        let mut args = vec!["convert", text(&input), "-o", text(dir.path()), "--strands", "200"];
        if force {
            args.push("--force");
        }
        let o = run(&args)?;
        ensure(!o.ok(), || format!("convert into the input's folder succeeded (force {force})"))?;
        ensure(o.stderr.contains("holds the input") && o.stderr.contains("head.gltf"), || o.stderr.clone())?;
        ensure(snapshot(dir.path()) == before, || "the folder changed".into())?;
    }
    Ok(())
}

fn a_folder_that_is_not_an_asset_is_replaced_only_with_force() -> Result<(), Failed> {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out");
    std::fs::create_dir(&out)?;
    for i in 0..6 {
        std::fs::write(out.join(format!("photo{i}.jpg")), "x")?;
    }
    let before = snapshot(dir.path());
    let cap = head_cap();
    let convert = |extra: &[&str]| {
        let mut args = vec!["convert", text(&cap), "-o", text(&out), "--strands", "200"];
        args.extend_from_slice(extra);
        run(&args)
    };
    let o = convert(&[])?;
    ensure(!o.ok(), || "a folder of photos was replaced".into())?;
    ensure(
        o.stderr.contains("photo0.jpg") && o.stderr.contains("and 2 more") && o.stderr.contains("--force"),
        || o.stderr.clone(),
    )?;
    ensure(snapshot(dir.path()) == before, || "the folder changed".into())?;
    // --force replaces it; then it is an asset, which a second conversion replaces by itself.
    let o = convert(&["--force"])?;
    ensure(o.ok(), || o.stderr.clone())?;
    ensure(!out.join("photo0.jpg").exists() && out.join("hair.json").exists(), || "not replaced".into())?;
    let o = convert(&[])?;
    ensure(o.ok(), || format!("re-converting over an asset: {}", o.stderr))?;
    // An asset folder someone added a file to is no longer only hairkit's.
    std::fs::write(out.join("README.txt"), "mine")?;
    let o = convert(&[])?;
    ensure(!o.ok() && o.stderr.contains("README.txt"), || o.stderr.clone())?;
    ensure(out.join("README.txt").exists(), || "the added file was deleted".into())?;
    Ok(())
}

fn single_file_outputs_replace_only_their_kind() -> Result<(), Failed> {
    let dir = tempfile::tempdir()?;
    let notes = dir.path().join("notes.gltf");
    std::fs::write(&notes, "dear diary")?;
    let o = run(&["head-cap", "-o", text(&notes)])?;
    ensure(!o.ok() && o.stderr.contains("not a glTF file written by hairkit"), || o.stderr.clone())?;
    ensure(std::fs::read_to_string(&notes)? == "dear diary", || "overwritten".into())?;
    let o = run(&["head-cap", "-o", text(&notes), "--force"])?;
    ensure(o.ok(), || o.stderr.clone())?;
    // Now a glTF: written again without --force.
    let o = run(&["head-cap", "-o", text(&notes)])?;
    ensure(o.ok(), || o.stderr.clone())?;
    // A folder, a named pipe and a device are never replaced by a file, even with --force.
    let fifo = dir.path().join("pipe.gltf");
    mkfifo(&fifo);
    for target in [dir.path(), fifo.as_path(), Path::new("/dev/null")] {
        let o = run(&["head-cap", "-o", text(target), "--force"])?;
        ensure(!o.ok() && o.stderr.contains(text(target)), || format!("{}: {}", target.display(), o.stderr))?;
    }
    let o = run(&["convert", text(&head_cap()), "-o", "/dev/null", "--force"])?;
    ensure(!o.ok() && o.stderr.contains("a device"), || o.stderr.clone())?;
    Ok(())
}

fn gltf_references_outside_its_folder_are_refused() -> Result<(), Failed> {
    let dir = tempfile::tempdir()?;
    let model = dir.path().join("model");
    std::fs::create_dir(&model)?;
    let secret = dir.path().join("secret.bin");
    let absolute = text(&secret).to_owned();
    let file_uri = format!("file://{absolute}");
    std::os::unix::fs::symlink(&secret, model.join("link.bin"))?;
    let cases: [(&str, &str); 6] = [
        ("../secret.bin", "outside the glTF's folder"),
        ("sub/../../secret.bin", "outside the glTF's folder"),
        (&absolute, "absolute path"),
        (&file_uri, "absolute path"),
        ("https://example.com/secret.bin", "`https:` URIs are not supported"),
        ("link.bin", "outside the glTF's folder"),
    ];
    std::fs::create_dir(model.join("sub"))?;
    for (i, (uri, expected)) in cases.iter().enumerate() {
        let gltf = triangle_gltf(&model, &format!("m{i}.gltf"), uri, Some(&secret));
        let out = dir.path().join(format!("out{i}"));
        let o = run(&["convert", text(&gltf), "-o", text(&out)])?;
        ensure(!o.ok(), || format!("{uri}: read"))?;
        ensure(o.stderr.contains(expected) && o.stderr.contains("buffers[0].uri"), || {
            format!("{uri}: {}", o.stderr)
        })?;
        ensure(!out.exists(), || format!("{uri}: wrote an output"))?;
    }
    // Trusted, an absolute path is read; a buffer beside the glTF always is.
    let gltf = triangle_gltf(&model, "abs.gltf", &absolute, Some(&secret));
    let o = run(&["convert", text(&gltf), "-o", text(&dir.path().join("trusted")), "--trust-paths"])?;
    ensure(o.ok(), || o.stderr.clone())?;
    let gltf = triangle_gltf(&model, "beside.gltf", "beside%20it.bin", Some(&model.join("beside it.bin")));
    let o = run(&["convert", text(&gltf), "-o", text(&dir.path().join("beside"))])?;
    ensure(o.ok(), || o.stderr.clone())?;
    Ok(())
}

fn special_files_are_refused_without_waiting() -> Result<(), Failed> {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out");
    let mut refused = Vec::new();
    for name in ["pipe.gltf", "pipe.glb", "pipe.obj"] {
        let fifo = dir.path().join(name);
        mkfifo(&fifo);
        refused.push(vec!["convert".to_owned(), text(&fifo).to_owned(), "-o".into(), text(&out).to_owned()]);
    }
    for name in ["pipe.tfx", "pipe.hair", "pipe.json"] {
        let fifo = dir.path().join(name);
        mkfifo(&fifo);
        refused.push(vec!["info".to_owned(), text(&fifo).to_owned()]);
    }
    let style = dir.path().join("style.json");
    mkfifo(&style);
    refused.push(vec![
        "convert".into(),
        text(&head_cap()).to_owned(),
        "-o".into(),
        text(&out).to_owned(),
        "--style".into(),
        text(&style).to_owned(),
    ]);
    let zero = dir.path().join("zero.glb");
    std::os::unix::fs::symlink("/dev/zero", &zero)?;
    refused.push(vec!["convert".into(), text(&zero).to_owned(), "-o".into(), text(&out).to_owned()]);
    // A buffer that is a named pipe beside the glTF.
    mkfifo(&dir.path().join("buffer.bin"));
    let gltf = triangle_gltf(dir.path(), "fifo-buffer.gltf", "buffer.bin", None);
    refused.push(vec!["convert".into(), text(&gltf).to_owned(), "-o".into(), text(&out).to_owned()]);
    for args in refused {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = run(&args)?;
        ensure(!o.ok(), || format!("{args:?} succeeded"))?;
        ensure(o.stderr.contains("a named pipe") || o.stderr.contains("a device"), || {
            format!("{args:?}: {}", o.stderr)
        })?;
    }
    ensure(!out.exists(), || "an output was written".into())?;
    Ok(())
}

fn every_read_is_bounded_by_the_cap() -> Result<(), Failed> {
    let dir = tempfile::tempdir()?;
    let o = run_with(
        &["convert", text(&head_cap()), "-o", text(&dir.path().join("out"))],
        &[("HAIRKIT_MAX_INPUT_BYTES", "1000")],
    )?;
    ensure(
        !o.ok()
            && o.stderr.contains("over the 1000-byte limit")
            && o.stderr.contains("HAIRKIT_MAX_INPUT_BYTES"),
        || o.stderr.clone(),
    )?;
    // A buffer is read only as far as it declares, so a long file beside it is no cost.
    let bin = dir.path().join("long.bin");
    let gltf = triangle_gltf(dir.path(), "m.gltf", "long.bin", Some(&bin));
    let mut bytes = std::fs::read(&bin)?;
    bytes.resize(4 << 20, 0);
    std::fs::write(&bin, bytes)?;
    let o = run_with(
        &["convert", text(&gltf), "-o", text(&dir.path().join("out2"))],
        &[("HAIRKIT_MAX_INPUT_BYTES", "100000")],
    )?;
    ensure(o.ok(), || o.stderr.clone())
}

fn a_closed_pipe_ends_the_command_quietly() -> Result<(), Failed> {
    let dir = tempfile::tempdir()?;
    let asset = dir.path().join("asset");
    let o = run(&["convert", text(&head_cap()), "-o", text(&asset), "--strands", "200"])?;
    ensure(o.ok(), || o.stderr.clone())?;
    let mut child = Command::new(env!("CARGO_BIN_EXE_hairmesh"))
        .args(["info", text(&asset)])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()?;
    // The reader goes away before anything is printed (`hairmesh info … | head -0`).
    drop(child.stdout.take());
    let output = child.wait_with_output()?;
    let stderr = String::from_utf8_lossy(&output.stderr);
    ensure(!stderr.contains("panicked"), || stderr.to_string())?;
    ensure(output.status.success() || output.status.signal() == Some(libc::SIGPIPE), || {
        format!("{:?}: {stderr}", output.status)
    })
}

/// A tmpfs mounted for one test, unmounted when dropped.
struct Tmpfs {
    path: PathBuf,
    _dir: tempfile::TempDir,
}

impl Tmpfs {
    fn mount(options: &str) -> Result<Self, Failed> {
        let dir = tempfile::tempdir()?;
        let path = dir.path().join("mnt");
        std::fs::create_dir(&path)?;
        let status =
            Command::new("mount").args(["-t", "tmpfs", "-o", options, "tmpfs"]).arg(&path).status()?;
        ensure(status.success(), || format!("mount -t tmpfs -o {options} failed"))?;
        Ok(Self { path, _dir: dir })
    }

    fn remount(&self, options: &str) -> Result<(), Failed> {
        let status =
            Command::new("mount").args(["-o", &format!("remount,{options}")]).arg(&self.path).status()?;
        ensure(status.success(), || format!("remount {options} failed"))
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.path).status();
    }
}

fn can_mount() -> Result<(), String> {
    // SAFETY: geteuid has no preconditions and cannot fail.
    let root = unsafe { libc::geteuid() } == 0;
    if !root {
        return Err("needs root to mount a small tmpfs".into());
    }
    if Command::new("mount").arg("--version").output().is_err() {
        return Err("no `mount` command".into());
    }
    Ok(())
}

fn a_read_only_folder_gives_an_error_and_keeps_the_asset() -> Result<(), Failed> {
    let fs = Tmpfs::mount("size=4m")?;
    let out = fs.path.join("asset");
    let convert = || run(&["convert", text(&head_cap()), "-o", text(&out), "--strands", "200"]);
    let o = convert()?;
    ensure(o.ok(), || o.stderr.clone())?;
    let before = snapshot(&fs.path);
    fs.remount("ro")?;
    let o = convert()?;
    ensure(!o.ok() && o.stderr.contains(text(&out)) && o.stderr.contains("Read-only file system"), || {
        o.stderr.clone()
    })?;
    ensure(snapshot(&fs.path) == before, || "the read-only folder changed".into())?;
    Ok(())
}

fn a_full_disk_gives_an_error_and_keeps_the_asset() -> Result<(), Failed> {
    let fs = Tmpfs::mount("size=1m")?;
    let out = fs.path.join("asset");
    let small =
        run(&["convert", text(&head_cap()), "-o", text(&out), "--strands", "100", "--layers", "1", "--f16"])?;
    ensure(small.ok(), || small.stderr.clone())?;
    let before = snapshot(&fs.path);
    let big = run(&["convert", text(&head_cap()), "-o", text(&out), "--strands", "100", "--layers", "32"])?;
    ensure(!big.ok() && big.stderr.contains("No space left on device"), || big.stderr.clone())?;
    // The earlier asset is whole and nothing half-written is left beside it.
    ensure(snapshot(&fs.path) == before, || "the earlier asset changed or temporary files remain".into())?;
    let info = run(&["info", text(&out)])?;
    ensure(info.ok(), || info.stderr.clone())
}

fn main() -> std::process::ExitCode {
    let args = Arguments::from_args();
    let mount = can_mount();
    let mut trials = vec![
        Trial::test(
            "an_output_folder_holding_the_input_is_never_replaced",
            an_output_folder_holding_the_input_is_never_replaced,
        ),
        Trial::test(
            "a_folder_that_is_not_an_asset_is_replaced_only_with_force",
            a_folder_that_is_not_an_asset_is_replaced_only_with_force,
        ),
        Trial::test(
            "single_file_outputs_replace_only_their_kind",
            single_file_outputs_replace_only_their_kind,
        ),
        Trial::test(
            "gltf_references_outside_its_folder_are_refused",
            gltf_references_outside_its_folder_are_refused,
        ),
        Trial::test("special_files_are_refused_without_waiting", special_files_are_refused_without_waiting),
        Trial::test("every_read_is_bounded_by_the_cap", every_read_is_bounded_by_the_cap),
        Trial::test("a_closed_pipe_ends_the_command_quietly", a_closed_pipe_ends_the_command_quietly),
    ];
    for (name, body) in [
        (
            "a_read_only_folder_gives_an_error_and_keeps_the_asset",
            a_read_only_folder_gives_an_error_and_keeps_the_asset as fn() -> _,
        ),
        ("a_full_disk_gives_an_error_and_keeps_the_asset", a_full_disk_gives_an_error_and_keeps_the_asset),
    ] {
        let trial = Trial::test(name, body);
        trials.push(match &mount {
            Ok(()) => trial,
            Err(reason) => {
                eprintln!("{name}: ignored: {reason}");
                trial.with_ignored_flag(true)
            }
        });
    }
    libtest_mimic::run(&args, trials).exit_code()
}
