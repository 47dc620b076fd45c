//! Scalp import from glTF 2.0 (`.gltf`, `.glb`) and Wavefront OBJ.
//!
//! glTF: every mesh instance of the default scene (or the first scene) with its node transform;
//! triangle lists, strips and fans, indexed (u8/u16/u32) or not; sparse accessors; external,
//! embedded (GLB) and `data:` URI buffers; morph targets become [`ScalpMesh::morph_layers`].
//! Point and line primitives are skipped with a warning. Files that *require* Draco
//! (`KHR_draco_mesh_compression`) or meshopt (`EXT_meshopt_compression`) are rejected, and so is
//! an accessor without data (a compressed file's empty fallback would otherwise load as zeros).
//!
//! OBJ: polygons are kept as they are (quads and n-gons), texture coordinates kept when present.
//! After loading, vertices are welded by position (tolerance 1e-6 of the bounds diagonal).

use std::path::Path;

use glam::{DMat4, DVec2, DVec3};

use crate::gltf_source::SourceError;
use crate::input::References;
use crate::scalp::{ScalpMesh, ScalpSelector};
use crate::{HairMeshError, Result};

/// Largest input file read (and largest glTF buffer), so a hostile file cannot exhaust memory.
pub const MAX_FILE_BYTES: u64 = 1 << 30;
/// Largest vertex or index count accepted from one accessor.
pub const MAX_ELEMENTS: usize = 1 << 26;
/// Relative weld tolerance (of the bounds diagonal).
pub const WELD_TOLERANCE: f64 = 1e-6;

const UNDECODABLE: &[&str] =
    &["KHR_draco_mesh_compression", "EXT_meshopt_compression", "KHR_meshopt_compression"];

/// Loads a scalp from a glTF/GLB or OBJ file, keeps the selected faces and welds. The files a
/// glTF refers to must be in its folder (see [`crate::input`]).
pub fn load_scalp(path: &Path, selector: &ScalpSelector) -> Result<ScalpMesh> {
    load_scalp_with(path, selector, References::InsideFolder)
}

/// Every face of the file as imported, before a selection and before welding: the faces a
/// `faces:` selector ([`ScalpSelector::Faces`]) numbers, as the editor's scalp brush paints
/// them.
pub fn load_faces(path: &Path, references: References) -> Result<ScalpMesh> {
    import(path, &ScalpSelector::All, references)
}

fn import(path: &Path, selector: &ScalpSelector, references: References) -> Result<ScalpMesh> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
    match ext.as_str() {
        "gltf" | "glb" => load_gltf(path, selector, references),
        "obj" => load_obj(path, selector),
        _ => Err(HairMeshError::Format {
            path: path.into(),
            message: "unknown file type (expected .gltf, .glb or .obj)".into(),
        }),
    }
}

/// [`load_scalp`], with the glTF's buffers read from where `references` allows.
pub fn load_scalp_with(path: &Path, selector: &ScalpSelector, references: References) -> Result<ScalpMesh> {
    finish(path, import(path, selector, references)?, selector)
}

/// [`load_scalp_with`], and the whole file as the head the scalp belongs to (every face,
/// welded), from one reading of the file (a `name:` selector is applied while importing, so
/// it reads the file again).
pub fn load_scalp_and_head(
    path: &Path,
    selector: &ScalpSelector,
    references: References,
) -> Result<(ScalpMesh, ScalpMesh)> {
    let whole = import(path, &ScalpSelector::All, references)?;
    let scalp = match selector {
        ScalpSelector::Named(_) => import(path, selector, references)?,
        _ => whole.clone(),
    };
    Ok((finish(path, scalp, selector)?, finish(path, whole, &ScalpSelector::All)?))
}

/// An imported mesh checked, its selected faces kept and welded.
fn finish(path: &Path, mut mesh: ScalpMesh, selector: &ScalpSelector) -> Result<ScalpMesh> {
    if mesh.positions.iter().any(|p| !p.is_finite()) {
        return Err(HairMeshError::Format {
            path: path.into(),
            message: "vertex positions contain NaN or infinity".into(),
        });
    }
    mesh.select(selector);
    mesh.weld(WELD_TOLERANCE);
    if mesh.faces.is_empty() {
        let detail = if *selector == ScalpSelector::All {
            String::new()
        } else {
            format!(" (after selecting `{selector}`)")
        };
        return Err(HairMeshError::NoFaces { path: path.into(), detail });
    }
    // Faces that are all degenerate (collinear or repeated vertices) leave nothing to put roots
    // on; compare with the selection's own extent so any unit works.
    let (lo, hi) = mesh.bounds().unwrap_or_default();
    let extent = (hi - lo).max_element();
    let area = mesh.area();
    if area.is_nan() || area <= 1e-12 * extent * extent {
        return Err(HairMeshError::Format {
            path: path.into(),
            message: format!(
                "the scalp ({} faces{}) has no area: every face is degenerate (its vertices on one line or repeated)",
                mesh.faces.len(),
                if *selector == ScalpSelector::All {
                    String::new()
                } else {
                    format!(" after selecting `{selector}`")
                }
            ),
        });
    }
    Ok(mesh)
}

fn read_file(path: &Path) -> Result<Vec<u8>> {
    crate::input::read_regular(path, MAX_FILE_BYTES)
        .map_err(|e| HairMeshError::Io { path: path.into(), message: e.to_string() })
}

fn load_gltf(path: &Path, selector: &ScalpSelector, references: References) -> Result<ScalpMesh> {
    let format = |message: String| HairMeshError::Format { path: path.into(), message };
    let bytes = read_file(path)?;
    let source = crate::gltf_source::parse(&bytes).map_err(|e| match e {
        SourceError::Invalid(message) => format(format!("not valid glTF: {message}")),
        SourceError::Unsupported(extension) if UNDECODABLE.contains(&extension.as_str()) => {
            HairMeshError::UnsupportedExtension { path: path.into(), extension }
        }
        SourceError::Unsupported(extension) => {
            format(format!("requires the glTF extension {extension}, which hairmesh does not support"))
        }
    })?;
    let document = &source.document;
    check_primitive_accessors(path, document.as_json())?;
    let compressed = source.used.iter().find(|e| UNDECODABLE.contains(&e.as_str()));
    let mut problems = Vec::new();
    {
        use gltf::json::validation::{Error, Validate};
        let root = document.as_json();
        root.validate(root, gltf::json::Path::new, &mut |p, e| {
            let p = p().to_string();
            // An accessor without data is all zeros (the specification's rule), unless the
            // file's meshes are compressed: then it is an empty fallback.
            let zeros =
                p.starts_with("accessors[") && p.ends_with(".bufferView") && matches!(e, Error::Missing);
            if !zeros || compressed.is_some() {
                problems.push(format!("{p}: {e}"));
            }
        });
    }
    if let Some(first) = problems.first() {
        let hint = compressed.map_or(String::new(), |e| {
            format!("; the file uses {e}, which hairmesh cannot decode, and has no uncompressed fallback")
        });
        return Err(format(format!("invalid glTF ({} problems), first: {first}{hint}", problems.len())));
    }
    let buffers = load_buffers(path, references, document, source.blob.as_deref())?;
    for view in document.views() {
        let len = buffers[view.buffer().index()].len();
        if view.offset().checked_add(view.length()).is_none_or(|end| end > len) {
            return Err(format(format!(
                "bufferView {} reaches past the end of buffer {}",
                view.index(),
                view.buffer().index()
            )));
        }
    }

    let mut mesh = ScalpMesh::default();
    let scene = document.default_scene().or_else(|| document.scenes().next());
    let mut stack: Vec<(gltf::Node<'_>, DMat4)> = match &scene {
        Some(s) => s.nodes().map(|n| (n, DMat4::IDENTITY)).collect(),
        None => document.nodes().map(|n| (n, DMat4::IDENTITY)).collect(),
    };
    let mut visited = 0usize;
    while let Some((node, parent)) = stack.pop() {
        visited += 1;
        if visited > 1_000_000 {
            return Err(format("node hierarchy is cyclic or absurdly deep".into()));
        }
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        let world = parent * local;
        stack.extend(node.children().map(|c| (c, world)));
        let Some(gmesh) = node.mesh() else { continue };
        for prim in gmesh.primitives() {
            let name_ok = match selector {
                ScalpSelector::Named(n) => {
                    gmesh.name() == Some(n.as_str()) || prim.material().name() == Some(n.as_str())
                }
                _ => true,
            };
            if !name_ok {
                continue;
            }
            add_primitive(path, &mut mesh, &gmesh, &prim, &buffers, world)?;
        }
    }
    Ok(mesh)
}

/// Every accessor a mesh primitive names must exist before the gltf crate validates the
/// document: its validation indexes the POSITION accessor without checking (it panics on
/// `"POSITION": 0` with no accessors).
fn check_primitive_accessors(path: &Path, root: &gltf::json::Root) -> Result<()> {
    let count = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let mut named: Vec<(String, usize)> = prim
                .attributes
                .iter()
                .map(|(semantic, i)| (format!("attributes.{}", semantic.to_string()), i.value()))
                .collect();
            named.extend(prim.indices.iter().map(|i| ("indices".to_owned(), i.value())));
            for (t, target) in prim.targets.iter().flatten().enumerate() {
                for (what, index) in [
                    ("POSITION", &target.positions),
                    ("NORMAL", &target.normals),
                    ("TANGENT", &target.tangents),
                ] {
                    named.extend(index.iter().map(|i| (format!("targets[{t}].{what}"), i.value())));
                }
            }
            if let Some((field, index)) = named.into_iter().find(|(_, i)| *i >= count) {
                return Err(HairMeshError::Format {
                    path: path.into(),
                    message: format!(
                        "meshes[{m}].primitives[{p}].{field}: accessor {index} does not exist (the file has {count} accessors)"
                    ),
                });
            }
        }
    }
    Ok(())
}

fn load_buffers(
    path: &Path,
    references: References,
    document: &gltf::Document,
    blob: Option<&[u8]>,
) -> Result<Vec<Vec<u8>>> {
    use base64::Engine as _;
    let format = |message: String| HairMeshError::Format { path: path.into(), message };
    document
        .buffers()
        .map(|buffer| {
            let data = match buffer.source() {
                gltf::buffer::Source::Bin => blob.map(<[u8]>::to_vec).ok_or_else(|| {
                    format(format!("buffer {} refers to a missing GLB binary chunk", buffer.index()))
                })?,
                gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                    let (_, payload) = uri.split_once(";base64,").ok_or_else(|| {
                        format(format!("buffer {}: only base64 data URIs are supported", buffer.index()))
                    })?;
                    base64::engine::general_purpose::STANDARD
                        .decode(payload)
                        .map_err(|e| format(format!("buffer {}: bad base64 data: {e}", buffer.index())))?
                }
                gltf::buffer::Source::Uri(uri) => {
                    let file = crate::input::resolve_reference(path, uri, references)
                        .map_err(|e| format(format!("buffers[{}].uri: {e}", buffer.index())))?;
                    // Never more than the buffer declares; a shorter file is refused below.
                    crate::input::read_prefix(&file, buffer.length() as u64).map_err(|e| {
                        format(format!("buffers[{}].uri: `{uri}` ({}) {e}", buffer.index(), file.display()))
                    })?
                }
            };
            if data.len() < buffer.length() {
                return Err(format(format!(
                    "buffer {} holds {} bytes but declares {}",
                    buffer.index(),
                    data.len(),
                    buffer.length()
                )));
            }
            Ok(data)
        })
        .collect()
}

/// A VEC3 accessor's values as f64: float, or integers (normalized or not) as
/// `KHR_mesh_quantization` allows; all zeros without data (the specification's rule). `None`
/// when the data is out of range or of a type no position has.
fn read_vec3(accessor: &gltf::Accessor<'_>, buffers: &[Vec<u8>]) -> Option<Vec<DVec3>> {
    use gltf::accessor::{DataType, Dimensions, Iter};
    if accessor.dimensions() != Dimensions::Vec3 {
        return None;
    }
    if accessor.view().is_none() && accessor.sparse().is_none() {
        return Some(vec![DVec3::ZERO; accessor.count()]);
    }
    let get = |b: gltf::Buffer<'_>| buffers.get(b.index()).map(Vec::as_slice);
    // Normalized integers map to [0, 1] or [−1, 1] (signed values below −1 clamp to −1).
    let normalized = accessor.normalized();
    fn convert<T: Copy + Into<f64>>(items: impl Iterator<Item = [T; 3]>, scale: Option<f64>) -> Vec<DVec3> {
        items
            .map(|v| {
                let v = DVec3::new(v[0].into(), v[1].into(), v[2].into());
                match scale {
                    Some(s) => (v * s).max(DVec3::NEG_ONE),
                    None => v,
                }
            })
            .collect()
    }
    let scale = |max: f64| normalized.then_some(1.0 / max);
    let a = accessor.clone();
    Some(match accessor.data_type() {
        DataType::F32 => convert(Iter::<[f32; 3]>::new(a, get)?, None),
        DataType::I8 => convert(Iter::<[i8; 3]>::new(a, get)?, scale(127.0)),
        DataType::U8 => convert(Iter::<[u8; 3]>::new(a, get)?, scale(255.0)),
        DataType::I16 => convert(Iter::<[i16; 3]>::new(a, get)?, scale(32767.0)),
        DataType::U16 => convert(Iter::<[u16; 3]>::new(a, get)?, scale(65535.0)),
        DataType::U32 => return None,
    })
}

/// POSITION's `min` and `max` must be the data's bounds (the specification requires them, and a
/// file where they are wrong was written by a broken exporter). Compared as stored, within a
/// float's rounding of the extent.
fn check_bounds(accessor: &gltf::Accessor<'_>, local: &[DVec3]) -> std::result::Result<(), String> {
    let declared = |v: Option<serde_json::Value>| -> Option<DVec3> {
        let a: Vec<f64> = v?.as_array()?.iter().filter_map(serde_json::Value::as_f64).collect();
        (a.len() == 3).then(|| DVec3::new(a[0], a[1], a[2]))
    };
    let (Some(min), Some(max)) = (declared(accessor.min()), declared(accessor.max())) else { return Ok(()) };
    let lo = local.iter().fold(DVec3::INFINITY, |a, &p| a.min(p));
    let hi = local.iter().fold(DVec3::NEG_INFINITY, |a, &p| a.max(p));
    // Quantized data is compared after dequantization; min and max are stored undequantized.
    if accessor.normalized() {
        return Ok(());
    }
    let tolerance = 1e-5 * (hi - lo).max_element().max(max.abs().max_element()).max(1e-30);
    if (min - lo).abs().max_element() > tolerance || (max - hi).abs().max_element() > tolerance {
        return Err(format!("min {min} and max {max} are not the data's bounds ({lo} .. {hi})"));
    }
    Ok(())
}

fn check_accessor(path: &Path, what: &str, accessor: &gltf::Accessor<'_>) -> Result<()> {
    let format = |message: String| HairMeshError::Format { path: path.into(), message };
    if accessor.count() == 0 || accessor.count() > MAX_ELEMENTS {
        return Err(format(format!(
            "{what} accessor {} has {} elements",
            accessor.index(),
            accessor.count()
        )));
    }
    Ok(())
}

fn add_primitive(
    path: &Path,
    mesh: &mut ScalpMesh,
    gmesh: &gltf::Mesh<'_>,
    prim: &gltf::Primitive<'_>,
    buffers: &[Vec<u8>],
    world: DMat4,
) -> Result<()> {
    use gltf::mesh::Mode;
    let format = |message: String| HairMeshError::Format { path: path.into(), message };
    let label =
        format!("mesh {} ({}) primitive {}", gmesh.index(), gmesh.name().unwrap_or("unnamed"), prim.index());
    if !matches!(prim.mode(), Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
        mesh.warnings.push(format!("{label}: skipped {:?} primitive (no faces)", prim.mode()));
        return Ok(());
    }
    let pos_accessor =
        prim.get(&gltf::Semantic::Positions).ok_or_else(|| format(format!("{label}: no POSITION")))?;
    check_accessor(path, "POSITION", &pos_accessor)?;
    let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
    let local: Vec<DVec3> = read_vec3(&pos_accessor, buffers)
        .ok_or_else(|| format(format!("{label}: POSITION data out of range")))?;
    if local.len() != pos_accessor.count() {
        return Err(format(format!("{label}: POSITION data out of range")));
    }
    check_bounds(&pos_accessor, &local)
        .map_err(|e| format(format!("{label}: POSITION accessor {}: {e}", pos_accessor.index())))?;
    // Normals are not used, but wrong ones mark a broken exporter whose positions are suspect too.
    if let Some(normals) = prim.get(&gltf::Semantic::Normals) {
        let values = read_vec3(&normals, buffers).filter(|v| v.len() == normals.count());
        let values = values.ok_or_else(|| format(format!("{label}: NORMAL data out of range")))?;
        let problem = check_bounds(&normals, &values).err().or_else(|| {
            // Loose enough for 8-bit quantized normals and exporters' rounding.
            let i = values.iter().position(|n| (n.length() - 1.0).abs() > 0.02)?;
            Some(format!("normal {i} ({}) is not of unit length", values[i]))
        });
        if let Some(problem) = problem {
            return Err(format(format!("{label}: NORMAL accessor {}: {problem}", normals.index())));
        }
    }
    let count = local.len();
    let indices: Vec<u32> = match prim.indices() {
        Some(acc) => {
            check_accessor(path, "index", &acc)?;
            let idx: Vec<u32> = if acc.view().is_none() && acc.sparse().is_none() {
                vec![0; acc.count()]
            } else {
                reader
                    .read_indices()
                    .ok_or_else(|| format(format!("{label}: index data out of range")))?
                    .into_u32()
                    .collect()
            };
            if idx.len() != acc.count() {
                return Err(format(format!("{label}: index data out of range")));
            }
            if let Some(bad) = idx.iter().find(|&&i| i as usize >= count) {
                return Err(format(format!("{label}: index {bad} is out of range for {count} vertices")));
            }
            idx
        }
        None => (0..count as u32).collect(),
    };
    let triangles: Vec<[u32; 3]> = match prim.mode() {
        Mode::Triangles => indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        Mode::TriangleStrip => (0..indices.len().saturating_sub(2))
            .map(|i| {
                // Alternate winding so every strip triangle keeps the strip's orientation.
                if i % 2 == 0 {
                    [indices[i], indices[i + 1], indices[i + 2]]
                } else {
                    [indices[i + 1], indices[i], indices[i + 2]]
                }
            })
            .collect(),
        _ => (1..indices.len().saturating_sub(1)).map(|i| [indices[0], indices[i], indices[i + 1]]).collect(),
    };
    let base = mesh.positions.len() as u32;
    let to_world = |p: DVec3| world.transform_point3(p);
    let had_uvs = mesh.uvs.is_some() || mesh.positions.is_empty();
    let uvs: Option<Vec<DVec2>> = reader
        .read_tex_coords(0)
        .map(|t| t.into_f32().map(|[u, v]| DVec2::new(f64::from(u), f64::from(v))).collect::<Vec<_>>())
        .filter(|t| t.len() == count);
    match (uvs, had_uvs) {
        (Some(t), true) => mesh.uvs.get_or_insert_with(Vec::new).extend(t),
        _ => {
            if mesh.uvs.take().is_some() || !mesh.positions.is_empty() {
                mesh.warnings.push(format!(
                    "{label}: not every primitive has TEXCOORD_0; using the automatic uv layout"
                ));
            }
        }
    }
    // Morph targets: one layer each, in world space; each must move every vertex by a finite
    // offset (a shorter target would leave layers with fewer vertices than the scalp).
    let mut targets: Vec<Vec<DVec3>> = Vec::new();
    for (t, target) in prim.morph_targets().enumerate() {
        let Some(accessor) = target.positions() else { continue };
        let deltas = read_vec3(&accessor, buffers)
            .ok_or_else(|| format(format!("{label}: morph target {t}: POSITION data out of range")))?;
        if deltas.len() != count {
            return Err(format(format!(
                "{label}: morph target {t}: POSITION has {} entries for {count} vertices",
                deltas.len()
            )));
        }
        if let Some(v) = deltas.iter().position(|d| !d.is_finite()) {
            return Err(format(format!(
                "{label}: morph target {t}: the offset of vertex {v} is not a finite number"
            )));
        }
        targets.push(deltas.iter().zip(&local).map(|(d, q)| to_world(*q + *d)).collect());
    }
    if !targets.is_empty() || !mesh.morph_layers.is_empty() {
        if mesh.morph_layers.is_empty() && base == 0 {
            mesh.morph_layers = targets;
        } else if targets.len() == mesh.morph_layers.len() && targets.iter().all(|t| t.len() == count) {
            for (layer, t) in mesh.morph_layers.iter_mut().zip(targets) {
                layer.extend(t);
            }
        } else {
            mesh.warnings
                .push(format!("{label}: morph targets differ between primitives; morph layers dropped"));
            mesh.morph_layers.clear();
        }
    }
    mesh.positions.extend(local.iter().map(|p| to_world(*p)));
    // A mirroring transform flips winding; keep faces front-facing.
    let flip = world.determinant() < 0.0;
    mesh.faces.extend(triangles.into_iter().map(|[a, b, c]| {
        if flip { vec![base + a, base + c, base + b] } else { vec![base + a, base + b, base + c] }
    }));
    Ok(())
}

/// The OBJ text with every comment (from `#` to the end of its line) removed: tobj reads a
/// comment after a face or vertex as more numbers.
fn without_obj_comments(bytes: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(bytes.len());
    for line in bytes.split_inclusive(|&b| b == b'\n') {
        match line.iter().position(|&b| b == b'#') {
            Some(at) => {
                out.extend_from_slice(&line[..at]);
                if line.ends_with(b"\n") {
                    out.push(b'\n');
                }
            }
            None => out.extend_from_slice(line),
        }
    }
    out
}

/// Every face index of an OBJ file must name an element defined before it (1-based, or
/// negative and relative): tobj multiplies indices without overflow checks and panics on a
/// huge one (found by the fuzz tests).
fn check_obj_indices(bytes: &[u8]) -> std::result::Result<(), String> {
    let text = String::from_utf8_lossy(bytes);
    // Elements defined so far: positions, texture coordinates, normals.
    let mut defined = [0i64; 3];
    const NAMES: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    for (number, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => defined[0] += 1,
            Some("vt") => defined[1] += 1,
            Some("vn") => defined[2] += 1,
            Some("f" | "l" | "p") => {
                for corner in words {
                    for (slot, field) in corner.split('/').enumerate().take(3) {
                        if field.is_empty() && slot > 0 {
                            continue;
                        }
                        let bad = || {
                            format!(
                                "line {}: `{corner}` is not a face corner (v, v/vt, v//vn or v/vt/vn)",
                                number + 1
                            )
                        };
                        let index: i64 = field.parse().map_err(|_| bad())?;
                        let resolved = if index < 0 {
                            defined[slot].saturating_add(index).saturating_add(1)
                        } else {
                            index
                        };
                        if index == 0 || resolved < 1 || resolved > defined[slot] {
                            return Err(format!(
                                "line {}: {} index {index} does not name one of the {} defined before it",
                                number + 1,
                                NAMES[slot],
                                defined[slot]
                            ));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

fn load_obj(path: &Path, selector: &ScalpSelector) -> Result<ScalpMesh> {
    let format = |message: String| HairMeshError::Format { path: path.into(), message };
    let bytes = without_obj_comments(&read_file(path)?);
    check_obj_indices(&bytes).map_err(format)?;
    let options =
        tobj::LoadOptions { single_index: true, triangulate: false, ignore_points: true, ignore_lines: true };
    let (models, _) = tobj::load_obj_buf(&mut std::io::Cursor::new(bytes), &options, |_| {
        Ok((Vec::new(), Default::default()))
    })
    .map_err(|e| format(format!("not a valid OBJ file: {e}")))?;
    let mut mesh = ScalpMesh::default();
    let mut all_uvs = true;
    let mut uvs = Vec::new();
    for model in &models {
        if let ScalpSelector::Named(n) = selector
            && &model.name != n
        {
            continue;
        }
        let m = &model.mesh;
        let count = m.positions.len() / 3;
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|p| DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))),
        );
        if m.texcoords.len() == count * 2 {
            uvs.extend(m.texcoords.chunks_exact(2).map(|t| DVec2::new(f64::from(t[0]), f64::from(t[1]))));
        } else {
            all_uvs = false;
        }
        let arities: Vec<u32> =
            if m.face_arities.is_empty() { vec![3; m.indices.len() / 3] } else { m.face_arities.clone() };
        let mut at = 0usize;
        for arity in arities {
            let end = at + arity as usize;
            let face = m
                .indices
                .get(at..end)
                .ok_or_else(|| format(format!("object `{}`: face list is truncated", model.name)))?;
            if let Some(bad) = face.iter().find(|&&i| i as usize >= count) {
                return Err(format(format!("object `{}`: vertex index {bad} out of range", model.name)));
            }
            if arity >= 3 {
                mesh.faces.push(face.iter().map(|&i| base + i).collect());
            }
            at = end;
        }
    }
    if all_uvs && !mesh.positions.is_empty() {
        mesh.uvs = Some(uvs);
    }
    Ok(mesh)
}
