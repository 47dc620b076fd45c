//! Reading what the user gave: only regular files are opened (a named pipe would block, a device
//! never ends), every read is bounded, and the files a glTF refers to must lie in its folder.
//!
//! A relative reference (`scalp.bin`, `buffers/scalp.bin`) resolves against the referring file's
//! folder with symlinks resolved, and must stay inside it. Absolute paths and `file:` URIs are
//! refused unless the caller trusts the file ([`References::Anywhere`], `--trust-paths` on the
//! command line); other URI schemes (`http:`, …) are always refused, since hairkit never fetches.

use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};

/// The largest input file read when `HAIRKIT_MAX_INPUT_BYTES` is not set.
pub const DEFAULT_MAX_INPUT_BYTES: u64 = 1 << 30;

/// The cap on every input file: `HAIRKIT_MAX_INPUT_BYTES` (bytes) if set and valid, else
/// [`DEFAULT_MAX_INPUT_BYTES`].
pub fn max_input_bytes() -> u64 {
    std::env::var("HAIRKIT_MAX_INPUT_BYTES")
        .ok()
        .and_then(|v| v.trim().parse::<u64>().ok())
        .filter(|&v| v > 0)
        .unwrap_or(DEFAULT_MAX_INPUT_BYTES)
}

/// Where the files an input refers to may be.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum References {
    /// Inside the referring file's folder (the default).
    #[default]
    InsideFolder,
    /// Also absolute paths and `file:` URIs: for files the user trusts.
    Anywhere,
}

fn invalid(message: String) -> std::io::Error {
    std::io::Error::new(std::io::ErrorKind::InvalidInput, message)
}

/// What a path is, in words, for messages: "a folder", "a named pipe", "a device", "a socket",
/// "a file".
pub fn describe(meta: &std::fs::Metadata) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    let t = meta.file_type();
    if t.is_dir() {
        "a folder"
    } else if t.is_fifo() {
        "a named pipe"
    } else if t.is_char_device() || t.is_block_device() {
        "a device"
    } else if t.is_socket() {
        "a socket"
    } else {
        "a file"
    }
}

/// Opens `path` for reading if it is a regular file (symlinks followed). Opened without
/// blocking, then checked on the open handle, so a FIFO swapped in meanwhile cannot hang it.
pub fn open_regular(path: &Path) -> std::io::Result<File> {
    use std::os::unix::fs::OpenOptionsExt;
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(invalid(format!("is {}, not a regular file", describe(&meta))));
    }
    let file = std::fs::OpenOptions::new().read(true).custom_flags(libc::O_NONBLOCK).open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(invalid(format!("is {}, not a regular file", describe(&meta))));
    }
    Ok(file)
}

/// Reads a whole regular file of at most `limit` bytes (and at most [`max_input_bytes`]).
pub fn read_regular(path: &Path, limit: u64) -> std::io::Result<Vec<u8>> {
    let limit = limit.min(max_input_bytes());
    let file = open_regular(path)?;
    let len = file.metadata()?.len();
    if len > limit {
        return Err(invalid(format!(
            "is {len} bytes, over the {limit}-byte limit (HAIRKIT_MAX_INPUT_BYTES raises the cap on input files)"
        )));
    }
    let mut bytes = Vec::with_capacity(len as usize);
    // A file that grows while it is read still stops at the limit.
    file.take(limit + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(invalid(format!("grew past the {limit}-byte limit while it was read")));
    }
    Ok(bytes)
}

/// Reads the first `len` bytes of a regular file that must hold at least that many (a glTF
/// buffer's `byteLength`): never more than the header promised.
pub fn read_prefix(path: &Path, len: u64) -> std::io::Result<Vec<u8>> {
    let cap = max_input_bytes();
    if len > cap {
        return Err(invalid(format!(
            "declares {len} bytes, over the {cap}-byte limit (HAIRKIT_MAX_INPUT_BYTES raises the cap on input files)"
        )));
    }
    let file = open_regular(path)?;
    let mut bytes = Vec::with_capacity(len.min(file.metadata()?.len()) as usize);
    file.take(len).read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// Does `uri` start with a scheme (`http:`, `file:`, …)? (RFC 3986: a letter, then letters,
/// digits, `+`, `-`, `.`, then `:`.)
fn scheme(uri: &str) -> Option<&str> {
    let (scheme, _) = uri.split_once(':')?;
    let mut chars = scheme.chars();
    let first = chars.next()?;
    (first.is_ascii_alphabetic() && chars.all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c)))
        .then_some(scheme)
}

/// Resolves a URI found in `referrer` (not a `data:` URI) to the file it names, checking it is
/// allowed. The error says why in words (the caller adds the file and field).
pub fn resolve_reference(referrer: &Path, uri: &str, references: References) -> Result<PathBuf, String> {
    let decoded = percent_encoding::percent_decode_str(uri)
        .decode_utf8()
        .map_err(|_| format!("`{uri}` is not valid UTF-8 once percent-decoded"))?
        .into_owned();
    let absolute = match scheme(uri) {
        Some(s) if s.eq_ignore_ascii_case("file") => {
            let path = decoded[s.len() + 1..].trim_start_matches("//");
            // `file:///x` and `file://localhost/x` name `/x`; other hosts are remote.
            let path = path.strip_prefix("localhost").unwrap_or(path);
            if !path.starts_with('/') {
                return Err(format!("`{uri}` names a file on another host"));
            }
            Some(PathBuf::from(path))
        }
        Some(s) => {
            return Err(format!(
                "`{uri}`: `{s}:` URIs are not supported (hairkit reads only files beside the glTF and data: URIs)"
            ));
        }
        None if decoded.starts_with('/') => Some(PathBuf::from(&decoded)),
        None => None,
    };
    if let Some(path) = absolute {
        return match references {
            References::Anywhere => Ok(path),
            References::InsideFolder => Err(format!(
                "`{uri}` is an absolute path; only files in the glTF's folder are read (trust the file with --trust-paths to allow it)"
            )),
        };
    }
    let folder = referrer.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let candidate = folder.join(&decoded);
    if references == References::Anywhere {
        return Ok(candidate);
    }
    let folder_real = std::fs::canonicalize(folder).map_err(|e| format!("{}: {e}", folder.display()))?;
    let real =
        std::fs::canonicalize(&candidate).map_err(|e| format!("`{uri}` ({}): {e}", candidate.display()))?;
    if !real.starts_with(&folder_real) {
        return Err(format!(
            "`{uri}` resolves to {}, outside the glTF's folder {}; only files in that folder are read (trust the file with --trust-paths to allow it)",
            real.display(),
            folder_real.display()
        ));
    }
    Ok(real)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schemes_are_recognized_and_windows_like_paths_are_not_relative() {
        assert_eq!(scheme("http://x/y.bin"), Some("http"));
        assert_eq!(scheme("file:///x"), Some("file"));
        assert_eq!(scheme("C:/x.bin"), Some("C"));
        assert_eq!(scheme("scalp.bin"), None);
        assert_eq!(scheme("a b:c"), None);
        assert_eq!(scheme("1x:y"), None);
    }

    #[test]
    fn references_stay_in_the_folder_unless_trusted() {
        let dir = tempfile::tempdir().expect("temp dir");
        let inner = dir.path().join("model");
        std::fs::create_dir(&inner).expect("mkdir");
        std::fs::write(inner.join("a.bin"), b"x").expect("write");
        std::fs::write(dir.path().join("outside.bin"), b"x").expect("write");
        let gltf = inner.join("m.gltf");
        assert!(resolve_reference(&gltf, "a.bin", References::InsideFolder).is_ok());
        assert!(resolve_reference(&gltf, "./a%2Ebin", References::InsideFolder).is_ok());
        let escape =
            resolve_reference(&gltf, "../outside.bin", References::InsideFolder).expect_err("refused");
        assert!(escape.contains("outside the glTF's folder"), "{escape}");
        let absolute = dir.path().join("outside.bin").display().to_string();
        let err = resolve_reference(&gltf, &absolute, References::InsideFolder).expect_err("refused");
        assert!(err.contains("absolute path"), "{err}");
        let err = resolve_reference(&gltf, &format!("file://{absolute}"), References::InsideFolder)
            .expect_err("refused");
        assert!(err.contains("absolute path"), "{err}");
        assert_eq!(
            resolve_reference(&gltf, &format!("file://{absolute}"), References::Anywhere).ok(),
            Some(PathBuf::from(&absolute))
        );
        let err =
            resolve_reference(&gltf, "https://example.com/a.bin", References::Anywhere).expect_err("refused");
        assert!(err.contains("`https:` URIs are not supported"), "{err}");
        // A symlink inside the folder that points out of it is outside.
        std::os::unix::fs::symlink(dir.path().join("outside.bin"), inner.join("link.bin")).expect("symlink");
        assert!(resolve_reference(&gltf, "link.bin", References::InsideFolder).is_err());
    }

    #[test]
    fn only_regular_files_are_read_and_reads_are_bounded() {
        let dir = tempfile::tempdir().expect("temp dir");
        let err = read_regular(dir.path(), 10).expect_err("refused");
        assert!(err.to_string().contains("a folder"), "{err}");
        let file = dir.path().join("f");
        std::fs::write(&file, [0u8; 100]).expect("write");
        assert!(read_regular(&file, 99).expect_err("refused").to_string().contains("over the 99-byte limit"));
        assert_eq!(read_regular(&file, 100).expect("read").len(), 100);
        assert_eq!(read_prefix(&file, 10).expect("prefix").len(), 10);
        let err = read_regular(Path::new("/dev/zero"), 10).expect_err("refused");
        assert!(err.to_string().contains("a device"), "{err}");
    }
}

/// A JSON error as `line L, column C: what` — the position once: serde_json's own text ends
/// with it again (" at line L column C"), which callers that name the position would repeat.
pub fn json_error(e: &serde_json::Error) -> String {
    let text = e.to_string();
    let position = format!(" at line {} column {}", e.line(), e.column());
    let what = text.strip_suffix(&position).unwrap_or(&text);
    format!("line {}, column {}: {what}", e.line(), e.column())
}

#[cfg(test)]
mod json_error_tests {
    #[test]
    fn a_json_error_names_its_position_once() {
        let e = serde_json::from_str::<serde_json::Value>("{\n  \"a\": tru }").expect_err("broken JSON");
        let text = super::json_error(&e);
        assert_eq!(text.matches("line 2").count(), 1, "{text}");
        assert!(text.starts_with("line 2, column "), "{text}");
    }
}
