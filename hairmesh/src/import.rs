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

/// [`load_scalp`], with the glTF's buffers read from where `references` allows.
pub fn load_scalp_with(path: &Path, selector: &ScalpSelector, references: References) -> Result<ScalpMesh> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
    let mut mesh = match ext.as_str() {
        "gltf" | "glb" => load_gltf(path, selector, references)?,
        "obj" => load_obj(path, selector)?,
        _ => {
            return Err(HairMeshError::Format {
                path: path.into(),
                message: "unknown file type (expected .gltf, .glb or .obj)".into(),
            });
        }
    };
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
            format!(" (after selecting {selector:?})")
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
                    format!(" after selecting {selector:?}")
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
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes)
        .map_err(|e| format(format!("not valid glTF: {e}")))?;
    for ext in gltf.extensions_required() {
        if UNDECODABLE.contains(&ext) {
            return Err(HairMeshError::UnsupportedExtension { path: path.into(), extension: ext.into() });
        }
    }
    check_primitive_accessors(path, gltf.document.as_json())?;
    let mut problems = Vec::new();
    {
        use gltf::json::validation::Validate;
        let root = gltf.document.as_json();
        root.validate(root, gltf::json::Path::new, &mut |p, e| problems.push(format!("{}: {e}", p())));
    }
    if let Some(first) = problems.first() {
        let compressed = gltf.extensions_used().find(|e| UNDECODABLE.contains(e));
        let hint = compressed.map_or(String::new(), |e| {
            format!("; the file uses {e}, which hairmesh cannot decode, and has no uncompressed fallback")
        });
        return Err(format(format!("invalid glTF ({} problems), first: {first}{hint}", problems.len())));
    }
    let buffers = load_buffers(path, references, &gltf)?;
    for view in gltf.document.views() {
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
    let scene = gltf.document.default_scene().or_else(|| gltf.document.scenes().next());
    let mut stack: Vec<(gltf::Node<'_>, DMat4)> = match &scene {
        Some(s) => s.nodes().map(|n| (n, DMat4::IDENTITY)).collect(),
        None => gltf.document.nodes().map(|n| (n, DMat4::IDENTITY)).collect(),
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
                .map(|(semantic, i)| (format!("attributes.{semantic:?}"), i.value()))
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

fn load_buffers(path: &Path, references: References, gltf: &gltf::Gltf) -> Result<Vec<Vec<u8>>> {
    use base64::Engine as _;
    let format = |message: String| HairMeshError::Format { path: path.into(), message };
    gltf.document
        .buffers()
        .map(|buffer| {
            let data = match buffer.source() {
                gltf::buffer::Source::Bin => gltf.blob.clone().ok_or_else(|| {
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

fn check_accessor(path: &Path, what: &str, accessor: &gltf::Accessor<'_>) -> Result<()> {
    let format = |message: String| HairMeshError::Format { path: path.into(), message };
    if accessor.count() == 0 || accessor.count() > MAX_ELEMENTS {
        return Err(format(format!(
            "{what} accessor {} has {} elements",
            accessor.index(),
            accessor.count()
        )));
    }
    if accessor.view().is_none() && accessor.sparse().is_none() {
        return Err(format(format!(
            "{what} accessor {} has no data (no bufferView): the file relies on mesh compression \
             (e.g. KHR_draco_mesh_compression) that hairmesh cannot decode",
            accessor.index()
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
    let local: Vec<DVec3> = reader
        .read_positions()
        .ok_or_else(|| format(format!("{label}: POSITION data out of range")))?
        .map(|p| DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])))
        .collect();
    if local.len() != pos_accessor.count() {
        return Err(format(format!("{label}: POSITION data out of range")));
    }
    let count = local.len();
    let indices: Vec<u32> = match prim.indices() {
        Some(acc) => {
            check_accessor(path, "index", &acc)?;
            let idx: Vec<u32> = reader
                .read_indices()
                .ok_or_else(|| format(format!("{label}: index data out of range")))?
                .into_u32()
                .collect();
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
    // Morph targets: one layer each, in world space.
    let targets: Vec<Vec<DVec3>> = reader
        .read_morph_targets()
        .filter_map(|(p, _, _)| p)
        .map(|p| {
            p.zip(&local)
                .map(|(d, q)| to_world(*q + DVec3::new(f64::from(d[0]), f64::from(d[1]), f64::from(d[2]))))
                .collect()
        })
        .collect();
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
    let bytes = read_file(path)?;
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
