//! The CPU reference generator: roots on the scalp, unit tangents, continuous LOD, and hard
//! cases that must stay finite.

use glam::DVec3;
use hairmesh::asset::{AssetParams, HairAsset, StrandCount};
use hairmesh::hair_mesh::{ExtrudeParams, HairMesh};
use hairmesh::reference::{LodParams, Projection, ViewParams, bundle_lod, style_term_level};
use hairmesh::rng::SplitMix64;
use hairmesh::style::{Clump, Curl, Frizz, Style, Wave};
use hairmesh::{BundleFace, ScalpMesh};

mod common;
use common::patch;

fn styled() -> Style {
    Style {
        curl: Curl { radius: 0.05, frequency: 2.0, phase: 0.0 },
        wave: Wave { amplitude: 0.03, frequency: 1.0, coherence: 0.0 },
        frizz: Frizz { amplitude: 0.01, frequency: 6.0, exponent: 2.0 },
        clump: Clump { strength: 0.4, exponent: 1.5 },
        twist: 0.25,
        length_variation: 0.2,
        ..Style::default()
    }
}

fn asset_of(scalp: &ScalpMesh, layers: u32, length: f64, style: Style, strands: u64) -> HairAsset {
    let hm = HairMesh::extrude(scalp, &ExtrudeParams { layers, length, droop: 0.5, gravity: DVec3::NEG_Y })
        .expect("extrude");
    HairAsset::build(
        &hm,
        &AssetParams { strands: StrandCount::Total(strands), sample_sets: 2, seed: 3, ..Default::default() },
        style,
    )
    .expect("asset")
}

fn view_at(distance: f64) -> ViewParams {
    ViewParams {
        eye: DVec3::new(0.0, 0.5, distance),
        vertical_resolution: 720.0,
        projection: Projection::Perspective { fov_y: 0.8 },
    }
}

fn assert_sane(asset: &HairAsset, view: &ViewParams, lod: &LodParams, what: &str) {
    for s in asset.generate_reference(view, lod) {
        for (k, p) in s.positions.iter().enumerate() {
            assert!(p.is_finite(), "{what}: bundle {} strand {} vertex {k} is {p}", s.bundle, s.index);
        }
        for t in &s.tangents {
            assert!((t.length() - 1.0).abs() < 1e-9, "{what}: tangent {t} is not unit length");
        }
        assert!(s.widths.iter().all(|w| w.is_finite() && *w > 0.0), "{what}: widths {:?}", s.widths);
    }
}

#[test]
fn strands_start_exactly_on_the_scalp_at_their_root_sample() {
    let mut rng = SplitMix64::new(5);
    let scalp = patch(3, DVec3::ZERO, 1.0, &mut rng);
    let asset = asset_of(&scalp, 4, 2.0, styled(), 400);
    let hm = HairMesh::extrude(
        &scalp,
        &ExtrudeParams { layers: 4, length: 2.0, droop: 0.5, gravity: DVec3::NEG_Y },
    )
    .expect("extrude");
    let lod = LodParams { enabled: false, ..LodParams::default() };
    let mut checked = 0;
    for s in asset.generate_reference(&view_at(5.0), &lod) {
        let root = asset.root_parameter(s.bundle, s.index);
        let face = hm.faces[s.bundle as usize];
        let v = |i: u32| hm.layers[0][i as usize];
        let expected = match face {
            BundleFace::Quad([a, b, c, d]) => {
                let (x, y) = (root.x, root.y);
                v(a) * (1.0 - x) * (1.0 - y) + v(b) * x * (1.0 - y) + v(c) * x * y + v(d) * (1.0 - x) * y
            }
            BundleFace::Triangle([a, b, c]) => {
                let set = asset.sample_set(s.bundle);
                // The sample as stored on the GPU (16-bit fixed point), like the generator, read
                // under the bundle's symmetry (a permutation of the triangle's corners).
                let xi = hairmesh::roots::permute_triangle_sample(
                    hairmesh::roots::quantize_sample(set.points[s.index as usize]),
                    asset.root_symmetry(s.bundle),
                );
                v(a) * (1.0 - xi.x - xi.y) + v(b) * xi.x + v(c) * xi.y
            }
        };
        assert!(s.positions[0].distance(expected) < 1e-12, "root {} vs {expected}", s.positions[0]);
        checked += 1;
    }
    assert_eq!(checked, asset.total_strands());
}

#[test]
fn lod_extremes_stay_valid() {
    let mut rng = SplitMix64::new(6);
    let asset = asset_of(&patch(3, DVec3::ZERO, 1.0, &mut rng), 4, 2.0, styled(), 300);
    let lod = LodParams::default();
    for distance in [0.0, 1e-9, 0.5, 3.0, 50.0, 1e6, f64::INFINITY] {
        let view = view_at(distance);
        for b in 0..asset.bundles.len() as u32 {
            let l = bundle_lod(&asset, b, &view, &lod);
            let n = asset.bundles[b as usize].strands;
            assert!(l.strands >= 1 && l.strands <= n, "d={distance}: {} of {n}", l.strands);
            assert!(l.width_scale.is_finite() && l.width_scale >= 1.0 && l.width_scale <= f64::from(n));
            assert!(l.gamma.is_finite() && (0.0..=1.0).contains(&l.gamma));
        }
        if distance.is_finite() {
            assert_sane(&asset, &view, &lod, &format!("distance {distance}"));
        }
    }
    // Orthographic views (shadow maps) too.
    let ortho = ViewParams { projection: Projection::Orthographic { height: 10.0 }, ..view_at(3.0) };
    assert_sane(&asset, &ortho, &lod, "orthographic");
}

#[test]
fn vertex_lod_morph_is_continuous() {
    let mut rng = SplitMix64::new(7);
    let asset = asset_of(&patch(2, DVec3::ZERO, 1.0, &mut rng), 4, 2.0, styled(), 60);
    assert_morph_continuous(&asset, &LodParams::default(), 1.003, 5000);
    // The style-aware rule moves where the levels change, not how they change (its x changes
    // faster with distance where a curl nears ε: finer steps).
    let aware = LodParams { vertex_alpha: 1024.0, vertex_error_pixels: 0.5, ..LodParams::default() };
    assert_morph_continuous(&asset, &aware, 1.0002, 40000);
}

/// Steps the distance by `ratio` from 1, finds where the vertex level changes and compares both
/// sides of each change.
fn assert_morph_continuous(asset: &HairAsset, lod: &LodParams, ratio: f64, steps: i32) {
    let lod = *lod;
    let mut previous: Option<(f64, hairmesh::reference::BundleLod)> = None;
    let mut transitions = 0;
    for i in 0..steps {
        let d = ratio.powi(i);
        let l = bundle_lod(asset, 0, &view_at(d), &lod);
        if let Some((_, prev)) = previous
            && prev.level != l.level
        {
            // Just before the switch (closer) the odd vertices are fully morphed (γ → 1); just
            // after, the coarser level draws exactly those points.
            let fine = asset.generate_strand(0, 0, &prev);
            // (The coarser level's own morph has just begun, γ ≈ 0; compare with its γ = 0 set.)
            let coarse = asset.generate_strand(0, 0, &hairmesh::reference::BundleLod { gamma: 0.0, ..l });
            assert!(prev.gamma > 0.99, "γ before the switch: {}", prev.gamma);
            assert_eq!(fine.positions.len(), 2 * coarse.positions.len() - 1);
            for (k, p) in coarse.positions.iter().enumerate() {
                assert!(p.distance(fine.positions[2 * k]) < 1e-12);
            }
            for k in (1..fine.positions.len()).step_by(2) {
                let mid = 0.5 * (fine.positions[k - 1] + fine.positions[k + 1]);
                assert!(
                    fine.positions[k].distance(mid)
                        < 0.02 * fine.positions[k - 1].distance(fine.positions[k + 1]) + 1e-9
                );
            }
            transitions += 1;
        }
        previous = Some((d, l));
    }
    assert!(transitions >= 3, "only {transitions} level changes seen with {lod:?}");
    // γ = 0 is the full set: equal to the unmorphed strand at that level.
    let mut l = bundle_lod(asset, 0, &view_at(1.0), &lod);
    l.gamma = 0.0;
    let unmorphed =
        asset.generate_strand(0, 0, &hairmesh::reference::BundleLod { coarse_level: l.level, ..l });
    assert_eq!(asset.generate_strand(0, 0, &l).positions, unmorphed.positions);
}

#[test]
fn style_term_levels_bound_the_chord_error_and_change_continuously() {
    // A curl of radius `a` pixels and `c` turns drawn with n segments: each chord spans 2πc/n
    // of phase and its midpoint lies a·(1 − cos(πc/n)) inside the circle, the largest deviation.
    let chord_error = |a: f64, c: f64, n: f64| a * (1.0 - (std::f64::consts::PI * c / n).cos());
    let lambda = 1.0;
    let mut checked = 0;
    for a in [0.2, 0.3, 0.6, 1.0, 3.0, 20.0, 300.0] {
        for c in [0.5, 3.0, 12.0] {
            for eps in [0.25, 0.5, 1.0] {
                let x = style_term_level(a, c, 1.0, eps, lambda);
                if 4.0 * a <= eps {
                    assert_eq!(x, f64::NEG_INFINITY, "a {a}: the whole curl is well within ε {eps}");
                    continue;
                }
                assert!(x.is_finite(), "a {a} c {c} ε {eps}: {x}");
                if 2.0 * a < eps {
                    continue; // the ramp: any polyline is within 2a < ε
                }
                // The coarser level of the morph band already meets the error.
                let drawn = 2f64.powf(x - lambda).ceil();
                assert!(chord_error(a, c, drawn) <= eps + 1e-9, "a {a} c {c} ε {eps}: {drawn} segments");
                // Tight: half as many segments (while a chord spans at most half a turn) exceed ε.
                if (drawn / 2.0).floor() >= c {
                    assert!(chord_error(a, c, (drawn / 2.0).floor()) > eps, "a {a} c {c} ε {eps}: not tight");
                }
                checked += 1;
            }
        }
    }
    assert!(checked > 20, "{checked}");
    // Continuous in the amplitude: from 0 where the term starts to count (a = ε/4), through the
    // end of the ramp (a = ε/2), so vertex levels never jump as a character recedes.
    for c in [0.5, 3.0, 12.0] {
        let eps = 0.5;
        let level = |a: f64| style_term_level(a, c, 1.0, eps, lambda);
        assert!(level(0.25 * eps * (1.0 + 1e-9)).abs() < 1e-6);
        assert!((level(0.5 * eps * (1.0 - 1e-9)) - level(0.5 * eps)).abs() < 1e-6, "c {c}");
        let mut previous = level(0.25 * eps * 1.0001);
        for k in 1..2000 {
            let x = level(0.25 * eps * (1.0001 + k as f64 * 0.002));
            assert!(x >= previous - 1e-9 && x - previous < 0.05, "c {c}: {previous} → {x}");
            previous = x;
        }
    }
    // Scale: amplitude in object units times pixels per unit; a zero error bound or a NaN asks
    // for nothing.
    let x = style_term_level(0.01, 4.0, 100.0, 0.5, lambda);
    assert!((x - style_term_level(1.0, 4.0, 1.0, 0.5, lambda)).abs() < 1e-12);
    assert_eq!(style_term_level(1.0, 4.0, 1.0, 0.0, lambda), f64::NEG_INFINITY);
    assert_eq!(style_term_level(f64::NAN, 4.0, 1.0, 0.5, lambda), f64::NEG_INFINITY);
    assert_eq!(style_term_level(1.0, 4.0, f64::INFINITY, 0.5, lambda), f64::NEG_INFINITY);
}

#[test]
fn style_aware_vertex_lod_keeps_curls_a_pixel_wide() {
    let mut rng = SplitMix64::new(9);
    let scalp = patch(2, DVec3::ZERO, 1.0, &mut rng);
    let curly = Style { curl: Curl { radius: 0.02, frequency: 4.0, phase: 0.0 }, ..Style::default() };
    let straight = Style::default();
    let linear = LodParams { vertex_alpha: 1024.0, ..LodParams::default() };
    let aware = LodParams { vertex_error_pixels: 0.5, ..linear };
    let (mut finer, mut same_far) = (0, false);
    let mut last_level = u32::MAX;
    let curly_asset = asset_of(&scalp, 4, 2.0, curly, 20);
    let straight_asset = asset_of(&scalp, 4, 2.0, straight, 20);
    for i in 0..400 {
        let d = 0.5 * 1.02f64.powi(i);
        let view = view_at(d);
        let (a, l) =
            (bundle_lod(&curly_asset, 0, &view, &aware), bundle_lod(&curly_asset, 0, &view, &linear));
        assert!(a.level >= l.level, "d {d}: the error bound only adds segments");
        assert!(a.level <= last_level, "d {d}: level {} after {last_level} nearer", a.level);
        last_level = a.level;
        finer += usize::from(a.level > l.level);
        // Straight hair has nothing the rule keeps: the linear rule alone.
        assert_eq!(
            bundle_lod(&straight_asset, 0, &view, &aware),
            bundle_lod(&straight_asset, 0, &view, &linear)
        );
        // Far enough that the curl's radius is below ε/4, only the linear rule counts.
        let pixels = hairmesh::reference::pixels_per_unit(d, &view);
        if 4.0 * 0.02 * pixels <= 0.5 {
            assert_eq!(a, l, "d {d}: a sub-pixel curl keeps nothing");
            same_far = true;
        }
    }
    assert!(finer > 50, "the curl kept extra segments at only {finer} distances");
    assert!(same_far, "no distance far enough for the curl to vanish");
}

#[test]
fn hard_cases_stay_finite_with_unit_tangents() {
    let mut rng = SplitMix64::new(8);
    let lod = LodParams::default();
    let cases: Vec<(&str, ScalpMesh, u32, f64)> = vec![
        ("far from the origin", patch(2, DVec3::splat(1e4), 1.0, &mut rng), 4, 2.0),
        ("tiny", patch(2, DVec3::ZERO, 1e-4, &mut rng), 4, 2e-4),
        ("one layer", patch(2, DVec3::ZERO, 1.0, &mut rng), 1, 2.0),
        ("32 layers", patch(2, DVec3::ZERO, 1.0, &mut rng), 32, 2.0),
    ];
    for (what, scalp, layers, length) in cases {
        let centre = scalp.positions[0];
        let asset = asset_of(&scalp, layers, length, styled(), 80);
        let view = ViewParams { eye: centre + DVec3::new(0.0, 0.5, 3.0) * length, ..view_at(0.0) };
        assert_sane(&asset, &view, &lod, what);
    }
    // Zero-area and needle triangles, coincident layers and a column doubling back.
    let scalp = ScalpMesh {
        positions: vec![
            DVec3::ZERO,
            DVec3::X,
            DVec3::X * 2.0,
            DVec3::new(1.0, 0.0, -1e-9),
            DVec3::new(0.0, 0.0, -1.0),
        ],
        faces: vec![vec![0, 1, 2], vec![0, 3, 1], vec![0, 1, 4]],
        uvs: None,
        ..Default::default()
    };
    let mut hm = HairMesh::extrude(
        &scalp,
        &ExtrudeParams { layers: 4, length: 1.0, droop: 0.0, gravity: DVec3::NEG_Y },
    )
    .expect("extrude");
    hm.layers[2] = hm.layers[1].clone(); // coincident layer vertices
    hm.layers[4] = hm.layers[2].clone(); // the column doubles back
    let asset = HairAsset::build(
        &hm,
        &AssetParams { strands: StrandCount::Total(30), sample_sets: 1, seed: 1, ..Default::default() },
        styled(),
    )
    .expect("asset");
    assert_sane(&asset, &view_at(2.0), &lod, "degenerate faces and columns");
    assert_sane(&asset, &view_at(2.0), &LodParams { enabled: false, ..lod }, "degenerate faces, LOD off");
}

/// Random meshes: jittered patches with random layer counts, lengths, droops and styles.
#[test]
fn random_meshes_property() {
    let mut rng = SplitMix64::new(2024);
    for case in 0..40 {
        let n = 1 + (rng.next_u64() % 4) as u32;
        let scale = 10f64.powf(rng.next_f64() * 4.0 - 2.0);
        let scalp = patch(n, DVec3::splat((rng.next_f64() - 0.5) * 100.0), scale, &mut rng);
        let layers = 1 + (rng.next_u64() % 8) as u32;
        let style = Style {
            seed: rng.next_u64() as u32,
            curl: Curl {
                radius: rng.next_f64() * 0.1 * scale,
                frequency: rng.next_f64() * 5.0 / scale,
                phase: rng.next_f64(),
            },
            frizz: Frizz {
                amplitude: rng.next_f64() * 0.05 * scale,
                frequency: 4.0 / scale,
                exponent: 1.0 + rng.next_f64(),
            },
            clump: Clump { strength: rng.next_f64(), exponent: rng.next_f64() * 2.0 },
            twist: rng.next_f64() - 0.5,
            ..Style::default()
        };
        let asset = asset_of(&scalp, layers, scale * (0.5 + 3.0 * rng.next_f64()), style, 50);
        let eye = scalp.positions[0] + DVec3::new(0.0, 1.0, 4.0) * scale * (0.1 + 10.0 * rng.next_f64());
        let view = ViewParams { eye, ..view_at(0.0) };
        assert_sane(&asset, &view, &LodParams::default(), &format!("random case {case}"));
    }
}
