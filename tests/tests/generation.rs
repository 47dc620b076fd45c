//! Strand generation on the GPU against the f64 CPU reference (`hairmesh::reference`), both
//! paths against each other, culling, LOD extremes and budgets. Validation layer on.

use std::process::ExitCode;

use anyhow::{Context as _, bail, ensure};
use gen_gpu::accuracy::Accuracy;
use gen_gpu::diagnostics::draw_hair;
use gen_gpu::{
    Capture, Context, Filtering, FrameInputs, GenerationPath, Generator, GeneratorOptions, GpuHair,
    TexturePrecision,
};
use glam::{DVec3, Vec3};
use hairkit_tests::harness::{GpuTest, Requirements, run_gpu_tests};
use hairkit_tests::image_compare::{Tolerance, compare, differing_pixels};
use hairmesh::asset::{AssetParams, HairAsset, StrandCount, VertexMove};
use hairmesh::hair_mesh::{ExtrudeParams, HairMesh};
use hairmesh::reference::LodParams;
use hairmesh::style::{Clump, Curl, Frizz, Style, Wave};
use hairmesh::texture::{CurveEvaluation, SliceLayout};

/// Extrudes `scalp` into 4 layers and builds its asset.
fn asset_from(
    scalp: &hairmesh::ScalpMesh,
    length: f64,
    strands: u64,
    style: Style,
) -> anyhow::Result<HairAsset> {
    let hm = HairMesh::extrude(
        scalp,
        &ExtrudeParams { layers: 4, length, droop: 0.4, ..ExtrudeParams::default() },
    )?;
    Ok(HairAsset::build(
        &hm,
        &AssetParams { strands: StrandCount::Total(strands), sample_sets: 2, seed: 5, ..Default::default() },
        style,
    )?)
}

fn head_cap_asset(strands: u64, style: Style) -> anyhow::Result<HairAsset> {
    asset_from(&hairmesh::procedural::head_cap(6, 24), 0.18, strands, style)
}

fn lee_perry_smith_asset(strands: u64, style: Style) -> anyhow::Result<HairAsset> {
    let path = data_set::locate(data_set::SAMPLE_HEAD)?;
    let scalp = hairmesh::import::load_scalp(&path, &hairmesh::ScalpSelector::parse("above:0,1,0,1.5")?)
        .with_context(|| path.display().to_string())?;
    asset_from(&scalp, 3.0, strands, style)
}

fn styled(scale: f64) -> Style {
    Style {
        width: 0.002 * scale,
        curl: Curl { radius: 0.02 * scale, frequency: 3.0 / scale, phase: 0.1 },
        wave: Wave { amplitude: 0.01 * scale, frequency: 2.0 / scale, coherence: 0.6 },
        frizz: Frizz { amplitude: 0.005 * scale, frequency: 8.0 / scale, exponent: 2.0 },
        clump: Clump { strength: 0.4, exponent: 1.5 },
        twist: 0.2,
        length_variation: 0.2,
        ..Style::default()
    }
}

fn compare_to_reference(
    asset: &HairAsset,
    inputs: &FrameInputs,
    capture: &Capture,
) -> anyhow::Result<Accuracy> {
    Ok(gen_gpu::accuracy::compare_to_reference(asset, inputs, capture)?)
}

fn inputs_for(asset: &HairAsset, eye: Vec3, lod: LodParams) -> FrameInputs {
    FrameInputs { lod, ..FrameInputs::looking_at(asset, eye, 256, 256) }
}

/// Position bounds, in strand widths (the style's root width), derived per configuration from
/// the asset's size S (its normalization scale) and the largest bundle diagonal D:
/// * strand-coherent evaluation blends the same texels with the same f32 lerps as manual
///   filtering (once per strand instead of per vertex), so it has manual filtering's bounds.
/// * f32 + manual filtering: f32 texels and single-precision math: positions ~S·6e-8, plus the
///   styling frame: û, v̂ are interpolated and normalized in f32 and ŵ = û×v̂ amplifies their
///   rounding where they are nearly parallel, turning the styling offset (at most M, the
///   style's maximum displacement) by a small angle: 1e-5·S + 0.01·M.
/// * f32 + hardware filtering: the same plus the sampler's sub-texel weight precision: a weight
///   is exact to 2^-bits, the texels it blends differ by at most D, per filtered axis (3): 3·D·2^-bits.
/// * f16 + hardware: f16 keeps 11 bits of the normalized position, 2^-12·S per coordinate, √3·
///   per vector, doubled for the two interpolations of a quadratic: 2·√3·2^-12·S, plus the
///   hardware term.
///
/// Tangents: 0.5° for f32 (finite differences of vertices several widths apart); for f16 the
/// position quantum 2·√3·2^-12·S over the shortest segment ℓ (shortest bundle length / 32) as
/// an angle, ×4 for the styling frame's own f16 rounding.
fn check_oracle(
    ctx: &Context,
    name: &str,
    asset: &HairAsset,
    eyes: &[Vec3],
    lods: &[LodParams],
) -> anyhow::Result<()> {
    let scale = asset.textures.normalization.scale;
    let diagonal = asset.bundles.iter().map(|b| b.bounds_min.distance(b.bounds_max)).fold(0.0, f64::max);
    let bits = ctx.capabilities().sub_texel_precision_bits;
    let width = asset.style.width;
    let f32_math = (1e-5 * scale + 0.01 * asset.style.max_displacement()) / width;
    let hardware = 3.0 * diagonal * 0.5f64.powi(bits as i32) / width;
    let half = 2.0 * 3f64.sqrt() * 0.5f64.powi(12) * scale / width;
    let shortest = asset.bundles.iter().map(|b| b.length).fold(f64::INFINITY, f64::min) / 32.0;
    let half_degrees = 4.0 * (half * width / shortest).atan().to_degrees();
    eprintln!(
        "  {name}: bounds f32 manual {f32_math:.3}, f32 hardware {:.3}, f16 {:.3} widths, f16 tangents {half_degrees:.1}° ({bits} sub-texel bits)",
        f32_math + hardware,
        f32_math + hardware + half
    );
    for (filtering, precision, max_widths, max_degrees) in [
        (Filtering::StrandCoherent, TexturePrecision::F32, f32_math, 0.5),
        (Filtering::StrandCoherent, TexturePrecision::F16, f32_math + half, half_degrees),
        (Filtering::Hardware, TexturePrecision::F32, f32_math + hardware, 0.5),
        (Filtering::Manual, TexturePrecision::F32, f32_math, 0.5),
        (Filtering::Hardware, TexturePrecision::F16, f32_math + hardware + half, half_degrees),
    ] {
        let hair = GpuHair::upload(ctx, asset, precision)?;
        let generator = Generator::new(ctx, filtering)?;
        for eye in eyes {
            for lod in lods {
                let inputs = inputs_for(asset, *eye, *lod);
                let capture = generator.capture(ctx, &hair, &inputs, GenerationPath::Compute)?;
                let e = compare_to_reference(asset, &inputs, &capture)?;
                eprintln!(
                    "  {name} {filtering:?}/{precision:?} eye {eye} lod {} (ε {} px): {} strands, {} vertices, position max {:.4} mean {:.5} widths, tangent max {:.3}°, width {:.1e}",
                    lod.enabled,
                    lod.vertex_error_pixels,
                    e.strands,
                    e.vertices,
                    e.max_position_widths,
                    e.mean_position_widths,
                    e.max_tangent_degrees,
                    e.max_width_relative
                );
                ensure!(e.strands > 0, "nothing generated");
                ensure!(e.max_position_widths <= max_widths, "{name} {filtering:?}/{precision:?}: {e:?}");
                ensure!(e.max_tangent_degrees <= max_degrees, "{name} {filtering:?}/{precision:?}: {e:?}");
                ensure!(e.max_width_relative <= 1e-4, "{name}: {e:?}");
            }
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    let full = LodParams { enabled: false, ..LodParams::default() };
    let lod = LodParams { strand_alpha: 2.0, vertex_alpha: 2.0, ..LodParams::default() };
    // `"lod": "auto"`'s vertex rule: the curls keep the segments the error bound asks for, on
    // the GPU as in the reference (same levels, same strands).
    let aware = LodParams {
        strand_alpha: 8.0,
        vertex_alpha: 1024.0,
        vertex_error_pixels: 0.5,
        ..LodParams::default()
    };
    run_gpu_tests(vec![
        GpuTest::new("gpu_matches_cpu_reference_on_the_head_cap", Requirements::NONE, move |ctx| {
            let asset = head_cap_asset(1500, styled(0.1))?;
            let eyes = [Vec3::new(0.0, 1.7, 0.5), Vec3::new(0.3, 1.8, 3.0)];
            // The error bound is what decides here: it keeps more vertices than α alone.
            let linear = LodParams { vertex_error_pixels: 0.0, ..aware };
            let vertices = |l: LodParams| {
                let inputs = inputs_for(&asset, eyes[1], l);
                asset
                    .generate_reference(&inputs.view, &inputs.lod)
                    .iter()
                    .map(|s| s.positions.len())
                    .sum::<usize>()
            };
            let (with_bound, without) = (vertices(aware), vertices(linear));
            eprintln!("  head cap, far eye: {with_bound} vertices with the error bound, {without} without");
            ensure!(with_bound > without + without / 2, "{with_bound} vs {without}");
            check_oracle(ctx, "head cap", &asset, &eyes, &[full, lod, aware])
        }),
        GpuTest::new("the_vertex_lod_cap_is_one_for_cpu_and_gpu", Requirements::NONE, move |ctx| {
            // At the cap, above it (clamped to it on both sides) and below it: the GPU and the
            // f64 reference generate the same vertex counts and the same strands.
            let cap = hairmesh::reference::MAX_SEGMENTS_LOG2;
            ensure!(cap == gen_gpu::contract::MAX_SEGMENTS_LOG2);
            let asset = head_cap_asset(400, styled(0.1))?;
            let eye = Vec3::new(0.0, 1.7, 0.5);
            let at = |e: u32| LodParams { enabled: false, max_segments_log2: e, ..LodParams::default() };
            let hair = GpuHair::upload(ctx, &asset, TexturePrecision::F32)?;
            let generator = Generator::new(ctx, Filtering::Manual)?;
            for e in [3, cap, cap + 1, 10, u32::MAX] {
                let inputs = inputs_for(&asset, eye, at(e));
                let capture = generator.capture(ctx, &hair, &inputs, GenerationPath::Compute)?;
                let vertices = (1usize << e.min(cap)) + 1;
                ensure!(
                    capture.strands.iter().all(|s| s.positions.len() == vertices),
                    "E = {e}: every strand has {vertices} vertices"
                );
                let reference = asset.generate_reference(&inputs.view, &inputs.lod);
                ensure!(
                    reference.iter().all(|s| s.positions.len() == vertices),
                    "E = {e}: the reference agrees on {vertices} vertices"
                );
                let accuracy = compare_to_reference(&asset, &inputs, &capture)?;
                ensure!(accuracy.strands == capture.strands.len(), "E = {e}: {accuracy:?}");
            }
            check_oracle(ctx, "head cap above the cap", &asset, &[eye], &[at(cap), at(cap + 3)])
        }),
        GpuTest::new("gpu_matches_cpu_reference_on_lee_perry_smith", Requirements::NONE, move |ctx| {
            let asset = lee_perry_smith_asset(2000, styled(1.0))?;
            let eyes = [Vec3::new(0.0, 6.0, 14.0), Vec3::new(5.0, 8.0, -60.0)];
            check_oracle(ctx, "LeePerrySmith", &asset, &eyes, &[full, lod, aware])
        }),
        GpuTest::new("lattice_and_block_layouts_generate_the_same_strands", Requirements::NONE, move |ctx| {
            // Same hair mesh, same roots; only where the texels sit differs (cells rotated and
            // mirrored, vertices shared), so the strands agree to f32 rounding.
            let hm = HairMesh::extrude(
                &hairmesh::procedural::head_cap(6, 24),
                &ExtrudeParams { layers: 4, length: 0.18, droop: 0.4, ..ExtrudeParams::default() },
            )?;
            let build = |layout| {
                HairAsset::build(
                    &hm,
                    &AssetParams { strands: StrandCount::Total(1200), layout, ..Default::default() },
                    styled(0.1),
                )
            };
            let (lattice, blocks) = (build(SliceLayout::Lattice)?, build(SliceLayout::Blocks)?);
            let (tl, tb) = (lattice.textures.layout.slice_texels(), blocks.textures.layout.slice_texels());
            ensure!(tl * 2 < tb, "lattice {tl} texels per slice vs blocks {tb}");
            let generator = Generator::new(ctx, Filtering::Manual)?;
            let inputs = inputs_for(&lattice, Vec3::new(0.1, 1.75, 0.45), full);
            let capture = |asset: &HairAsset| -> anyhow::Result<_> {
                let hair = GpuHair::upload(ctx, asset, TexturePrecision::F32)?;
                Ok(generator.capture(ctx, &hair, &inputs, GenerationPath::Compute)?)
            };
            let (a, b) = (capture(&lattice)?, capture(&blocks)?);
            ensure!(a.strands.len() == b.strands.len() && !a.strands.is_empty());
            let tolerance = 1e-5 * lattice.textures.normalization.scale as f32;
            let mut worst = 0f32;
            for (x, y) in a.strands.iter().zip(&b.strands) {
                ensure!((x.bundle, x.index, x.positions.len()) == (y.bundle, y.index, y.positions.len()));
                for (p, q) in x.positions.iter().zip(&y.positions) {
                    worst = worst.max(p.distance(*q));
                }
            }
            eprintln!(
                "  {tl} vs {tb} texels per slice; largest difference {worst:.2e} (tolerance {tolerance:.2e})"
            );
            ensure!(worst <= tolerance);
            Ok(())
        }),
        GpuTest::new(
            "vertices_stored_as_64_bit_words_are_the_same_strands",
            Requirements::NONE,
            move |ctx| {
                // Where the device has shaderInt64 the generate pass stores each vertex as one
                // u64vec4 (generate_int64.comp) instead of two vec4s: the same bytes, so the same
                // strands bit for bit, for both evaluations, with LOD morphing on and off.
                let asset = head_cap_asset(1500, styled(0.1))?;
                let hair = GpuHair::upload(ctx, &asset, TexturePrecision::F32)?;
                for filtering in [Filtering::StrandCoherent, Filtering::Hardware] {
                    let default = Generator::new(ctx, filtering)?;
                    let vec4 = Generator::with_options(
                        ctx,
                        GeneratorOptions {
                            filtering,
                            vec4_vertex_stores: true,
                            ..GeneratorOptions::default()
                        },
                    )?;
                    ensure!(default.int64_vertex_stores() == ctx.capabilities().shader_int64);
                    ensure!(!vec4.int64_vertex_stores(), "vec4 stores when asked for");
                    for l in [full, lod] {
                        let inputs = inputs_for(&asset, Vec3::new(0.3, 1.8, 1.2), l);
                        let a = default.capture(ctx, &hair, &inputs, GenerationPath::Compute)?;
                        let b = vec4.capture(ctx, &hair, &inputs, GenerationPath::Compute)?;
                        ensure!(
                            !a.strands.is_empty() && a.stats == b.stats,
                            "{:?} vs {:?}",
                            a.stats,
                            b.stats
                        );
                        ensure!(
                            a.strands == b.strands,
                            "{filtering:?}: the two stores give different strands"
                        );
                    }
                }
                if !ctx.capabilities().shader_int64 {
                    eprintln!("  the device has no shaderInt64: both generators store vec4s");
                }
                Ok(())
            },
        ),
        GpuTest::new(
            "an_updated_gpu_hair_generates_what_a_fresh_upload_of_the_edit_does",
            Requirements::NONE,
            move |ctx| {
                // Edit an uploaded asset (tips pulled sideways, one far past the rest bounds), send
                // only the change, and generate: the strands must be those of the edited asset
                // uploaded from scratch, bit for bit, in f32 and f16.
                let asset = head_cap_asset(1500, styled(0.1))?;
                let generator = Generator::new(ctx, Filtering::Manual)?;
                let inputs = inputs_for(&asset, Vec3::new(0.1, 1.75, 0.45), full);
                let tips = asset.mesh().layers.len() as u32 - 1;
                let moves: Vec<VertexMove> = [3u32, 40, 41, 90]
                    .iter()
                    .enumerate()
                    .map(|(i, &v)| {
                        let by =
                            if i == 3 { DVec3::new(0.0, 0.0, 0.5) } else { DVec3::new(0.02, -0.01, 0.015) };
                        VertexMove {
                            layer: tips,
                            vertex: v,
                            position: asset.mesh().layers[tips as usize][v as usize] + by,
                        }
                    })
                    .collect();
                for precision in [TexturePrecision::F32, TexturePrecision::F16] {
                    let mut edited = asset.clone();
                    let mut hair = GpuHair::upload(ctx, &edited, precision)?;
                    let before = generator.capture(ctx, &hair, &inputs, GenerationPath::Compute)?;
                    let first = edited.move_vertices(&moves[..2])?;
                    let second = edited.move_vertices(&moves[2..])?;
                    let change = first.clone().then(&second)?;
                    let sent = hair.update(ctx, &edited, &change)?;
                    ensure!(hair.revision() == 2);
                    let updated = generator.capture(ctx, &hair, &inputs, GenerationPath::Compute)?;
                    let fresh = GpuHair::upload(ctx, &edited, precision)?;
                    let expected = generator.capture(ctx, &fresh, &inputs, GenerationPath::Compute)?;
                    ensure!(updated.stats == expected.stats, "{:?} vs {:?}", updated.stats, expected.stats);
                    ensure!(
                        updated.strands == expected.strands,
                        "{precision:?}: updated and fresh uploads generate different strands"
                    );
                    ensure!(updated.strands != before.strands, "the edit changed nothing");
                    let full_bytes = fresh.bytes.total();
                    eprintln!(
                        "  {precision:?}: {} texel columns in {} regions, {} bundles: {} bytes sent vs {full_bytes} for a fresh upload",
                        sent.texel_columns, sent.regions, sent.bundles, sent.bytes
                    );
                    ensure!(
                        sent.bytes * 4 < full_bytes,
                        "the update sent {} of {full_bytes} bytes",
                        sent.bytes
                    );
                    ensure!(sent.bundles == change.bundles.len() as u64 && sent.bundles > 0);
                    // The edited asset against the f64 reference of the edit.
                    if precision == TexturePrecision::F32 {
                        let e = compare_to_reference(&edited, &inputs, &updated)?;
                        ensure!(e.max_position_widths < 0.05, "{e:?}");
                    }
                    // A change applied twice (or out of order) is refused and changes nothing.
                    let again = hair.update(ctx, &edited, &change).expect_err("stale change").to_string();
                    ensure!(again.contains("revision 2") && again.contains("0..2"), "{again}");
                    ensure!(hair.revision() == 2);
                }
                Ok(())
            },
        ),
        GpuTest::new(
            "strand_coherent_generation_matches_per_vertex_on_hard_cases",
            Requirements::NONE,
            move |ctx| {
                // Roots on face corners and edges (s or t = 0 or 1), triangle bundles (the head
                // cap's pole fan), 1 and 64 layers, vertex LOD at its cap and with morphing, and a
                // bundle of one strand: the coherent strands equal the per-vertex manual ones to f32
                // rounding (same blends, done once per strand) and stay within the reference bounds.
                let with_edge_roots = |mut asset: HairAsset| {
                    let square = [
                        (0.0, 0.0),
                        (1.0, 0.0),
                        (0.0, 1.0),
                        (1.0, 1.0),
                        (0.5, 0.0),
                        (0.0, 0.5),
                        (1.0, 0.5),
                        (0.5, 1.0),
                    ];
                    let triangle = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.5, 0.0), (0.0, 0.5), (0.5, 0.5)];
                    for (sets, points) in
                        [(&mut asset.square_sets, &square[..]), (&mut asset.triangle_sets, &triangle[..])]
                    {
                        for set in sets.iter_mut() {
                            for (p, &(s, t)) in set.points.iter_mut().zip(points) {
                                *p = glam::DVec2::new(s, t);
                            }
                        }
                    }
                    asset
                };
                let layered = |layers: u32| -> anyhow::Result<HairAsset> {
                    // 13 segments: the pole's triangle fan keeps one triangle unpaired.
                    let hm = HairMesh::extrude(
                        &hairmesh::procedural::head_cap(3, 13),
                        &ExtrudeParams { layers, length: 0.18, droop: 0.4, ..ExtrudeParams::default() },
                    )?;
                    Ok(HairAsset::build(
                        &hm,
                        &AssetParams { strands: StrandCount::Total(600), seed: 3, ..Default::default() },
                        styled(0.1),
                    )?)
                };
                let one_strand = {
                    let scalp = hairmesh::ScalpMesh {
                        positions: vec![DVec3::ZERO, DVec3::X * 0.01, DVec3::new(0.01, 0.0, -0.01)],
                        faces: vec![vec![0, 1, 2]],
                        ..Default::default()
                    };
                    let hm = HairMesh::extrude(
                        &scalp,
                        &ExtrudeParams { layers: 2, length: 0.05, ..ExtrudeParams::default() },
                    )?;
                    HairAsset::build(
                        &hm,
                        &AssetParams { strands: StrandCount::Total(1), ..Default::default() },
                        styled(0.01),
                    )?
                };
                // Without length variation, a subgroup's strands of one bundle enter their
                // segments together and fetch the corner texels together (StrandStream); with
                // it (styled), each strand fetches its own.
                let even_lengths = Style { length_variation: 0.0, ..styled(0.1) };
                let cases = [
                    ("head cap, edge roots", with_edge_roots(head_cap_asset(1200, styled(0.1))?)),
                    ("head cap, even lengths", head_cap_asset(6000, even_lengths)?),
                    ("1 layer", with_edge_roots(layered(1)?)),
                    ("64 layers", with_edge_roots(layered(hairmesh::hair_mesh::MAX_LAYERS)?)),
                    ("one strand", one_strand),
                ];
                let cap = LodParams { enabled: false, ..LodParams::default() };
                let morphing = LodParams {
                    strand_alpha: 1.0,
                    vertex_alpha: 40.0,
                    morph_band: 0.8,
                    ..LodParams::default()
                };
                let coherent = Generator::new(ctx, Filtering::StrandCoherent)?;
                let per_vertex = Generator::new(ctx, Filtering::Manual)?;
                for (name, asset) in &cases {
                    ensure!(
                        name != &"1 layer" || !asset.triangle_sets.is_empty(),
                        "the 13-segment head cap has triangle bundles"
                    );
                    let hair = GpuHair::upload(ctx, asset, TexturePrecision::F32)?;
                    let (lo, hi) = asset.bounds();
                    let eye =
                        (0.5 * (lo + hi)).as_vec3() + Vec3::new(0.05, 0.1, 0.4) * (hi - lo).length() as f32;
                    for lod in [cap, morphing] {
                        let inputs = inputs_for(asset, eye, lod);
                        let a = coherent.capture(ctx, &hair, &inputs, GenerationPath::Compute)?;
                        let b = per_vertex.capture(ctx, &hair, &inputs, GenerationPath::Compute)?;
                        ensure!(
                            a.stats == b.stats && !a.strands.is_empty(),
                            "{name}: {:?} vs {:?}",
                            a.stats,
                            b.stats
                        );
                        let tolerance = 1e-5 * asset.textures.normalization.scale as f32;
                        let mut worst = 0f32;
                        let mut worst_tangent = 0f32;
                        for (x, y) in a.strands.iter().zip(&b.strands) {
                            ensure!(
                                (x.bundle, x.index, x.positions.len())
                                    == (y.bundle, y.index, y.positions.len())
                            );
                            for (p, q) in x.positions.iter().zip(&y.positions) {
                                worst = worst.max(p.distance(*q));
                            }
                            for (p, q) in x.tangents.iter().zip(&y.tangents) {
                                worst_tangent = worst_tangent.max(p.angle_between(*q).to_degrees());
                            }
                        }
                        let e = compare_to_reference(asset, &inputs, &a)?;
                        eprintln!(
                            "  {name}, lod {}: {} strands, coherent vs per-vertex {worst:.2e} (tolerance {tolerance:.2e}), tangents {worst_tangent:.4}°; vs reference {:.4} widths",
                            lod.enabled,
                            a.strands.len(),
                            e.max_position_widths
                        );
                        ensure!(worst <= tolerance, "{name}: {worst} > {tolerance}");
                        ensure!(worst_tangent <= 0.05, "{name}: tangents differ by {worst_tangent}°");
                        let bound = (1e-5 * asset.textures.normalization.scale
                            + 0.01 * asset.style.max_displacement())
                            / asset.style.width;
                        ensure!(e.max_position_widths <= bound, "{name}: {e:?} over {bound}");
                    }
                }
                Ok(())
            },
        ),
        GpuTest::new("mesh_path_matches_compute_path", Requirements::MESH_SHADER, move |ctx| {
            let asset = head_cap_asset(1500, styled(0.1))?;
            let hair = GpuHair::upload(ctx, &asset, TexturePrecision::F32)?;
            // Coarse vertex levels pack several strands into one mesh workgroup (16 at 2
            // vertices): a high vertex α exercises that packing, with morphing in between.
            let coarse = LodParams { vertex_alpha: 2000.0, ..lod };
            let coarser = LodParams { vertex_alpha: 20000.0, ..lod };
            for (filtering, lod) in [
                (Filtering::Hardware, full),
                (Filtering::Hardware, lod),
                (Filtering::Hardware, coarse),
                (Filtering::Hardware, coarser),
                (Filtering::StrandCoherent, full),
                (Filtering::StrandCoherent, coarser),
            ] {
                let generator = Generator::new(ctx, filtering)?;
                let inputs = inputs_for(&asset, Vec3::new(0.1, 1.75, 0.45), lod);
                let compute = generator.capture(ctx, &hair, &inputs, GenerationPath::Compute)?;
                let mesh = generator.capture(ctx, &hair, &inputs, GenerationPath::Mesh)?;
                ensure!(compute.strands.len() == mesh.strands.len());
                // Same include, same inputs: the strands agree to f32 rounding (a compiler may
                // contract differently per stage): 1e-5 of the asset's size.
                let tolerance = 1e-5 * asset.textures.normalization.scale as f32;
                let mut largest = 0f32;
                for (a, b) in compute.strands.iter().zip(&mesh.strands) {
                    ensure!(
                        (a.bundle, a.index) == (b.bundle, b.index) && a.positions.len() == b.positions.len()
                    );
                    for (p, q) in a.positions.iter().zip(&b.positions) {
                        let d = p.distance(*q);
                        ensure!(d <= tolerance, "{p} vs {q}");
                        largest = largest.max(d);
                    }
                }
                let (mesh_image, mt) = draw_hair(ctx, &generator, &hair, &inputs, GenerationPath::Mesh)?;
                let (compute_image, ct) =
                    draw_hair(ctx, &generator, &hair, &inputs, GenerationPath::Compute)?;
                // Same triangles in the same order per strand. Where two strands lie on top of
                // each other for a few pixels the depth test picks one of them by rounding, and
                // the paths' positions differ by rounding (2.4e-7 above): those pixels may
                // differ, nothing else. So: mean FLIP ≤ 0.01 and at most 0.5 % of the hair's
                // pixels different (measured ≤ 0.1 %). FLIP's percentiles are no bound here:
                // its filter spreads one pixel over its neighbours.
                let vertex_counts: std::collections::BTreeSet<usize> =
                    compute.strands.iter().map(|s| s.positions.len()).collect();
                if lod.vertex_alpha >= 20000.0 {
                    ensure!(
                        vertex_counts.iter().all(|&n| n <= 5),
                        "packing not exercised: {vertex_counts:?}"
                    );
                }
                let stats = compare(
                    &format!("hair_mesh_vs_compute_{filtering:?}_alpha_{}", lod.vertex_alpha),
                    &mesh_image,
                    &compute_image,
                    Tolerance { mean: 0.01, percentile: (0.99, 1.0) },
                )
                .map_err(anyhow::Error::msg)?;
                let covered = compute_image.pixels.chunks_exact(4).filter(|p| p[0] > 10).count();
                ensure!(covered > 500, "only {covered} hair pixels");
                let differing = differing_pixels(&mesh_image, &compute_image);
                ensure!(
                    differing * 200 <= covered,
                    "{differing} of {covered} hair pixels differ between the mesh and compute paths"
                );
                eprintln!(
                    "  {filtering:?} lod {} vertex α {} (vertices per strand {vertex_counts:?}): positions within {largest:.2e}, {differing} of {covered} pixels differ, FLIP mean {:.5}; mesh {:.1} ms, compute {:.1} ms",
                    lod.enabled,
                    lod.vertex_alpha,
                    stats.mean,
                    mt.passes[0].gpu_ms.unwrap_or(f64::NAN),
                    ct.passes[0].gpu_ms.unwrap_or(f64::NAN)
                );
            }
            Ok(())
        }),
        GpuTest::new("bundles_outside_the_frustum_generate_nothing", Requirements::NONE, move |ctx| {
            let asset = head_cap_asset(800, Style::default())?;
            let hair = GpuHair::upload(ctx, &asset, TexturePrecision::F32)?;
            let generator = Generator::new(ctx, Filtering::Hardware)?;
            // A narrow view of the cap's right side: bundles far from the view axis are out.
            let eye = Vec3::new(0.5, 1.65, 0.0);
            let mut inputs = inputs_for(&asset, eye, full);
            let proj = glam::Mat4::perspective_rh(0.2, 1.0, 0.01, 10.0);
            inputs.view_proj = glam::Mat4::from_scale(Vec3::new(1.0, -1.0, 1.0))
                * proj
                * glam::Mat4::look_at_rh(eye, Vec3::new(0.1, 1.65, 0.0), Vec3::Y);
            let capture = generator.capture(ctx, &hair, &inputs, GenerationPath::Compute)?;
            let stats = capture.stats;
            eprintln!(
                "  culled {} of {} bundles, {} strands",
                stats.bundles_culled, stats.bundles, stats.strands
            );
            ensure!(stats.bundles_culled > 0 && stats.bundles_culled < stats.bundles, "{stats:?}");
            let generated: std::collections::HashSet<u32> =
                capture.strands.iter().map(|s| s.bundle).collect();
            // The CPU's view of each bundle's bounds, with a margin against f32 rounding at the
            // frustum planes: clearly outside → nothing; clearly inside → all its strands.
            for (b, info) in asset.bundles.iter().enumerate() {
                let corners: Vec<glam::Vec4> = (0..8)
                    .map(|c| {
                        let p = DVec3::new(
                            if c & 1 != 0 { info.bounds_max.x } else { info.bounds_min.x },
                            if c & 2 != 0 { info.bounds_max.y } else { info.bounds_min.y },
                            if c & 4 != 0 { info.bounds_max.z } else { info.bounds_min.z },
                        );
                        inputs.view_proj * p.as_vec3().extend(1.0)
                    })
                    .collect();
                let outside = |f: &dyn Fn(&glam::Vec4) -> f32| corners.iter().all(|c| f(c) > 1e-3);
                let clearly_out = outside(&|c| -c.x - c.w)
                    || outside(&|c| c.x - c.w)
                    || outside(&|c| -c.y - c.w)
                    || outside(&|c| c.y - c.w)
                    || outside(&|c| -c.z)
                    || outside(&|c| c.z - c.w);
                let inside = |c: &glam::Vec4| {
                    c.x.abs() < c.w - 1e-3 && c.y.abs() < c.w - 1e-3 && c.z > 1e-3 && c.z < c.w - 1e-3
                };
                let clearly_in = corners.iter().any(inside);
                ensure!(
                    !(clearly_out && generated.contains(&(b as u32))),
                    "bundle {b} is outside the frustum but generated strands"
                );
                ensure!(
                    !clearly_in || generated.contains(&(b as u32)),
                    "bundle {b} is in view but generated nothing"
                );
            }
            ensure!(stats.strands == capture.strands.len() as u64);
            Ok(())
        }),
        GpuTest::new("lod_extremes_stay_valid_on_the_gpu", Requirements::NONE, move |ctx| {
            let asset = head_cap_asset(800, styled(0.1))?;
            let hair = GpuHair::upload(ctx, &asset, TexturePrecision::F32)?;
            let generator = Generator::new(ctx, Filtering::Hardware)?;
            for (eye, what) in
                [(Vec3::new(0.0, 1.6, 0.0), "eye at the centre"), (Vec3::new(0.0, 1.7, 1e5), "far away")]
            {
                // The reference does not cull; here all bundles must come out.
                let mut inputs = FrameInputs { cull: false, ..inputs_for(&asset, eye, lod) };
                if what == "far away" {
                    // Keep it in view: a narrow frustum 100 km away.
                    inputs.view_proj = glam::Mat4::from_scale(Vec3::new(1.0, -1.0, 1.0))
                        * glam::Mat4::perspective_rh(1e-5, 1.0, 10.0, 2e5)
                        * glam::Mat4::look_at_rh(eye, Vec3::new(0.0, 1.65, 0.0), Vec3::Y);
                }
                let capture = generator.capture(ctx, &hair, &inputs, GenerationPath::Compute)?;
                let e = compare_to_reference(&asset, &inputs, &capture).with_context(|| what.to_owned())?;
                let per_bundle = capture.strands.len() as f64 / asset.bundles.len() as f64;
                eprintln!(
                    "  {what}: {} strands ({per_bundle:.2} per bundle), max error {:.4} widths",
                    e.strands, e.max_position_widths
                );
                ensure!(capture.strands.iter().all(|s| s.positions.iter().all(|p| p.is_finite())));
                if what == "far away" {
                    ensure!(
                        capture.strands.len() == asset.bundles.len(),
                        "≥1 and here exactly 1 strand per bundle"
                    );
                    ensure!(
                        capture.strands.iter().all(|s| s.positions.len() == 2),
                        "lowest vertex level: 2 vertices"
                    );
                } else {
                    ensure!(
                        capture.strands.iter().all(|s| s.positions.len() == 33),
                        "highest vertex level: 33 vertices"
                    );
                }
            }
            Ok(())
        }),
        GpuTest::new("exact_cubic_variant_matches_the_cpu_cubic", Requirements::NONE, move |ctx| {
            let mut asset = head_cap_asset(600, styled(0.1))?;
            let hair = GpuHair::upload(ctx, &asset, TexturePrecision::F32)?;
            let generator = Generator::with_options(
                ctx,
                GeneratorOptions {
                    filtering: Filtering::Manual,
                    exact_cubic: true,
                    ..GeneratorOptions::default()
                },
            )?;
            let inputs = inputs_for(&asset, Vec3::new(0.0, 1.7, 0.5), full);
            let capture = generator.capture(ctx, &hair, &inputs, GenerationPath::Compute)?;
            let quadratic = compare_to_reference(&asset, &inputs, &capture)?;
            asset.curve = CurveEvaluation::Cubic;
            let cubic = compare_to_reference(&asset, &inputs, &capture)?;
            eprintln!(
                "  exact cubic on the GPU: {:.4} widths from the CPU cubic; the quadratics differ from it by up to {:.3} widths",
                cubic.max_position_widths, quadratic.max_position_widths
            );
            let bound = (1e-5 * asset.textures.normalization.scale + 0.01 * asset.style.max_displacement())
                / asset.style.width;
            ensure!(cubic.max_position_widths <= bound, "{cubic:?}");
            ensure!(
                quadratic.max_position_widths > cubic.max_position_widths,
                "the variant is really different"
            );
            Ok(())
        }),
        GpuTest::new("a_view_that_sees_nothing_generates_zero_strands", Requirements::NONE, move |ctx| {
            let asset = head_cap_asset(500, Style::default())?;
            let hair = GpuHair::upload(ctx, &asset, TexturePrecision::F32)?;
            let generator = Generator::new(ctx, Filtering::Hardware)?;
            // Looking away from the hair.
            let mut inputs = inputs_for(&asset, Vec3::new(0.0, 1.7, 0.5), lod);
            inputs.view_proj = glam::Mat4::perspective_rh(0.8, 1.0, 0.01, 10.0)
                * glam::Mat4::look_at_rh(Vec3::new(0.0, 1.7, 0.5), Vec3::new(0.0, 1.7, 2.0), Vec3::Y);
            for path in [GenerationPath::Compute, GenerationPath::Mesh] {
                if path == GenerationPath::Mesh && ctx.capabilities().mesh_shader.is_none() {
                    continue;
                }
                let capture = generator.capture(ctx, &hair, &inputs, path)?;
                ensure!(
                    capture.strands.is_empty() && capture.stats.bundles_culled == capture.stats.bundles,
                    "{:?}",
                    capture.stats
                );
                let (image, _) = draw_hair(ctx, &generator, &hair, &inputs, path)?;
                ensure!(
                    image.pixels.chunks_exact(4).all(|p| p[0] < 10),
                    "{path}: an empty view draws nothing"
                );
            }
            Ok(())
        }),
        GpuTest::new("strand_buffers_are_chunked_past_the_storage_range", Requirements::NONE, move |ctx| {
            // Chunks of 256 slots stand in for the 128 MiB range (127k slots on lavapipe).
            let asset = head_cap_asset(1500, styled(0.1))?;
            let hair = GpuHair::upload(ctx, &asset, TexturePrecision::F32)?;
            let chunked = Generator::with_options(
                ctx,
                GeneratorOptions { max_chunk_slots: Some(256), ..GeneratorOptions::default() },
            )?;
            let whole = Generator::new(ctx, Filtering::default())?;
            let inputs = inputs_for(&asset, Vec3::new(0.0, 1.7, 0.5), full);
            let frame = chunked.prepare(ctx, &hair, &inputs)?;
            ensure!(frame.chunks() == 6, "{} chunks", frame.chunks());
            let capture = chunked.capture(ctx, &hair, &inputs, GenerationPath::Compute)?;
            let e = compare_to_reference(&asset, &inputs, &capture)?;
            ensure!(e.strands == 1500 && e.max_position_widths < 0.05, "{e:?}");
            let (a, _) = draw_hair(ctx, &chunked, &hair, &inputs, GenerationPath::Compute)?;
            let (b, _) = draw_hair(ctx, &whole, &hair, &inputs, GenerationPath::Compute)?;
            ensure!(a == b, "chunked and whole draws differ");
            if ctx.capabilities().mesh_shader.is_some() {
                let refused = chunked.capture(ctx, &hair, &inputs, GenerationPath::Mesh);
                ensure!(
                    matches!(refused, Err(gen_gpu::GpuError::OverBudget { .. })),
                    "mesh capture spans one chunk"
                );
            }
            Ok(())
        }),
        GpuTest::new("requests_over_the_budget_fail_before_allocating", Requirements::NONE, move |ctx| {
            // 16 chunks of 64 slots hold 1024 strands; 1500 do not fit.
            let asset = head_cap_asset(1500, Style::default())?;
            let hair = GpuHair::upload(ctx, &asset, TexturePrecision::F32)?;
            let generator = Generator::with_options(
                ctx,
                GeneratorOptions { max_chunk_slots: Some(64), ..GeneratorOptions::default() },
            )?;
            let inputs = inputs_for(&asset, Vec3::new(0.0, 1.7, 0.5), full);
            match generator.capture(ctx, &hair, &inputs, GenerationPath::Compute) {
                Err(gen_gpu::GpuError::OverBudget { requested, budget, .. }) => {
                    ensure!(requested > budget, "{requested} vs {budget}");
                    Ok(())
                }
                other => bail!("expected an over-budget error, got {:?}", other.map(|c| c.strands.len())),
            }
        }),
        GpuTest::new("bundles_of_different_lengths_match_the_reference", Requirements::NONE, move |ctx| {
            // Tip layers 1..=4 side by side (a short fringe beside a long back): each bundle's
            // strands end at their own layer, under strand and vertex LOD too, on every
            // filtering and precision of the compute path and (where the device has it) on
            // the mesh path.
            let mut asset = head_cap_asset(1500, styled(0.1))?;
            let layers = asset.mesh().layer_count() as u32;
            for b in 0..asset.bundles.len() as u32 {
                asset.set_tip_layer(&[b], 1 + b % layers)?;
            }
            let short = asset.bundles.iter().map(|b| b.length).fold(f64::INFINITY, f64::min);
            let long = asset.bundles.iter().map(|b| b.length).fold(0.0, f64::max);
            ensure!(short < 0.4 * long, "the bundles are not of different lengths: {short} vs {long}");
            let (near, far) = (Vec3::new(0.0, 1.7, 0.5), Vec3::new(0.3, 1.8, 3.0));
            // Coarse enough at the far eye to drop strands and vertices (short bundles first).
            let coarse = LodParams { strand_alpha: 8.0, vertex_alpha: 24.0, ..lod };
            check_oracle(ctx, "mixed tip layers", &asset, &[near, far], &[full, coarse])?;
            if ctx.capabilities().mesh_shader.is_some() {
                let hair = GpuHair::upload(ctx, &asset, TexturePrecision::F32)?;
                let generator = Generator::new(ctx, Filtering::StrandCoherent)?;
                for (eye, l) in [(near, full), (far, coarse)] {
                    let inputs = inputs_for(&asset, eye, l);
                    let capture = generator.capture(ctx, &hair, &inputs, GenerationPath::Mesh)?;
                    let e = compare_to_reference(&asset, &inputs, &capture)?;
                    eprintln!("  mixed tip layers, mesh path, lod {}: {e:?}", l.enabled);
                    ensure!(e.strands > 0 && e.max_position_widths <= 0.05, "mesh path: {e:?}");
                    if l.enabled {
                        ensure!(
                            e.strands < 1500 && e.vertices < 33 * e.strands,
                            "LOD kept every strand and vertex: {e:?}"
                        );
                    }
                }
            } else {
                eprintln!(
                    "  mixed tip layers: no mesh shaders on this device, the mesh path is not compared"
                );
            }
            Ok(())
        }),
        GpuTest::new("strands_stay_out_of_the_head_as_in_the_reference", Requirements::NONE, move |ctx| {
            // Long hair draped over the sample head, converted with its head field: every
            // strand vertex the GPU generates is outside the head (by the exact surface), as the
            // reference's are; without the field, vertices of the same hair enter it.
            let head = data_set::locate(data_set::SAMPLE_HEAD)?;
            let mesh = hairmesh::import::load_scalp(&head, &hairmesh::ScalpSelector::All)?;
            let surface = hairmesh::head::HeadSurface::from_mesh(&mesh);
            let frame = hairmesh::head_frame::HeadFrame::estimate(&mesh).context("head frame")?;
            let settings = hairmesh::convert::ConvertSettings {
                scalp: "auto".into(),
                layers: 6,
                length: Some(2.5 * frame.radius),
                shape: hairmesh::convert::LayerShape::Drape {
                    centre: frame.centre,
                    comb: -2.5 * frame.front,
                    lift: 0.04,
                },
                up: frame.up,
                strands: 3000,
                style: styled(frame.radius * 5.0),
                ..hairmesh::convert::ConvertSettings::default()
            };
            let asset = hairmesh::convert::convert_scalp(&head, &settings, &mut |_| {})?.asset;
            let field = asset.head_field.as_ref().context("no head field")?;
            let tolerance = hairmesh::head::CHECK_TOLERANCE * surface.size();
            let inside = |capture: &Capture| -> usize {
                capture
                    .strands
                    .iter()
                    .flat_map(|s| s.positions.iter().skip(1))
                    .filter(|p| surface.signed_distance(p.as_dvec3()) < -tolerance)
                    .count()
            };
            let eye = (frame.centre + frame.front * 6.0 * frame.radius).as_vec3();
            let mut bare = asset.clone();
            bare.head_field = None;
            for (filtering, precision) in [
                (Filtering::StrandCoherent, TexturePrecision::F32),
                (Filtering::Hardware, TexturePrecision::F16),
            ] {
                let generator = Generator::new(ctx, filtering)?;
                let inputs = inputs_for(&asset, eye, full);
                let capture = generator.capture(
                    ctx,
                    &GpuHair::upload(ctx, &asset, precision)?,
                    &inputs,
                    GenerationPath::Compute,
                )?;
                let e = compare_to_reference(&asset, &inputs, &capture)?;
                let without = generator.capture(
                    ctx,
                    &GpuHair::upload(ctx, &bare, precision)?,
                    &inputs,
                    GenerationPath::Compute,
                )?;
                let (kept, entered) = (inside(&capture), inside(&without));
                eprintln!(
                    "  {filtering:?}/{precision:?}: {} vertices, {kept} inside the head with the field ({}×{}×{}), {entered} without; against the reference: position max {:.4} mean {:.5} widths",
                    e.vertices,
                    field.distance.width,
                    field.distance.height,
                    field.distance.depth,
                    e.max_position_widths,
                    e.mean_position_widths
                );
                ensure!(entered > 0, "without the field no vertex enters the head: the test shows nothing");
                ensure!(kept == 0, "{kept} generated vertices inside the head");
                // (Half-float textures are off by more than this anyway: check_oracle's bounds.)
                if precision == TexturePrecision::F32 {
                    ensure!(e.mean_position_widths < 0.01 && e.max_position_widths < 0.5, "{e:?}");
                }
            }
            Ok(())
        }),
        GpuTest::new("a_bundle_with_one_strand_and_tiny_assets", Requirements::NONE, move |ctx| {
            let scalp = hairmesh::ScalpMesh {
                positions: vec![
                    DVec3::ZERO,
                    DVec3::X * 0.01,
                    DVec3::new(0.01, 0.0, -0.01),
                    DVec3::new(0.0, 0.0, -0.01),
                ],
                faces: vec![vec![0, 1, 2, 3]],
                ..Default::default()
            };
            let hm = HairMesh::extrude(
                &scalp,
                &ExtrudeParams { layers: 1, length: 0.05, ..ExtrudeParams::default() },
            )?;
            let asset = HairAsset::build(
                &hm,
                &AssetParams {
                    strands: StrandCount::Total(1),
                    sample_sets: 1,
                    seed: 1,
                    ..Default::default()
                },
                styled(0.01),
            )?;
            let hair = GpuHair::upload(ctx, &asset, TexturePrecision::F32)?;
            let generator = Generator::new(ctx, Filtering::Hardware)?;
            let inputs = inputs_for(&asset, Vec3::new(0.0, 0.03, 0.1), full);
            let capture = generator.capture(ctx, &hair, &inputs, GenerationPath::Compute)?;
            ensure!(capture.strands.len() == 1);
            let e = compare_to_reference(&asset, &inputs, &capture)?;
            ensure!(e.max_position_widths < 0.05, "{e:?}");
            Ok(())
        }),
    ])
}
