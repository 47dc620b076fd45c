//! Where hairkit finds its third-party data set: the scanned heads, artists' grooms and glTF
//! samples that its tests, benches, `hair-bench` and the demo read.
//!
//! Those files are other people's work under their own licences, so they live beside the
//! repository, not in it (as OpenCV keeps `opencv_extra` and Blender its `tests/data` checkout).
//! [`DataSet::from_env`] looks for them, file by file, in this order:
//!
//! 1. the folder named by `HAIRKIT_DATA`, if that variable is set (and then only there, so an
//!    explicit choice is never silently replaced by another copy);
//! 2. `shared/testdata` beside the checkout this crate was built from (development and CI
//!    machines have it there, read-only);
//! 3. the per-user cache, `$XDG_CACHE_HOME/hairkit/testdata` or `~/.cache/hairkit/testdata`,
//!    which `cargo xtask data` fills from the origins listed in [`SOURCES_TSV`].
//!
//! Where none holds a file, the error names the file, every folder looked in, `HAIRKIT_DATA`
//! and the command that downloads the data.
//!
//! ```no_run
//! let head = data_set::locate("heads/LeePerrySmith/LeePerrySmith.glb")?;
//! # Ok::<(), data_set::MissingData>(())
//! ```

use std::ffi::OsString;
use std::fmt;
use std::path::{Path, PathBuf};

/// The environment variable that names the data folder.
pub const ENV_VAR: &str = "HAIRKIT_DATA";

/// The command that downloads the data set into the user cache.
pub const FETCH_COMMAND: &str = "cargo xtask data";

/// Every file of the data set: path, bytes, SHA-256, origin URL and licence, tab-separated
/// (`#` lines are comments). The list is the project's own; the files are not.
pub const SOURCES_TSV: &str = include_str!("../testdata.tsv");

/// The sample head the demo, the editor's "Open sample head" and the benches use.
pub const SAMPLE_HEAD: &str = "heads/LeePerrySmith/LeePerrySmith.glb";

/// Why a folder is on the search list.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Place {
    /// Named by `HAIRKIT_DATA`.
    EnvVar,
    /// `shared/testdata` beside the checkout.
    BesideCheckout,
    /// The per-user cache that `cargo xtask data` fills.
    UserCache,
}

impl fmt::Display for Place {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Place::EnvVar => ENV_VAR,
            Place::BesideCheckout => "beside the checkout",
            Place::UserCache => "user cache",
        })
    }
}

/// A folder that may hold the data set.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Root {
    pub path: PathBuf,
    pub place: Place,
}

/// A file of the data set that none of the folders holds.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub struct MissingData {
    /// The file asked for, relative to the data folder.
    pub file: PathBuf,
    /// Where it was looked for, in order.
    pub looked_in: Vec<Root>,
    /// Where `cargo xtask data` would put it.
    pub cache: Option<PathBuf>,
}

impl fmt::Display for MissingData {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "the data file `{}` was not found; looked in:", self.file.display())?;
        for root in &self.looked_in {
            writeln!(f, "  {} ({})", root.path.display(), root.place)?;
        }
        if self.looked_in.is_empty() {
            writeln!(
                f,
                "  (no folder: {ENV_VAR} is unset and neither a checkout nor a home folder was found)"
            )?;
        }
        write!(
            f,
            "hairkit's heads, grooms and glTF samples are third-party files kept outside the repository: \
             set {ENV_VAR} to a folder holding the data set, or run `{FETCH_COMMAND}` to download it"
        )?;
        if let Some(cache) = &self.cache {
            write!(f, " into {}", cache.display())?;
        }
        Ok(())
    }
}

/// The folders the data set is looked for in.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DataSet {
    roots: Vec<Root>,
    cache: Option<PathBuf>,
}

impl DataSet {
    /// The folders this process should look in: `HAIRKIT_DATA` alone when it is set, otherwise
    /// the folder beside the checkout and then the user cache.
    pub fn from_env() -> Self {
        Self::new(hairkit_data().map(Into::into), Some(beside_checkout()), user_cache())
    }

    /// The search list from its parts (for tests and tools that want another environment).
    /// An empty `hairkit_data` counts as unset.
    pub fn new(hairkit_data: Option<OsString>, beside: Option<PathBuf>, cache: Option<PathBuf>) -> Self {
        let roots = match hairkit_data.filter(|v| !v.is_empty()) {
            Some(dir) => vec![Root { path: PathBuf::from(dir), place: Place::EnvVar }],
            None => beside
                .map(|path| Root { path, place: Place::BesideCheckout })
                .into_iter()
                .chain(cache.clone().map(|path| Root { path, place: Place::UserCache }))
                .collect(),
        };
        DataSet { roots, cache }
    }

    /// The folders, in the order they are searched.
    pub fn roots(&self) -> &[Root] {
        &self.roots
    }

    /// The file or folder `relative` (a path inside the data set, `/`-separated) in the first
    /// folder that holds it.
    pub fn locate(&self, relative: impl AsRef<Path>) -> Result<PathBuf, MissingData> {
        let relative = relative.as_ref();
        self.roots.iter().map(|root| root.path.join(relative)).find(|p| p.exists()).ok_or_else(|| {
            MissingData {
                file: relative.to_path_buf(),
                looked_in: self.roots.clone(),
                cache: self.cache.clone(),
            }
        })
    }

    /// The name of `path` inside the data set (`/`-separated, relative to the first folder of
    /// the search list that holds it), if it is a file of the data set.
    pub fn name_of(&self, path: &Path) -> Option<String> {
        let file = path.canonicalize().ok()?;
        self.roots.iter().find_map(|root| {
            let rel = file.strip_prefix(root.path.canonicalize().ok()?).ok()?;
            let parts: Vec<&str> = rel.components().map(|c| c.as_os_str().to_str()).collect::<Option<_>>()?;
            Some(parts.join("/"))
        })
    }

    /// The first folder that holds every file of [`sources`] (with the listed size), if any:
    /// what `cargo xtask` checks before deciding to download.
    pub fn complete_root(&self) -> Option<&Root> {
        let listed = sources().ok()?;
        self.roots.iter().find(|root| {
            listed.iter().all(|s| {
                std::fs::metadata(root.path.join(&s.path)).is_ok_and(|m| m.is_file() && m.len() == s.bytes)
            })
        })
    }
}

/// The folder `HAIRKIT_DATA` names, if it is set and not empty.
pub fn hairkit_data() -> Option<PathBuf> {
    std::env::var_os(ENV_VAR).filter(|v| !v.is_empty()).map(PathBuf::from)
}

/// [`DataSet::from_env`]`.locate(relative)`.
pub fn locate(relative: impl AsRef<Path>) -> Result<PathBuf, MissingData> {
    DataSet::from_env().locate(relative)
}

/// How a file of the data set is named where its place differs per machine (an asset's
/// provenance, an editor session): this prefix and its name inside the data set.
pub const NAME_PREFIX: &str = "data:";

/// `path` as a portable name: `data:NAME` when it is a file of the data set
/// ([`DataSet::name_of`]), else `None`.
pub fn portable_name(path: &Path) -> Option<String> {
    DataSet::from_env().name_of(path).map(|n| format!("{NAME_PREFIX}{n}"))
}

/// The file a name from [`portable_name`] stands for on this machine (other names are paths
/// as they are).
pub fn resolve_name(name: &str) -> Result<PathBuf, MissingData> {
    match name.strip_prefix(NAME_PREFIX) {
        Some(rel) => locate(rel),
        None => Ok(PathBuf::from(name)),
    }
}

/// [`locate`] for tests and benches: a missing file panics with the resolver's message, so a
/// test that needs the data fails saying how to get it instead of being skipped.
pub fn require(relative: impl AsRef<Path>) -> PathBuf {
    match locate(relative) {
        Ok(path) => path,
        Err(missing) => panic!("{missing}"),
    }
}

/// The root of the checkout this crate was built from.
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// `shared/testdata` beside the checkout: the one place outside the repository that hairkit's
/// sources name (development and CI machines keep the read-only data set there).
pub fn beside_checkout() -> PathBuf {
    let root = workspace_root();
    root.parent().unwrap_or(&root).join("shared").join("testdata")
}

/// The per-user cache folder `cargo xtask data` downloads into: `$XDG_CACHE_HOME/hairkit/testdata`,
/// else `$HOME/.cache/hairkit/testdata` (`%LOCALAPPDATA%` on Windows).
pub fn user_cache() -> Option<PathBuf> {
    let nonempty = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty()).map(PathBuf::from);
    let base = nonempty("XDG_CACHE_HOME")
        .or_else(|| nonempty("HOME").map(|h| h.join(".cache")))
        .or_else(|| nonempty("LOCALAPPDATA"))?;
    Some(base.join("hairkit").join("testdata"))
}

/// One file of the data set, as [`SOURCES_TSV`] lists it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Source {
    /// Path inside the data set, `/`-separated.
    pub path: String,
    pub bytes: u64,
    /// Lower-case hex SHA-256 of the whole file.
    pub sha256: String,
    /// Where the file is downloaded from.
    pub url: String,
    pub licence: String,
}

/// A line of a sources list that cannot be read.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("sources list line {line}: {problem}")]
pub struct BadSourceLine {
    pub line: usize,
    pub problem: String,
}

/// The files of the data set, from [`SOURCES_TSV`].
pub fn sources() -> Result<Vec<Source>, BadSourceLine> {
    parse_sources(SOURCES_TSV)
}

/// A sources list: one file a line, `path\tbytes\tsha256\turl\tlicence`; `#` lines and blank
/// lines are skipped. Paths must stay inside the data folder.
pub fn parse_sources(text: &str) -> Result<Vec<Source>, BadSourceLine> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let bad = |problem: String| BadSourceLine { line: i + 1, problem };
        if line.trim().is_empty() || line.starts_with('#') {
            continue;
        }
        let cells: Vec<&str> = line.split('\t').collect();
        let [path, bytes, sha256, url, licence] = cells[..] else {
            return Err(bad(format!("expected 5 tab-separated fields, found {}", cells.len())));
        };
        let escapes = path.starts_with('/') || path.split('/').any(|c| c == ".." || c.is_empty() || c == ".");
        if escapes || path.contains('\\') {
            return Err(bad(format!("path `{path}` is not a plain relative path inside the data folder")));
        }
        let bytes = bytes.parse().map_err(|_| bad(format!("size `{bytes}` is not a number of bytes")))?;
        if sha256.len() != 64 || !sha256.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b)) {
            return Err(bad(format!("`{sha256}` is not a lower-case hex SHA-256")));
        }
        if !(url.starts_with("https://") || url.starts_with("http://")) {
            return Err(bad(format!("origin `{url}` is not an http(s) URL")));
        }
        out.push(Source {
            path: path.into(),
            bytes,
            sha256: sha256.into(),
            url: url.into(),
            licence: licence.into(),
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hairkit_data_alone_is_searched_when_set() {
        let set = DataSet::new(Some("/data".into()), Some("/beside".into()), Some("/cache".into()));
        assert_eq!(set.roots(), &[Root { path: "/data".into(), place: Place::EnvVar }]);
        let unset = DataSet::new(None, Some("/beside".into()), Some("/cache".into()));
        assert_eq!(
            unset.roots().iter().map(|r| r.place).collect::<Vec<_>>(),
            [Place::BesideCheckout, Place::UserCache]
        );
        let empty = DataSet::new(Some("".into()), Some("/beside".into()), None);
        assert_eq!(empty.roots()[0].place, Place::BesideCheckout);
    }

    #[test]
    fn a_file_is_found_in_the_first_folder_that_holds_it() {
        let beside = tempfile::tempdir().expect("temp dir");
        let cache = tempfile::tempdir().expect("temp dir");
        std::fs::create_dir_all(cache.path().join("heads")).expect("mkdir");
        std::fs::write(cache.path().join("heads/a.obj"), "v 0 0 0").expect("write");
        let set = DataSet::new(None, Some(beside.path().into()), Some(cache.path().into()));
        assert_eq!(set.locate("heads/a.obj"), Ok(cache.path().join("heads/a.obj")));
        std::fs::create_dir_all(beside.path().join("heads")).expect("mkdir");
        std::fs::write(beside.path().join("heads/a.obj"), "v 0 0 0").expect("write");
        assert_eq!(set.locate("heads/a.obj"), Ok(beside.path().join("heads/a.obj")));
    }

    #[test]
    fn a_missing_file_names_itself_the_folders_the_variable_and_the_command() {
        let empty = tempfile::tempdir().expect("temp dir");
        let set =
            DataSet::new(Some(empty.path().into()), None, Some("/home/u/.cache/hairkit/testdata".into()));
        let message = set.locate(SAMPLE_HEAD).expect_err("nothing there").to_string();
        for needle in [SAMPLE_HEAD, &empty.path().display().to_string(), ENV_VAR, FETCH_COMMAND] {
            assert!(message.contains(needle), "`{needle}` missing from: {message}");
        }
    }

    #[test]
    fn the_shipped_sources_list_reads_and_names_the_sample_head() {
        let listed = sources().expect("testdata.tsv reads");
        assert!(listed.len() > 300, "{} files", listed.len());
        let head = listed.iter().find(|s| s.path == SAMPLE_HEAD).expect("the sample head is listed");
        assert_eq!(head.bytes, 404_976);
        assert!(head.url.starts_with("https://"));
        let mut paths: Vec<&str> = listed.iter().map(|s| s.path.as_str()).collect();
        paths.sort_unstable();
        paths.dedup();
        assert_eq!(paths.len(), listed.len(), "a path is listed twice");
    }

    #[test]
    fn bad_sources_lines_are_refused_with_their_line() {
        let good = format!("a/b.bin\t3\t{}\thttps://x/y\tMIT", "0".repeat(64));
        assert_eq!(parse_sources(&format!("# c\n\n{good}\n")).map(|s| s.len()), Ok(1));
        for bad in [
            good.replace("a/b.bin", "../b.bin"),
            good.replace("a/b.bin", "/etc/passwd"),
            good.replace("\t3\t", "\tthree\t"),
            good.replace(&"0".repeat(64), "abc"),
            good.replace("https://x/y", "file:///etc/passwd"),
            "a\tb".into(),
        ] {
            let err = parse_sources(&format!("# c\n{bad}\n")).expect_err(&bad);
            assert_eq!(err.line, 2, "{err}");
        }
    }
}
