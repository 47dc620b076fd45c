//! The five textures of a hair asset and how they are addressed (paper Table 1).
//!
//! **Layout.** Every bundle (root face) owns a *cell* of 2×2 texels in every 2D slice
//! ([`crate::lattice`]): by default the shared-vertex lattice, where neighbouring faces of a quad
//! grid share the texels of their common vertices (about one texel per vertex), or one separate
//! 2×2 block per face ([`SliceLayout::Blocks`], the paper's layout, four texels per face). A cell
//! records where the face's corners sit: a fetch at texel coordinate `cell + ½ + O(s, t)` (`O` the
//! cell's [`SquareSymmetry`], `s, t ∈ [0, 1]`) is exactly the bilinear patch of a quad, and for a
//! triangle (`[a, b, c, c]`, its last corner repeated) with `s = ξ1 / (1 − ξ2)`, `t = ξ2` it is
//! barycentric interpolation.
//!
//! **Hair-mesh texture** (3D, xyz): `1 + 3L` slices, position of each vertex column. Slice 0 is
//! the root layer; segment `i` (layer `i` to `i+1`) adds slices `3i+1 = q_a`, `3i+2 = q_b`,
//! `3i+3 = layer i+1` (see [`crate::curve`]). The paper also stores the quadratics' shared point
//! `m = (q_a + q_b)/2`; it is not needed: on the first quadratic `(B0, q_a, m)` the point
//! `lerp(q_a, m, q)` is `lerp(q_a, q_b, q/2)`, on the second `(m, q_b, B3)` `lerp(m, q_b, q)` is
//! `lerp(q_a, q_b, (1+q)/2)`, each still one trilinear fetch, so a point costs two fetches and a
//! lerp as before and the texture is a quarter smaller. Positions are stored normalized,
//! `(p − origin) / scale` with the asset's bounds `origin` (min corner) and `scale` (largest
//! extent), so f16 storage keeps ~1/2048 of the hair's size as precision everywhere.
//!
//! **uv** (2D, xy): root styling coordinate per vertex. **w** (3D, x): `L+1` slices, path length
//! along the vertex column from the root, in object units. **u, v** (3D, xyz): `L+1` slices,
//! unit styling directions per layer ([`styling_frames`]).

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use crate::curve::column_segments;
use crate::hair_mesh::{BundleFace, HairMesh};
pub use crate::lattice::{Cell, Lattice, SquareSymmetry};

/// How strand points are evaluated between layers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CurveEvaluation {
    /// Two quadratics per segment (two trilinear fetches and a lerp): the real-time path.
    #[default]
    Quadratic,
    /// The exact cubic Bézier, for measuring what the quadratics cost.
    Cubic,
}

/// How bundles are laid out in the 2D slices.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SliceLayout {
    /// Charts of faces sharing their common vertices' texels ([`Lattice::build`]).
    #[default]
    Lattice,
    /// One 2×2 block per face (the paper's layout; 4 texels per face).
    Blocks,
}

/// Where each bundle's cell is; shared by all five textures.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TextureLayout {
    pub bundles: u32,
    /// Texels.
    pub width: u32,
    pub height: u32,
    /// Hair-mesh layers above the root (`L`).
    pub layers: u32,
    /// One per bundle, `[x, y, orientation]`.
    pub cells: Vec<Cell>,
}

impl TextureLayout {
    pub fn new(lattice: &Lattice, layers: u32) -> Self {
        Self {
            bundles: lattice.cells.len() as u32,
            width: lattice.width,
            height: lattice.height,
            layers,
            cells: lattice.cells.clone(),
        }
    }

    /// Slices of the hair-mesh texture: `1 + 3L`.
    pub fn curve_slices(&self) -> u32 {
        1 + 3 * self.layers
    }

    /// Slices of the w, u and v textures: `L + 1`.
    pub fn layer_slices(&self) -> u32 {
        self.layers + 1
    }

    /// Texel holding face corner `k` (0..4) of `bundle`.
    pub fn corner_texel(&self, bundle: u32, k: usize) -> (u32, u32) {
        self.cells[bundle as usize].corner_texel(k)
    }

    /// Continuous texel coordinate (texel centres at +½) of block parameter `(s, t)`.
    pub fn block_coord(&self, bundle: u32, s: f64, t: f64) -> DVec2 {
        self.cells[bundle as usize].coord(DVec2::new(s, t))
    }

    /// Texels of one 2D slice.
    pub fn slice_texels(&self) -> u64 {
        u64::from(self.width) * u64::from(self.height)
    }
}

/// A 3D array of texels with `channels` f64 values each (2D textures have depth 1). The f64
/// master copy: files and GPU uploads convert it to f32 or f16.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Texture3 {
    pub width: u32,
    pub height: u32,
    pub depth: u32,
    pub channels: u32,
    pub data: Vec<f64>,
}

impl Texture3 {
    pub fn new(width: u32, height: u32, depth: u32, channels: u32) -> Self {
        let len = width as usize * height as usize * depth as usize * channels as usize;
        Self { width, height, depth, channels, data: vec![0.0; len] }
    }

    fn index(&self, x: u32, y: u32, z: u32) -> usize {
        ((z as usize * self.height as usize + y as usize) * self.width as usize + x as usize)
            * self.channels as usize
    }

    pub fn texel(&self, x: u32, y: u32, z: u32) -> &[f64] {
        let i = self.index(x, y, z);
        &self.data[i..i + self.channels as usize]
    }

    pub fn set(&mut self, x: u32, y: u32, z: u32, value: &[f64]) {
        let i = self.index(x, y, z);
        let n = self.channels as usize;
        self.data[i..i + n].copy_from_slice(&value[..n]);
    }

    /// Trilinear filtering with clamp-to-edge at continuous texel coordinates (texel centres
    /// at +½), as a GPU sampler with `LINEAR` filters and unnormalized coordinates computes it
    /// (in f64 here, without the hardware's few sub-texel weight bits).
    pub fn sample(&self, coord: DVec3, out: &mut [f64]) {
        let axis = |c: f64, size: u32| -> (u32, u32, f64) {
            let f = (c - 0.5).clamp(0.0, f64::from(size - 1));
            let i0 = f.floor() as u32;
            let i1 = (i0 + 1).min(size - 1);
            (i0, i1, f - f64::from(i0))
        };
        let (x0, x1, fx) = axis(coord.x, self.width);
        let (y0, y1, fy) = axis(coord.y, self.height);
        let (z0, z1, fz) = axis(coord.z, self.depth);
        let n = self.channels as usize;
        out[..n].fill(0.0);
        for (z, wz) in [(z0, 1.0 - fz), (z1, fz)] {
            for (y, wy) in [(y0, 1.0 - fy), (y1, fy)] {
                for (x, wx) in [(x0, 1.0 - fx), (x1, fx)] {
                    let w = wx * wy * wz;
                    if w != 0.0 {
                        for (o, v) in out[..n].iter_mut().zip(self.texel(x, y, z)) {
                            *o += w * v;
                        }
                    }
                }
            }
        }
    }

    pub fn bytes_f32(&self) -> usize {
        self.data.len() * 4
    }
}

/// The asset's position normalization: stored = `(p − origin) / scale`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Normalization {
    pub origin: DVec3,
    pub scale: f64,
}

impl Normalization {
    /// The normalization of a hair mesh's bounds over all layers.
    pub fn of_mesh(hm: &HairMesh) -> Self {
        let (min, max) = hm
            .layers
            .iter()
            .flatten()
            .fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), p| {
                (lo.min(*p), hi.max(*p))
            });
        Self::from_bounds(min, max)
    }

    pub fn from_bounds(min: DVec3, max: DVec3) -> Self {
        let extent = (max - min).max_element();
        Self { origin: min, scale: if extent > 0.0 && extent.is_finite() { extent } else { 1.0 } }
    }

    pub fn to_stored(&self, p: DVec3) -> DVec3 {
        (p - self.origin) / self.scale
    }

    pub fn to_object(&self, q: DVec3) -> DVec3 {
        self.origin + q * self.scale
    }
}

/// The five textures with their layout and normalization.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HairTextures {
    pub layout: TextureLayout,
    pub normalization: Normalization,
    pub hair_mesh: Texture3,
    pub uv: Texture3,
    pub w: Texture3,
    pub u: Texture3,
    pub v: Texture3,
}

/// The four vertex indices a bundle's block holds (triangles repeat vertex 2).
pub fn block_vertices(face: &BundleFace) -> [u32; 4] {
    match *face {
        BundleFace::Quad(q) => q,
        BundleFace::Triangle([a, b, c]) => [a, b, c, c],
    }
}

/// Per-vertex root uv: the file's TEXCOORD_0, or the automatic layout: a planar projection of
/// the root layer along its area-weighted mean normal, scaled uniformly into `[0, 1]²`
/// (u along the projected direction of the largest spread, v perpendicular to it).
pub fn root_uvs(hm: &HairMesh) -> Vec<DVec2> {
    if let Some(uvs) = &hm.uvs
        && uvs.len() == hm.vertex_count()
        && uvs.iter().all(|u| u.is_finite())
    {
        return uvs.clone();
    }
    let root = &hm.layers[0];
    let mut normal = DVec3::ZERO;
    for face in &hm.faces {
        let v = block_vertices(face).map(|i| root[i as usize]);
        normal += (v[1] - v[0]).cross(v[2] - v[0]) + (v[2] - v[0]).cross(v[3] - v[0]);
    }
    let n = normal.try_normalize().unwrap_or(DVec3::Y);
    let (a, b) = n.any_orthonormal_pair();
    let projected: Vec<DVec2> = root.iter().map(|p| DVec2::new(p.dot(a), p.dot(b))).collect();
    let lo = projected.iter().fold(DVec2::splat(f64::INFINITY), |m, p| m.min(*p));
    let hi = projected.iter().fold(DVec2::splat(f64::NEG_INFINITY), |m, p| m.max(*p));
    let extent = (hi - lo).max_element();
    let scale = if extent > 0.0 && extent.is_finite() { 1.0 / extent } else { 1.0 };
    projected.iter().map(|p| (*p - lo) * scale).collect()
}

/// Unit styling directions `(û, v̂, ŵ)` for every layer and vertex (DESIGN.md, Eq. 1–3).
///
/// For each face corner at the vertex (the vertex `p0` and its two neighbours `p1`, `p2` in
/// that face): `T = [[u1−u0, u2−u0], [v1−v0, v2−v0]]`, `[u_i v_i] = [p1−p0, p2−p0]·T⁻¹`,
/// weighted by the texture-space area `A_i = |det T| / 2`; `û = Σ A_i u_i / |Σ A_i u_i|`, same
/// for `v̂`, `ŵ = û×v̂ / |û×v̂|`. Corners with `|det T|` below 1e-12 of the uv extent² (zero
/// uv area) are skipped; negative areas (mirrored uvs) count with their magnitude, their
/// `T⁻¹` already flips the directions. Fallback when nothing usable remains (all corners
/// degenerate, or `û ∥ v̂`): `ŵ` = the layer's vertex normal (or the column direction, or +Y),
/// `û` = the first face edge projected perpendicular to `ŵ` (or any perpendicular), `v̂ = ŵ×û`.
pub fn styling_frames(hm: &HairMesh, uvs: &[DVec2]) -> Vec<Vec<[DVec3; 3]>> {
    styling_frames_of(hm, uvs, None)
}

/// [`styling_frames`] for the vertices `only` marks (all when `None`); other entries are
/// unspecified. The sums run over the faces in the same order either way, so a marked vertex
/// gets bit for bit the frame of the full computation.
fn styling_frames_of(hm: &HairMesh, uvs: &[DVec2], only: Option<&[bool]>) -> Vec<Vec<[DVec3; 3]>> {
    let vcount = hm.vertex_count();
    let wanted = |v: u32| only.is_none_or(|m| m[v as usize]);
    let lo = uvs.iter().fold(DVec2::splat(f64::INFINITY), |m, p| m.min(*p));
    let hi = uvs.iter().fold(DVec2::splat(f64::NEG_INFINITY), |m, p| m.max(*p));
    let uv_extent = (hi - lo).max_element().max(1e-300);
    let min_det = 1e-12 * uv_extent * uv_extent;
    hm.layers
        .iter()
        .enumerate()
        .map(|(k, layer)| {
            let mut su = vec![DVec3::ZERO; vcount];
            let mut sv = vec![DVec3::ZERO; vcount];
            let mut normal = vec![DVec3::ZERO; vcount];
            let mut first_edge = vec![DVec3::ZERO; vcount];
            for face in &hm.faces {
                let verts = face.vertices();
                let n = verts.len();
                for c in 0..n {
                    let (i0, i1, i2) = (verts[c], verts[(c + 1) % n], verts[(c + n - 1) % n]);
                    if !wanted(i0) {
                        continue;
                    }
                    let (p0, p1, p2) = (layer[i0 as usize], layer[i1 as usize], layer[i2 as usize]);
                    let (e1, e2) = (p1 - p0, p2 - p0);
                    normal[i0 as usize] += e1.cross(e2);
                    if first_edge[i0 as usize] == DVec3::ZERO {
                        first_edge[i0 as usize] = e1;
                    }
                    let (t0, t1, t2) = (uvs[i0 as usize], uvs[i1 as usize], uvs[i2 as usize]);
                    let (a, b, c2, d) = (t1.x - t0.x, t2.x - t0.x, t1.y - t0.y, t2.y - t0.y);
                    let det = a * d - b * c2;
                    if det.abs() <= min_det || !det.is_finite() {
                        continue;
                    }
                    // [e1 e2] · T⁻¹ with T⁻¹ = [[d, −b], [−c, a]] / det.
                    let du = (e1 * d - e2 * c2) / det;
                    let dv = (e2 * a - e1 * b) / det;
                    let area = 0.5 * det.abs();
                    su[i0 as usize] += area * du;
                    sv[i0 as usize] += area * dv;
                }
            }
            (0..vcount)
                .map(|v| {
                    if !wanted(v as u32) {
                        return [DVec3::X, DVec3::Y, DVec3::Z];
                    }
                    let column_dir = if k + 1 < hm.layers.len() {
                        hm.layers[k + 1][v] - layer[v]
                    } else if k > 0 {
                        layer[v] - hm.layers[k - 1][v]
                    } else {
                        DVec3::ZERO
                    };
                    frame_or_fallback(su[v], sv[v], normal[v], column_dir, first_edge[v])
                })
                .collect()
        })
        .collect()
}

/// Smallest `|û×v̂|` (sine of the angle between û and v̂) kept; below it the uv mapping is
/// nearly singular there and ŵ = û×v̂ would amplify any rounding of û, v̂ (f16 textures, f32
/// math) into large turns of the styling frame, so the fallback frame is used instead.
pub const MIN_FRAME_SINE: f64 = 0.2;

fn frame_or_fallback(su: DVec3, sv: DVec3, normal: DVec3, column_dir: DVec3, edge: DVec3) -> [DVec3; 3] {
    if let (Some(u), Some(v)) = (su.try_normalize(), sv.try_normalize()) {
        let cross = u.cross(v);
        if cross.length() >= MIN_FRAME_SINE {
            return [u, v, cross.normalize()];
        }
    }
    let w = normal.try_normalize().or_else(|| column_dir.try_normalize()).unwrap_or(DVec3::Y);
    let u = (edge - w * edge.dot(w)).try_normalize().unwrap_or_else(|| w.any_orthonormal_vector());
    [u, w.cross(u), w]
}

/// The hair-mesh texture's slices for one vertex column: the root, then `q_a, q_b, end` of
/// each segment's two quadratics.
fn curve_slices(hm: &HairMesh, vertex: u32) -> Vec<DVec3> {
    let column = hm.column(vertex);
    let mut slices = vec![column[0]];
    for seg in column_segments(&column) {
        let q = seg.to_quadratics();
        slices.extend([q.q_a, q.q_b, q.end]);
    }
    slices
}

/// The vertex each texel of a slice holds (row-major, `None` where no cell reaches), from a
/// layout and the faces it was built for: the [`Lattice::texels`] of the conversion,
/// recovered from what an asset stores. An error names the first bundle whose corners do not
/// fit the layout (a cell outside the slice, or a texel claimed by two vertices).
pub fn texel_vertices(layout: &TextureLayout, faces: &[BundleFace]) -> Result<Vec<Option<u32>>, String> {
    if faces.len() != layout.cells.len() {
        return Err(format!("{} faces for {} cells", faces.len(), layout.cells.len()));
    }
    let mut texels = vec![None; layout.slice_texels() as usize];
    for (b, face) in faces.iter().enumerate() {
        for (k, &v) in block_vertices(face).iter().enumerate() {
            let (x, y) = layout.corner_texel(b as u32, k);
            if x >= layout.width || y >= layout.height {
                return Err(format!("bundle {b}: corner {k} at texel ({x}, {y}) is outside the slice"));
            }
            let slot = &mut texels[(y * layout.width + x) as usize];
            match *slot {
                Some(other) if other != v => {
                    return Err(format!("bundle {b}: texel ({x}, {y}) holds vertex {other} and vertex {v}"));
                }
                _ => *slot = Some(v),
            }
        }
    }
    Ok(texels)
}

impl HairTextures {
    /// Builds the five textures of a hair mesh: its slice layout, a normalization from its
    /// bounds, every texel baked.
    pub fn build(hm: &HairMesh, slice_layout: SliceLayout) -> Self {
        let layers = hm.layer_count() as u32;
        let corners: Vec<[u32; 4]> = hm.faces.iter().map(block_vertices).collect();
        let lattice = match slice_layout {
            SliceLayout::Lattice => Lattice::build(&corners),
            SliceLayout::Blocks => Lattice::blocks(&corners),
        };
        let layout = TextureLayout::new(&lattice, layers);
        let normalization = Normalization::of_mesh(hm);
        let mut textures = Self::empty(layout, normalization);
        textures.bake(hm, &lattice.texels, None);
        textures
    }

    /// The textures of `hm` — the faces and vertices these were baked from, any number of
    /// layers (one inserted, removed or extruded) — on this 2D slice layout, with a
    /// normalization from `hm`'s bounds.
    pub fn rebuilt_with(&self, hm: &HairMesh) -> Result<Self, String> {
        let texels = texel_vertices(&self.layout, &hm.faces)?;
        let layout = TextureLayout { layers: hm.layer_count() as u32, ..self.layout.clone() };
        let mut textures = Self::empty(layout, Normalization::of_mesh(hm));
        textures.bake(hm, &texels, None);
        Ok(textures)
    }

    /// All-zero textures of a layout.
    fn empty(layout: TextureLayout, normalization: Normalization) -> Self {
        let (w, h) = (layout.width, layout.height);
        Self {
            hair_mesh: Texture3::new(w, h, layout.curve_slices(), 3),
            uv: Texture3::new(w, h, 1, 2),
            w: Texture3::new(w, h, layout.layer_slices(), 1),
            u: Texture3::new(w, h, layout.layer_slices(), 3),
            v: Texture3::new(w, h, layout.layer_slices(), 3),
            layout,
            normalization,
        }
    }

    /// Re-bakes, after hair-mesh vertices moved, the texels of the vertices `moved` marks and
    /// of their face neighbours (whose styling frames read the moved positions), keeping the
    /// layout and the normalization: positions stay `(p − origin) / scale` with the rest
    /// pose's origin and scale, so texels that did not change keep their values bit for bit
    /// (a move past the rest bounds stores values outside `[0, 1]`). `texels` is
    /// [`texel_vertices`] of this layout. Returns the rewritten texels (indices into a slice,
    /// row-major, ascending).
    pub fn rebake(&mut self, hm: &HairMesh, texels: &[Option<u32>], moved: &[bool]) -> Vec<u32> {
        let mut affected = moved.to_vec();
        for face in &hm.faces {
            if face.vertices().iter().any(|&v| moved[v as usize]) {
                for &v in face.vertices() {
                    affected[v as usize] = true;
                }
            }
        }
        self.bake(hm, texels, Some(&affected))
    }

    /// Writes the texels whose vertex `only` marks (all when `None`); returns them.
    fn bake(&mut self, hm: &HairMesh, texels: &[Option<u32>], only: Option<&[bool]>) -> Vec<u32> {
        let wanted = |v: u32| only.is_none_or(|m| m[v as usize]);
        let uvs = root_uvs(hm);
        let w_values = hm.w();
        let frames = styling_frames_of(hm, &uvs, only);
        let width = self.layout.width;
        let mut written = Vec::new();
        for (i, vertex) in texels.iter().enumerate() {
            let Some(vertex) = *vertex else { continue };
            if !wanted(vertex) {
                continue;
            }
            let (x, y) = (i as u32 % width, i as u32 / width);
            let vi = vertex as usize;
            for (z, p) in curve_slices(hm, vertex).iter().enumerate() {
                self.hair_mesh.set(x, y, z as u32, &self.normalization.to_stored(*p).to_array());
            }
            self.uv.set(x, y, 0, &uvs[vi].to_array());
            for l in 0..self.layout.layer_slices() as usize {
                self.w.set(x, y, l as u32, &[w_values[l][vi]]);
                self.u.set(x, y, l as u32, &frames[l][vi][0].to_array());
                self.v.set(x, y, l as u32, &frames[l][vi][1].to_array());
            }
            written.push(i as u32);
        }
        written
    }

    /// Object-space position on the curve surface of `bundle` at block parameter `(s, t)` and
    /// strand parameter `tau ∈ [0, 1]` (root to tip): two trilinear fetches and one lerp per
    /// quadratic, as the GPU does.
    pub fn curve_position(&self, bundle: u32, s: f64, t: f64, tau: f64) -> DVec3 {
        let xy = self.layout.block_coord(bundle, s, t);
        let layers = f64::from(self.layout.layers.max(1));
        let x = (tau.clamp(0.0, 1.0) * layers).min(layers);
        let segment = x.floor().min(layers - 1.0);
        let local = x - segment;
        // Slices from z = 3·segment: B0, q_a, q_b, B3 (module docs: m is implicit).
        let z = 3.0 * segment + 0.5;
        let (za, zb, q) = if local < 0.5 {
            let q = 2.0 * local;
            (z + q, z + 1.0 + 0.5 * q, q)
        } else {
            let q = 2.0 * local - 1.0;
            (z + 1.0 + 0.5 * (1.0 + q), z + 2.0 + q, q)
        };
        let mut a = [0.0; 3];
        let mut b = [0.0; 3];
        self.hair_mesh.sample(DVec3::new(xy.x, xy.y, za), &mut a);
        self.hair_mesh.sample(DVec3::new(xy.x, xy.y, zb), &mut b);
        let stored = DVec3::from_array(a).lerp(DVec3::from_array(b), q);
        self.normalization.to_object(stored)
    }

    /// [`Self::curve_position`] with the exact cubic instead of the two quadratics: the cubic's
    /// control points are recovered from the same slices, `B1 = B0 + 4/3 (q_a − B0)`,
    /// `B2 = B3 + 4/3 (q_b − B3)` (four bilinear fetches at whole slices). For the accuracy
    /// benchmark: what the quadratic approximation costs.
    pub fn curve_position_cubic(&self, bundle: u32, s: f64, t: f64, tau: f64) -> DVec3 {
        let xy = self.layout.block_coord(bundle, s, t);
        let layers = f64::from(self.layout.layers.max(1));
        let x = (tau.clamp(0.0, 1.0) * layers).min(layers);
        let segment = x.floor().min(layers - 1.0);
        let local = x - segment;
        let fetch = |slice: f64| {
            let mut out = [0.0; 3];
            self.hair_mesh.sample(DVec3::new(xy.x, xy.y, slice + 0.5), &mut out);
            DVec3::from_array(out)
        };
        let z = 3.0 * segment;
        let (b0, q_a, q_b, b3) = (fetch(z), fetch(z + 1.0), fetch(z + 2.0), fetch(z + 3.0));
        let b1 = b0 + (q_a - b0) * (4.0 / 3.0);
        let b2 = b3 + (q_b - b3) * (4.0 / 3.0);
        self.normalization.to_object(crate::curve::CubicBezier([b0, b1, b2, b3]).eval(local))
    }

    /// The curve point by the chosen evaluation.
    pub fn curve_point(&self, evaluation: CurveEvaluation, bundle: u32, s: f64, t: f64, tau: f64) -> DVec3 {
        match evaluation {
            CurveEvaluation::Quadratic => self.curve_position(bundle, s, t, tau),
            CurveEvaluation::Cubic => self.curve_position_cubic(bundle, s, t, tau),
        }
    }

    /// Texture memory in bytes at 4 bytes per channel (the hair-mesh texture padded to 4
    /// channels as RGBA32F).
    pub fn bytes_f32(&self) -> usize {
        self.hair_mesh.data.len() / 3 * 16
            + self.uv.bytes_f32()
            + self.w.bytes_f32()
            + self.u.data.len() / 3 * 16
            + self.v.data.len() / 3 * 16
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hair_mesh::ExtrudeParams;
    use crate::scalp::ScalpMesh;

    fn quad_and_triangle() -> HairMesh {
        let scalp = ScalpMesh {
            positions: vec![
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(1.0, 0.0, 0.0),
                DVec3::new(1.0, 0.0, -1.0),
                DVec3::new(0.0, 0.0, -1.0),
                DVec3::new(2.0, 0.0, -0.5),
            ],
            faces: vec![vec![0, 1, 2, 3], vec![1, 4, 2]],
            uvs: Some(vec![
                DVec2::new(0.0, 0.0),
                DVec2::new(0.5, 0.0),
                DVec2::new(0.5, 1.0),
                DVec2::new(0.0, 1.0),
                DVec2::new(1.0, 0.5),
            ]),
            ..Default::default()
        };
        HairMesh::extrude(
            &scalp,
            &ExtrudeParams { layers: 3, length: 1.5, droop: 0.4, gravity: DVec3::NEG_Y },
        )
        .expect("valid")
    }

    #[test]
    fn texel_vertices_recover_the_lattice_of_the_conversion() {
        let hm = quad_and_triangle();
        let corners: Vec<[u32; 4]> = hm.faces.iter().map(block_vertices).collect();
        for lattice in [Lattice::build(&corners), Lattice::blocks(&corners)] {
            let layout = TextureLayout::new(&lattice, hm.layer_count() as u32);
            assert_eq!(texel_vertices(&layout, &hm.faces), Ok(lattice.texels.clone()));
        }
        let layout = TextureLayout::new(&Lattice::build(&corners), 1);
        let mut faces = hm.faces.clone();
        faces[0] = BundleFace::Quad([9, 9, 9, 9]);
        let e = texel_vertices(&layout, &faces).expect_err("conflict");
        assert!(e.contains("holds vertex"), "{e}");
    }

    #[test]
    fn strands_start_on_the_root_face_and_end_at_the_tip_layer() {
        let hm = quad_and_triangle();
        let tex = HairTextures::build(&hm, SliceLayout::Lattice);
        let quad = tex.curve_position(0, 0.25, 0.5, 0.0);
        let expected = DVec3::new(0.25, 0.0, -0.5);
        assert!(quad.distance(expected) < 1e-12, "{quad}");
        // Triangle (1, 4, 2) at barycentric (ξ1, ξ2) = (0.2, 0.3): s = ξ1/(1−ξ2), t = ξ2.
        let (x1, x2) = (0.2, 0.3);
        let p = tex.curve_position(1, x1 / (1.0 - x2), x2, 0.0);
        let bary = hm.layers[0][1] * (1.0 - x1 - x2) + hm.layers[0][4] * x1 + hm.layers[0][2] * x2;
        assert!(p.distance(bary) < 1e-12, "{p} vs {bary}");
        // The tip is on the last layer.
        let tip = tex.curve_position(0, 0.0, 0.0, 1.0);
        assert!(tip.distance(hm.layers[3][0]) < 1e-12);
        // Layer k is hit exactly at tau = k/L.
        let mid = tex.curve_position(0, 1.0, 0.0, 2.0 / 3.0);
        assert!(mid.distance(hm.layers[2][1]) < 1e-12);
    }

    #[test]
    fn texture_curve_matches_the_quadratics() {
        let hm = quad_and_triangle();
        let tex = HairTextures::build(&hm, SliceLayout::Lattice);
        let column = hm.column(0);
        let segs = column_segments(&column);
        for i in 0..=60 {
            let tau = f64::from(i) / 60.0;
            let seg = ((tau * 3.0).floor() as usize).min(2);
            let local = tau * 3.0 - seg as f64;
            let expected = segs[seg].to_quadratics().eval(local);
            let got = tex.curve_position(0, 0.0, 0.0, tau);
            assert!(got.distance(expected) < 1e-12, "tau {tau}: {got} vs {expected}");
        }
    }

    #[test]
    fn cubic_evaluation_recovers_the_catmull_rom_segments() {
        let hm = quad_and_triangle();
        let tex = HairTextures::build(&hm, SliceLayout::Lattice);
        let segs = column_segments(&hm.column(0));
        for i in 0..=30 {
            let tau = f64::from(i) / 30.0;
            let seg = ((tau * 3.0).floor() as usize).min(2);
            let expected = segs[seg].eval(tau * 3.0 - seg as f64);
            assert!(tex.curve_position_cubic(0, 0.0, 0.0, tau).distance(expected) < 1e-12);
        }
    }

    #[test]
    fn frames_are_orthonormal_for_good_and_bad_uvs() {
        let mut hm = quad_and_triangle();
        let frames = styling_frames(&hm, &root_uvs(&hm));
        let [u, v, w] = frames[0][0];
        assert!(u.distance(DVec3::X) < 1e-9, "û follows +u: {u}");
        assert!(v.distance(DVec3::NEG_Z) < 1e-9, "v̂ follows +v: {v}");
        assert!(w.distance(DVec3::Y) < 1e-9, "ŵ = û×v̂ = X×(−Z) = +Y: {w}");
        // Zero-area and mirrored uvs: still unit frames everywhere.
        for uvs in [vec![DVec2::ZERO; 5], {
            let mut m = root_uvs(&hm);
            m[4] = DVec2::new(-1.0, 2.0);
            m
        }] {
            hm.uvs = Some(uvs.clone());
            for layer in styling_frames(&hm, &uvs) {
                for [u, v, w] in layer {
                    for d in [u, v, w] {
                        assert!((d.length() - 1.0).abs() < 1e-9, "{d}");
                    }
                    assert!(u.dot(w).abs() < 1e-9 && v.dot(w).abs() < 1e-9);
                }
            }
        }
    }

    #[test]
    fn automatic_uvs_fill_the_unit_square() {
        let mut hm = quad_and_triangle();
        hm.uvs = None;
        let uvs = root_uvs(&hm);
        assert!(
            uvs.iter()
                .all(|u| (-1e-12..=1.0 + 1e-12).contains(&u.x) && (-1e-12..=1.0 + 1e-12).contains(&u.y))
        );
        let max = uvs.iter().fold(0.0f64, |m, u| m.max(u.x).max(u.y));
        assert!((max - 1.0).abs() < 1e-12);
    }

    #[test]
    fn both_layouts_give_the_same_curves() {
        let hm = quad_and_triangle();
        let lattice = HairTextures::build(&hm, SliceLayout::Lattice);
        let blocks = HairTextures::build(&hm, SliceLayout::Blocks);
        assert!(lattice.layout.slice_texels() < blocks.layout.slice_texels());
        for bundle in 0..2 {
            for (s, t, tau) in [(0.1, 0.9, 0.3), (0.7, 0.2, 0.55), (1.0, 1.0, 1.0), (0.0, 0.5, 0.0)] {
                for eval in [CurveEvaluation::Quadratic, CurveEvaluation::Cubic] {
                    let a = lattice.curve_point(eval, bundle, s, t, tau);
                    let b = blocks.curve_point(eval, bundle, s, t, tau);
                    assert!(a.distance(b) < 1e-12, "bundle {bundle} ({s}, {t}, {tau}): {a} vs {b}");
                }
            }
        }
    }
}
