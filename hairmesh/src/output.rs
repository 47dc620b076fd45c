//! What a hairkit command may write over. An existing path is replaced only when it is a
//! previous output of the same kind, or the user said `--force`; the command's inputs are never
//! inside what gets replaced, even with `--force`. Like `tar` and `rsync`, hairkit does not
//! delete what it did not write.
//!
//! Kinds of output and how a previous one is recognized:
//!
//! | kind | recognized by |
//! |---|---|
//! | hair asset folder | `hair.json` of format `hairkit.hair-asset`, and no file the asset writer does not write |
//! | command folder (`hairkit demo`, `crowd`, `hair-bench`) | the marker file [`FOLDER_MARKER`] naming the same command |
//! | single file | its signature: PNG, OpenEXR, simulation cache, or JSON (glTF, statistics) |
//!
//! A path that does not exist, and an empty folder, can always be written.

use std::io::Read;
use std::path::{Path, PathBuf};

/// The file a command folder's writer leaves in it (its content names the command).
pub const FOLDER_MARKER: &str = ".hairkit-output";

/// Files an asset folder may hold (the asset writer's names).
const ASSET_FILES: &[&str] =
    &["hair.json", "hair_mesh.exr", "uv.exr", "w.exr", "u.exr", "v.exr", "preview.png", "head_field.exr"];

/// Largest JSON file read to recognize it.
const MAX_RECOGNIZED_JSON: u64 = 64 << 20;

/// How many unknown entries an error lists by name.
const LISTED: usize = 4;

/// Whether an existing output that is not recognized may be replaced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Replace {
    /// Only a previous output of the same kind (the default everywhere).
    #[default]
    OwnOutput,
    /// Anything but the inputs and the folders that hold them (`--force`).
    Anything,
}

impl Replace {
    pub fn from_force(force: bool) -> Self {
        if force { Self::Anything } else { Self::OwnOutput }
    }
}

/// A single file a command writes, recognized by its first bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileKind {
    Png,
    Exr,
    /// A hairkit simulation cache (`render::animation::SimCache`).
    SimCache,
    /// A USD text layer.
    Usda,
    /// A TressFX 4.x strand file.
    Tfx,
    /// A JSON object with these top-level keys (e.g. a glTF has `asset`, hair-render's
    /// statistics `device` and `passes`).
    Json {
        what: &'static str,
        keys: &'static [&'static str],
    },
}

impl FileKind {
    /// The kind an output path asks for, from its extension.
    pub fn from_extension(path: &Path) -> Option<Self> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "png" => Self::Png,
            "exr" => Self::Exr,
            "sim" => Self::SimCache,
            "usda" => Self::Usda,
            "tfx" => Self::Tfx,
            "gltf" => Self::GLTF,
            _ => return None,
        })
    }

    /// A glTF file (JSON with an `asset` object).
    pub const GLTF: Self = Self::Json { what: "glTF file", keys: &["asset"] };

    fn name(self) -> &'static str {
        match self {
            Self::Png => "PNG image",
            Self::Exr => "OpenEXR image",
            Self::SimCache => "hairkit simulation cache",
            Self::Usda => "USD text layer",
            Self::Tfx => "TressFX 4 strand file",
            Self::Json { what, .. } => what,
        }
    }

    /// Is the file at `path` (a regular file) of this kind?
    fn recognizes(self, path: &Path) -> bool {
        let signature: &[u8] = match self {
            Self::Png => b"\x89PNG\r\n\x1a\n",
            Self::Exr => &[0x76, 0x2f, 0x31, 0x01],
            Self::SimCache => b"hairkit-sim\0",
            Self::Usda => b"#usda 1.0",
            Self::Tfx => &[0, 0, 0x80, 0x40],
            Self::Json { keys, .. } => {
                let Ok(bytes) = head_of(path, MAX_RECOGNIZED_JSON) else { return false };
                let Ok(serde_json::Value::Object(map)) = serde_json::from_slice(&bytes) else { return false };
                return keys.iter().all(|k| map.contains_key(*k));
            }
        };
        head_of(path, signature.len() as u64).is_ok_and(|head| head == signature)
    }
}

/// Why an output path was refused.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error(
        "{output}: refusing to write here: it holds the input {input}, which would be lost; choose another output"
    )]
    HoldsInput { output: PathBuf, input: PathBuf },
    #[error("{output}: refusing to write here: it is an input of this command; choose another output")]
    IsInput { output: PathBuf },
    #[error(
        "{output}: refusing to replace it: it holds the current folder or your home folder; choose another output"
    )]
    HoldsWorkingFolder { output: PathBuf },
    #[error(
        "{path}: refusing to replace it: it exists and is not {what} written by hairkit ({found}); choose a new path, or pass --force to replace it"
    )]
    NotOwnOutput { path: PathBuf, what: String, found: String },
    #[error("{path}: cannot write here: {problem}")]
    Unusable { path: PathBuf, problem: String },
}

fn canonical_or_absolute(path: &Path) -> PathBuf {
    std::fs::canonicalize(path)
        .unwrap_or_else(|_| std::path::absolute(path).unwrap_or_else(|_| path.to_owned()))
}

/// Refuses `output` when it is one of `inputs` or holds one (symlinks resolved).
fn check_inputs(output: &Path, inputs: &[&Path]) -> Result<(), OutputError> {
    let out = canonical_or_absolute(output);
    for input in inputs {
        let input_abs = canonical_or_absolute(input);
        if input_abs == out {
            return Err(OutputError::IsInput { output: output.to_owned() });
        }
        if input_abs.starts_with(&out) {
            return Err(OutputError::HoldsInput { output: output.to_owned(), input: input.to_path_buf() });
        }
    }
    Ok(())
}

/// Up to [`LISTED`] names of a folder's entries, and how many there are.
fn listing(entries: &[String]) -> String {
    let mut shown: Vec<&str> = entries.iter().take(LISTED).map(String::as_str).collect();
    if entries.len() > LISTED {
        let more = format!("and {} more", entries.len() - LISTED);
        return format!("it holds {} {more}", shown.join(", "));
    }
    if shown.len() == 1 {
        return format!("it holds {}", shown.remove(0));
    }
    format!("it holds {}", shown.join(", "))
}

fn entries(dir: &Path) -> Result<Vec<String>, OutputError> {
    let unusable = |e: std::io::Error| OutputError::Unusable { path: dir.to_owned(), problem: e.to_string() };
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map_err(unusable)?
        .map(|e| e.map(|e| e.file_name().to_string_lossy().into_owned()))
        .collect::<Result<_, _>>()
        .map_err(unusable)?;
    names.sort();
    Ok(names)
}

/// Reads at most `limit` bytes of a regular file (never blocks on a FIFO or device).
fn head_of(path: &Path, limit: u64) -> std::io::Result<Vec<u8>> {
    let mut head = Vec::new();
    crate::input::open_regular(path)?.take(limit).read_to_end(&mut head)?;
    Ok(head)
}

fn is_asset_manifest(path: &Path) -> bool {
    let Ok(bytes) = head_of(path, crate::asset_io::MAX_MANIFEST_BYTES) else { return false };
    #[derive(serde::Deserialize)]
    struct Format {
        format: String,
    }
    serde_json::from_slice::<Format>(&bytes).is_ok_and(|f| f.format == crate::asset_io::FORMAT)
}

/// May a hair asset be written to the folder `dir` (replacing what is there)?
pub fn check_asset_folder(dir: &Path, inputs: &[&Path], replace: Replace) -> Result<(), OutputError> {
    check_inputs(dir, inputs)?;
    let Ok(meta) = std::fs::symlink_metadata(dir) else { return Ok(()) };
    if !meta.is_dir() {
        return match replace {
            Replace::Anything if meta.is_file() || meta.is_symlink() => Ok(()),
            _ => Err(OutputError::NotOwnOutput {
                path: dir.to_owned(),
                what: "a hair asset folder".into(),
                found: format!("it is {}", crate::input::describe(&meta)),
            }),
        };
    }
    let names = entries(dir)?;
    let unknown: Vec<String> = names.iter().filter(|n| !ASSET_FILES.contains(&n.as_str())).cloned().collect();
    let own = unknown.is_empty() && (names.is_empty() || is_asset_manifest(&dir.join("hair.json")));
    if own {
        return Ok(());
    }
    if replace == Replace::Anything {
        return check_not_working_folder(dir);
    }
    let found = if unknown.is_empty() {
        "its hair.json is not a hairkit asset manifest".to_owned()
    } else {
        listing(&unknown)
    };
    Err(OutputError::NotOwnOutput { path: dir.to_owned(), what: "a hair asset folder".into(), found })
}

/// Replacing the current folder or the home folder (or a folder holding them) is never right.
fn check_not_working_folder(dir: &Path) -> Result<(), OutputError> {
    let out = canonical_or_absolute(dir);
    let protected = [std::env::current_dir().ok(), std::env::var_os("HOME").map(PathBuf::from)];
    for p in protected.into_iter().flatten() {
        if canonical_or_absolute(&p).starts_with(&out) {
            return Err(OutputError::HoldsWorkingFolder { output: dir.to_owned() });
        }
    }
    Ok(())
}

/// May `command` write its files into the folder `dir`? Yes when it does not exist, is empty,
/// holds the marker of an earlier run of the same command (call [`mark_folder`] after creating
/// it), or holds only names the command writes (`own`; a trailing `*` matches a prefix), as a
/// folder from before the marker does.
pub fn check_command_folder(
    dir: &Path,
    command: &str,
    own: &[&str],
    replace: Replace,
) -> Result<(), OutputError> {
    // Files are written into the folder, so a symlink to a folder is followed.
    let Ok(meta) = std::fs::metadata(dir) else { return Ok(()) };
    if !meta.is_dir() {
        return Err(OutputError::Unusable {
            path: dir.to_owned(),
            problem: format!("it is {}", crate::input::describe(&meta)),
        });
    }
    let names = entries(dir)?;
    if names.is_empty() {
        return Ok(());
    }
    let marker = head_of(&dir.join(FOLDER_MARKER), 4096).unwrap_or_default();
    if String::from_utf8_lossy(&marker).trim() == command {
        return Ok(());
    }
    let owned = |name: &String| {
        own.iter().any(|o| match o.strip_suffix('*') {
            Some(prefix) => name.starts_with(prefix),
            None => name == o,
        })
    };
    if names.iter().all(owned) {
        return Ok(());
    }
    if replace == Replace::Anything {
        // Files are written into the folder; nothing else in it is touched.
        return Ok(());
    }
    Err(OutputError::NotOwnOutput {
        path: dir.to_owned(),
        what: format!("an output folder of `{command}`"),
        found: listing(&names),
    })
}

/// Bytes free for an unprivileged writer on the file system that holds `path` (or the folder
/// it would be created in); `None` if that cannot be told.
pub fn free_bytes(path: &Path) -> Option<u64> {
    let mut folder = if path.is_dir() { path.to_owned() } else { path.parent()?.to_owned() };
    if folder.as_os_str().is_empty() {
        folder = PathBuf::from(".");
    }
    // The nearest folder that exists (outputs create their parents).
    while !folder.exists() {
        folder = folder.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new(".")).to_owned();
    }
    let c_path = std::ffi::CString::new(folder.as_os_str().as_encoded_bytes()).ok()?;
    let mut stats = std::mem::MaybeUninit::<libc::statvfs>::uninit();
    // SAFETY: `c_path` is a valid NUL-terminated string and `stats` is writable memory of the
    // size statvfs fills; it is read only when the call succeeds.
    let stats = unsafe {
        if libc::statvfs(c_path.as_ptr(), stats.as_mut_ptr()) != 0 {
            return None;
        }
        stats.assume_init()
    };
    #[allow(clippy::useless_conversion, reason = "the field types differ between targets")]
    Some(u64::from(stats.f_bavail).saturating_mul(u64::from(stats.f_frsize)))
}

/// Bytes of the regular files under `dir` (symlinks not followed): what an output took.
pub fn folder_bytes(dir: &Path) -> u64 {
    let mut total = 0;
    let mut stack = vec![dir.to_owned()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            match entry.file_type() {
                Ok(t) if t.is_dir() => stack.push(entry.path()),
                Ok(t) if t.is_file() => total += entry.metadata().map_or(0, |m| m.len()),
                _ => {}
            }
        }
    }
    total
}

/// Refuses to start writing `bytes` to `path` when its disk cannot hold them (an estimate the
/// caller makes before hours of work, not a guarantee).
pub fn check_space(path: &Path, bytes: u64) -> Result<(), OutputError> {
    match free_bytes(path) {
        Some(free) if free < bytes => Err(OutputError::Unusable {
            path: path.to_owned(),
            problem: format!(
                "this needs about {} and the disk has {} free",
                crate::terminal::bytes(bytes),
                crate::terminal::bytes(free)
            ),
        }),
        _ => Ok(()),
    }
}

/// Leaves the marker that lets the next run of `command` write into `dir` again.
pub fn mark_folder(dir: &Path, command: &str) -> std::io::Result<()> {
    crate::atomic::write_file_atomic(&dir.join(FOLDER_MARKER), |w| writeln!(w, "{command}"))
}

/// May the single file `path` of `kind` be written (replacing what is there)?
pub fn check_file(
    path: &Path,
    kind: FileKind,
    inputs: &[&Path],
    replace: Replace,
) -> Result<(), OutputError> {
    check_inputs(path, inputs)?;
    let Ok(meta) = std::fs::symlink_metadata(path) else { return Ok(()) };
    // A symlink is replaced by the rename, not followed: what it points at is not touched.
    if meta.is_symlink() || (meta.is_file() && replace == Replace::Anything) {
        return Ok(());
    }
    if !meta.is_file() {
        return Err(OutputError::Unusable {
            path: path.to_owned(),
            problem: format!("it is {}, not a file", crate::input::describe(&meta)),
        });
    }
    if meta.len() == 0 || kind.recognizes(path) {
        return Ok(());
    }
    Err(OutputError::NotOwnOutput {
        path: path.to_owned(),
        what: format!("a {}", kind.name()),
        found: format!("it is a {}-byte file of another kind", meta.len()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn space_is_checked_before_long_work() {
        let dir = tempfile::tempdir().expect("temp dir");
        std::fs::create_dir(dir.path().join("sub")).expect("mkdir");
        std::fs::write(dir.path().join("sub/a"), [0u8; 1000]).expect("write");
        std::fs::write(dir.path().join("b"), [0u8; 24]).expect("write");
        assert_eq!(folder_bytes(dir.path()), 1024);
        let target = dir.path().join("not/yet/there.sim");
        assert!(free_bytes(&target).is_some_and(|b| b > 0));
        assert!(check_space(&target, 1).is_ok());
        let e = check_space(&target, u64::MAX).expect_err("no disk holds that").to_string();
        assert!(e.contains("this needs about") && e.contains("free"), "{e}");
    }
}
