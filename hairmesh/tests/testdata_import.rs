//! Every glTF and head of the data set's `gltf/` and `heads/` either imports or fails with the documented error.

use std::path::{Path, PathBuf};

mod common;
use common::testdata;

use hairmesh::import::load_scalp;
use hairmesh::{HairMeshError, ScalpSelector};

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<PathBuf> =
        std::fs::read_dir(dir).expect("readable test data").map(|e| e.expect("entry").path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            files(&p, out);
        } else if matches!(p.extension().and_then(|e| e.to_str()), Some("gltf" | "glb" | "obj")) {
            out.push(p);
        }
    }
}

/// What a file is expected to do: import with at least this many faces, or fail like this.
fn expectation(name: &str) -> Result<usize, &'static str> {
    match name {
        // Draco required: refused by name.
        "BoxMetaDraco.gltf"
        | "DracoSparseMesh.gltf"
        | "2CylinderEngine.gltf"
        | "Box_Draco.glb"
        | "DenseSphere.glb" => Err("KHR_draco_mesh_compression"),
        // Draco only *used*, with empty fallback accessors: must not load as zeros.
        "BoxDraco.gltf" => Err(
            "uses KHR_draco_mesh_compression, which hairmesh cannot decode, and has no uncompressed fallback",
        ),
        // Points and lines only.
        n if ["00", "01", "02", "03", "07", "08", "09", "10"]
            .iter()
            .any(|m| n == format!("Mesh_PrimitiveMode_{m}.gltf")) =>
        {
            Err("no triangles or polygons")
        }
        "Triangle.gltf" | "TriangleWithoutIndices.gltf" => Ok(1),
        _ => Ok(2),
    }
}

#[test]
fn every_test_file_imports_or_fails_as_documented() {
    let mut all = Vec::new();
    files(&testdata("gltf"), &mut all);
    files(&testdata("heads"), &mut all);
    assert!(all.len() >= 30, "found only {} files", all.len());
    let mut report = String::new();
    for path in &all {
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
        let result = load_scalp(path, &ScalpSelector::All);
        match (&result, expectation(name)) {
            (Ok(mesh), Ok(min_faces)) => {
                assert!(mesh.faces.len() >= min_faces, "{name}: {} faces", mesh.faces.len());
                assert!(mesh.positions.iter().all(|p| p.is_finite()));
                assert!(mesh.area() > 0.0, "{name}: zero area (loaded as zeros?)");
                report += &format!(
                    "{name}: {} vertices, {} faces, uvs: {}\n",
                    mesh.positions.len(),
                    mesh.faces.len(),
                    mesh.uvs.is_some()
                );
            }
            (Err(e), Err(expected)) => {
                let text = e.to_string();
                assert!(
                    text.contains(expected),
                    "{name}: expected an error containing `{expected}`, got: {text}"
                );
                assert!(text.contains(name), "{name}: the error must name the file: {text}");
                report += &format!("{name}: refused: {text}\n");
            }
            (Ok(mesh), Err(expected)) => {
                panic!("{name}: loaded {} faces but should fail with `{expected}`", mesh.faces.len())
            }
            (Err(e), Ok(_)) => panic!("{name}: should load but failed: {e}"),
        }
    }
    eprintln!("{report}");
}

#[test]
fn malformed_files_give_clear_errors() {
    let dir = tempfile::tempdir().expect("temp dir");
    let cases: &[(&str, &[u8], &str)] = &[
        ("garbage.gltf", b"{ not json", "not valid glTF"),
        ("empty.glb", b"", "not valid glTF"),
        ("missing_buffer.gltf", br#"{"asset":{"version":"2.0"},"buffers":[{"uri":"nope.bin","byteLength":12}]}"#, "nope.bin"),
        ("short_buffer.gltf", br#"{"asset":{"version":"2.0"},"buffers":[{"uri":"data:application/octet-stream;base64,AAAA","byteLength":12}]}"#, "declares 12"),
        ("bad.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n", "bad.obj"),
        ("nan.obj", b"v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "nan.obj"),
        ("lines.obj", b"v 0 0 0\nv 1 0 0\nl 1 2\n", "no triangles"),
        ("scalp.txt", b"", "unknown file type"),
        // Issue #17: an attribute naming an accessor that does not exist used to panic inside
        // the gltf crate's validation.
        (
            "no_accessors.gltf",
            br#"{"asset":{"version":"2.0"},"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}]}"#,
            "accessor 0",
        ),
        (
            "bad_indices.gltf",
            br#"{"asset":{"version":"2.0"},"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":7}]}],"accessors":[{"componentType":5126,"count":3,"type":"VEC3"}]}"#,
            "accessor 7",
        ),
        // Found by the fuzz tests: tobj multiplied a huge texture-coordinate index without an
        // overflow check and panicked.
        (
            "huge_index.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/9223372036854775807 2/1 3/1\n",
            "texture coordinate index 9223372036854775807",
        ),
        ("not_a_corner.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", "line 4"),
        // A comment after a face is the OBJ format's, not a corner.
        ("comment.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 # a face\nf 1 2 x\n", "line 5"),
        // Every triangle on one line: no area to put roots on.
        ("collinear.obj", b"v 0 0 0\nv 1 0 0\nv 2 0 0\nv 3 0 0\nf 1 2 3\nf 2 3 4\n", "no area"),
    ];
    for (name, bytes, expected) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).expect("write");
        let e = load_scalp(&path, &ScalpSelector::All).expect_err(name);
        let text = e.to_string();
        assert!(text.contains(expected), "{name}: `{text}` should mention `{expected}`");
        assert!(text.contains(name), "{name}: `{text}` should name the file");
        assert!(!matches!(e, HairMeshError::InvalidParameter { .. }));
    }
}

#[test]
fn scalp_selections_of_the_real_heads() {
    // LeePerrySmith (metres, +Y up, face toward +Z): the crown and back of the head.
    let lee = testdata("heads/LeePerrySmith/LeePerrySmith.glb");
    let whole = load_scalp(&lee, &ScalpSelector::All).expect("LeePerrySmith loads");
    let (lo, hi) = whole.bounds().expect("bounds");
    eprintln!(
        "LeePerrySmith: {} vertices, {} faces, bounds {lo} .. {hi}",
        whole.positions.len(),
        whole.faces.len()
    );
    let sintel = testdata("heads/sintel/sintel_bust.obj");
    let whole = load_scalp(&sintel, &ScalpSelector::All).expect("sintel loads");
    let (lo, hi) = whole.bounds().expect("bounds");
    eprintln!("sintel: {} vertices, {} faces, bounds {lo} .. {hi}", whole.positions.len(), whole.faces.len());
}

/// The documented scalp selections of the README, turned into hair meshes.
#[test]
fn real_heads_become_hair_meshes() {
    use hairmesh::{BundleFace, ExtrudeParams, HairMesh};
    for (file, selector, length) in [
        ("heads/LeePerrySmith/LeePerrySmith.glb", "above:0,0.8192,-0.5735,1.3435", 3.0),
        ("heads/sintel/sintel_bust.obj", "above:0,0.9138,-0.4061,32", 15.0),
    ] {
        let selector = ScalpSelector::parse(selector).expect("valid selector");
        let scalp = load_scalp(&testdata(file), &selector).expect("scalp loads");
        let hm = HairMesh::extrude(
            &scalp,
            &ExtrudeParams { layers: 4, length, droop: 0.3, gravity: glam::DVec3::NEG_Y },
        )
        .expect("extrudes");
        let quads = hm.faces.iter().filter(|f| matches!(f, BundleFace::Quad(_))).count();
        eprintln!(
            "{file}: scalp {} vertices / {} faces (area {:.2}) -> {} bundles ({quads} quads)",
            scalp.positions.len(),
            scalp.faces.len(),
            scalp.area(),
            hm.faces.len()
        );
        assert!(hm.faces.len() > 50, "{file}: selection too small");
        assert!(hm.layers.iter().flatten().all(|p| p.is_finite()));
        // Both heads were modelled in quads: most triangles pair back up.
        assert!(quads * 2 > hm.faces.len(), "{file}: only {quads} of {} bundles are quads", hm.faces.len());
    }
}

/// The documented hairlines: hair from each real head's selection, laid over the head, has no
/// root below the hairline and keeps clear of the face.
#[test]
fn real_heads_get_hair_above_their_hairlines_and_off_their_faces() {
    use glam::DVec3;
    use hairmesh::{DrapeParams, HairMesh};
    struct Head {
        file: &'static str,
        selector: &'static str,
        /// The hairline as a plane: every root has `dot(normal, root) > offset`.
        hairline: (DVec3, f64),
        skull: DVec3,
        length: f64,
        /// Below the hairline in front: (x half-width, y range, the face's z from which on no
        /// hair may be).
        face: (f64, (f64, f64), f64),
    }
    let heads = [
        // Face towards +Z, top of the head at y = 3.97, nose tip at z = 2.59: the hairline at
        // y ≈ 2.9 over the forehead, above the ears at the sides, y ≈ 0.3 at the nape.
        Head {
            file: "heads/LeePerrySmith/LeePerrySmith.glb",
            selector: "above:0,0.8192,-0.5735,1.3435",
            hairline: (DVec3::new(0.0, 1.0, -0.7), 1.3),
            skull: DVec3::new(0.0, 1.9, -0.2),
            length: 4.5,
            face: (1.2, (-0.6, 2.4), 1.5),
        },
        // Centimetres, face towards +Z, top at y = 45.5, nose tip at (0, 28.4, 11.9); the face
        // between the temples (|x| < 5) and below the brows (y < 36).
        Head {
            file: "heads/sintel/sintel_bust.obj",
            selector: "above:0,0.9138,-0.4061,32",
            hairline: (DVec3::new(0.0, 0.9138, -0.4061), 30.0),
            skull: DVec3::new(0.0, 34.0, -0.5),
            length: 25.0,
            face: (5.0, (22.0, 36.0), 6.0),
        },
    ];
    for head in heads {
        let selector = ScalpSelector::parse(head.selector).expect("valid selector");
        let scalp = load_scalp(&testdata(head.file), &selector).expect("scalp loads");
        let hm = HairMesh::drape(
            &scalp,
            &DrapeParams {
                layers: 6,
                length: head.length,
                centre: head.skull,
                lift: 0.04,
                gravity: DVec3::NEG_Y,
                comb: DVec3::new(0.0, 0.0, -2.5),
            },
        )
        .expect("drapes");
        let (normal, offset) = head.hairline;
        let lowest = hm.layers[0].iter().map(|r| normal.dot(*r)).fold(f64::INFINITY, f64::min);
        assert!(lowest > offset, "{}: a root at {lowest} is below the hairline {offset}", head.file);
        let (half_width, (y0, y1), front) = head.face;
        let in_face = |p: &&DVec3| p.x.abs() < half_width && p.y > y0 && p.y < y1 && p.z > front;
        let covering: Vec<&DVec3> = hm.layers.iter().flatten().filter(in_face).collect();
        assert!(
            covering.is_empty(),
            "{}: {} hair points over the face, e.g. {}",
            head.file,
            covering.len(),
            covering[0]
        );
        // In front of the face (between the temples, below the hairline) the hair's bounds stay
        // behind it.
        let front_of_hair = hm
            .layers
            .iter()
            .flatten()
            .filter(|p| p.y < y1 && p.x.abs() < half_width)
            .map(|p| p.z)
            .fold(f64::NEG_INFINITY, f64::max);
        assert!(front_of_hair < front, "{}: hair below the hairline reaches z = {front_of_hair}", head.file);
        eprintln!(
            "{}: {} roots, lowest {lowest:.2} > {offset}; hair in front of the face reaches z = {front_of_hair:.2} < {front}",
            head.file,
            hm.vertex_count()
        );
    }
}

/// Run by the two tests below in a child process with `HAIRKIT_DATA` set (on its own it checks
/// the data set this machine resolves): the sample head is found through the resolver, inside
/// `HAIRKIT_DATA_EXPECTED_ROOT` when that is set, and loads.
#[test]
fn the_sample_head_loads_through_the_resolver() {
    let head = hairmesh::convert::sample_head::locate().unwrap_or_else(|missing| panic!("{missing}"));
    if let Some(root) = std::env::var_os("HAIRKIT_DATA_EXPECTED_ROOT") {
        assert!(head.starts_with(&root), "{} is not inside {}", head.display(), Path::new(&root).display());
    }
    let selector = ScalpSelector::parse(hairmesh::convert::sample_head::SCALP).expect("selector");
    let scalp = load_scalp(&head, &selector).expect("the sample head loads");
    assert!(scalp.faces.len() > 1000, "{} faces", scalp.faces.len());
}

/// This test binary again, running only the test above, with `HAIRKIT_DATA` set to `data`.
fn the_sample_head_test_with_data_at(data: &Path) -> std::process::Output {
    std::process::Command::new(std::env::current_exe().expect("this test binary"))
        .args(["--exact", "the_sample_head_loads_through_the_resolver", "--test-threads", "1"])
        .env(data_set::ENV_VAR, data)
        .env("HAIRKIT_DATA_EXPECTED_ROOT", data)
        .output()
        .expect("run the test binary")
}

#[test]
fn hairkit_data_pointing_at_a_copy_of_the_data_is_used() {
    let copy = tempfile::tempdir().expect("temp dir");
    let original = testdata(data_set::SAMPLE_HEAD);
    let target = copy.path().join(data_set::SAMPLE_HEAD);
    std::fs::create_dir_all(target.parent().expect("a folder")).expect("mkdir");
    std::fs::copy(&original, &target).expect("copy the head");
    let out = the_sample_head_test_with_data_at(copy.path());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("1 passed"), "the child ran no test: {stdout}");
}

#[test]
fn hairkit_data_pointing_at_an_empty_folder_names_the_file_and_the_variable() {
    let empty = tempfile::tempdir().expect("temp dir");
    let out = the_sample_head_test_with_data_at(empty.path());
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(!out.status.success(), "found a head in an empty folder: {text}");
    for needle in [
        data_set::SAMPLE_HEAD,
        data_set::ENV_VAR,
        data_set::FETCH_COMMAND,
        &empty.path().display().to_string(),
    ] {
        assert!(text.contains(needle), "`{needle}` missing from the failure: {text}");
    }
}

/// Reasons a valid glTF may be refused: real limitations of a scalp importer, named in words.
const NAMED_LIMITATIONS: &[&str] =
    &["no triangles or polygons to use as a scalp", "has no area: every face is degenerate"];

/// The data set's glTF importer corpus (`gltf-sample-assets/MANIFEST.json`, with the Khronos
/// validator's verdict per file): every valid model imports or names a real limitation, every
/// invalid one is refused with an error naming the file, and none panics.
#[test]
fn every_gltf_sample_asset_imports_or_names_its_limitation() {
    let manifest_path = testdata("gltf-sample-assets/MANIFEST.json");
    let root = manifest_path.parent().expect("the corpus folder").to_owned();
    let manifest: Vec<serde_json::Value> =
        serde_json::from_slice(&std::fs::read(&manifest_path).expect("MANIFEST.json"))
            .expect("MANIFEST.json is JSON");
    assert!(manifest.len() >= 100, "only {} entries", manifest.len());
    let mut failures = Vec::new();
    let mut loaded = 0;
    for entry in &manifest {
        let file = entry["file"].as_str().expect("file");
        let expect = entry["expect"].as_str().expect("expect");
        let path = root.join(file);
        let result = std::panic::catch_unwind(|| load_scalp(&path, &ScalpSelector::All));
        let Ok(result) = result else {
            failures.push(format!("{file}: panicked"));
            continue;
        };
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
        match (expect, result) {
            ("load", Ok(mesh)) | ("refuse-named-limitation", Ok(mesh)) => {
                loaded += 1;
                if !(mesh.area() > 0.0 && mesh.positions.iter().all(|p| p.is_finite())) {
                    failures.push(format!("{file}: loaded without area or with non-finite positions"));
                }
            }
            ("load", Err(e)) => {
                let text = e.to_string();
                if !NAMED_LIMITATIONS.iter().any(|l| text.contains(l)) {
                    failures.push(format!("{file}: valid but refused: {text}"));
                }
            }
            ("refuse-named-limitation", Err(e)) => {
                let wanted =
                    entry["extensions_required"].as_array().into_iter().flatten().filter_map(|x| x.as_str());
                let text = e.to_string();
                if !wanted.clone().any(|x| text.contains(x)) {
                    failures.push(format!(
                        "{file}: refused without naming {:?}: {text}",
                        wanted.collect::<Vec<_>>()
                    ));
                }
            }
            ("refuse", Ok(_)) => {
                failures.push(format!("{file}: invalid ({}) but loaded", entry["first_errors"]));
            }
            ("refuse", Err(e)) => {
                if !e.to_string().contains(name) {
                    failures.push(format!("{file}: the error does not name the file: {e}"));
                }
            }
            (other, _) => failures.push(format!("{file}: unknown expectation `{other}`")),
        }
    }
    assert!(failures.is_empty(), "{} of {} files:\n{}", failures.len(), manifest.len(), failures.join("\n"));
    assert!(loaded >= 50, "only {loaded} files loaded");
}

/// A one-triangle glTF with one morph target of `deltas` (embedded as a data URI).
fn morph_gltf(deltas: &[f32]) -> Vec<u8> {
    use base64::Engine as _;
    let positions: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let bytes: Vec<u8> = positions.iter().chain(deltas).flat_map(|v| v.to_le_bytes()).collect();
    let data = base64::engine::general_purpose::STANDARD.encode(&bytes);
    serde_json::to_vec(&serde_json::json!({
        "asset": {"version": "2.0"},
        "buffers": [{"uri": format!("data:application/octet-stream;base64,{data}"), "byteLength": bytes.len()}],
        "bufferViews": [
            {"buffer": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": deltas.len() * 4}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": deltas.len() / 3, "type": "VEC3"}
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "targets": [{"POSITION": 1}]}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}]
    }))
    .expect("json")
}

/// A morph target shorter than its mesh used to panic (in conversion and as an occluder);
/// non-finite offsets made layers of NaN.
#[test]
fn morph_targets_that_do_not_fit_their_mesh_are_refused() {
    let dir = tempfile::tempdir().expect("temp dir");
    let ok = [0.0, 0.0, 0.1, 0.0, 0.0, 0.1, 0.0, 0.0, 0.1];
    let path = dir.path().join("fits.gltf");
    std::fs::write(&path, morph_gltf(&ok)).expect("write");
    let mesh = load_scalp(&path, &ScalpSelector::All).expect("a fitting morph target loads");
    assert_eq!(mesh.morph_layers.len(), 1);
    assert_eq!(mesh.morph_layers[0].len(), mesh.positions.len());
    for (name, deltas, expected) in [
        ("short.gltf", &ok[..6], "morph target 0: POSITION has 2 entries for 3 vertices"),
        (
            "nan.gltf",
            &[0.0, 0.0, f32::NAN, 0.0, 0.0, 0.1, 0.0, 0.0, 0.1][..],
            "vertex 0 is not a finite number",
        ),
        (
            "inf.gltf",
            &[0.0, 0.0, 0.1, f32::INFINITY, 0.0, 0.1, 0.0, 0.0, 0.1][..],
            "vertex 1 is not a finite number",
        ),
    ] {
        let path = dir.path().join(name);
        std::fs::write(&path, morph_gltf(deltas)).expect("write");
        let e = std::panic::catch_unwind(|| load_scalp(&path, &ScalpSelector::All))
            .unwrap_or_else(|_| panic!("{name}: panicked"))
            .expect_err(name)
            .to_string();
        assert!(e.contains(expected) && e.contains(name), "{name}: {e}");
    }
}

/// The OBJ format lets a comment end any line; tobj read one after a vertex or face as data.
#[test]
fn obj_comments_at_the_end_of_a_line_are_comments() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("commented.obj");
    std::fs::write(&path, "# a triangle\nv 0 0 0\nv 1 0 0 # right\nv 0 1 0\nf 1 2 3 # the face\n")
        .expect("write");
    let mesh = load_scalp(&path, &ScalpSelector::All).expect("a commented OBJ loads");
    assert_eq!((mesh.positions.len(), mesh.faces.len()), (3, 1));
}

/// `KHR_mesh_quantization`: the quantized cube (16-bit positions and morph offsets, with the
/// dequantization in its node transform) is the float cube.
#[test]
fn a_quantized_model_loads_as_its_float_original() {
    let load = |file: &str| {
        load_scalp(&testdata(&format!("gltf-sample-assets/{file}")), &ScalpSelector::All).expect(file)
    };
    let float = load("assimp/AnimatedMorphCube/glTF/AnimatedMorphCube.gltf");
    let quantized = load("khronos/AnimatedMorphCube/glTF-Quantized/AnimatedMorphCube.gltf");
    let (a, b) = (float.bounds().expect("bounds"), quantized.bounds().expect("bounds"));
    let extent = (a.1 - a.0).max_element();
    assert!(
        (a.0 - b.0).abs().max_element() < 1e-3 * extent && (a.1 - b.1).abs().max_element() < 1e-3 * extent,
        "float {a:?}, quantized {b:?}"
    );
    assert_eq!(float.morph_layers.len(), quantized.morph_layers.len());
    assert!((float.area() - quantized.area()).abs() < 1e-2 * float.area());
}

/// Hair laid over the sample head went through its ears and shoulders: the conversion now drapes
/// it over the whole head mesh (not only the scalp selection) and moves out what is left.
#[test]
fn converted_hair_meshes_stay_outside_the_head() {
    use hairmesh::convert::{LayerShape, convert_scalp, sample_head};
    let head_file = testdata(sample_head::PATH);
    let settings = sample_head::long_hair(2000);
    let converted = convert_scalp(&head_file, &settings, &mut |_| {}).expect("converts");
    let head =
        hairmesh::head::HeadSurface::from_mesh(&load_scalp(&head_file, &ScalpSelector::All).expect("head"));
    // The drape that ignores the head puts many vertices inside it.
    let scalp =
        load_scalp(&head_file, &ScalpSelector::parse(sample_head::SCALP).expect("selector")).expect("scalp");
    let LayerShape::Drape { centre, comb, lift } = settings.shape else { unreachable!("a drape") };
    let length = settings.length.expect("a length");
    let params = hairmesh::DrapeParams {
        layers: settings.layers,
        length,
        centre,
        comb,
        lift,
        gravity: glam::DVec3::NEG_Y,
    };
    let blind = hairmesh::HairMesh::drape(&scalp, &params).expect("drapes");
    let inside = blind.layers[1..].iter().flatten().filter(|p| head.signed_distance(**p) < 0.0).count();
    assert!(inside > 100, "the blind drape put only {inside} vertices inside the head");
    let mesh = converted.asset.mesh();
    let worst =
        mesh.layers[1..].iter().flatten().map(|p| head.signed_distance(*p)).fold(f64::INFINITY, f64::min);
    assert!(worst > 0.0, "a hair-mesh vertex {worst} inside the head");
}
