//! `cargo xtask data`: downloads the third-party data set (heads, grooms, glTF samples) into
//! the user cache, from the origins `data-set/testdata.tsv` lists.
//!
//! Each file is streamed into `NAME.part` beside its final place, never past its listed size;
//! a `.part` left by an interrupted run is resumed with an HTTP range request; the whole file's
//! SHA-256 must match the list before it is renamed into place, and a file that does not match
//! is deleted. A failure names the file, its URL and what went wrong, and the other files are
//! still fetched.

use std::fs::{File, OpenOptions};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context as _, Result, bail};
use data_set::Source;
use sha2::{Digest, Sha256};

/// What happened to one file.
#[derive(Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Already in place with the listed hash.
    Present,
    /// Downloaded; `resumed_from` bytes came from an earlier, interrupted run.
    Downloaded { resumed_from: u64 },
}

/// An HTTP agent for the downloads: statuses are handled here, so a 404 gets the file's name.
pub fn agent() -> ureq::Agent {
    ureq::Agent::config_builder()
        .http_status_as_error(false)
        .timeout_connect(Some(Duration::from_secs(30)))
        .timeout_recv_response(Some(Duration::from_secs(60)))
        .timeout_recv_body(Some(Duration::from_secs(300)))
        .user_agent("hairkit-xtask-data")
        .build()
        .into()
}

/// When this many files in a row fail from the start, the others are not tried: the network
/// is most likely unreachable, and 400 timeouts would tell the user nothing more.
const GIVE_UP_AFTER: usize = 5;

/// Fetches every file of `sources` into `dest`, printing a line per file to `log`; returns an
/// error listing every file that failed.
pub fn fetch_all(agent: &ureq::Agent, sources: &[Source], dest: &Path, log: &mut impl Write) -> Result<()> {
    let total: u64 = sources.iter().map(|s| s.bytes).sum();
    writeln!(
        log,
        "xtask data: {} files, {:.1} MB, into {}",
        sources.len(),
        total as f64 / 1e6,
        dest.display()
    )?;
    let mut failures = Vec::new();
    for (i, source) in sources.iter().enumerate() {
        if failures.len() >= GIVE_UP_AFTER && failures.len() == i {
            bail!(
                "giving up after the first {i} files all failed (is the network reachable?):\n  {}",
                failures.join("\n  ")
            );
        }
        let line = format!("[{:>3}/{}] {} ({} bytes)", i + 1, sources.len(), source.path, source.bytes);
        match fetch_file(agent, source, dest) {
            Ok(Outcome::Present) => writeln!(log, "{line}: already present")?,
            Ok(Outcome::Downloaded { resumed_from: 0 }) => writeln!(log, "{line}: downloaded")?,
            Ok(Outcome::Downloaded { resumed_from }) => {
                writeln!(log, "{line}: downloaded (resumed after {resumed_from} bytes)")?;
            }
            Err(e) => {
                writeln!(log, "{line}: FAILED: {e:#}")?;
                failures.push(format!("{} from {}: {e:#}", source.path, source.url));
            }
        }
    }
    if !failures.is_empty() {
        bail!(
            "{} of {} files could not be fetched (run `cargo xtask data` again to resume):\n  {}",
            failures.len(),
            sources.len(),
            failures.join("\n  ")
        );
    }
    writeln!(log, "xtask data: the data set is complete in {}", dest.display())?;
    Ok(())
}

/// Fetches one file into `dest/source.path` (see the module's notes).
pub fn fetch_file(agent: &ureq::Agent, source: &Source, dest: &Path) -> Result<Outcome> {
    let target = dest.join(&source.path);
    if target.is_file() && sha256_of(&target)? == source.sha256 {
        return Ok(Outcome::Present);
    }
    let part = part_path(&target);
    let mut have = std::fs::metadata(&part).map_or(0, |m| m.len());
    if have >= source.bytes {
        // Complete but not renamed (a hash mismatch would have deleted it) or longer than it
        // can be: start over rather than trust it.
        remove(&part)?;
        have = 0;
    }
    let mut request = agent.get(&source.url);
    if have > 0 {
        request = request.header("Range", format!("bytes={have}-"));
    }
    let response = request.call().context("the request failed")?;
    let status = response.status().as_u16();
    let resumed_from = match status {
        206 if have > 0 && range_starts_at(&response, have) => have,
        200 | 206 => 0,
        _ => bail!("the server answered HTTP {status}"),
    };
    let dir = target.parent().context("a data file without a folder")?;
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut file =
        if resumed_from > 0 { OpenOptions::new().append(true).open(&part) } else { File::create(&part) }
            .with_context(|| format!("opening {}", part.display()))?;
    let mut body = response.into_body().into_reader();
    let copied = copy_at_most(&mut body, &mut file, source.bytes - resumed_from);
    file.sync_all().with_context(|| format!("writing {}", part.display()))?;
    drop(file);
    let received = resumed_from + copied.as_ref().map_or_else(|(n, _)| *n, |n| *n);
    if let Err((_, e)) = copied {
        // Kept: the next run resumes from here.
        bail!(
            "the download stopped after {received} of {} bytes ({e}); the part is kept to resume",
            source.bytes
        );
    }
    // copy_at_most never goes past the listed size: fewer bytes means the body ended early.
    if received != source.bytes {
        bail!("the server sent {received} bytes, the list says {}; the part is kept to resume", source.bytes);
    }
    let mut extra = [0u8; 1];
    if body.read(&mut extra).is_ok_and(|n| n > 0) {
        remove(&part)?;
        bail!("the server sent more than the listed {} bytes; nothing kept", source.bytes);
    }
    let actual = sha256_of(&part)?;
    if actual != source.sha256 {
        remove(&part)?;
        bail!("its SHA-256 is {actual}, the list says {}; nothing kept", source.sha256);
    }
    std::fs::rename(&part, &target).with_context(|| format!("renaming {} into place", part.display()))?;
    Ok(Outcome::Downloaded { resumed_from })
}

/// `NAME.part` beside `target`.
fn part_path(target: &Path) -> PathBuf {
    let mut name = target.file_name().unwrap_or_default().to_owned();
    name.push(".part");
    target.with_file_name(name)
}

/// Whether a 206 answer's `Content-Range` starts where the part ends.
fn range_starts_at(response: &ureq::http::Response<ureq::Body>, at: u64) -> bool {
    response
        .headers()
        .get("content-range")
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.starts_with(&format!("bytes {at}-")))
}

/// Copies up to `limit` bytes; on an error, how many were copied before it.
fn copy_at_most(from: &mut impl Read, to: &mut impl Write, limit: u64) -> Result<u64, (u64, std::io::Error)> {
    let mut buffer = vec![0u8; 64 << 10];
    let mut copied = 0u64;
    while copied < limit {
        let want = usize::try_from(limit - copied).unwrap_or(usize::MAX).min(buffer.len());
        let n = match from.read(&mut buffer[..want]) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err((copied, e)),
        };
        to.write_all(&buffer[..n]).map_err(|e| (copied, e))?;
        copied += n as u64;
    }
    Ok(copied)
}

fn sha256_of(path: &Path) -> Result<String> {
    let mut file = File::open(path).with_context(|| format!("reading {}", path.display()))?;
    let mut hasher = Sha256::new();
    std::io::copy(&mut file, &mut hasher).with_context(|| format!("reading {}", path.display()))?;
    Ok(hasher.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

fn remove(path: &Path) -> Result<()> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            Err(e).with_context(|| format!("removing {}", path.display()))
        }
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    //! The downloader against a small HTTP server on loopback (no network in tests).

    use std::collections::HashMap;
    use std::io::{BufRead, BufReader};
    use std::net::TcpListener;
    use std::sync::{Arc, Mutex};

    use super::*;

    /// How the server answers for one path.
    #[derive(Clone)]
    enum Serve {
        /// The bytes, honouring `Range`.
        Whole(Vec<u8>),
        /// The bytes, but the connection closes after this many of them (every request).
        DropAfter(Vec<u8>, usize),
        /// 404.
        Missing,
    }

    /// A request's path and its `Range` header.
    type Request = (String, Option<String>);

    struct Server {
        base: String,
        /// Every request's path and `Range` header, in order.
        requests: Arc<Mutex<Vec<Request>>>,
        routes: Arc<Mutex<HashMap<String, Serve>>>,
    }

    impl Server {
        fn start() -> Server {
            let listener = TcpListener::bind("127.0.0.1:0").expect("bind loopback");
            let base = format!("http://{}", listener.local_addr().expect("address"));
            let requests = Arc::new(Mutex::new(Vec::new()));
            let routes: Arc<Mutex<HashMap<String, Serve>>> = Arc::default();
            let (log, table) = (requests.clone(), routes.clone());
            std::thread::spawn(move || {
                for stream in listener.incoming() {
                    let Ok(mut stream) = stream else { continue };
                    let mut reader = BufReader::new(stream.try_clone().expect("clone stream"));
                    let mut first = String::new();
                    if reader.read_line(&mut first).is_err() {
                        continue;
                    }
                    let path = first.split_whitespace().nth(1).unwrap_or("/").to_owned();
                    let mut range = None;
                    loop {
                        let mut line = String::new();
                        if reader.read_line(&mut line).unwrap_or(0) == 0 || line.trim().is_empty() {
                            break;
                        }
                        if let Some((k, v)) = line.split_once(':')
                            && k.eq_ignore_ascii_case("range")
                        {
                            range = Some(v.trim().to_owned());
                        }
                    }
                    log.lock().expect("log").push((path.clone(), range.clone()));
                    let serve = table.lock().expect("routes").get(&path).cloned().unwrap_or(Serve::Missing);
                    let (bytes, cut) = match serve {
                        Serve::Missing => {
                            let _ = stream.write_all(
                                b"HTTP/1.1 404 Not Found\r\ncontent-length: 0\r\nconnection: close\r\n\r\n",
                            );
                            continue;
                        }
                        Serve::Whole(b) => (b, usize::MAX),
                        Serve::DropAfter(b, n) => (b, n),
                    };
                    let start = range
                        .as_deref()
                        .and_then(|r| r.strip_prefix("bytes="))
                        .and_then(|r| r.trim_end_matches('-').parse::<usize>().ok())
                        .filter(|&s| s < bytes.len());
                    let head = match start {
                        Some(s) => format!(
                            "HTTP/1.1 206 Partial Content\r\ncontent-length: {}\r\ncontent-range: bytes {s}-{}/{}\r\nconnection: close\r\n\r\n",
                            bytes.len() - s,
                            bytes.len() - 1,
                            bytes.len()
                        ),
                        None => format!(
                            "HTTP/1.1 200 OK\r\ncontent-length: {}\r\nconnection: close\r\n\r\n",
                            bytes.len()
                        ),
                    };
                    let body = &bytes[start.unwrap_or(0)..];
                    let _ = stream.write_all(head.as_bytes());
                    let _ = stream.write_all(&body[..body.len().min(cut)]);
                }
            });
            Server { base, requests, routes }
        }

        fn serve(&self, path: &str, how: Serve) -> String {
            self.routes.lock().expect("routes").insert(path.into(), how);
            format!("{}{path}", self.base)
        }
    }

    fn bytes(n: usize, seed: u8) -> Vec<u8> {
        (0..n).map(|i| (i as u8).wrapping_mul(31).wrapping_add(seed)).collect()
    }

    fn sha(b: &[u8]) -> String {
        Sha256::digest(b).iter().map(|b| format!("{b:02x}")).collect()
    }

    fn source(path: &str, content: &[u8], url: String) -> Source {
        Source {
            path: path.into(),
            bytes: content.len() as u64,
            sha256: sha(content),
            url,
            licence: "test".into(),
        }
    }

    fn files_under(dir: &Path) -> Vec<PathBuf> {
        let mut out = Vec::new();
        for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
            let p = entry.path();
            if p.is_dir() { out.extend(files_under(&p)) } else { out.push(p) }
        }
        out
    }

    #[test]
    fn a_good_file_is_downloaded_then_found_present() {
        let server = Server::start();
        let dest = tempfile::tempdir().expect("temp dir");
        let content = bytes(200_000, 1);
        let s =
            source("heads/a/head.glb", &content, server.serve("/a/head.glb", Serve::Whole(content.clone())));
        let mut log = Vec::new();
        fetch_all(&agent(), std::slice::from_ref(&s), dest.path(), &mut log).expect("fetched");
        assert_eq!(std::fs::read(dest.path().join("heads/a/head.glb")).expect("written"), content);
        assert_eq!(files_under(dest.path()).len(), 1, "nothing but the file is left");
        let log = String::from_utf8(log).expect("utf-8");
        assert!(log.contains("[  1/1] heads/a/head.glb (200000 bytes): downloaded"), "{log}");
        assert_eq!(fetch_file(&agent(), &s, dest.path()).expect("again"), Outcome::Present);
        assert_eq!(server.requests.lock().expect("log").len(), 1, "a present file is not fetched again");
    }

    #[test]
    fn a_file_with_the_wrong_hash_is_refused_and_nothing_is_left() {
        let server = Server::start();
        let dest = tempfile::tempdir().expect("temp dir");
        let listed = bytes(5000, 2);
        let mut served = listed.clone();
        served[4000] ^= 1;
        let s = source("gltf/x.gltf", &listed, server.serve("/x.gltf", Serve::Whole(served)));
        let err = fetch_all(&agent(), &[s], dest.path(), &mut Vec::new()).expect_err("hash mismatch");
        let message = format!("{err:#}");
        for needle in ["gltf/x.gltf", "/x.gltf", "SHA-256", "nothing kept"] {
            assert!(message.contains(needle), "`{needle}` missing from: {message}");
        }
        assert_eq!(files_under(dest.path()), Vec::<PathBuf>::new(), "nothing left behind");
    }

    #[test]
    fn a_dropped_connection_names_the_file_and_a_later_run_resumes() {
        let server = Server::start();
        let dest = tempfile::tempdir().expect("temp dir");
        let content = bytes(300_000, 3);
        let url = server.serve("/big.tfx", Serve::DropAfter(content.clone(), 120_000));
        let s = source("strands/big.tfx", &content, url.clone());
        let err = fetch_all(&agent(), std::slice::from_ref(&s), dest.path(), &mut Vec::new())
            .expect_err("the connection drops");
        let message = format!("{err:#}");
        for needle in ["strands/big.tfx", &url, "stopped after 120000 of 300000 bytes"] {
            assert!(message.contains(needle), "`{needle}` missing from: {message}");
        }
        assert!(!dest.path().join("strands/big.tfx").exists(), "no file in place after a failure");
        let part = dest.path().join("strands/big.tfx.part");
        assert_eq!(std::fs::metadata(&part).expect("part kept").len(), 120_000);

        // The server recovers: the next run asks for the rest and completes the file.
        server.serve("/big.tfx", Serve::Whole(content.clone()));
        let outcome = fetch_file(&agent(), &s, dest.path()).expect("resumed");
        assert_eq!(outcome, Outcome::Downloaded { resumed_from: 120_000 });
        assert_eq!(std::fs::read(dest.path().join("strands/big.tfx")).expect("written"), content);
        assert!(!part.exists());
        let requests = server.requests.lock().expect("log");
        assert_eq!(requests.last().map(|r| r.1.clone()), Some(Some("bytes=120000-".into())));
    }

    #[test]
    fn a_missing_origin_is_reported_and_the_other_files_still_come() {
        let server = Server::start();
        let dest = tempfile::tempdir().expect("temp dir");
        let good = bytes(1000, 4);
        let sources = [
            source("a/gone.bin", &good, server.serve("/gone.bin", Serve::Missing)),
            source("a/good.bin", &good, server.serve("/good.bin", Serve::Whole(good.clone()))),
        ];
        let err = fetch_all(&agent(), &sources, dest.path(), &mut Vec::new()).expect_err("one fails");
        let message = format!("{err:#}");
        assert!(
            message.contains("1 of 2 files")
                && message.contains("a/gone.bin")
                && message.contains("HTTP 404"),
            "{message}"
        );
        assert!(dest.path().join("a/good.bin").is_file());
        assert!(!dest.path().join("a/gone.bin").exists() && !dest.path().join("a/gone.bin.part").exists());
    }

    /// The shipped list describes the data set this machine has: every listed file is there
    /// with its size and SHA-256, and every file there (but the set's own notes) is listed.
    #[test]
    fn the_sources_list_matches_the_data_set_found() {
        let set = data_set::DataSet::from_env();
        let listed = data_set::sources().expect("the list reads");
        let Some(root) = set.complete_root() else {
            panic!(
                "{}",
                set.locate(&listed[0].path).err().map_or("no complete data set".into(), |m| m.to_string())
            );
        };
        for s in &listed {
            let path = root.path.join(&s.path);
            assert_eq!(sha256_of(&path).expect("readable"), s.sha256, "{}", path.display());
        }
        let notes = ["README.md", "SOURCES.md", "MANIFEST.json"];
        let unlisted: Vec<String> = files_under(&root.path)
            .iter()
            .filter_map(|p| p.strip_prefix(&root.path).ok().map(|r| r.to_string_lossy().replace('\\', "/")))
            .filter(|r| !notes.iter().any(|n| r.ends_with(n)) && !listed.iter().any(|s| &s.path == r))
            .filter(|r| !r.ends_with(".part"))
            .collect();
        assert!(
            unlisted.is_empty(),
            "files of {} missing from data-set/testdata.tsv: {unlisted:?}",
            root.path.display()
        );
    }
}
