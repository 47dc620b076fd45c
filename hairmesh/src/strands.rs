//! Explicit strand files: TressFX 3.x / 4.x `.tfx`, TressFX `.tfxbone` skinning, and Cem
//! Yuksel's `.hair`. Artists' existing grooms, and the stored-strand baseline of benchmarks.
//!
//! Every count and offset is checked against the file size *before* anything is allocated, so
//! a hostile header (a billion strands in a 1 KB file) is refused with a clear error.
//!
//! Layouts (little-endian):
//! * **TressFX 4.x**: 160-byte header: f32 version (4.x), u32 strands, u32 vertices per strand,
//!   u32 byte offsets of positions (4×f32 per vertex: xyz, w = 0 pinned / 1 free), per-strand
//!   uv (2×f32), per-vertex uv, per-strand thickness (f32), per-vertex colour (4×f32), then 32
//!   reserved u32. Offset 0 = absent.
//! * **TressFX 3.x**: 296-byte header: f32 version (3.x), u32 guide strands, u32 vertices per
//!   strand, u32 follow hairs per guide, i32 both-ends-immovable, 31 reserved u32, six u32
//!   offsets (vertices 3×f32, thickness, texcoords, colours, guide indices, vertex texcoords),
//!   32 reserved u32. Vertices at the vertex offset, or right after the header when it is 0.
//! * **`.tfxbone`**: i32 bone count; per bone i32 index, i32 name length incl. NUL, the name;
//!   i32 strand count; per strand i32 index and four (i32 bone, f32 weight) pairs.
//! * **`.hair`**: 128-byte header: `HAIR`, u32 strands, u32 points, u32 flags (1 segments,
//!   2 points, 4 thickness, 8 transparency, 16 colours), u32 default segments, f32 default
//!   thickness, f32 default transparency, 3×f32 default colour, 88 bytes of text; then the
//!   flagged arrays in that order. Points must equal Σ(segments + 1).

use std::path::Path;

use glam::Vec3;

use crate::{HairMeshError, Result};

/// Strands as a file holds them.
#[derive(Clone, Debug, PartialEq)]
pub struct StrandSet {
    /// `"TressFX 4.0"`, `"TressFX 3.0"`, `"Cem Yuksel .hair"`.
    pub format: String,
    /// All points, strand after strand.
    pub points: Vec<Vec3>,
    /// Points per strand (sums to `points.len()`).
    pub strand_points: Vec<u32>,
    /// Per-strand thickness when the file has it.
    pub thickness: Option<Vec<f32>>,
    /// Per-strand root uv when the file has it.
    pub root_uv: Option<Vec<[f32; 2]>>,
}

impl StrandSet {
    /// Generated strands (the CPU reference's, `HairAsset::generate_reference`) as a strand set
    /// in f32, strand after strand: what a stored-strand renderer draws in their place.
    pub fn from_reference(strands: &[crate::reference::Strand]) -> Self {
        Self {
            format: "hairkit reference strands".into(),
            points: strands.iter().flat_map(|s| s.positions.iter().map(|p| p.as_vec3())).collect(),
            strand_points: strands.iter().map(|s| s.positions.len() as u32).collect(),
            thickness: None,
            root_uv: None,
        }
    }

    pub fn strand_count(&self) -> usize {
        self.strand_points.len()
    }

    /// The first point of every strand.
    pub fn roots(&self) -> Vec<Vec3> {
        let mut at = 0usize;
        self.strand_points
            .iter()
            .map(|&n| {
                let p = self.points[at];
                at += n as usize;
                p
            })
            .collect()
    }

    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let first = *self.points.first()?;
        Some(self.points.iter().fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))))
    }
}

/// Skinning of TressFX strands to bones.
#[derive(Clone, Debug, PartialEq)]
pub struct BoneSkinning {
    pub bones: Vec<(i32, String)>,
    /// Per strand: its index and four (bone, weight) pairs.
    pub strands: Vec<(i32, [(i32, f32); 4])>,
}

/// Most points accepted from one file.
pub const MAX_POINTS: u64 = 1 << 28;

struct Reader<'a> {
    path: &'a Path,
    bytes: &'a [u8],
}

impl Reader<'_> {
    fn err(&self, message: impl Into<String>) -> HairMeshError {
        HairMeshError::Format { path: self.path.to_owned(), message: message.into() }
    }

    fn u32_at(&self, offset: usize, field: &str) -> Result<u32> {
        self.bytes.get(offset..offset + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])).ok_or_else(
            || {
                self.err(format!(
                    "{field}: the file ends at byte {} (needs {})",
                    self.bytes.len(),
                    offset + 4
                ))
            },
        )
    }

    fn f32_at(&self, offset: usize, field: &str) -> Result<f32> {
        self.u32_at(offset, field).map(f32::from_bits)
    }

    /// `count` records of `size` bytes at `offset`, checked against the file size.
    fn array(&self, offset: u64, count: u64, size: u64, field: &str) -> Result<&[u8]> {
        let len = count
            .checked_mul(size)
            .and_then(|l| l.checked_add(offset).map(|end| (l, end)))
            .filter(|(_, end)| *end <= self.bytes.len() as u64)
            .map(|(l, _)| l)
            .ok_or_else(|| {
                self.err(format!(
                    "{field}: {count} × {size} bytes at offset {offset} do not fit in the {}-byte file",
                    self.bytes.len()
                ))
            })?;
        Ok(&self.bytes[offset as usize..(offset + len) as usize])
    }
}

fn f32s(bytes: &[u8]) -> impl Iterator<Item = f32> + '_ {
    bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

fn read_all(path: &Path) -> Result<Vec<u8>> {
    let io = |e: std::io::Error| HairMeshError::Io { path: path.to_owned(), message: e.to_string() };
    crate::input::read_regular(path, MAX_POINTS * 16 + 4096).map_err(io)
}

/// Loads `.tfx` (TressFX 3.x or 4.x, by its version field) or `.hair`.
pub fn load_strands(path: &Path) -> Result<StrandSet> {
    let bytes = read_all(path)?;
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
    let r = Reader { path, bytes: &bytes };
    match ext.as_str() {
        "tfx" => {
            let version = r.f32_at(0, "version")?;
            if (4.0..5.0).contains(&version) {
                tressfx4(&r, version)
            } else if (3.0..4.0).contains(&version) {
                tressfx3(&r, version)
            } else {
                Err(r.err(format!("version {version} is not a TressFX 3.x or 4.x file")))
            }
        }
        "hair" => cem_yuksel(&r),
        _ => Err(r.err("unknown strand file type (expected .tfx or .hair)")),
    }
}

fn check_counts(r: &Reader<'_>, strands: u32, per_strand: u32) -> Result<u64> {
    if strands == 0 {
        return Err(r.err("strand count is 0"));
    }
    if !(2..=1024).contains(&per_strand) {
        return Err(r.err(format!("{per_strand} vertices per strand (expected 2..=1024)")));
    }
    let total = u64::from(strands) * u64::from(per_strand);
    if total > MAX_POINTS {
        return Err(
            r.err(format!("{strands} strands × {per_strand} vertices is over the {MAX_POINTS}-point limit"))
        );
    }
    Ok(total)
}

fn tressfx4(r: &Reader<'_>, version: f32) -> Result<StrandSet> {
    let strands = r.u32_at(4, "strand count")?;
    let per_strand = r.u32_at(8, "vertices per strand")?;
    let total = check_counts(r, strands, per_strand)?;
    let pos_offset = r.u32_at(12, "position offset")?;
    if pos_offset == 0 {
        return Err(r.err("the position offset is 0 (no positions)"));
    }
    let positions = r.array(u64::from(pos_offset), total, 16, "positions")?;
    let points: Vec<Vec3> = positions
        .chunks_exact(16)
        .map(|c| {
            let v: Vec<f32> = f32s(c).collect();
            Vec3::new(v[0], v[1], v[2])
        })
        .collect();
    let uv_offset = r.u32_at(16, "strand uv offset")?;
    let root_uv = if uv_offset == 0 {
        None
    } else {
        let bytes = r.array(u64::from(uv_offset), u64::from(strands), 8, "strand uvs")?;
        Some(
            bytes
                .chunks_exact(8)
                .map(|c| {
                    let v: Vec<f32> = f32s(c).collect();
                    [v[0], v[1]]
                })
                .collect(),
        )
    };
    let thickness_offset = r.u32_at(24, "thickness offset")?;
    let thickness = if thickness_offset == 0 {
        None
    } else {
        Some(f32s(r.array(u64::from(thickness_offset), u64::from(strands), 4, "thickness")?).collect())
    };
    finish(r, format!("TressFX {version:.1}"), points, vec![per_strand; strands as usize], thickness, root_uv)
}

fn tressfx3(r: &Reader<'_>, version: f32) -> Result<StrandSet> {
    const HEADER: u64 = 296;
    let strands = r.u32_at(4, "guide strand count")?;
    let per_strand = r.u32_at(8, "vertices per strand")?;
    let total = check_counts(r, strands, per_strand)?;
    let offset = match r.u32_at(144, "vertex offset")? {
        0 => HEADER,
        o => u64::from(o),
    };
    let positions = r.array(offset, total, 12, "vertices")?;
    let points = positions
        .chunks_exact(12)
        .map(|c| {
            let v: Vec<f32> = f32s(c).collect();
            Vec3::new(v[0], v[1], v[2])
        })
        .collect();
    finish(r, format!("TressFX {version:.1}"), points, vec![per_strand; strands as usize], None, None)
}

fn cem_yuksel(r: &Reader<'_>) -> Result<StrandSet> {
    if r.bytes.get(0..4) != Some(b"HAIR") {
        return Err(r.err("missing the HAIR signature"));
    }
    let strands = r.u32_at(4, "strand count")?;
    let points = r.u32_at(8, "point count")?;
    let flags = r.u32_at(12, "flags")?;
    let default_segments = r.u32_at(16, "default segments")?;
    let default_thickness = r.f32_at(20, "default thickness")?;
    if strands == 0 || u64::from(points) > MAX_POINTS {
        return Err(r.err(format!("{strands} strands with {points} points")));
    }
    if flags & 2 == 0 {
        return Err(r.err("the file has no points array (flag 2)"));
    }
    let mut at: u64 = 128;
    let strand_points: Vec<u32> = if flags & 1 != 0 {
        let bytes = r.array(at, u64::from(strands), 2, "segments")?;
        at += u64::from(strands) * 2;
        bytes.chunks_exact(2).map(|c| u32::from(u16::from_le_bytes([c[0], c[1]])) + 1).collect()
    } else {
        if default_segments == 0 || default_segments > 65535 {
            return Err(r.err(format!("default segments {default_segments} (expected 1..=65535)")));
        }
        vec![default_segments + 1; strands as usize]
    };
    let sum: u64 = strand_points.iter().map(|&n| u64::from(n)).sum();
    if sum != u64::from(points) {
        return Err(
            r.err(format!("the strands hold {sum} points (Σ segments + 1) but the header says {points}"))
        );
    }
    let bytes = r.array(at, u64::from(points), 12, "points")?;
    at += u64::from(points) * 12;
    let pts = bytes
        .chunks_exact(12)
        .map(|c| {
            let v: Vec<f32> = f32s(c).collect();
            Vec3::new(v[0], v[1], v[2])
        })
        .collect();
    let thickness = if flags & 4 != 0 {
        // Per point in the file; keep the root's as the strand's.
        let bytes = r.array(at, u64::from(points), 4, "thickness")?;
        let all: Vec<f32> = f32s(bytes).collect();
        let mut first = 0usize;
        Some(
            strand_points
                .iter()
                .map(|&n| {
                    let t = all[first];
                    first += n as usize;
                    t
                })
                .collect(),
        )
    } else {
        Some(vec![default_thickness; strands as usize])
    };
    finish(r, "Cem Yuksel .hair".into(), pts, strand_points, thickness, None)
}

fn finish(
    r: &Reader<'_>,
    format: String,
    points: Vec<Vec3>,
    strand_points: Vec<u32>,
    thickness: Option<Vec<f32>>,
    root_uv: Option<Vec<[f32; 2]>>,
) -> Result<StrandSet> {
    if let Some(i) = points.iter().position(|p| !p.is_finite()) {
        return Err(r.err(format!("point {i} is not finite")));
    }
    Ok(StrandSet { format, points, strand_points, thickness, root_uv })
}

/// Loads a TressFX `.tfxbone` file.
pub fn load_tfxbone(path: &Path) -> Result<BoneSkinning> {
    let bytes = read_all(path)?;
    let r = Reader { path, bytes: &bytes };
    let count = |v: u32, field: &str| -> Result<u64> {
        let v = i32::from_le_bytes(v.to_le_bytes());
        if v < 0 {
            return Err(r.err(format!("{field} is negative ({v})")));
        }
        Ok(v as u64)
    };
    let bone_count = count(r.u32_at(0, "bone count")?, "bone count")?;
    // Each bone takes at least 8 bytes: refuse counts the file cannot hold before allocating.
    r.array(4, bone_count, 8, "bones")?;
    let mut at = 4usize;
    let mut bones = Vec::with_capacity(bone_count as usize);
    for b in 0..bone_count {
        let index = r.u32_at(at, &format!("bone {b} index"))? as i32;
        let len = count(r.u32_at(at + 4, &format!("bone {b} name length"))?, "name length")?;
        let name = r.array(at as u64 + 8, len, 1, &format!("bone {b} name"))?;
        let name = String::from_utf8_lossy(name).trim_end_matches('\0').to_owned();
        bones.push((index, name));
        at += 8 + len as usize;
    }
    let strand_count = count(r.u32_at(at, "strand count")?, "strand count")?;
    let records = r.array(at as u64 + 4, strand_count, 36, "strand weights")?;
    let strands = records
        .chunks_exact(36)
        .map(|c| {
            let w = |i: usize| [c[i], c[i + 1], c[i + 2], c[i + 3]];
            let pair = |k: usize| (i32::from_le_bytes(w(4 + 8 * k)), f32::from_le_bytes(w(8 + 8 * k)));
            (i32::from_le_bytes(w(0)), [pair(0), pair(1), pair(2), pair(3)])
        })
        .collect();
    Ok(BoneSkinning { bones, strands })
}
