//! Hair asset folders: `hair.json` (the manifest) plus the five textures as OpenEXR files and a
//! PNG preview of the root slice.
//!
//! ```text
//! ASSET/
//!   hair.json        format, version, units, normalization, layout, bundle table, sample sets,
//!                    style, the hair mesh (vertices per layer, faces, root uvs), its provenance
//!   hair_mesh.exr    channels R,G,B = normalized position; (1 + 3L) slices
//!   uv.exr           channels R,G = root uv; 1 slice
//!   w.exr            channel R = w; L + 1 slices
//!   u.exr, v.exr     channels R,G,B = unit styling direction; L + 1 slices
//!   preview.png      the root slice's normalized positions as colours
//! ```
//!
//! A 3D texture of `W × H × D` texels is stored as one 2D image `W × (H·D)`: slice `z` occupies
//! rows `z·H … z·H + H − 1`. Samples are f32, or f16 when the asset was converted with `--f16`.
//! Loading checks every field and every image size against the manifest; errors name the file
//! and the field; the stored hair mesh must fit the layout and agree with the hair-mesh
//! texture (at every vertex's layer slices, within the sample precision). The folder is written
//! atomically (built beside the target, then swapped in).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::asset::{BundleInfo, HairAsset, SampleSet, ScalpProvenance};
use crate::hair_mesh::{BundleFace, HairMesh};
use crate::head_field::HeadField;
use crate::output::Replace;
use crate::roots::SampleDomain;
use crate::style::Style;
use crate::texture::{HairTextures, Normalization, Texture3, TextureLayout, texel_vertices};
use crate::{HairMeshError, Result};

pub const FORMAT: &str = "hairkit.hair-asset";
/// 3: the manifest stores the hair mesh (`mesh`) and where it came from (`scalp`), so an asset
/// can be edited and re-baked. 2: shared-vertex lattice cells in `layout.cells`, `1 + 3L`
/// hair-mesh slices, no mesh. 1: 2×2 blocks, `1 + 4L` slices. Older versions are refused with
/// a "re-convert" error (their hair mesh is not in the folder).
pub const FORMAT_VERSION: u32 = 3;
/// Largest texture side accepted (texels).
pub const MAX_TEXTURE_SIDE: u32 = 16_384;
pub const MANIFEST: &str = "hair.json";
/// Largest texture accepted when loading (texels of one 3D texture).
pub const MAX_TEXELS: u64 = 1 << 28;
/// Largest manifest read.
pub const MAX_MANIFEST_BYTES: u64 = 512 << 20;

/// Sample precision of the texture files.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Precision {
    #[default]
    F32,
    F16,
}

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TextureFile {
    pub file: String,
    pub channels: u32,
    pub slices: u32,
}

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TextureFiles {
    pub hair_mesh: TextureFile,
    pub uv: TextureFile,
    pub w: TextureFile,
    pub u: TextureFile,
    pub v: TextureFile,
}

/// `hair.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    pub format: String,
    pub format_version: u32,
    /// The source file's length unit (glTF: metres; OBJ: whatever the artist used).
    pub units: String,
    pub source: Option<String>,
    pub precision: Precision,
    pub normalization: Normalization,
    pub layout: TextureLayout,
    pub textures: TextureFiles,
    pub bundles: Vec<BundleInfo>,
    pub square_sets: Vec<SampleSet>,
    pub triangle_sets: Vec<SampleSet>,
    pub style: Style,
    /// The hair mesh: `layers[k][v]` object-space positions (`L + 1` layers), the bundle faces
    /// (bundle `b` is face `b`) and the root uvs.
    pub mesh: HairMesh,
    /// The scalp file, face selector and layer source the mesh was made from.
    pub scalp: Option<ScalpProvenance>,
    /// The head's distance field strands are kept out of ([`crate::head_field`]), when the
    /// asset was converted with a head.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub head_field: Option<HeadFieldFile>,
}

/// Where a [`HeadField`] is stored and its grid: `size` points from `lo`, `cell` apart, one
/// channel of signed distances in `file` (slices stacked in rows).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeadFieldFile {
    pub file: String,
    pub lo: glam::DVec3,
    pub cell: f64,
    pub margin: f64,
    pub size: [u32; 3],
}

const HEAD_FIELD_FILE: &str = "head_field.exr";

const CHANNELS_3: [&str; 3] = ["R", "G", "B"];

fn texture_files(layout: &TextureLayout) -> TextureFiles {
    let file = |name: &str, channels, slices| TextureFile { file: format!("{name}.exr"), channels, slices };
    TextureFiles {
        hair_mesh: file("hair_mesh", 3, layout.curve_slices()),
        uv: file("uv", 2, 1),
        w: file("w", 1, layout.layer_slices()),
        u: file("u", 3, layout.layer_slices()),
        v: file("v", 3, layout.layer_slices()),
    }
}

/// Writes `asset` to the folder `dir`, replacing it atomically if it is a hair asset (an
/// existing folder of anything else is refused: see [`crate::output`]).
pub fn write_asset(
    dir: &Path,
    asset: &HairAsset,
    precision: Precision,
    units: &str,
    source: Option<&str>,
) -> Result<()> {
    write_asset_replacing(dir, asset, precision, units, source, Replace::OwnOutput)
}

/// [`write_asset`], replacing whatever `dir` is with [`Replace::Anything`] (`--force`).
pub fn write_asset_replacing(
    dir: &Path,
    asset: &HairAsset,
    precision: Precision,
    units: &str,
    source: Option<&str>,
    replace: Replace,
) -> Result<()> {
    crate::output::check_asset_folder(dir, &[], replace)?;
    // Never write what could not be read back (JSON has no NaN or infinity: they become null).
    let unreadable = |message: String| HairMeshError::Io { path: dir.to_owned(), message };
    asset.style.validate().map_err(|e| unreadable(format!("not written: style.{e}")))?;
    if !asset.mesh().layers.iter().flatten().all(|p| p.is_finite()) {
        return Err(unreadable(
            "not written: the hair mesh has a position that is not a finite number".into(),
        ));
    }
    let t = &asset.textures;
    let files = texture_files(&t.layout);
    let manifest = Manifest {
        format: FORMAT.into(),
        format_version: FORMAT_VERSION,
        units: units.into(),
        source: source.map(str::to_owned),
        precision,
        normalization: t.normalization,
        layout: t.layout.clone(),
        textures: files.clone(),
        bundles: asset.bundles.clone(),
        square_sets: asset.square_sets.clone(),
        triangle_sets: asset.triangle_sets.clone(),
        style: asset.style,
        mesh: asset.mesh().clone(),
        scalp: asset.provenance.clone(),
        head_field: asset.head_field.as_ref().map(|f| HeadFieldFile {
            file: HEAD_FIELD_FILE.into(),
            lo: f.lo,
            cell: f.cell,
            margin: f.margin,
            size: [f.distance.width, f.distance.height, f.distance.depth],
        }),
    };
    let json = serde_json::to_vec_pretty(&manifest)
        .map_err(|e| HairMeshError::Io { path: dir.join(MANIFEST), message: e.to_string() })?;
    // The manifest as a reader will see it: an overflow written as `null` is caught here.
    serde_json::from_slice::<Manifest>(&json)
        .map_err(|e| e.to_string())
        .and_then(|m| validate_manifest(&dir.join(MANIFEST), &m).map_err(|e| e.to_string()))
        .map_err(|e| unreadable(format!("not written, it could not be read back: {e}")))?;
    crate::atomic::replace_dir_atomic(dir, |tmp| {
        for (file, tex) in [
            (&files.hair_mesh, &t.hair_mesh),
            (&files.uv, &t.uv),
            (&files.w, &t.w),
            (&files.u, &t.u),
            (&files.v, &t.v),
        ] {
            let bytes = encode_exr(tex, precision).map_err(std::io::Error::other)?;
            std::fs::write(tmp.join(&file.file), bytes)?;
        }
        if let Some(field) = &asset.head_field {
            // Half floats whatever the asset's precision: the field holds no more.
            let bytes = encode_exr(&field.distance, Precision::F16).map_err(std::io::Error::other)?;
            std::fs::write(tmp.join(HEAD_FIELD_FILE), bytes)?;
        }
        write_preview(&tmp.join("preview.png"), &t.hair_mesh)?;
        std::fs::write(tmp.join(MANIFEST), &json)
    })
    .map_err(|e| HairMeshError::Io {
        path: dir.to_owned(),
        message: format!("writing the asset failed: {e}"),
    })
}

fn encode_exr(tex: &Texture3, precision: Precision) -> std::result::Result<Vec<u8>, String> {
    use exr::prelude::*;
    let (w, h) = (tex.width as usize, tex.height as usize * tex.depth as usize);
    let n = tex.channels as usize;
    let channels: Vec<AnyChannel<FlatSamples>> = (0..n)
        .map(|c| {
            let values = tex.data.iter().skip(c).step_by(n);
            let samples = match precision {
                Precision::F32 => FlatSamples::F32(values.map(|v| *v as f32).collect()),
                Precision::F16 => FlatSamples::F16(values.map(|v| f16::from_f64(*v)).collect()),
            };
            AnyChannel::new(CHANNELS_3[c], samples)
        })
        .collect();
    let layer = Layer::new(
        (w, h),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels.into()),
    );
    let mut out = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer).write().to_buffered(&mut out).map_err(|e| e.to_string())?;
    Ok(out.into_inner())
}

fn write_preview(path: &Path, hair_mesh: &Texture3) -> std::io::Result<()> {
    let (w, h) = (hair_mesh.width, hair_mesh.height);
    let mut pixels = Vec::with_capacity(w as usize * h as usize * 3);
    for y in 0..h {
        for x in 0..w {
            for v in hair_mesh.texel(x, y, 0) {
                pixels.push((v.clamp(0.0, 1.0) * 255.0).round() as u8);
            }
        }
    }
    let file = std::fs::File::create(path)?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), w, h);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(std::io::Error::other)?;
    writer.write_image_data(&pixels).map_err(std::io::Error::other)?;
    writer.finish().map_err(std::io::Error::other)
}

fn field_error(path: &Path, field: &str, message: impl std::fmt::Display) -> HairMeshError {
    HairMeshError::Format { path: path.to_owned(), message: format!("{field}: {message}") }
}

fn read_limited(path: &Path, limit: u64) -> Result<Vec<u8>> {
    crate::input::read_regular(path, limit)
        .map_err(|e| HairMeshError::Io { path: path.to_owned(), message: e.to_string() })
}

/// Reads an asset folder (or its `hair.json`), validating everything against the manifest.
pub fn read_asset(path: &Path) -> Result<(HairAsset, Manifest)> {
    let (dir, manifest_path) = if path.is_dir() {
        (path.to_owned(), path.join(MANIFEST))
    } else {
        (path.parent().unwrap_or(Path::new(".")).to_owned(), path.to_owned())
    };
    let bytes = read_limited(&manifest_path, MAX_MANIFEST_BYTES)?;
    refuse_old_versions(&manifest_path, &bytes)?;
    let manifest: Manifest = serde_json::from_slice(&bytes).map_err(|e| HairMeshError::Format {
        path: manifest_path.clone(),
        message: crate::input::json_error(&e),
    })?;
    validate_manifest(&manifest_path, &manifest)?;
    let m = &manifest;
    let load = |file: &TextureFile, field: &str| read_texture(&dir.join(&file.file), field, m, file);
    let textures = HairTextures {
        layout: m.layout.clone(),
        normalization: m.normalization,
        hair_mesh: load(&m.textures.hair_mesh, "textures.hair_mesh")?,
        uv: load(&m.textures.uv, "textures.uv")?,
        w: load(&m.textures.w, "textures.w")?,
        u: load(&m.textures.u, "textures.u")?,
        v: load(&m.textures.v, "textures.v")?,
    };
    let asset = HairAsset {
        textures,
        curve: crate::texture::CurveEvaluation::Quadratic,
        bundles: m.bundles.clone(),
        square_sets: m.square_sets.clone(),
        triangle_sets: m.triangle_sets.clone(),
        style: m.style,
        mesh: m.mesh.clone(),
        provenance: m.scalp.clone(),
        head_field: match &m.head_field {
            Some(f) => Some(std::sync::Arc::new(HeadField {
                lo: f.lo,
                cell: f.cell,
                margin: f.margin,
                distance: read_texture_sized(&dir.join(&f.file), "head_field", Precision::F16, f.size, 1)?,
            })),
            None => None,
        },
        revision: 0,
    };
    check_mesh_matches_texture(&dir.join(&m.textures.hair_mesh.file), m, &asset.textures.hair_mesh)?;
    Ok((asset, manifest))
}

/// An older manifest does not parse as today's (it lacks `mesh`): look at its version first so
/// the error says what to do rather than which field is missing.
fn refuse_old_versions(path: &Path, bytes: &[u8]) -> Result<()> {
    #[derive(Deserialize)]
    struct Header {
        format: Option<String>,
        format_version: Option<u32>,
        source: Option<String>,
    }
    let Ok(header) = serde_json::from_slice::<Header>(bytes) else { return Ok(()) };
    match (header.format.as_deref(), header.format_version) {
        (Some(FORMAT), Some(v)) if v < FORMAT_VERSION => Err(field_error(
            path,
            "format_version",
            format!(
                "{v} is an older format without the hair mesh (this build reads {FORMAT_VERSION}); \
                 re-convert it with `hairmesh convert`{} — nothing was changed",
                header.source.map(|s| format!(" from {s}")).unwrap_or_default()
            ),
        )),
        _ => Ok(()),
    }
}

/// The stored mesh must be the one the hair-mesh texture was baked from: every vertex's
/// position at layer `k` is slice `3k` of its texels (up to the files' sample precision).
fn check_mesh_matches_texture(path: &Path, m: &Manifest, hair_mesh: &Texture3) -> Result<()> {
    let texels = texel_vertices(&m.layout, &m.mesh.faces).map_err(|e| field_error(path, "mesh.faces", e))?;
    let tolerance = match m.precision {
        Precision::F32 => 1e-6,
        Precision::F16 => 2e-3,
    };
    for (i, vertex) in texels.iter().enumerate() {
        let Some(v) = *vertex else { continue };
        let (x, y) = (i as u32 % m.layout.width, i as u32 / m.layout.width);
        for (k, layer) in m.mesh.layers.iter().enumerate() {
            let expected = m.normalization.to_stored(layer[v as usize]);
            let stored = glam::DVec3::from_slice(hair_mesh.texel(x, y, 3 * k as u32));
            let error = (stored - expected).abs().max_element();
            if error > tolerance * expected.abs().max_element().max(1.0) {
                return Err(field_error(
                    path,
                    "textures.hair_mesh",
                    format!(
                        "texel ({x}, {y}) of slice {} holds {stored} but hair.json's mesh.layers[{k}][{v}] \
                         normalizes to {expected}: the mesh and the textures disagree (re-convert the asset)",
                        3 * k
                    ),
                ));
            }
        }
    }
    Ok(())
}

fn validate_manifest(path: &Path, m: &Manifest) -> Result<()> {
    let err = |field: &str, message: String| field_error(path, field, message);
    if m.format != FORMAT {
        return Err(err("format", format!("`{}` is not `{FORMAT}`", m.format)));
    }
    if m.format_version != FORMAT_VERSION {
        return Err(err(
            "format_version",
            format!(
                "{} is not supported (this build reads {FORMAT_VERSION}; re-convert older assets with `hairmesh convert`)",
                m.format_version
            ),
        ));
    }
    let n = &m.normalization;
    if !(n.origin.is_finite() && n.scale.is_finite() && n.scale > 0.0) {
        return Err(err("normalization", "origin must be finite and scale positive".into()));
    }
    let l = &m.layout;
    if l.layers == 0 || l.layers > crate::hair_mesh::MAX_LAYERS {
        return Err(err(
            "layout.layers",
            format!("{} (expected 1..={})", l.layers, crate::hair_mesh::MAX_LAYERS),
        ));
    }
    if !(2..=MAX_TEXTURE_SIDE).contains(&l.width) || !(2..=MAX_TEXTURE_SIDE).contains(&l.height) {
        return Err(err(
            "layout",
            format!("{}×{} texels (each side must be 2..={MAX_TEXTURE_SIDE})", l.width, l.height),
        ));
    }
    if l.cells.len() != l.bundles as usize {
        return Err(err("layout.cells", format!("{} cells for {} bundles", l.cells.len(), l.bundles)));
    }
    if let Some(f) = &m.head_field {
        let most = HeadField::MAX_POINTS;
        // Only the file this version writes, in the asset's own folder.
        if f.file != HEAD_FIELD_FILE {
            return Err(err("head_field.file", format!("`{}` (expected `{HEAD_FIELD_FILE}`)", f.file)));
        }
        if !f.size.iter().all(|n| (2..=most).contains(n)) {
            return Err(err("head_field.size", format!("{:?} (each 2..={most})", f.size)));
        }
        if !(f.lo.is_finite()
            && f.cell.is_finite()
            && f.cell > 0.0
            && f.margin.is_finite()
            && f.margin >= 0.0)
        {
            return Err(err(
                "head_field",
                format!("lo {}, cell {}, margin {} (finite, cell > 0, margin ≥ 0)", f.lo, f.cell, f.margin),
            ));
        }
    }
    if let Some(i) = l.cells.iter().position(|c| c.x >= l.width - 1 || c.y >= l.height - 1) {
        return Err(err(
            &format!("layout.cells[{i}]"),
            format!(
                "cell ({}, {}) does not fit a {}×{} slice",
                l.cells[i].x, l.cells[i].y, l.width, l.height
            ),
        ));
    }
    if u64::from(l.width) * u64::from(l.height) * u64::from(l.curve_slices()) > MAX_TEXELS {
        return Err(err(
            "layout",
            format!("{}×{}×{} texels is over the limit", l.width, l.height, l.curve_slices()),
        ));
    }
    if m.bundles.len() != l.bundles as usize {
        return Err(err(
            "bundles",
            format!("{} entries but layout.bundles = {}", m.bundles.len(), l.bundles),
        ));
    }
    let expected = texture_files(l);
    for (name, found, wanted) in [
        ("hair_mesh", &m.textures.hair_mesh, &expected.hair_mesh),
        ("uv", &m.textures.uv, &expected.uv),
        ("w", &m.textures.w, &expected.w),
        ("u", &m.textures.u, &expected.u),
        ("v", &m.textures.v, &expected.v),
    ] {
        if found != wanted {
            return Err(err(
                &format!("textures.{name}"),
                format!(
                    "file `{}` with {} channels and {} slices does not match the layout, which needs file `{}` with {} channels and {} slices",
                    found.file, found.channels, found.slices, wanted.file, wanted.channels, wanted.slices
                ),
            ));
        }
    }
    m.style.validate().map_err(|e| err("style", e))?;
    if !m.mesh.layers.iter().flatten().all(|p| p.is_finite()) {
        return Err(err("mesh.layers", "a position is not a finite number".into()));
    }
    let longest = |sets: &[SampleSet]| sets.iter().map(|s| s.points.len()).min().unwrap_or(0);
    for (i, b) in m.bundles.iter().enumerate() {
        let field = format!("bundles[{i}]");
        if b.strands == 0 || b.strands > crate::asset::MAX_STRANDS_PER_BUNDLE {
            return Err(err(
                &field,
                format!("strands = {} (expected 1..={})", b.strands, crate::asset::MAX_STRANDS_PER_BUNDLE),
            ));
        }
        if !(b.area.is_finite()
            && b.bounds_min.is_finite()
            && b.bounds_max.is_finite()
            && b.length.is_finite())
        {
            return Err(err(&field, "non-finite area, bounds or length".into()));
        }
        let sets = match b.domain {
            SampleDomain::Square => &m.square_sets,
            SampleDomain::Triangle => &m.triangle_sets,
        };
        if (longest(sets) as u64) < u64::from(b.strands) {
            return Err(err(
                &field,
                format!(
                    "{} strands but its {:?} sample sets hold {} samples",
                    b.strands,
                    b.domain,
                    longest(sets)
                ),
            ));
        }
    }
    for (name, sets, domain) in [
        ("square_sets", &m.square_sets, SampleDomain::Square),
        ("triangle_sets", &m.triangle_sets, SampleDomain::Triangle),
    ] {
        for (i, s) in sets.iter().enumerate() {
            if s.domain != domain || s.points.iter().any(|p| !domain.contains(*p)) {
                return Err(err(
                    &format!("{name}[{i}]"),
                    format!("samples must lie in the {domain:?} domain"),
                ));
            }
        }
    }
    validate_mesh(path, m)?;
    Ok(())
}

fn validate_mesh(path: &Path, m: &Manifest) -> Result<()> {
    let err = |field: &str, message: String| field_error(path, field, message);
    let mesh = &m.mesh;
    let vertices = mesh.vertex_count();
    if mesh.layers.len() != m.layout.layers as usize + 1 {
        return Err(err(
            "mesh.layers",
            format!(
                "{} layers but layout.layers = {} (expected {})",
                mesh.layers.len(),
                m.layout.layers,
                m.layout.layers + 1
            ),
        ));
    }
    for (k, layer) in mesh.layers.iter().enumerate() {
        if layer.len() != vertices {
            return Err(err(
                &format!("mesh.layers[{k}]"),
                format!("{} vertices, layer 0 has {vertices}", layer.len()),
            ));
        }
        if let Some(v) = layer.iter().position(|p| !p.is_finite()) {
            return Err(err(&format!("mesh.layers[{k}][{v}]"), "not finite".into()));
        }
    }
    if mesh.faces.len() != m.bundles.len() {
        return Err(err("mesh.faces", format!("{} faces for {} bundles", mesh.faces.len(), m.bundles.len())));
    }
    for (b, (face, info)) in mesh.faces.iter().zip(&m.bundles).enumerate() {
        if let Some(&v) = face.vertices().iter().find(|&&v| v as usize >= vertices) {
            return Err(err(&format!("mesh.faces[{b}]"), format!("vertex {v} of {vertices}")));
        }
        let domain = match face {
            BundleFace::Quad(_) => SampleDomain::Square,
            BundleFace::Triangle(_) => SampleDomain::Triangle,
        };
        if domain != info.domain {
            return Err(err(
                &format!("mesh.faces[{b}]"),
                format!("a {domain:?} face but bundles[{b}] is {:?}", info.domain),
            ));
        }
    }
    mesh.check_tip_layers().map_err(|e| err("mesh.tip_layers", e))?;
    match &mesh.uvs {
        Some(uvs) if uvs.len() == vertices && uvs.iter().all(|u| u.is_finite()) => Ok(()),
        Some(uvs) => Err(err(
            "mesh.uvs",
            format!("{} finite uvs expected, {} given (or some not finite)", vertices, uvs.len()),
        )),
        None => Err(err("mesh.uvs", "missing (an asset stores its root uvs)".into())),
    }
}

fn read_texture(path: &Path, field: &str, m: &Manifest, file: &TextureFile) -> Result<Texture3> {
    read_texture_sized(
        path,
        field,
        m.precision,
        [m.layout.width, m.layout.height, file.slices],
        file.channels,
    )
}

/// An EXR holding `size[2]` slices of `size[0]`×`size[1]` texels of `channels` channels in
/// `precision`, stacked in rows.
fn read_texture_sized(
    path: &Path,
    field: &str,
    precision: Precision,
    size: [u32; 3],
    channels: u32,
) -> Result<Texture3> {
    use exr::prelude::*;
    let err = |message: String| field_error(path, field, message);
    let [w, h, d] = size;
    let file = TextureFile { file: String::new(), channels, slices: d };
    // Compressed EXR of this size can hardly exceed 4× its raw f32 size plus headers.
    let limit = u64::from(w) * u64::from(h) * u64::from(d) * u64::from(file.channels) * 16 + (1 << 20);
    let bytes = read_limited(path, limit)?;
    // The header first: the decoder sizes its buffers from the header's data window and
    // channel list, so a damaged header could ask for any amount of memory.
    let meta = MetaData::read_from_buffered(std::io::Cursor::new(&bytes), false)
        .map_err(|e| err(format!("not a readable OpenEXR file: {e}")))?;
    let [header] = meta.headers.as_slice() else {
        return Err(err(format!("{} layers (expected 1)", meta.headers.len())));
    };
    let size = header.layer_size;
    if (size.0 as u64, size.1 as u64) != (u64::from(w), u64::from(h) * u64::from(d)) {
        return Err(err(format!(
            "image is {}×{}, the manifest says {}×{} ({} slices of {})",
            size.0,
            size.1,
            w,
            h * d,
            d,
            h
        )));
    }
    if header.deep || header.channels.list.len() != file.channels as usize {
        return Err(err(format!(
            "{} channels{} (expected {} flat channels)",
            header.channels.list.len(),
            if header.deep { ", deep data" } else { "" },
            file.channels
        )));
    }
    if header.channels.list.iter().any(|c| c.sampling != Vec2(1, 1)) {
        return Err(err("subsampled channels (expected one sample per pixel)".into()));
    }
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(|e| err(format!("not a readable OpenEXR file: {e}")))?;
    let channels = &image.layer_data.channel_data.list;
    let mut names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
    names.sort();
    let mut expected: Vec<&str> = CHANNELS_3[..file.channels as usize].to_vec();
    expected.sort_unstable();
    if names != expected {
        return Err(err(format!("channels {names:?}, expected {expected:?}")));
    }
    let mut tex = Texture3::new(w, h, d, file.channels);
    let n = file.channels as usize;
    // EXR keeps channels sorted by name; place each by its name.
    for channel in channels {
        let Some(c) = CHANNELS_3.iter().position(|name| channel.name.to_string() == *name) else { continue };
        let ok_type = matches!(
            (&channel.sample_data, precision),
            (FlatSamples::F32(_), Precision::F32) | (FlatSamples::F16(_), Precision::F16)
        );
        if !ok_type {
            return Err(err(format!("channel {} is not {precision:?} as the manifest says", channel.name)));
        }
        for (i, v) in channel.sample_data.values_as_f32().enumerate() {
            if !v.is_finite() {
                return Err(err(format!("channel {} holds a non-finite value at texel {i}", channel.name)));
            }
            tex.data[i * n + c] = f64::from(v);
        }
    }
    Ok(tex)
}

/// The files of an asset folder, for reporting.
pub fn asset_files(dir: &Path, m: &Manifest) -> Vec<PathBuf> {
    let t = &m.textures;
    [MANIFEST, &t.hair_mesh.file, &t.uv.file, &t.w.file, &t.u.file, &t.v.file, "preview.png"]
        .iter()
        .map(|f| dir.join(f))
        .chain(m.head_field.as_ref().map(|f| dir.join(&f.file)))
        .collect()
}
