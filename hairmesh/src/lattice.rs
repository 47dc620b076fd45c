//! The shared-vertex lattice layout of the textures' 2D slices (paper §3.1).
//!
//! Every bundle (root face) owns one *cell*: the 2×2 texels `(x, y) … (x + 1, y + 1)`, so a
//! bilinear fetch inside the cell is the bilinear patch of the face. Faces that are neighbours
//! in a regular quad grid share the texels of their common vertices: a grid of `a × b` faces
//! costs `(a + 1)(b + 1)` texels per slice instead of the `4ab` of one 2×2 block per face, close
//! to one texel per vertex. The scalp is split into *charts*, rectangles of cells grown greedily
//! over edge-adjacent faces ("splitting the scalp mesh into multiple pieces", paper §3.1), which
//! are then shelf-packed into the slice.
//!
//! A face's corners may sit in its cell rotated or mirrored: each cell records the
//! [`SquareSymmetry`] that maps the face's block parameter `(s, t)` (corner 0 at `(0,0)`, 1 at
//! `(1,0)`, 2 at `(1,1)`, 3 at `(0,1)`) to the cell's. Bilinear interpolation commutes with the
//! symmetries of the square, so the fetch still returns the face's bilinear patch. Triangles
//! (`[a, b, c, c]`) join charts like quads; their repeated corner becomes two texels of `c`, so a
//! fan of triangles around a pole packs as one row of cells over a row of pole texels.

use std::collections::HashMap;

use glam::DVec2;
use serde::{Deserialize, Serialize};

/// One of the 8 symmetries of the unit square: bit 0 swaps `s` and `t`, then bit 1 mirrors
/// `s → 1 − s` and bit 2 mirrors `t → 1 − t`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(try_from = "u8", into = "u8")]
pub struct SquareSymmetry(u8);

impl SquareSymmetry {
    pub const IDENTITY: Self = Self(0);
    pub const ALL: [Self; 8] = [Self(0), Self(1), Self(2), Self(3), Self(4), Self(5), Self(6), Self(7)];

    /// `None` for codes ≥ 8.
    pub fn new(code: u8) -> Option<Self> {
        (code < 8).then_some(Self(code))
    }

    pub fn code(self) -> u8 {
        self.0
    }

    pub fn apply(self, p: DVec2) -> DVec2 {
        let p = if self.0 & 1 != 0 { DVec2::new(p.y, p.x) } else { p };
        DVec2::new(
            if self.0 & 2 != 0 { 1.0 - p.x } else { p.x },
            if self.0 & 4 != 0 { 1.0 - p.y } else { p.y },
        )
    }

    /// The same map on lattice corners (`0` or `1` per axis).
    fn apply_corner(self, (x, y): Point) -> Point {
        let (x, y) = if self.0 & 1 != 0 { (y, x) } else { (x, y) };
        (if self.0 & 2 != 0 { 1 - x } else { x }, if self.0 & 4 != 0 { 1 - y } else { y })
    }

    /// `other ∘ self`: first `self`, then `other`.
    pub fn then(self, other: Self) -> Self {
        let image = |s: Self| CORNERS.map(|c| other.apply_corner(s.apply_corner(c)));
        let want = image(self);
        Self::ALL.into_iter().find(|s| CORNERS.map(|c| s.apply_corner(c)) == want).unwrap_or(Self::IDENTITY)
    }
}

impl TryFrom<u8> for SquareSymmetry {
    type Error = String;
    fn try_from(code: u8) -> Result<Self, String> {
        Self::new(code).ok_or_else(|| format!("square symmetry {code} (expected 0..=7)"))
    }
}

impl From<SquareSymmetry> for u8 {
    fn from(s: SquareSymmetry) -> u8 {
        s.0
    }
}

/// A lattice point or a cell (its `(0,0)` corner), in chart coordinates.
type Point = (i32, i32);

/// Block-parameter corners of face corners 0..4.
const CORNERS: [Point; 4] = [(0, 0), (1, 0), (1, 1), (0, 1)];

/// Where a bundle's cell is: its `(0,0)` texel and how the face sits in it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "[u32; 3]", into = "[u32; 3]")]
pub struct Cell {
    pub x: u32,
    pub y: u32,
    pub orientation: SquareSymmetry,
}

impl TryFrom<[u32; 3]> for Cell {
    type Error = String;
    fn try_from([x, y, o]: [u32; 3]) -> Result<Self, String> {
        let orientation = u8::try_from(o).ok().and_then(SquareSymmetry::new);
        let orientation = orientation.ok_or_else(|| format!("cell orientation {o} (expected 0..=7)"))?;
        Ok(Self { x, y, orientation })
    }
}

impl From<Cell> for [u32; 3] {
    fn from(c: Cell) -> Self {
        [c.x, c.y, u32::from(c.orientation.code())]
    }
}

impl Cell {
    /// Continuous texel coordinate (texel centres at +½) of block parameter `(s, t)`.
    pub fn coord(&self, st: DVec2) -> DVec2 {
        DVec2::new(f64::from(self.x), f64::from(self.y)) + 0.5 + self.orientation.apply(st)
    }

    /// The texel holding face corner `k` (0..4).
    pub fn corner_texel(&self, k: usize) -> (u32, u32) {
        let (dx, dy) = self.orientation.apply_corner(CORNERS[k]);
        (self.x + dx as u32, self.y + dy as u32)
    }
}

/// The packed slice: size, one cell per face and the vertex each texel holds.
#[derive(Clone, Debug, PartialEq)]
pub struct Lattice {
    pub width: u32,
    pub height: u32,
    pub cells: Vec<Cell>,
    /// Row-major, `width × height`; `None` for texels no chart covers.
    pub texels: Vec<Option<u32>>,
}

impl Lattice {
    /// The one-2×2-block-per-face layout (blocks in rows of `⌈√F⌉`): the baseline the lattice is
    /// measured against, and a layout every face set has.
    pub fn blocks(corners: &[[u32; 4]]) -> Self {
        let (width, height) = Self::block_slice(corners.len());
        let per_row = width / 2;
        let cells: Vec<Cell> = (0..corners.len() as u32)
            .map(|f| Cell {
                x: 2 * (f % per_row),
                y: 2 * (f / per_row),
                orientation: SquareSymmetry::IDENTITY,
            })
            .collect();
        let mut texels = vec![None; width as usize * height as usize];
        for (cell, face) in cells.iter().zip(corners) {
            for (k, &v) in face.iter().enumerate() {
                let (x, y) = cell.corner_texel(k);
                texels[(y * width + x) as usize] = Some(v);
            }
        }
        Self { width, height, cells, texels }
    }

    /// Texels (width, height) of a slice of [`Self::blocks`] for `faces` faces.
    pub fn block_slice(faces: usize) -> (u32, u32) {
        let per_row = (f64::from(faces.max(1) as u32).sqrt().ceil() as u32).max(1);
        (2 * per_row, 2 * (faces.max(1) as u32).div_ceil(per_row))
    }

    /// Grows charts over the faces (`corners[f]` = the face's four corner vertices, triangles
    /// repeating their last one) and packs them. Deterministic: same faces, same lattice.
    pub fn build(corners: &[[u32; 4]]) -> Self {
        let mut edges: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
        for (f, c) in corners.iter().enumerate() {
            for k in 0..4 {
                let (a, b) = (c[k], c[(k + 1) % 4]);
                if a != b {
                    edges.entry((a.min(b), a.max(b))).or_default().push(f);
                }
            }
        }
        // Seeds in the interior of regular grid regions first (fewest corners whose vertex is
        // not shared by exactly four faces): a chart grown from an irregular face (a pole, a
        // face spanning two grid edges) would otherwise cut the regular region around it.
        let mut valence: HashMap<u32, u32> = HashMap::new();
        for c in corners {
            for (k, v) in c.iter().enumerate() {
                if !c[..k].contains(v) {
                    *valence.entry(*v).or_default() += 1;
                }
            }
        }
        let irregular = |c: &[u32; 4]| c.iter().filter(|v| valence.get(v) != Some(&4)).count();
        let mut seeds: Vec<usize> = (0..corners.len()).collect();
        seeds.sort_by_key(|&f| (irregular(&corners[f]), f));
        let mut assigned = vec![false; corners.len()];
        let mut charts = Vec::new();
        for seed in seeds {
            if !assigned[seed] {
                charts.push(Chart::grow(seed, corners, &edges, &mut assigned));
            }
        }
        pack(charts, corners.len())
    }
}

/// A rectangle of cells `lo ≤ (i, j) < hi` with the lattice points of its corners.
struct Chart {
    cells: HashMap<Point, (usize, SquareSymmetry)>,
    points: HashMap<Point, u32>,
    lo: Point,
    hi: Point,
}

/// The four growth directions: +x, +y, −x, −y.
const DIRECTIONS: [Point; 4] = [(1, 0), (0, 1), (-1, 0), (0, -1)];

impl Chart {
    fn grow(
        seed: usize,
        corners: &[[u32; 4]],
        edges: &HashMap<(u32, u32), Vec<usize>>,
        assigned: &mut [bool],
    ) -> Self {
        let mut chart = Self { cells: HashMap::new(), points: HashMap::new(), lo: (0, 0), hi: (1, 1) };
        let placed = chart.placement(corners[seed], (0, 0), &HashMap::new());
        // A face always fits an empty cell (no lattice point is known yet).
        let (orientation, points) = placed.unwrap_or((SquareSymmetry::IDENTITY, Vec::new()));
        chart.points.extend(points);
        chart.cells.insert((0, 0), (seed, orientation));
        assigned[seed] = true;
        let mut open = [true; 4];
        while open.iter().any(|o| *o) {
            for (d, &dir) in DIRECTIONS.iter().enumerate() {
                if open[d] {
                    open[d] = chart.extend(dir, corners, edges, assigned);
                }
            }
        }
        chart
    }

    /// Orientation putting `face` into `cell` consistently with the known lattice points (and
    /// `pending` ones), with the corner points it sets.
    fn placement(
        &self,
        face: [u32; 4],
        cell: Point,
        pending: &HashMap<Point, u32>,
    ) -> Option<(SquareSymmetry, Vec<(Point, u32)>)> {
        SquareSymmetry::ALL.into_iter().find_map(|o| {
            let mut points = Vec::with_capacity(4);
            for (k, &v) in face.iter().enumerate() {
                let (dx, dy) = o.apply_corner(CORNERS[k]);
                let p = (cell.0 + dx, cell.1 + dy);
                match self.points.get(&p).or_else(|| pending.get(&p)) {
                    Some(&known) if known != v => return None,
                    _ => points.push((p, v)),
                }
            }
            Some((o, points))
        })
    }

    /// Adds one row or column of cells on side `dir` if every new cell finds an unassigned
    /// neighbour face that fits; returns whether it did.
    fn extend(
        &mut self,
        dir: Point,
        corners: &[[u32; 4]],
        edges: &HashMap<(u32, u32), Vec<usize>>,
        assigned: &mut [bool],
    ) -> bool {
        // The new cells and, for each, the two lattice points of the edge it shares.
        let (new_cells, shared): (Vec<Point>, Vec<(Point, Point)>) = match dir {
            (1, 0) => {
                (self.lo.1..self.hi.1).map(|j| ((self.hi.0, j), ((self.hi.0, j), (self.hi.0, j + 1)))).unzip()
            }
            (-1, 0) => (self.lo.1..self.hi.1)
                .map(|j| ((self.lo.0 - 1, j), ((self.lo.0, j), (self.lo.0, j + 1))))
                .unzip(),
            (0, 1) => {
                (self.lo.0..self.hi.0).map(|i| ((i, self.hi.1), ((i, self.hi.1), (i + 1, self.hi.1)))).unzip()
            }
            _ => (self.lo.0..self.hi.0)
                .map(|i| ((i, self.lo.1 - 1), ((i, self.lo.1), (i + 1, self.lo.1))))
                .unzip(),
        };
        let mut pending_points: HashMap<Point, u32> = HashMap::new();
        let mut pending_cells = Vec::with_capacity(new_cells.len());
        for (cell, (p, q)) in new_cells.into_iter().zip(shared) {
            let (Some(&a), Some(&b)) = (self.points.get(&p), self.points.get(&q)) else {
                return false;
            };
            if a == b {
                return false; // a triangle's collapsed side has no neighbour
            }
            let candidates = edges.get(&(a.min(b), a.max(b))).map(Vec::as_slice).unwrap_or(&[]);
            let fit = candidates.iter().find_map(|&f| {
                if assigned[f] || pending_cells.iter().any(|(_, g, _)| *g == f) {
                    return None;
                }
                self.placement(corners[f], cell, &pending_points).map(|(o, pts)| (f, o, pts))
            });
            let Some((face, orientation, points)) = fit else {
                return false;
            };
            pending_points.extend(points);
            pending_cells.push((cell, face, orientation));
        }
        for (cell, face, orientation) in pending_cells {
            assigned[face] = true;
            self.cells.insert(cell, (face, orientation));
        }
        self.points.extend(pending_points);
        self.lo = (self.lo.0.min(self.lo.0 + dir.0), self.lo.1.min(self.lo.1 + dir.1));
        self.hi = (self.hi.0.max(self.hi.0 + dir.0), self.hi.1.max(self.hi.1 + dir.1));
        true
    }

    /// Texels: `(cells + 1)` per axis.
    fn size(&self) -> (u32, u32) {
        ((self.hi.0 - self.lo.0 + 1) as u32, (self.hi.1 - self.lo.1 + 1) as u32)
    }
}

/// Shelf-packs the charts (each laid wider than tall, tallest first) at the width that gives
/// the smallest slice.
fn pack(charts: Vec<Chart>, faces: usize) -> Lattice {
    let mut charts: Vec<(Chart, bool)> = charts
        .into_iter()
        .map(|c| {
            let (w, h) = c.size();
            (c, h > w)
        })
        .collect();
    let dims = |(c, transposed): &(Chart, bool)| {
        let (w, h) = c.size();
        if *transposed { (h, w) } else { (w, h) }
    };
    charts.sort_by_key(|c| {
        let (w, h) = dims(c);
        (std::cmp::Reverse(h), std::cmp::Reverse(w))
    });
    let area: u64 = charts.iter().map(|c| u64::from(dims(c).0) * u64::from(dims(c).1)).sum();
    let widest = charts.iter().map(|c| dims(c).0).max().unwrap_or(2);
    let shelves = |width: u32| -> (u32, Vec<(u32, u32)>) {
        let (mut x, mut y, mut shelf) = (0u32, 0u32, 0u32);
        let mut origins = Vec::with_capacity(charts.len());
        for c in &charts {
            let (w, h) = dims(c);
            if x + w > width {
                (x, y, shelf) = (0, y + shelf, 0);
            }
            origins.push((x, y));
            x += w;
            shelf = shelf.max(h);
        }
        (y + shelf, origins)
    };
    let side = (area as f64).sqrt().ceil() as u32;
    let (width, (height, origins)) = [1.0, 1.1, 1.25, 1.5, 2.0]
        .iter()
        .map(|k| widest.max((f64::from(side) * k).ceil() as u32))
        .map(|w| (w, shelves(w)))
        .min_by_key(|(w, (h, _))| (u64::from(*w) * u64::from(*h), *w))
        .unwrap_or((2, (2, Vec::new())));
    // An empty face set still gets a valid (2×2) texture.
    let height = height.max(2);
    let mut cells = vec![Cell { x: 0, y: 0, orientation: SquareSymmetry::IDENTITY }; faces];
    let mut texels = vec![None; width as usize * height as usize];
    // Transposing a chart swaps the axes of its lattice, which composes a swap into every cell.
    let swap = SquareSymmetry(1);
    for ((chart, transposed), (ox, oy)) in charts.iter().zip(origins) {
        let place = |(i, j): Point| {
            let (x, y) = ((i - chart.lo.0) as u32, (j - chart.lo.1) as u32);
            if *transposed { (ox + y, oy + x) } else { (ox + x, oy + y) }
        };
        for (&p, &v) in &chart.points {
            let (x, y) = place(p);
            texels[(y * width + x) as usize] = Some(v);
        }
        for (&cell, &(face, orientation)) in &chart.cells {
            let (x, y) = place(cell);
            let orientation = if *transposed { orientation.then(swap) } else { orientation };
            cells[face] = Cell { x, y, orientation };
        }
    }
    Lattice { width, height, cells, texels }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An `a × b` grid of quads, vertex `(i, j)` = `j·(a+1) + i`, faces counter-clockwise.
    fn grid(a: u32, b: u32) -> Vec<[u32; 4]> {
        let v = |i: u32, j: u32| j * (a + 1) + i;
        (0..b)
            .flat_map(|j| (0..a).map(move |i| [v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)]))
            .collect()
    }

    /// Every cell's corners hold the face's vertices where its orientation says.
    fn assert_consistent(corners: &[[u32; 4]], l: &Lattice) {
        assert_eq!(l.cells.len(), corners.len());
        assert_eq!(l.texels.len(), (l.width * l.height) as usize);
        for (f, (cell, face)) in l.cells.iter().zip(corners).enumerate() {
            for (k, &v) in face.iter().enumerate() {
                let (x, y) = cell.corner_texel(k);
                assert!(x < l.width && y < l.height, "face {f} corner {k} outside");
                assert_eq!(l.texels[(y * l.width + x) as usize], Some(v), "face {f} corner {k}");
            }
        }
    }

    #[test]
    fn symmetries_form_the_dihedral_group() {
        for a in SquareSymmetry::ALL {
            let p = DVec2::new(0.2, 0.7);
            for b in SquareSymmetry::ALL {
                let composed = a.then(b).apply(p);
                assert!(composed.distance(b.apply(a.apply(p))) < 1e-15, "{a:?} then {b:?}");
            }
            // Each maps the corners onto the corners.
            let mut image = CORNERS.map(|c| a.apply_corner(c));
            image.sort_unstable();
            let mut sorted = CORNERS;
            sorted.sort_unstable();
            assert_eq!(image, sorted);
        }
    }

    #[test]
    fn a_quad_grid_becomes_one_chart_of_one_texel_per_vertex() {
        let corners = grid(6, 4);
        let l = Lattice::build(&corners);
        assert_consistent(&corners, &l);
        assert_eq!(l.width * l.height, 7 * 5, "{}×{}", l.width, l.height);
        assert!(l.texels.iter().all(Option::is_some));
    }

    #[test]
    fn mirrored_and_rotated_faces_still_share_texels() {
        // Reverse the winding of every other face and rotate the start corner of others.
        let mut corners = grid(5, 5);
        for (f, c) in corners.iter_mut().enumerate() {
            if f % 2 == 0 {
                c.reverse();
            }
            c.rotate_left(f % 4);
        }
        let l = Lattice::build(&corners);
        assert_consistent(&corners, &l);
        assert_eq!(l.width * l.height, 36);
    }

    #[test]
    fn a_triangle_fan_shares_its_pole() {
        // A ring of 8 quads capped by a fan of 8 triangles around vertex 16.
        let n = 8;
        let mut corners: Vec<[u32; 4]> = (0..n).map(|i| [i, (i + 1) % n, n + (i + 1) % n, n + i]).collect();
        corners.extend((0..n).map(|i| [n + i, n + (i + 1) % n, 2 * n, 2 * n]));
        let l = Lattice::build(&corners);
        assert_consistent(&corners, &l);
        // One chart of 8 × 2 cells: 9 × 3 texels (the seam column repeats), vs 64 as blocks.
        assert_eq!(l.width * l.height, 27, "{}×{}", l.width, l.height);
    }

    #[test]
    fn irregular_and_degenerate_faces_get_cells() {
        // A non-manifold edge (three faces on 0–1), a face repeating a vertex, an isolated face.
        let corners = vec![[0, 1, 2, 3], [1, 0, 4, 5], [0, 1, 6, 7], [8, 8, 8, 8], [9, 10, 11, 11]];
        let l = Lattice::build(&corners);
        assert_consistent(&corners, &l);
        let blocks = Lattice::blocks(&corners);
        assert_consistent(&corners, &blocks);
        assert!(l.width * l.height <= blocks.width * blocks.height);
        assert_consistent(&[], &Lattice::build(&[]));
    }

    #[test]
    fn cell_coordinates_interpolate_the_face() {
        let corners = grid(3, 2);
        let mut rotated = corners.clone();
        rotated[4].rotate_left(1);
        rotated[2].reverse();
        let l = Lattice::build(&rotated);
        // Values at texels: vertex id as a number; bilinear fetch inside the cell must equal the
        // bilinear patch of the face's corners in face order.
        let value = |x: f64, y: f64| {
            let (fx, fy) = (x - 0.5, y - 0.5);
            let (x0, y0) = (fx.floor(), fy.floor());
            let (tx, ty) = (fx - x0, fy - y0);
            let at = |x: f64, y: f64| {
                let x = (x as u32).min(l.width - 1);
                let y = (y as u32).min(l.height - 1);
                f64::from(l.texels[(y * l.width + x) as usize].unwrap_or(0))
            };
            (at(x0, y0) * (1.0 - tx) + at(x0 + 1.0, y0) * tx) * (1.0 - ty)
                + (at(x0, y0 + 1.0) * (1.0 - tx) + at(x0 + 1.0, y0 + 1.0) * tx) * ty
        };
        for (cell, face) in l.cells.iter().zip(&rotated) {
            for st in [DVec2::new(0.25, 0.6), DVec2::new(0.9, 0.1)] {
                let c = cell.coord(st);
                let f = face.map(f64::from);
                let expected = (f[0] * (1.0 - st.x) + f[1] * st.x) * (1.0 - st.y)
                    + (f[3] * (1.0 - st.x) + f[2] * st.x) * st.y;
                assert!((value(c.x, c.y) - expected).abs() < 1e-12);
            }
        }
    }
}
