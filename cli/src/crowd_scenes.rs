//! Crowd scenes for the benchmarks and for users: `N` characters with unique hair meshes
//! (variations of the procedural head cap: scalp resolution, layers, length, droop, style and
//! colour, all from one seed) and a crowd of hairy Utah teapots (the hair-mesh paper's
//! 200-teapot figure), each scene with a camera path through the crowd. Written as hair asset
//! folders, occluder meshes and scene files (`heads.json`, `teapots.json`).

use std::path::{Path, PathBuf};

use glam::Vec3;
use hairmesh::asset::{AssetParams, HairAsset, StrandCount};
use hairmesh::hair_mesh::{ExtrudeParams, HairMesh};
use hairmesh::rng::SplitMix64;
use hairmesh::style::{Clump, Curl, Frizz, Style, Wave};
use hairmesh::teapot::TeapotParts;

/// What to generate.
#[derive(Clone, Debug)]
pub struct CrowdOptions {
    pub out: PathBuf,
    pub characters: u32,
    /// Strands per character.
    pub strands: u64,
    pub teapots: u32,
    pub teapot_strands: u64,
    /// Distinct teapot hair assets the teapots cycle through.
    pub teapot_variants: u32,
    pub size: (u32, u32),
    pub seed: u64,
    /// Also write `heads_animated.json`: every head turning and nodding with its own phase and
    /// its hair simulated in its own wind.
    pub animated: bool,
    /// Whether `out` may be a folder that is not an earlier crowd (`--force`).
    pub replace: hairmesh::output::Replace,
}

/// The command named in a crowd folder's marker ([`hairmesh::output::mark_folder`]).
pub const CROWD_COMMAND: &str = "hairkit crowd";

impl Default for CrowdOptions {
    fn default() -> Self {
        Self {
            out: PathBuf::from("target/crowd"),
            characters: 100,
            strands: 100_000,
            teapots: 200,
            teapot_strands: 20_000,
            teapot_variants: 8,
            size: (1280, 720),
            replace: hairmesh::output::Replace::OwnOutput,
            seed: 1,
            animated: false,
        }
    }
}

/// The scene files written.
#[derive(Clone, Debug)]
pub struct CrowdScenes {
    pub heads: PathBuf,
    pub teapots: PathBuf,
    /// With [`CrowdOptions::animated`].
    pub heads_animated: Option<PathBuf>,
}

#[derive(Debug, thiserror::Error)]
pub enum CrowdError {
    #[error(transparent)]
    HairMesh(#[from] hairmesh::HairMeshError),
    #[error("{path}: {message}")]
    Io { path: PathBuf, message: String },
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> CrowdError + '_ {
    move |e| CrowdError::Io { path: path.to_owned(), message: e.to_string() }
}

/// A uniform number in [lo, hi).
fn uniform(rng: &mut SplitMix64, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.next_f64()
}

/// Hair colours (linear RGB): black, dark brown, brown, auburn, copper, blond, grey.
const PALETTE: [[f64; 3]; 7] = [
    [0.006, 0.004, 0.003],
    [0.035, 0.013, 0.005],
    [0.1, 0.04, 0.012],
    [0.2, 0.045, 0.012],
    [0.35, 0.09, 0.02],
    [0.5, 0.33, 0.13],
    [0.3, 0.28, 0.25],
];

fn color(rng: &mut SplitMix64) -> [f32; 3] {
    let base = PALETTE[(rng.next_u64() % PALETTE.len() as u64) as usize];
    let jitter = uniform(rng, 0.8, 1.25);
    base.map(|c| (c * jitter) as f32)
}

/// A random style at `scale` (object units of a head ≈ 0.2).
fn style(rng: &mut SplitMix64, scale: f64) -> Style {
    let curly = rng.next_f64() < 0.3;
    Style {
        seed: rng.next_u64() as u32,
        width: scale * uniform(rng, 0.006, 0.01),
        length_variation: uniform(rng, 0.05, 0.3),
        curl: if curly {
            Curl {
                radius: scale * uniform(rng, 0.02, 0.06),
                frequency: uniform(rng, 3.0, 8.0),
                phase: rng.next_f64(),
            }
        } else {
            Curl::default()
        },
        wave: Wave {
            amplitude: scale * uniform(rng, 0.0, 0.06),
            frequency: uniform(rng, 2.0, 10.0),
            coherence: 0.0,
        },
        frizz: Frizz { amplitude: scale * uniform(rng, 0.0, 0.01), frequency: 20.0, exponent: 2.0 },
        clump: Clump { strength: uniform(rng, 0.0, 0.7), exponent: uniform(rng, 0.5, 2.0) },
        twist: uniform(rng, -0.3, 0.3),
        ..Style::default()
    }
}

fn write_asset(dir: &Path, asset: &HairAsset, source: &str) -> Result<(), CrowdError> {
    Ok(hairmesh::asset_io::write_asset(
        dir,
        asset,
        hairmesh::asset_io::Precision::F16,
        "metres",
        Some(source),
    )?)
}

fn write_scene(path: &Path, scene: &serde_json::Value) -> Result<(), CrowdError> {
    let text = serde_json::to_vec_pretty(scene)
        .map_err(|e| CrowdError::Io { path: path.to_owned(), message: e.to_string() })?;
    hairmesh::atomic::write_file_atomic(path, |w| w.write_all(&text)).map_err(io_error(path))
}

fn key(eye: Vec3, target: Vec3) -> serde_json::Value {
    serde_json::json!({ "eye": eye.to_array(), "target": target.to_array() })
}

/// A camera path over a crowd occupying `x ∈ ±half_width`, `z ∈ [-depth, 0]` at height
/// `height`: in from the front above, down to eye level through the middle, out at the back.
fn camera_path(half_width: f32, depth: f32, height: f32) -> Vec<serde_json::Value> {
    let centre = Vec3::new(0.0, height, -0.5 * depth);
    vec![
        key(Vec3::new(0.0, height + 0.4 * depth, 0.6 * depth), centre),
        key(Vec3::new(0.3 * half_width, height + 0.3, 0.8), Vec3::new(0.0, height, -0.3 * depth)),
        key(
            Vec3::new(-0.2 * half_width, height + 0.15, -0.45 * depth),
            Vec3::new(0.3 * half_width, height, -0.8 * depth),
        ),
        key(Vec3::new(0.0, height + 0.5 * depth, -1.6 * depth), centre),
    ]
}

/// Position `(x, z)` of crowd member `i` in a grid of `columns` centred on x = 0, rows going
/// back from z = 0.
fn grid_position(i: u32, columns: u32, spacing: f32) -> (f32, f32) {
    let (col, row) = (i % columns, i / columns);
    ((col as f32 - (columns - 1) as f32 / 2.0) * spacing, -(row as f32) * spacing)
}

/// A crowd scene: key and fill light, blended hair (its strands are mostly thinner than a pixel:
/// blended mode keeps their density, and their look under strand LOD) with LOD, the camera at
/// the path's first key.
fn crowd_scene(
    size: (u32, u32),
    path: &[serde_json::Value],
    characters: &[serde_json::Value],
) -> serde_json::Value {
    let (width, height) = size;
    serde_json::json!({
        "output": { "width": width, "height": height },
        "camera": { "eye": path[0]["eye"], "target": path[0]["target"], "fov_y_degrees": 50 },
        "camera_path": path,
        "lights": [
            { "directional": { "direction": [0.4, 0.8, 0.5], "color": [1.0, 0.97, 0.92] } },
            { "directional": { "direction": [-0.6, 0.3, -0.5], "color": [0.2, 0.25, 0.35], "cast_shadows": false } }
        ],
        "characters": characters,
        "effects": { "transparency": "blended" },
        "lod": "auto"
    })
}

/// Writes both crowds; `progress(done, total, what)` after each asset.
pub fn write_crowds(
    options: &CrowdOptions,
    mut progress: impl FnMut(u64, u64, &str),
) -> Result<CrowdScenes, CrowdError> {
    let out = &options.out;
    let own = [
        "heads",
        "teapots",
        "head_cap_*",
        "teapot.gltf",
        "heads.json",
        "heads_animated.json",
        "teapots.json",
    ];
    hairmesh::output::check_command_folder(out, CROWD_COMMAND, &own, options.replace)
        .map_err(hairmesh::HairMeshError::from)?;
    std::fs::create_dir_all(out).map_err(io_error(out))?;
    hairmesh::output::mark_folder(out, CROWD_COMMAND).map_err(io_error(out))?;
    let total =
        u64::from(options.characters) + u64::from(options.teapot_variants.min(options.teapots.max(1)));
    let mut done = 0;
    let mut rng = SplitMix64::new(options.seed);

    // Heads: a few scalp resolutions (each also drawn as the occluder), one asset per character.
    let scalps: Vec<(hairmesh::ScalpMesh, PathBuf)> = [(6, 24), (8, 32), (10, 40)]
        .iter()
        .map(|&(rings, segments)| {
            let mesh = hairmesh::procedural::head_cap(rings, segments);
            let path = out.join(format!("head_cap_{rings}x{segments}.gltf"));
            hairmesh::procedural::write_gltf(&path, &mesh, "head cap").map_err(io_error(&path))?;
            Ok((mesh, path))
        })
        .collect::<Result<_, CrowdError>>()?;
    let columns = (f64::from(options.characters).sqrt().ceil() as u32).max(1);
    let rows = options.characters.div_ceil(columns).max(1);
    let spacing = 0.55;
    let mut characters = Vec::new();
    for i in 0..options.characters {
        let (scalp, scalp_path) = &scalps[(rng.next_u64() % scalps.len() as u64) as usize];
        let extrude = ExtrudeParams {
            layers: 4 + (rng.next_u64() % 3) as u32,
            length: uniform(&mut rng, 0.1, 0.35),
            droop: uniform(&mut rng, 0.4, 1.5),
            ..ExtrudeParams::default()
        };
        let hair_mesh = HairMesh::extrude(scalp, &extrude)?;
        let params = AssetParams {
            strands: StrandCount::Total(options.strands),
            sample_sets: 1,
            seed: rng.next_u64(),
            ..AssetParams::default()
        };
        let asset = HairAsset::build(&hair_mesh, &params, style(&mut rng, 0.2))?;
        let name = format!("heads/hair_{i:03}");
        write_asset(&out.join(&name), &asset, "hairkit crowd (procedural head cap)")?;
        if i == 0 {
            // The first asset tells what the rest will take: refuse now, not when the disk is full.
            let each = hairmesh::output::folder_bytes(&out.join(&name));
            let rest = u64::from(options.characters - 1)
                + u64::from(options.teapot_variants.min(options.teapots.max(1)));
            hairmesh::output::check_space(out, each * rest).map_err(hairmesh::HairMeshError::from)?;
        }
        let (x, z) = grid_position(i, columns, spacing);
        let x = x + uniform(&mut rng, -0.08, 0.08) as f32;
        let z = z + uniform(&mut rng, -0.08, 0.08) as f32;
        characters.push(serde_json::json!({
            "hair": name,
            // The head cap is centred at y = 1.6; characters stand at slightly different heights.
            "transform": {
                "translation": [x, uniform(&mut rng, -0.08, 0.08) as f32, z],
                "rotation_y_degrees": uniform(&mut rng, -40.0, 40.0) as f32
            },
            "color": color(&mut rng),
            "occluder": { "mesh": scalp_path.file_name().map(|f| f.to_string_lossy().into_owned()) },
        }));
        done += 1;
        progress(done, total, "head hair assets");
    }
    let heads_path = out.join("heads.json");
    let path = camera_path(0.5 * columns as f32 * spacing, rows as f32 * spacing, 1.6);
    let heads_scene = crowd_scene(options.size, &path, &characters);
    write_scene(&heads_path, &heads_scene)?;
    let heads_animated = if options.animated {
        let animated_path = out.join("heads_animated.json");
        write_scene(&animated_path, &animated_crowd(heads_scene, &mut rng))?;
        Some(animated_path)
    } else {
        None
    };

    // Teapots: a hairy teapot is 0.1 × the original (31.5 cm tall).
    let scale = 0.1;
    let teapot_mesh = hairmesh::teapot::teapot(4, TeapotParts::Whole);
    let teapot_path = out.join("teapot.gltf");
    hairmesh::procedural::write_gltf(&teapot_path, &teapot_mesh, "Utah teapot")
        .map_err(io_error(&teapot_path))?;
    let scalp = hairmesh::teapot::teapot(3, TeapotParts::Scalp);
    let variants = options.teapot_variants.clamp(1, options.teapots.max(1));
    for v in 0..variants {
        let extrude = ExtrudeParams {
            layers: 4,
            length: uniform(&mut rng, 0.5, 1.2),
            droop: uniform(&mut rng, 0.3, 1.0),
            ..ExtrudeParams::default()
        };
        let hair_mesh = HairMesh::extrude(&scalp, &extrude)?;
        let params = AssetParams {
            strands: StrandCount::Total(options.teapot_strands),
            sample_sets: 1,
            seed: rng.next_u64(),
            ..AssetParams::default()
        };
        let asset = HairAsset::build(&hair_mesh, &params, style(&mut rng, 2.0))?;
        write_asset(&out.join(format!("teapots/hair_{v}")), &asset, "hairkit crowd (Utah teapot)")?;
        done += 1;
        progress(done, total, "teapot hair assets");
    }
    let columns = (f64::from(options.teapots) * 2.0).sqrt().ceil().max(1.0) as u32;
    let rows = options.teapots.div_ceil(columns).max(1);
    let spacing = 0.75;
    let teapots: Vec<serde_json::Value> = (0..options.teapots)
        .map(|i| {
            let (x, z) = grid_position(i, columns, spacing);
            serde_json::json!({
                "hair": format!("teapots/hair_{}", i % variants),
                "transform": {
                    "translation": [x, 0.0, z],
                    "rotation_y_degrees": uniform(&mut rng, 0.0, 360.0) as f32,
                    "scale": scale
                },
                "color": color(&mut rng),
                "occluder": { "mesh": "teapot.gltf", "color": [0.6, 0.6, 0.62] },
            })
        })
        .collect();
    let teapots_path = out.join("teapots.json");
    let path = camera_path(0.5 * columns as f32 * spacing, rows as f32 * spacing, 0.2);
    write_scene(&teapots_path, &crowd_scene(options.size, &path, &teapots))?;
    Ok(CrowdScenes { heads: heads_path, teapots: teapots_path, heads_animated })
}

/// The heads crowd animated: 5 s at 24 fps, each head turning and nodding with its own period
/// and phase about its neck, its hair simulated (colliding with its head cap) in a wind of its
/// own direction and gusts.
fn animated_crowd(mut scene: serde_json::Value, rng: &mut SplitMix64) -> serde_json::Value {
    scene["animation"] = serde_json::json!({ "frames": 120, "fps": 24 });
    scene["effects"]["dynamics"] = true.into();
    if let Some(characters) = scene["characters"].as_array_mut() {
        for c in characters {
            let wind = uniform(rng, 0.0, std::f64::consts::TAU);
            c["motion"] = serde_json::json!({
                "pivot": [0.0, 1.45, 0.0],
                "turn": { "degrees": uniform(rng, 15.0, 45.0), "period": uniform(rng, 1.5, 3.0), "phase": rng.next_f64() },
                "nod": { "degrees": uniform(rng, 4.0, 12.0), "period": uniform(rng, 0.8, 1.6), "phase": rng.next_f64() }
            });
            c["dynamics"] = serde_json::json!({
                "collide_with_occluder": true,
                "seed": rng.next_u64() >> 11,
                "wind": {
                    "velocity": [wind.cos() * uniform(rng, 0.3, 1.2), 0.0, wind.sin() * uniform(rng, 0.3, 1.2)],
                    "turbulence": uniform(rng, 0.3, 0.8)
                }
            });
        }
    }
    scene
}
