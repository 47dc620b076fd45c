//! Simulation caches: the simulated hair-mesh positions of every dynamic character for every
//! frame of an animation, the file that lets any process render any frame range
//! ([`crate::animation`]).
//!
//! Both directions stream: [`write_sim_cache`] steps the simulation and writes each frame as it
//! is made, and [`SimCache`] reads one frame when it is asked for, so an animation of any
//! length is simulated and rendered in the memory of one frame.
//!
//! File layout (little endian): the 16-byte magic `hairkit-sim\0v001`, the key (u64), fps
//! (f32), frames (u32), characters (u32), each character's vertex count (u32), then per frame
//! per character its positions (3 × f32 per vertex, layer-major, object space).

use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use glam::Vec3;

use crate::RenderError;
use crate::animation::Animation;

const CACHE_MAGIC: &[u8; 16] = b"hairkit-sim\0v001";
/// Largest cache written or read.
pub const MAX_CACHE_BYTES: u64 = 16 << 30;

fn error(path: &Path, message: String) -> RenderError {
    RenderError::Animation { path: path.to_owned(), message }
}

fn header_bytes(characters: usize) -> u64 {
    36 + 4 * characters as u64
}

/// Bytes of one frame of `vertex_counts`' characters.
fn frame_bytes(vertex_counts: &[u32]) -> u64 {
    vertex_counts.iter().map(|&n| u64::from(n) * 12).sum()
}

/// The size of the cache of `frames` frames of `animation`: what `--simulate` checks against
/// [`MAX_CACHE_BYTES`] and the disk before it starts.
pub fn cache_bytes(animation: &Animation, frames: u32) -> u64 {
    let counts = animation.vertex_counts();
    header_bytes(counts.len()) + frame_bytes(&counts) * u64::from(frames)
}

/// Simulates frames `0..frames` of `animation` and writes them to `path` as they are made,
/// atomically (a reader never sees half a file); `progress` hears each frame written.
pub fn write_sim_cache(
    animation: &Animation,
    frames: u32,
    path: &Path,
    progress: &dyn Fn(u32),
) -> Result<(), RenderError> {
    let bytes = cache_bytes(animation, frames);
    if bytes > MAX_CACHE_BYTES {
        return Err(error(
            path,
            format!(
                "{frames} frames of {} simulated characters make a {bytes}-byte cache, over the {MAX_CACHE_BYTES}-byte limit",
                animation.dynamic_characters()
            ),
        ));
    }
    let counts = animation.vertex_counts();
    let mut header = Vec::new();
    header.extend_from_slice(CACHE_MAGIC);
    header.extend_from_slice(&animation.cache_key().to_le_bytes());
    header.extend_from_slice(&animation.fps().to_le_bytes());
    header.extend_from_slice(&frames.to_le_bytes());
    header.extend_from_slice(&(counts.len() as u32).to_le_bytes());
    for n in &counts {
        header.extend_from_slice(&n.to_le_bytes());
    }
    hairmesh::atomic::write_file_atomic(path, |w| {
        w.write_all(&header)?;
        let mut live = animation.start();
        for f in 0..frames {
            if f > 0 {
                live.advance();
            }
            for positions in live.positions() {
                let bytes: Vec<u8> =
                    positions.iter().flat_map(|p| p.to_array()).flat_map(f32::to_le_bytes).collect();
                w.write_all(&bytes)?;
            }
            progress(f + 1);
        }
        Ok(())
    })
    .map_err(|e| error(path, format!("writing: {e}")))
}

/// An open simulation cache: its header checked against the animation, frames read on demand.
#[derive(Debug)]
pub struct SimCache {
    path: PathBuf,
    file: Mutex<std::fs::File>,
    vertex_counts: Vec<u32>,
    frames: u32,
}

impl SimCache {
    /// Opens a cache and checks it belongs to `animation` (same key, fps and characters) and is
    /// whole; a cache of another scene or an older version of it is refused, naming what
    /// differs.
    pub fn open(path: &Path, animation: &Animation) -> Result<Self, RenderError> {
        let fail = |message: String| error(path, message);
        let mut file = hairmesh::input::open_regular(path).map_err(|e| fail(e.to_string()))?;
        let len = file.metadata().map_err(|e| fail(e.to_string()))?.len();
        if len > MAX_CACHE_BYTES {
            return Err(fail(format!(
                "{len} bytes is larger than a simulation cache may be ({MAX_CACHE_BYTES})"
            )));
        }
        let mut head = [0u8; 36];
        let not_cache = || fail("not a hairkit simulation cache (or one of another version)".into());
        file.read_exact(&mut head).map_err(|_| not_cache())?;
        if &head[..16] != CACHE_MAGIC {
            return Err(not_cache());
        }
        let word = |at: usize| [head[at], head[at + 1], head[at + 2], head[at + 3]];
        let key = u64::from_le_bytes(head[16..24].try_into().map_err(|_| not_cache())?);
        let fps = f32::from_le_bytes(word(24));
        let frames = u32::from_le_bytes(word(28));
        let characters = u32::from_le_bytes(word(32)) as usize;
        if key != animation.cache_key() || fps != animation.fps() {
            return Err(fail(
                "was simulated from another scene, other assets or other dynamics settings: simulate again"
                    .into(),
            ));
        }
        let expected = animation.vertex_counts();
        if characters != expected.len() {
            return Err(fail(format!(
                "holds {characters} characters, the scene simulates {}",
                expected.len()
            )));
        }
        let mut counts = vec![0u8; 4 * characters];
        file.read_exact(&mut counts).map_err(|_| fail("truncated: the file is damaged".into()))?;
        let vertex_counts: Vec<u32> =
            counts.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        if vertex_counts != expected {
            return Err(fail(format!(
                "vertex counts {}, the scene's hair meshes have {}",
                list(&vertex_counts),
                list(&expected)
            )));
        }
        let want = header_bytes(characters) + frame_bytes(&vertex_counts) * u64::from(frames);
        if want != len {
            return Err(fail(format!(
                "{len} bytes, but its header describes {want} ({frames} frames): the file is damaged"
            )));
        }
        Ok(Self { path: path.to_owned(), file: Mutex::new(file), vertex_counts, frames })
    }

    /// Frames held (from frame 0).
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// Positions of every dynamic character at `frame`, read from the file; `None` past the
    /// frames it holds.
    pub fn positions(&self, frame: u32) -> Result<Option<Vec<Vec<Vec3>>>, RenderError> {
        if frame >= self.frames {
            return Ok(None);
        }
        let fail = |message: String| error(&self.path, format!("frame {frame}: {message}"));
        let per_frame = frame_bytes(&self.vertex_counts);
        let mut bytes = vec![0u8; per_frame as usize];
        {
            let mut file = self.file.lock().map_err(|_| fail("the file handle is poisoned".into()))?;
            file.seek(SeekFrom::Start(header_bytes(self.vertex_counts.len()) + per_frame * u64::from(frame)))
                .and_then(|_| file.read_exact(&mut bytes))
                .map_err(|e| fail(e.to_string()))?;
        }
        let mut at = 0;
        let mut frame_positions = Vec::with_capacity(self.vertex_counts.len());
        for &n in &self.vertex_counts {
            let positions: Vec<Vec3> = bytes[at..at + n as usize * 12]
                .chunks_exact(12)
                .map(|c| {
                    let f = |i: usize| f32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]);
                    Vec3::new(f(0), f(4), f(8))
                })
                .collect();
            if positions.iter().any(|p| !p.is_finite()) {
                return Err(fail("holds a position that is not finite: the file is damaged".into()));
            }
            frame_positions.push(positions);
            at += n as usize * 12;
        }
        Ok(Some(frame_positions))
    }
}

fn list(counts: &[u32]) -> String {
    counts.iter().map(u32::to_string).collect::<Vec<_>>().join(", ")
}
