//! A hair asset: the five textures plus what generation needs besides them (bundle table,
//! root sample sets, style), and the hair mesh they were baked from. Built from a
//! [`HairMesh`]; stored by [`crate::asset_io`].
//!
//! **Editing.** An asset keeps its hair mesh, so it can be reopened and edited:
//! [`HairAsset::move_vertices`] moves hair-mesh vertices and re-bakes only the texels they
//! reach, keeping the texture layout, the root uvs and the normalization of the rest pose (so
//! untouched texels keep their values bit for bit) and each bundle's strand count. It returns
//! an [`AssetChange`] naming the texels and bundles rewritten, which is what a GPU copy
//! uploads again (`gen_gpu::GpuHair::update`), and bumps [`HairAsset::revision`], which keys
//! every cache derived from the asset (shadow maps, volumes).
//!
//! ```
//! use glam::DVec3;
//! use hairmesh::asset::{AssetParams, HairAsset, VertexMove};
//! use hairmesh::hair_mesh::{ExtrudeParams, HairMesh};
//! # fn main() -> hairmesh::Result<()> {
//! let scalp = hairmesh::procedural::head_cap(2, 8);
//! let hm = HairMesh::extrude(&scalp, &ExtrudeParams { layers: 3, length: 0.2, ..Default::default() })?;
//! let mut asset = HairAsset::build(&hm, &AssetParams::default(), Default::default())?;
//! // Pull the tip of vertex 5 sideways.
//! let tip = asset.mesh().layers[3][5];
//! let change = asset.move_vertices(&[VertexMove { layer: 3, vertex: 5, position: tip + DVec3::X * 0.05 }])?;
//! assert_eq!(asset.revision(), 1);
//! assert!(!change.texels.is_empty() && change.texels.len() < asset.textures.layout.slice_texels() as usize);
//! # Ok(()) }
//! ```

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use crate::curve::column_segments;
use crate::hair_mesh::{BundleFace, HairMesh};
use crate::roots::{
    EliminationParams, SampleDomain, permute_triangle_sample, prefix_quality, progressive_samples,
    triangle_to_square,
};
use crate::style::Style;
use crate::style::pcg_hash;
use crate::texture::{HairTextures, SliceLayout, block_vertices, root_uvs, texel_vertices};
use crate::{HairMeshError, Result};

/// How many strands each bundle gets.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StrandCount {
    /// Strands per unit of root-face area (object units²).
    Density(f64),
    /// A total, shared by area.
    Total(u64),
}

impl std::fmt::Display for StrandCount {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Density(d) => write!(f, "a density of {d} strands per unit²"),
            Self::Total(n) => write!(f, "{n} strands"),
        }
    }
}

/// Most strands one bundle may hold (the length of every sample set).
pub const MAX_STRANDS_PER_BUNDLE: u32 = 16_384;
/// Most strands an asset may hold.
pub const MAX_TOTAL_STRANDS: u64 = 50_000_000;

/// Build settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AssetParams {
    pub strands: StrandCount,
    /// Sample sets per domain; bundle `b` uses set `b mod sets`, under a symmetry of its domain
    /// chosen per bundle ([`HairAsset::root_symmetry`]), so one set already gives neighbours 8
    /// (squares) or 6 (triangles) different patterns. Each set costs 4 bytes per strand of the
    /// largest bundle on the GPU.
    pub sample_sets: u32,
    pub seed: u64,
    /// How bundles are laid out in the textures' slices.
    #[serde(default)]
    pub layout: SliceLayout,
}

impl Default for AssetParams {
    fn default() -> Self {
        Self { strands: StrandCount::Total(10_000), sample_sets: 1, seed: 1, layout: SliceLayout::Lattice }
    }
}

/// Per-bundle facts the generator needs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BundleInfo {
    pub domain: SampleDomain,
    /// `N_i`, the full strand count.
    pub strands: u32,
    /// Root-face area.
    pub area: f64,
    /// Axis-aligned bounds of the bundle's curves (the Bézier hull), object space.
    pub bounds_min: DVec3,
    pub bounds_max: DVec3,
    /// Longest vertex column (object length), the `h` of vertex LOD.
    pub length: f64,
}

impl BundleInfo {
    /// The `h` of strand LOD: the root face's size.
    pub fn face_size(&self) -> f64 {
        self.area.max(0.0).sqrt()
    }

    pub fn centre(&self) -> DVec3 {
        0.5 * (self.bounds_min + self.bounds_max)
    }
}

/// A progressive blue-noise sample set and its quality figures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SampleSet {
    pub domain: SampleDomain,
    pub seed: u64,
    pub points: Vec<DVec2>,
    /// Normalized minimum distance of power-of-two prefixes.
    pub quality: Vec<(usize, f64)>,
}

/// How the layers of a hair mesh were made.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LayerSource {
    /// Extruded along smoothed vertex normals ([`HairMesh::extrude`]).
    Extruded(crate::hair_mesh::ExtrudeParams),
    /// Laid over the head ([`HairMesh::drape`]).
    Draped(crate::hair_mesh::DrapeParams),
    /// One morph target of the scalp file per layer ([`HairMesh::from_morph_targets`]).
    MorphTargets,
}

/// Where an asset's hair mesh came from: enough to convert it again.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScalpProvenance {
    /// The scalp file as the converter was given it.
    pub file: String,
    /// The face selector (`all`, `name:…`, `above:…`, `sphere:…`).
    pub selector: String,
    pub layers: LayerSource,
}

impl ScalpProvenance {
    /// The scalp file on this machine: a file of the data set wherever it is (recorded as
    /// `data:NAME`, [`data_set::portable_name`]), else as recorded or relative to the asset
    /// folder `asset_dir` (an asset moved with its head keeps finding it).
    pub fn locate(&self, asset_dir: &std::path::Path) -> Option<std::path::PathBuf> {
        if self.file.starts_with(data_set::NAME_PREFIX) {
            return data_set::resolve_name(&self.file).ok().filter(|f| f.is_file());
        }
        let file = std::path::PathBuf::from(&self.file);
        [file.clone(), asset_dir.join(&file)].into_iter().find(|f| f.is_file())
    }
}

/// One hair-mesh vertex moved to a new position (object space).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct VertexMove {
    /// 0 = the root layer (the scalp), up to `L`.
    pub layer: u32,
    pub vertex: u32,
    pub position: DVec3,
}

impl VertexMove {
    /// Every vertex above the root layer moved to `positions`, the whole hair mesh layer-major
    /// with `per_layer` vertices per layer (what a simulation step yields; the roots stay on
    /// the scalp).
    pub fn above_roots(positions: &[glam::Vec3], per_layer: usize) -> Vec<VertexMove> {
        let per_layer = per_layer.max(1);
        positions
            .iter()
            .enumerate()
            .skip(per_layer)
            .map(|(i, p)| VertexMove {
                layer: (i / per_layer) as u32,
                vertex: (i % per_layer) as u32,
                position: p.as_dvec3(),
            })
            .collect()
    }
}

/// What an edit rewrote: the GPU copy uploads these again.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct AssetChange {
    /// Texels of the 2D slice (row-major indices, ascending) rewritten in every slice of the
    /// hair-mesh, w, u and v textures (and uv, whose values stay).
    pub texels: Vec<u32>,
    /// Bundles whose table entry (bounds, area, length) changed, ascending.
    pub bundles: Vec<u32>,
    /// The asset's revision before the edit(s) this change covers.
    pub since: u64,
    /// The asset's revision after them.
    pub revision: u64,
}

impl AssetChange {
    /// One change covering `self` and then `next` (e.g. several drags of an editor frame
    /// uploaded at once). `next` must start where `self` ends.
    pub fn then(mut self, next: &AssetChange) -> Result<AssetChange> {
        if next.since != self.revision {
            return Err(HairMeshError::InvalidParameter {
                what: "asset change",
                message: format!(
                    "revisions {}..{} cannot follow {}..{}",
                    next.since, next.revision, self.since, self.revision
                ),
            });
        }
        for (into, from) in [(&mut self.texels, &next.texels), (&mut self.bundles, &next.bundles)] {
            into.extend_from_slice(from);
            into.sort_unstable();
            into.dedup();
        }
        self.revision = next.revision;
        Ok(self)
    }
}

/// Everything needed to generate the hair.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HairAsset {
    pub textures: HairTextures,
    /// Curve evaluation of the reference generator (quadratics unless measuring accuracy).
    #[serde(default)]
    pub curve: crate::texture::CurveEvaluation,
    pub bundles: Vec<BundleInfo>,
    pub square_sets: Vec<SampleSet>,
    pub triangle_sets: Vec<SampleSet>,
    pub style: Style,
    /// The hair mesh the textures were baked from (its root uvs filled in), as edited.
    pub(crate) mesh: HairMesh,
    /// Where the hair mesh came from, when it came from a scalp file.
    #[serde(default)]
    pub provenance: Option<ScalpProvenance>,
    /// The head strands are kept out of ([`crate::head_field`]), when the asset was made
    /// with a head: every generator pushes strand vertices out of it. Shared: an edit clones
    /// the asset (the editor's preview may hold the last one), never the field.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub head_field: Option<std::sync::Arc<crate::head_field::HeadField>>,
    /// Edits since the asset was built or loaded ([`Self::move_vertices`]).
    #[serde(skip)]
    pub(crate) revision: u64,
}

/// The bundle-table entry of face `b`: its root area, the bounds of its curves up to its tip
/// layer (widened by the styling `margin`) and its longest vertex column up to that layer.
fn bundle_info(hm: &HairMesh, b: usize, strands: u32, margin: f64) -> BundleInfo {
    let face = &hm.faces[b];
    let tip = hm.tip_layer(b) as usize;
    let root = &hm.layers[0];
    let v = block_vertices(face).map(|i| root[i as usize]);
    let area = 0.5 * ((v[1] - v[0]).cross(v[2] - v[0]).length() + (v[2] - v[0]).cross(v[3] - v[0]).length());
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    let mut length: f64 = 0.0;
    for &v in face.vertices() {
        let column = hm.column(v);
        length =
            length.max(column[..=tip.min(column.len() - 1)].windows(2).map(|p| p[0].distance(p[1])).sum());
        // The segments are those of the whole column: a short bundle's last segment still
        // bends toward the layer after its tip, as the generator's curve does.
        for p in column_segments(&column).iter().take(tip).flat_map(|s| s.0) {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        lo = lo.min(column[0]);
        hi = hi.max(column[0]);
    }
    BundleInfo {
        domain: match face {
            BundleFace::Quad(_) => SampleDomain::Square,
            BundleFace::Triangle(_) => SampleDomain::Triangle,
        },
        strands,
        area,
        bounds_min: lo - DVec3::splat(margin),
        bounds_max: hi + DVec3::splat(margin),
        length,
    }
}

impl HairAsset {
    pub fn build(hm: &HairMesh, params: &AssetParams, style: Style) -> Result<Self> {
        let bad = |message: String| HairMeshError::InvalidParameter { what: "asset parameters", message };
        if hm.faces.is_empty() {
            return Err(bad("the hair mesh has no bundles".into()));
        }
        if params.sample_sets == 0 || params.sample_sets > 64 {
            return Err(bad(format!("{} sample sets (expected 1..=64)", params.sample_sets)));
        }
        style.validate().map_err(|e| HairMeshError::InvalidParameter { what: "style", message: e })?;
        hm.check_tip_layers().map_err(|e| bad(format!("the hair mesh's tip layers: {e}")))?;
        if !hm.layers.iter().flatten().all(|p| p.is_finite()) {
            return Err(bad(
                "the hair mesh has positions out of floating-point range (is the length or droop far too large?)"
                    .into(),
            ));
        }
        // The root uvs are part of the rest pose: an edit that moves the scalp keeps them.
        let mut mesh = hm.clone();
        mesh.uvs = Some(root_uvs(hm));
        let hm = &mesh;
        let textures = HairTextures::build(hm, params.layout);
        let margin = style.max_displacement();
        let areas: Vec<f64> = (0..hm.faces.len()).map(|b| bundle_info(hm, b, 1, margin).area).collect();
        let total_area: f64 = areas.iter().sum();
        if !(total_area > 0.0 && total_area.is_finite()) {
            return Err(bad(format!(
                "the hair mesh's {} root faces have no area (every face is degenerate): there is nowhere to put roots",
                hm.faces.len()
            )));
        }
        let counts: Vec<u32> = match params.strands {
            StrandCount::Density(d) if d.is_finite() && d > 0.0 => {
                let total = d * total_area;
                if total > MAX_TOTAL_STRANDS as f64 {
                    return Err(bad(format!(
                        "density {d} gives {total:.0} strands, over {MAX_TOTAL_STRANDS}"
                    )));
                }
                areas
                    .iter()
                    .map(|a| (d * a).round().clamp(1.0, f64::from(MAX_STRANDS_PER_BUNDLE)) as u32)
                    .collect()
            }
            StrandCount::Total(n) if n > 0 && n <= MAX_TOTAL_STRANDS => {
                let per_area = if total_area > 0.0 { n as f64 / total_area } else { 0.0 };
                areas
                    .iter()
                    .map(|a| {
                        let share =
                            if total_area > 0.0 { per_area * a } else { n as f64 / areas.len() as f64 };
                        share.round().clamp(1.0, f64::from(MAX_STRANDS_PER_BUNDLE)) as u32
                    })
                    .collect()
            }
            other => {
                return Err(bad(format!(
                    "{other} (expected a positive density or 1..={MAX_TOTAL_STRANDS} strands)"
                )));
            }
        };
        let longest = counts.iter().copied().max().unwrap_or(1);
        let bundles = counts.iter().enumerate().map(|(b, &n)| bundle_info(hm, b, n, margin)).collect();
        let sets = |domain: SampleDomain, salt: u64| -> Vec<SampleSet> {
            (0..params.sample_sets)
                .map(|k| {
                    let seed = params.seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ (salt + u64::from(k));
                    let points =
                        progressive_samples(longest as usize, domain, seed, &EliminationParams::default());
                    let quality = prefix_quality(&points, domain);
                    SampleSet { domain, seed, points, quality }
                })
                .collect()
        };
        let has = |d: SampleDomain| {
            hm.faces.iter().any(|f| {
                matches!(
                    (f, d),
                    (BundleFace::Quad(_), SampleDomain::Square)
                        | (BundleFace::Triangle(_), SampleDomain::Triangle)
                )
            })
        };
        Ok(Self {
            textures,
            curve: crate::texture::CurveEvaluation::Quadratic,
            bundles,
            square_sets: if has(SampleDomain::Square) { sets(SampleDomain::Square, 0) } else { Vec::new() },
            triangle_sets: if has(SampleDomain::Triangle) {
                sets(SampleDomain::Triangle, 1 << 32)
            } else {
                Vec::new()
            },
            style,
            mesh,
            provenance: None,
            head_field: None,
            revision: 0,
        })
    }

    /// The hair mesh the textures were baked from (root uvs filled in).
    pub fn mesh(&self) -> &HairMesh {
        &self.mesh
    }

    /// Edits since the asset was built or loaded: a cache made from revision `r` of this asset
    /// is stale once the revision differs.
    pub fn revision(&self) -> u64 {
        self.revision
    }

    /// Replaces the style. The bundle bounds include the style's largest displacement, so
    /// every bundle entry is rewritten (the textures are not); the revision is bumped.
    pub fn set_style(&mut self, style: Style) -> AssetChange {
        self.style = style;
        let margin = style.max_displacement();
        for b in 0..self.mesh.faces.len() {
            self.bundles[b] = bundle_info(&self.mesh, b, self.bundles[b].strands, margin);
        }
        let since = self.revision;
        self.revision += 1;
        AssetChange {
            texels: Vec::new(),
            bundles: (0..self.bundles.len() as u32).collect(),
            since,
            revision: self.revision,
        }
    }

    /// Moves hair-mesh vertices and re-bakes what they reach (module docs): all moves are
    /// checked before any is applied, so an error leaves the asset as it was.
    pub fn move_vertices(&mut self, moves: &[VertexMove]) -> Result<AssetChange> {
        let (layers, vertices) = (self.mesh.layers.len(), self.mesh.vertex_count());
        let bad = |message: String| HairMeshError::InvalidParameter { what: "vertex move", message };
        for (i, m) in moves.iter().enumerate() {
            if m.layer as usize >= layers || m.vertex as usize >= vertices {
                return Err(bad(format!(
                    "moves[{i}]: layer {} vertex {} does not exist ({layers} layers of {vertices} vertices)",
                    m.layer, m.vertex
                )));
            }
            if !m.position.is_finite() {
                return Err(bad(format!("moves[{i}]: position {} is not finite", m.position)));
            }
        }
        let texels = texel_vertices(&self.textures.layout, &self.mesh.faces)
            .map_err(|message| bad(format!("the asset's layout does not fit its mesh: {message}")))?;
        let mut moved = vec![false; vertices];
        for m in moves {
            self.mesh.layers[m.layer as usize][m.vertex as usize] = m.position;
            moved[m.vertex as usize] = true;
        }
        let texels = self.textures.rebake(&self.mesh, &texels, &moved);
        let margin = self.style.max_displacement();
        let mut bundles = Vec::new();
        for (b, face) in self.mesh.faces.iter().enumerate() {
            if face.vertices().iter().any(|&v| moved[v as usize]) {
                self.bundles[b] = bundle_info(&self.mesh, b, self.bundles[b].strands, margin);
                bundles.push(b as u32);
            }
        }
        let since = self.revision;
        self.revision += 1;
        Ok(AssetChange { texels, bundles, since, revision: self.revision })
    }

    /// The layer bundle `b`'s strands end at (1..=L; [`HairMesh::tip_layers`]).
    pub fn tip_layer(&self, bundle: u32) -> u32 {
        self.mesh.tip_layer(bundle as usize)
    }

    /// The fraction of the hair mesh's curve parameter bundle `b`'s strands cover: its tip
    /// layer over L (1 for a bundle that reaches the last layer). Every generator scales a
    /// strand's curve parameter by it, with the style's length variation.
    pub fn reach(&self, bundle: u32) -> f64 {
        f64::from(self.tip_layer(bundle)) / f64::from(self.mesh.layer_count().max(1) as u32)
    }

    /// Ends the strands of `bundles` at `layer` (clamped to 1..=L): a shorter or longer bundle
    /// of the same hair mesh ([`Self::set_tip_layers`]).
    pub fn set_tip_layer(&mut self, bundles: &[u32], layer: u32) -> Result<AssetChange> {
        let tips: Vec<(u32, u32)> = bundles.iter().map(|&b| (b, layer)).collect();
        self.set_tip_layers(&tips)
    }

    /// Ends each bundle of `tips` (`(bundle, layer)`) at its layer (clamped to 1..=L). Rewrites
    /// those bundles' table entries (bounds, length), one change; the textures stay. An unknown
    /// bundle is refused before anything changes.
    pub fn set_tip_layers(&mut self, tips: &[(u32, u32)]) -> Result<AssetChange> {
        if let Some(&(b, _)) = tips.iter().find(|(b, _)| *b as usize >= self.bundles.len()) {
            return Err(HairMeshError::InvalidParameter {
                what: "tip layer",
                message: format!("bundle {b} does not exist ({} bundles)", self.bundles.len()),
            });
        }
        let last = (self.mesh.layer_count() as u32).max(1);
        let mut all = self.mesh.tips();
        for &(b, layer) in tips {
            all[b as usize] = layer.clamp(1, last);
        }
        self.mesh.set_tips(all);
        let margin = self.style.max_displacement();
        let mut changed: Vec<u32> = tips.iter().map(|&(b, _)| b).collect();
        changed.sort_unstable();
        changed.dedup();
        for &b in &changed {
            self.bundles[b as usize] =
                bundle_info(&self.mesh, b as usize, self.bundles[b as usize].strands, margin);
        }
        let since = self.revision;
        self.revision += 1;
        Ok(AssetChange { texels: Vec::new(), bundles: changed, since, revision: self.revision })
    }

    /// This asset with its hair mesh replaced by `mesh` — the same faces and vertices, any
    /// number of layers ([`crate::layer_ops`]) — its textures baked again on the same slice
    /// layout and its bundle entries measured again; strands per bundle, root sample sets,
    /// style, provenance and head field stay. A new asset (its revision starts over): the GPU
    /// copy is uploaded whole.
    pub fn with_layers(&self, mut mesh: HairMesh) -> Result<HairAsset> {
        let bad = |message: String| HairMeshError::InvalidParameter { what: "layer edit", message };
        if mesh.faces != self.mesh.faces || mesh.vertex_count() != self.mesh.vertex_count() {
            return Err(bad("the faces or vertices differ from the asset's hair mesh".into()));
        }
        let layers = mesh.layer_count();
        if layers == 0 || layers > crate::hair_mesh::MAX_LAYERS as usize {
            return Err(bad(format!("{layers} layers (expected 1..={})", crate::hair_mesh::MAX_LAYERS)));
        }
        if mesh.layers.iter().any(|l| l.len() != mesh.vertex_count())
            || !mesh.layers.iter().flatten().all(|p| p.is_finite())
        {
            return Err(bad(
                "a layer has the wrong number of vertices or a position that is not finite".into()
            ));
        }
        mesh.check_tip_layers().map_err(|e| bad(format!("tip layers: {e}")))?;
        mesh.uvs = self.mesh.uvs.clone();
        let textures = self.textures.rebuilt_with(&mesh).map_err(bad)?;
        let margin = self.style.max_displacement();
        let bundles =
            (0..mesh.faces.len()).map(|b| bundle_info(&mesh, b, self.bundles[b].strands, margin)).collect();
        Ok(HairAsset {
            textures,
            curve: self.curve,
            bundles,
            square_sets: self.square_sets.clone(),
            triangle_sets: self.triangle_sets.clone(),
            style: self.style,
            mesh,
            provenance: self.provenance.clone(),
            head_field: self.head_field.clone(),
            revision: 0,
        })
    }

    /// Union of the bundles' bounds (object space, with the styling margin).
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.bundles.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), b| {
            (lo.min(b.bounds_min), hi.max(b.bounds_max))
        })
    }

    pub fn total_strands(&self) -> u64 {
        self.bundles.iter().map(|b| u64::from(b.strands)).sum()
    }

    /// The sample set bundle `b` draws its roots from.
    pub fn sample_set(&self, bundle: u32) -> &SampleSet {
        let info = &self.bundles[bundle as usize];
        let sets = match info.domain {
            SampleDomain::Square => &self.square_sets,
            SampleDomain::Triangle => &self.triangle_sets,
        };
        &sets[bundle as usize % sets.len()]
    }

    /// The symmetry of its domain under which bundle `b` reads its sample set: a
    /// [`crate::lattice::SquareSymmetry`] code (0..8) for squares, a
    /// [`crate::roots::TRIANGLE_PERMUTATIONS`] index (0..6) for triangles. A hash of the bundle
    /// index, so neighbours sharing a set still get different root patterns.
    pub fn root_symmetry(&self, bundle: u32) -> u8 {
        let h = pcg_hash(bundle ^ 0x68e3_1da4);
        match self.bundles[bundle as usize].domain {
            SampleDomain::Square => (h % 8) as u8,
            SampleDomain::Triangle => (h % 6) as u8,
        }
    }

    /// Block parameter `(s, t)` of strand `j` of bundle `b`.
    pub fn root_parameter(&self, bundle: u32, strand: u32) -> DVec2 {
        let set = self.sample_set(bundle);
        let p = crate::roots::quantize_sample(set.points[strand as usize % set.points.len()]);
        let symmetry = self.root_symmetry(bundle);
        match self.bundles[bundle as usize].domain {
            SampleDomain::Square => {
                crate::lattice::SquareSymmetry::new(symmetry).unwrap_or_default().apply(p)
            }
            SampleDomain::Triangle => triangle_to_square(permute_triangle_sample(p, symmetry)),
        }
    }

    /// Block parameter of the bundle's centre curve: `(½, ½)` for quads, the centroid
    /// `(ξ1, ξ2) = (⅓, ⅓)` → `(½, ⅓)` for triangles.
    pub fn centre_parameter(&self, bundle: u32) -> DVec2 {
        match self.bundles[bundle as usize].domain {
            SampleDomain::Square => DVec2::new(0.5, 0.5),
            SampleDomain::Triangle => DVec2::new(0.5, 1.0 / 3.0),
        }
    }
}
