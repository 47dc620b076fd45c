//! The compute rasterizer against its CPU port (coverage and visibility, strand by strand, on
//! the hard cases: the screen edge, the near plane, behind the camera, zero-width, sub-pixel and
//! very wide strands, an odd output size), against the triangle raster on whole scenes (FLIP
//! and hair density), and determinism, empty and tiny frames, the `raster` choice. GPU harness,
//! validation layer on.

use std::process::ExitCode;

use anyhow::{Context as _, ensure};
use gen_gpu::{FrameInputs, GenerationPath, StoredStrands};
use glam::{Mat4, Vec3};
use hairkit_tests::harness::{GpuTest, Requirements, run_gpu_tests};
use hairkit_tests::image_compare::{Tolerance, compare, output_dir};
use hairkit_tests::scenes::{scene_with, scene_with_edit, sintel_scene};
use render::cpu::raster::{self as cpu, RasterView, StrandPoint};
use render::frame::{RenderedFrame, SceneRenderer};
use render::raster::{
    ComputeRaster, DepthClipping, FusedStrands, LoadPath, RasterPath, claimed_slots, coverage_sum,
};
use render::scene::{LoadedScene, load_scene};

/// Mean alpha (hair + occluder coverage) of a frame.
fn mean_alpha(frame: &RenderedFrame) -> f64 {
    let n = (frame.linear.rgba.len() / 4).max(1) as f64;
    frame.linear.rgba.chunks_exact(4).map(|p| f64::from(p[3])).sum::<f64>() / n
}

/// `name` at `size` with `effects` through `raster`; the image is written for inspection.
fn render(
    ctx: &gen_gpu::Context,
    name: &str,
    size: (u32, u32),
    mut effects: serde_json::Value,
    raster: &str,
) -> anyhow::Result<RenderedFrame> {
    let dir = tempfile::tempdir()?;
    if let Some(e) = effects.as_object_mut() {
        e.insert("raster".into(), serde_json::json!(raster));
    }
    let scene = load_scene(&scene_with(dir.path(), name, size.0, size.1, effects)?)?;
    let renderer = SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?;
    let expected = if raster == "compute" { RasterPath::Compute } else { RasterPath::Triangles };
    ensure!(renderer.raster() == expected, "{raster}: the renderer uses {:?}", renderer.raster());
    let frame = renderer.render(ctx)?;
    let file = output_dir().join(format!("raster-{name}-{raster}.png"));
    render::output::write_png(&file, &frame.image)?;
    Ok(frame)
}

/// The compute rasterizer against the triangle raster on one scene: mean FLIP against the
/// triangle raster's images in the same transparency mode and in OIT (the closer counts: the
/// compute rasterizer keeps the coverage that the opaque mode loses behind sub-pixel strands,
/// as OIT does), and the hair's density (mean alpha) against blended mode's (the triangle mode
/// that keeps the coverage of sub-pixel strands).
fn against_triangles(
    ctx: &gen_gpu::Context,
    name: &str,
    size: (u32, u32),
    effects: serde_json::Value,
    flip_mean: f32,
) -> anyhow::Result<()> {
    let with = |transparency: &str| {
        let mut e = effects.clone();
        if let Some(o) = e.as_object_mut() {
            o.insert("transparency".into(), serde_json::json!(transparency));
        }
        e
    };
    let compute = render(ctx, name, size, effects.clone(), "compute")?;
    ensure!(
        compute.passes.iter().any(|p| p.starts_with("raster hair (compute raster, fused generation)"))
            && compute.passes.iter().any(|p| p == "resolve hair (compute raster)"),
        "{:?}",
        compute.passes
    );
    let triangles = render(ctx, name, size, effects.clone(), "triangles")?;
    let blended = render(ctx, name, size, with("blended"), "triangles")?;
    let oit = render(ctx, name, size, with("oit"), "triangles")?;
    let any = Tolerance { mean: 1.0, percentile: (0.99, 1.0) };
    let flip = |reference: &RenderedFrame, what: &str| {
        compare(&format!("raster_{name}_{what}"), &compute.image, &reference.image, any)
            .map_err(anyhow::Error::msg)
    };
    let (vs_same, vs_oit) = (flip(&triangles, "same_mode")?, flip(&oit, "oit")?);
    let (c, t, b) = (mean_alpha(&compute), mean_alpha(&triangles), mean_alpha(&blended));
    eprintln!(
        "  {name}: FLIP mean vs the triangle raster {:.4} (same mode), {:.4} (OIT); mean alpha compute {c:.4}, triangles {t:.4}, blended {b:.4}",
        vs_same.mean, vs_oit.mean
    );
    ensure!(
        vs_same.mean.min(vs_oit.mean) <= flip_mean,
        "FLIP {:.4} / {:.4} over {flip_mean}",
        vs_same.mean,
        vs_oit.mean
    );
    ensure!((c - b).abs() <= 0.03 * b, "the density should be blended mode's: alpha {c:.4} vs {b:.4}");
    Ok(())
}

/// Vertices of a stored strand as `StoredStrands::upload` makes them (≤ 33 points): the same
/// tangents (the reference's Eq. 5–6) and taper, for the CPU port.
fn stored_points(points: &[Vec3], width: f32, tip_width: f32) -> Vec<StrandPoint> {
    let as_f64: Vec<glam::DVec3> = points.iter().map(|p| p.as_dvec3()).collect();
    let tangents = hairmesh::reference::tangents(&as_f64);
    let n = points.len();
    points
        .iter()
        .zip(&tangents)
        .enumerate()
        .map(|(k, (&position, t))| {
            let tau = k as f32 / (n - 1) as f32;
            StrandPoint {
                position,
                width: width * (1.0 + (tip_width - 1.0) * tau),
                tangent: t.as_vec3(),
                tau,
            }
        })
        .collect()
}

/// A `width × height` frame seen from z = 1 looking down −z (60° vertical field of view).
fn camera_at_z1(width: u32, height: u32) -> FrameInputs {
    let proj = Mat4::perspective_rh(60f32.to_radians(), width as f32 / height as f32, 0.01, 100.0);
    let flip = Mat4::from_scale(Vec3::new(1.0, -1.0, 1.0));
    let eye = Vec3::new(0.0, 0.0, 1.0);
    FrameInputs {
        view_proj: flip * proj * Mat4::look_at_rh(eye, Vec3::ZERO, Vec3::Y),
        view: hairmesh::reference::ViewParams {
            eye: eye.as_dvec3(),
            vertical_resolution: f64::from(height),
            projection: hairmesh::reference::Projection::Perspective { fov_y: 60f64.to_radians() },
        },
        lod: hairmesh::reference::LodParams::default(),
        viewport: [width, height],
        cull: false,
    }
}

/// A straight strand from `a` to `b` with `n` points.
fn line(a: Vec3, b: Vec3, n: usize) -> Vec<Vec3> {
    (0..n).map(|k| a.lerp(b, k as f32 / (n - 1) as f32)).collect()
}

/// The raster kernel twice: reading through buffer references (where the device has them, as
/// frames do) and through the bindings (`LoadPath`), whose outputs must be the same.
struct KernelPair {
    referenced: ComputeRaster,
    bound: ComputeRaster,
}

impl KernelPair {
    /// Kernels for any number of visibility slots (they read K from their push constants).
    fn new(ctx: &gen_gpu::Context) -> anyhow::Result<Self> {
        Self::specialized(ctx, None)
    }

    /// Kernels specialized for `slots` visibility slots per pixel as frames make them (`None`:
    /// any).
    fn specialized(ctx: &gen_gpu::Context, slots: Option<u32>) -> anyhow::Result<Self> {
        let pair = Self {
            referenced: ComputeRaster::new(
                ctx,
                1,
                1,
                LoadPath::BufferReferences,
                slots,
                FusedStrands::Styled,
            )?,
            bound: ComputeRaster::new(ctx, 1, 1, LoadPath::Bindings, slots, FusedStrands::Styled)?,
        };
        let wanted = if ctx.capabilities().buffer_device_address {
            LoadPath::BufferReferences
        } else {
            LoadPath::Bindings
        };
        ensure!(
            pair.referenced.load_path() == wanted,
            "references where the device has buffer device addresses"
        );
        ensure!(pair.bound.load_path() == LoadPath::Bindings, "bindings when asked for");
        Ok(pair)
    }
}

/// Rasterizes `strands` (each with its root width) on the GPU and with the CPU port; returns
/// both, after checking they agree: the covered pixels, every pixel's coverage (fixed point,
/// within 1 % + 2 units) and the visibility words' depth, tangent and τ bits.
fn kernel_vs_port(
    ctx: &gen_gpu::Context,
    rasters: &KernelPair,
    inputs: &FrameInputs,
    strands: &[(Vec<Vec3>, f32)],
) -> anyhow::Result<(cpu::RasterBuffers, cpu::RasterBuffers)> {
    let [width, height] = inputs.viewport;
    let eye = inputs.view.eye.as_vec3();
    let view = RasterView {
        view_proj: inputs.view_proj,
        eye,
        width,
        height,
        model: Mat4::IDENTITY,
        max_half_width: 64.0,
    };
    let mut port = cpu::RasterBuffers::new(width, height);
    let mut gpu = cpu::RasterBuffers::new(width, height);
    for (points, w) in strands {
        let stored = StoredStrands::upload(ctx, points, &[points.len() as u32], *w, 0.5)?;
        let one = rasters.referenced.rasterize_stored(ctx, &stored, inputs, Mat4::IDENTITY, 3)?;
        // The plain loads through buffer references or through the binding: the same words.
        let bound = rasters.bound.rasterize_stored(ctx, &stored, inputs, Mat4::IDENTITY, 3)?;
        ensure!(one == bound, "reading through buffer references changed the kernel's output");
        // A strand wholly inside the view volume's depth goes through the kernel without depth
        // clipping (as in frames): the kernel with it leaves the same words.
        if DepthClipping::for_bounds(inputs.view_proj, stored.bounds) == DepthClipping::Skip {
            let words = |clipping| {
                rasters.referenced.rasterize_stored_words(
                    ctx,
                    &stored,
                    inputs,
                    Mat4::IDENTITY,
                    3,
                    1,
                    None,
                    Some(clipping),
                )
            };
            ensure!(
                words(DepthClipping::Skip)? == words(DepthClipping::Clip)?,
                "skipping the depth clipping changed the kernel's output"
            );
        }
        cpu::raster_strand(&view, &mut port, &stored_points(points, *w, 0.5), 3, 0.0);
        for i in 0..one.visibility.len() {
            gpu.visibility[i] = gpu.visibility[i].min(one.visibility[i]);
            gpu.coverage[i] += one.coverage[i];
        }
    }
    agrees_with_port(&gpu, &port)?;
    Ok((gpu, port))
}

/// The CPU port's view of `inputs`, and `strands` (one width for all) uploaded as one set, so
/// that one dispatch draws them all and its invocations race for the same pixels.
fn upload_together(
    ctx: &gen_gpu::Context,
    inputs: &FrameInputs,
    strands: &[(Vec<Vec3>, f32)],
) -> anyhow::Result<(RasterView, StoredStrands)> {
    let [width, height] = inputs.viewport;
    let view = RasterView {
        view_proj: inputs.view_proj,
        eye: inputs.view.eye.as_vec3(),
        width,
        height,
        model: Mat4::IDENTITY,
        max_half_width: 64.0,
    };
    let points: Vec<Vec3> = strands.iter().flat_map(|(p, _)| p.iter().copied()).collect();
    let counts: Vec<u32> = strands.iter().map(|(p, _)| p.len() as u32).collect();
    let width_of_all = strands.first().context("no strands")?.1;
    ensure!(strands.iter().all(|(_, w)| *w == width_of_all), "one width for all the strands");
    Ok((view, StoredStrands::upload(ctx, &points, &counts, width_of_all, 0.5)?))
}

/// Rasterizes `strands` (one width) in one dispatch with one slot per pixel, through both load
/// paths, where invocations race for the same pixels and dense pixels turn opaque early, and
/// checks both against the CPU port as [`kernel_vs_port`] does (coverage clamped at the limit,
/// the sum the resolve reads): whatever lets a fragment skip its atomics must only skip
/// fragments that would change nothing.
fn dense_opaque_vs_port(
    ctx: &gen_gpu::Context,
    rasters: &KernelPair,
    inputs: &FrameInputs,
    strands: &[(Vec<Vec3>, f32)],
) -> anyhow::Result<()> {
    let [width, height] = inputs.viewport;
    let (view, stored) = upload_together(ctx, inputs, strands)?;
    let mut port = cpu::RasterBuffers::new(width, height);
    for (p, w) in strands {
        cpu::raster_strand(&view, &mut port, &stored_points(p, *w, 0.5), 3, 0.0);
    }
    let opaque =
        (0..port.coverage.len()).filter(|&i| port.coverage[i] >= u64::from(cpu::COVERAGE_LIMIT)).count();
    ensure!(opaque > 100, "too few opaque pixels ({opaque}) to test the fragments that skip their atomics");
    for raster in [&rasters.referenced, &rasters.bound] {
        let words = raster.rasterize_stored_words(ctx, &stored, inputs, Mat4::IDENTITY, 3, 1, None, None)?;
        let gpu = cpu::RasterBuffers {
            width,
            height,
            visibility: words.iter().step_by(2).copied().collect(),
            coverage: words.iter().skip(1).step_by(2).map(|&w| coverage_sum(w)).collect(),
        };
        agrees_with_port(&gpu, &port)?;
    }
    Ok(())
}

/// The checks of [`kernel_vs_port`]: the same pixels covered, coverage (clamped at the limit)
/// within 1 % + 2 units and the nearest words' depth and tangent within a step, but in at most
/// 0.5 % of the pixels.
fn agrees_with_port(gpu: &cpu::RasterBuffers, port: &cpu::RasterBuffers) -> anyhow::Result<()> {
    let covered = |b: &cpu::RasterBuffers| b.coverage.iter().filter(|&&c| c > 0).count();
    let (n_gpu, n_port) = (covered(gpu), covered(port));
    let mut coverage_off = 0;
    let mut word_off = 0;
    // The octahedral tangent's two 9-bit coordinates may round one step apart.
    let tangent_close = |a: u64, b: u64| {
        let (ta, tb) = ((a >> 12) & 0x3ffff, (b >> 12) & 0x3ffff);
        ((ta >> 9) as i64 - (tb >> 9) as i64).abs() <= 1 && ((ta & 511) as i64 - (tb & 511) as i64).abs() <= 1
    };
    let limit = u64::from(cpu::COVERAGE_LIMIT);
    for i in 0..gpu.coverage.len() {
        let (g, p) = (gpu.coverage[i].min(limit) as f64, port.coverage[i].min(limit) as f64);
        if (g - p).abs() > 0.01 * p.max(g) + 2.0 {
            coverage_off += 1;
        }
        let (gw, pw) = (gpu.visibility[i], port.visibility[i]);
        let agree = match (gw == u64::MAX, pw == u64::MAX) {
            (true, true) => true,
            (false, false) => {
                let depth_step = ((gw >> 40) as i64 - (pw >> 40) as i64).abs();
                // One depth step apart, another fragment may win.
                depth_step <= 1 && (depth_step == 1 || tangent_close(gw, pw))
            }
            _ => false,
        };
        if !agree {
            word_off += 1;
        }
    }
    eprintln!(
        "  {n_gpu} pixels covered on the GPU, {n_port} by the CPU port; {coverage_off} coverages and {word_off} visibility words differ"
    );
    let allowed = (n_port as f64 * 0.005).ceil() as usize;
    ensure!(coverage_off <= allowed && word_off <= allowed, "more than {allowed} pixels differ");
    Ok(())
}

/// With K > 1 slots the kernel keeps each pixel's K nearest fragments unordered, claiming
/// empty slots through the coverage word's count and then replacing the farthest by
/// compare-and-swap: rasterizes `strands` (uploaded together, so invocations race for the same
/// pixels) twice on the GPU and checks every pixel: the filled slots come first, at least as
/// many slots were claimed as are filled (every fill but those after a failed claim or past K
/// went through a claim), the threshold word is at or beyond the farthest of them (all ones
/// while a slot is empty),
/// both runs keep the same set of words and the same coverage, and the set is the CPU port's K
/// nearest fragments (sorted, word by word within a depth step; at most 1 % of the pixels may
/// differ, by fragments on pixel boundaries). Returns the pixels holding K fragments.
fn k_nearest_vs_port(
    ctx: &gen_gpu::Context,
    rasters: &KernelPair,
    inputs: &FrameInputs,
    strands: &[(Vec<Vec3>, f32)],
    k: u32,
) -> anyhow::Result<usize> {
    let [width, height] = inputs.viewport;
    let (view, stored) = upload_together(ctx, inputs, strands)?;
    let stride = render::raster::pixel_stride(k) as usize;
    let runs = [
        rasters.referenced.rasterize_stored_words(ctx, &stored, inputs, Mat4::IDENTITY, 3, k, None, None)?,
        rasters.bound.rasterize_stored_words(ctx, &stored, inputs, Mat4::IDENTITY, 3, k, None, None)?,
    ];
    // A third run over words where an earlier insertion (the volume march's, which claims no
    // slot) filled every pixel's first slot with the nearest word there can be: the strands'
    // claims count from 0 and find that slot taken, and it must stay among the K nearest.
    let earlier = 5u64 << 32;
    let mut initial = vec![u64::MAX; (width * height) as usize * stride];
    for pixel in initial.chunks_exact_mut(stride) {
        pixel[0] = earlier;
    }
    let over_earlier = rasters.referenced.rasterize_stored_words(
        ctx,
        &stored,
        inputs,
        Mat4::IDENTITY,
        3,
        k,
        Some(&initial),
        None,
    )?;
    let mut port: Vec<Vec<u64>> = vec![Vec::new(); (width * height) as usize];
    for (p, w) in strands {
        cpu::strand_fragments(&view, &stored_points(p, *w, 0.5), 3, 0.0, |pixel, _, word| {
            port[pixel].push(word);
        });
    }
    let k = k as usize;
    // `unclaimed`: slots the words started with filled (no claim counted for them).
    let sorted_slots = |words: &[u64], pixel: usize, unclaimed: usize| -> anyhow::Result<Vec<u64>> {
        let w = &words[pixel * stride..(pixel + 1) * stride];
        let filled = w[..k].iter().take_while(|&&x| x != u64::MAX).count();
        ensure!(
            w[filled..k].iter().all(|&x| x == u64::MAX),
            "pixel {pixel}: slots filled out of order: {w:x?}"
        );
        let claimed = claimed_slots(w[k]) as usize;
        ensure!(claimed + unclaimed >= filled, "pixel {pixel}: {filled} slots filled, {claimed} claimed");
        let farthest = w[..filled].iter().copied().max().unwrap_or(0);
        let threshold = w[k + 1];
        ensure!(
            threshold >= farthest && (filled == k || threshold == u64::MAX),
            "pixel {pixel}: threshold {threshold:x} below the farthest slot {farthest:x} or set early"
        );
        let mut s = w[..filled].to_vec();
        s.sort_unstable();
        Ok(s)
    };
    let depth_step = |a: u64, b: u64| ((a >> 42) as i64 - (b >> 42) as i64).abs();
    let mut off = 0;
    let mut full = 0;
    let mut covered = 0;
    for (pixel, fragments) in port.iter_mut().enumerate() {
        let gpu = sorted_slots(&runs[0], pixel, 0)?;
        // Coverage past its limit depends on the order (it is read clamped there).
        let coverage =
            |run: &[u64]| coverage_sum(run[pixel * stride + k]).min(u64::from(cpu::COVERAGE_LIMIT));
        ensure!(
            gpu == sorted_slots(&runs[1], pixel, 0)? && coverage(&runs[0]) == coverage(&runs[1]),
            "pixel {pixel}: two runs kept different words"
        );
        fragments.sort_unstable();
        fragments.truncate(k);
        covered += usize::from(!fragments.is_empty());
        full += usize::from(gpu.len() == k);
        let agree = gpu.len() == fragments.len()
            && gpu.iter().zip(fragments.iter()).all(|(&g, &c)| depth_step(g, c) <= 1);
        // Over the earlier word: it, then the port's K - 1 nearest.
        let over = sorted_slots(&over_earlier, pixel, 1)?;
        ensure!(over.first() == Some(&earlier), "pixel {pixel}: the earlier insertion was lost: {over:x?}");
        let agree_over = over.len() == (fragments.len() + 1).min(k)
            && over[1..].iter().zip(fragments.iter()).all(|(&g, &c)| depth_step(g, c) <= 1);
        off += usize::from(!agree || !agree_over);
    }
    eprintln!("  K = {k}: {covered} pixels covered by the CPU port, {full} with K fragments, {off} differ");
    let allowed = (covered as f64 * 0.01).ceil() as usize;
    ensure!(off <= allowed, "more than {allowed} pixels differ from the port's K nearest");
    Ok(full)
}

/// The compute shadow kernel against its CPU port on `strands` (uploaded together) in the
/// `size`² map of `inputs`: the nearest depth per texel (within f32 rounding of the GPU's
/// interpolation), then the opacity sums over the GPU's depth map (within 1 % + 2 units per
/// texel). At most 0.5 % of the covered texels may differ (a fragment on a pixel boundary).
fn shadow_kernel_vs_port(
    ctx: &gen_gpu::Context,
    shadow: &render::shadow::ComputeShadow,
    inputs: &FrameInputs,
    light: &render::shadow::LightShadow,
    strands: &[(Vec<Vec3>, f32)],
) -> anyhow::Result<(Vec<u32>, Vec<[u32; 4]>)> {
    use render::shadow::ShadowMode;
    let size = inputs.viewport[0];
    let view = RasterView {
        view_proj: inputs.view_proj,
        eye: inputs.view.eye.as_vec3(),
        width: size,
        height: size,
        model: Mat4::IDENTITY,
        max_half_width: render::raster::MAX_HALF_WIDTH_PIXELS,
    };
    let points: Vec<Vec3> = strands.iter().flat_map(|(p, _)| p.iter().copied()).collect();
    let counts: Vec<u32> = strands.iter().map(|(p, _)| p.len() as u32).collect();
    // One width for the upload: the strands share it.
    let width = strands.first().map_or(0.01, |s| s.1);
    let stored = StoredStrands::upload(ctx, &points, &counts, width, 0.5)?;
    let [near, far, perspective, _] = light.depth_params;
    let mut port = cpu::ShadowMaps::new((size * size) as usize, light.layer_ends, [near, far, perspective]);
    let (gpu_depth, _) = shadow.rasterize_stored(ctx, &stored, inputs, light, ShadowMode::Depth, None)?;
    for (p, _) in strands {
        cpu::shadow_strand(&view, &mut port, &stored_points(p, width, 0.5), false);
    }
    let far_bits = 1f32.to_bits();
    let covered = port.depth_bits.iter().filter(|&&b| b != far_bits).count();
    let depth_off = gpu_depth
        .iter()
        .zip(&port.depth_bits)
        .filter(|&(&g, &p)| {
            let (g, p) = (f32::from_bits(g), f32::from_bits(p));
            // NaN on either side counts as a difference.
            (g - p).abs() > 1e-5 * p.abs().max(1e-3) || g.is_nan() || p.is_nan()
        })
        .count();
    // Opacity over the GPU's depth map on both sides, so the layers are measured alike.
    port.depth_bits = gpu_depth.clone();
    let (_, gpu_opacity) =
        shadow.rasterize_stored(ctx, &stored, inputs, light, ShadowMode::Opacity, Some(&gpu_depth))?;
    for (p, _) in strands {
        cpu::shadow_strand(&view, &mut port, &stored_points(p, width, 0.5), true);
    }
    let opacity_off = gpu_opacity
        .iter()
        .zip(&port.opacity)
        .filter(|(g, p)| {
            (0..3).any(|l| (f64::from(g[l]) - f64::from(p[l])).abs() > 0.01 * f64::from(p[l].max(g[l])) + 2.0)
        })
        .count();
    eprintln!(
        "  {covered} texels hold hair; {depth_off} depths and {opacity_off} opacity texels differ from the CPU port"
    );
    let allowed = (covered as f64 * 0.005).ceil() as usize;
    ensure!(depth_off <= allowed && opacity_off <= allowed, "more than {allowed} texels differ");
    Ok((gpu_depth, gpu_opacity))
}

/// `name` with shadows through the compute rasterizer, its maps made by the compute kernels
/// and by the triangle pipeline: the mean FLIP between the two images, which must stay within
/// `flip_mean`.
fn compute_maps_against_triangle_maps(
    ctx: &gen_gpu::Context,
    name: &str,
    path: &std::path::Path,
    flip_mean: f32,
) -> anyhow::Result<()> {
    let scene = load_scene(path)?;
    let mut renderer = SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?;
    ensure!(renderer.compute_shadows(), "the compute rasterizer should make its maps in compute");
    let compute = renderer.render(ctx)?;
    let shadow_passes: Vec<&String> = compute.passes.iter().filter(|p| p.starts_with("shadow")).collect();
    ensure!(
        shadow_passes.iter().any(|p| p.contains("opacity (compute raster"))
            && !shadow_passes.iter().any(|p| p.ends_with(": opacity")),
        "{shadow_passes:?}"
    );
    renderer.use_triangle_shadows();
    let triangles = renderer.render(ctx)?;
    ensure!(triangles.passes.iter().any(|p| p.ends_with(": opacity")), "{:?}", triangles.passes);
    for (what, frame) in [("compute", &compute), ("triangles", &triangles)] {
        render::output::write_png(
            &output_dir().join(format!("shadow-maps-{name}-{what}.png")),
            &frame.image,
        )?;
    }
    let stats = compare(
        &format!("shadow_maps_{name}"),
        &compute.image,
        &triangles.image,
        Tolerance { mean: flip_mean, percentile: (0.99, 1.0) },
    )
    .map_err(anyhow::Error::msg)?;
    eprintln!(
        "  {name}: compute maps vs triangle maps, FLIP mean {:.4} (99th {:.4})",
        stats.mean, stats.percentile
    );
    Ok(())
}

/// `scene` drawn with the occlusion tiles (two raster phases) and without them (one phase, every
/// fragment drawn): what the tiles skip must not change the image.
fn with_and_without_tiles(
    ctx: &gen_gpu::Context,
    scene: &LoadedScene,
) -> anyhow::Result<(RenderedFrame, RenderedFrame)> {
    let tiled = SceneRenderer::new(ctx, scene, GenerationPath::Compute)?.render(ctx)?;
    let single =
        SceneRenderer::new(ctx, scene, GenerationPath::Compute)?.with_occlusion_tiles(false).render(ctx)?;
    Ok((tiled, single))
}

/// A 6000-strand character (45 strands per bundle) generated inside the compute rasterizer's
/// kernel (three phases with the occlusion tiles before the second and the third, LOD off)
/// against its CPU reference strands drawn as stored strands (two phases) through the same
/// rasterizer: the same strands, so the same image but for f32 rounding (mean FLIP 0.0095). The
/// fused kernel maps each phase's slots to strands (the front's to each bundle's first eighth,
/// the second phase's to its next eighth, the rest's to the others: `front_first_strand` in
/// `hair_raster.comp`); a mapping that drew some strand twice and another never would show
/// (verified: the second phase drawing the front's strands again instead of the next eighth
/// fails the density by 1.5 %; with 3000 strands and two phases, drawing each bundle's second
/// strand in place of its first failed at mean FLIP 0.021 and its 99th percentile 0.43 against
/// 0.009 and 0.06, and drawing half of each bundle's strands twice the density by 5 %).
fn fused_against_stored(ctx: &gen_gpu::Context) -> anyhow::Result<()> {
    let (hair, view) = six_thousand_strands(0.0)?;
    let lod_off =
        hairmesh::reference::LodParams { enabled: false, ..hairmesh::reference::LodParams::default() };
    let reference = hair.generate_reference(&view, &lod_off);
    let set = hairmesh::strands::StrandSet::from_reference(&reference);
    let (fused, stored) = fused_and_stored_frames(ctx, hair, set, FusedStrands::Styled)?;
    let second = fused.passes.iter().filter(|p| p.ends_with(": second eighth, tile-culled")).count();
    ensure!(second == 1, "the fused frame drew {second} second eighths, not one: {:?}", fused.passes);
    same_image_but_rounding("raster-fused-vs-stored", &fused, &stored)
}

/// The fused kernel's benchmark variant (`FusedStrands::Straight`: every strand the straight
/// line from its root to its tip, for measuring what generation costs) against its CPU port
/// `raster::straight_strand` drawn as stored strands through the same rasterizer: the same
/// lines, so the same image but for f32 rounding (mean FLIP 0.005), and the passes named for
/// it. Verified to fail with the end of the first curve segment taken for the tip (lines a
/// quarter as long) and with the strands' length scale ignored.
fn fused_straight_against_port(ctx: &gen_gpu::Context) -> anyhow::Result<()> {
    // Lengths that vary from strand to strand, so that each line ends at its own strand's length.
    let (hair, _) = six_thousand_strands(0.3)?;
    let segments = 1u32 << hairmesh::reference::MAX_SEGMENTS_LOG2;
    let mut set = hairmesh::strands::StrandSet::from_reference(&[]);
    for (bundle, info) in (0u32..).zip(&hair.bundles) {
        for strand in 0..info.strands {
            set.points.extend(render::raster::straight_strand(&hair, bundle, strand, segments));
            set.strand_points.push(segments + 1);
        }
    }
    let (fused, stored) = fused_and_stored_frames(ctx, hair, set, FusedStrands::Straight)?;
    let straight = fused.passes.iter().filter(|p| p.contains("fused generation, straight lines)")).count();
    ensure!(straight >= 2, "the raster passes should say they draw straight lines: {:?}", fused.passes);
    same_image_but_rounding("raster-straight-vs-port", &fused, &stored)
}

/// The fused frame and the stored strands' frame of [`fused_and_stored_frames`] hold the same
/// strands: enough hair to compare, the same density (mean alpha within 1 %) and the same image
/// but for f32 rounding (FLIP mean ≤ 0.015, 99th percentile ≤ 0.1; images under `name`).
fn same_image_but_rounding(name: &str, fused: &RenderedFrame, stored: &RenderedFrame) -> anyhow::Result<()> {
    let (a, b) = (mean_alpha(fused), mean_alpha(stored));
    ensure!(a > 0.05, "too little hair on screen to compare (mean alpha {a})");
    ensure!((a - b).abs() <= 0.01 * b, "mean alpha {a} (fused) against {b} (stored strands)");
    let tolerance = Tolerance { mean: 0.015, percentile: (0.99, 0.1) };
    let stats = compare(name, &fused.image, &stored.image, tolerance).map_err(anyhow::Error::msg)?;
    println!("{name}: mean alpha {a:.4} (fused) / {b:.4} (stored), FLIP {:.5}", stats.mean);
    Ok(())
}

/// A 6000-strand character (45 strands per bundle, tapering to 0.3 of its root width as stored
/// strands do; the style's `length_variation` given) and the view of [`fused_and_stored_frames`].
fn six_thousand_strands(
    length_variation: f64,
) -> anyhow::Result<(hairmesh::asset::HairAsset, hairmesh::reference::ViewParams)> {
    use hairmesh::asset::{AssetParams, HairAsset, StrandCount};
    use hairmesh::style::Style;
    use hairmesh::{ExtrudeParams, HairMesh};
    let scalp = hairmesh::procedural::head_cap(6, 24);
    let mesh = HairMesh::extrude(
        &scalp,
        &ExtrudeParams { layers: 4, length: 0.25, droop: 1.2, ..ExtrudeParams::default() },
    )?;
    let style = Style { width: 0.003, tip_width: 0.3, length_variation, ..Style::default() };
    let params =
        AssetParams { strands: StrandCount::Total(6000), sample_sets: 1, seed: 5, ..AssetParams::default() };
    let hair = HairAsset::build(&mesh, &params, style)?;
    let (width, height) = FUSED_VS_STORED_SIZE;
    let view = FrameInputs::looking_at(&hair, FUSED_VS_STORED_EYE, width, height).view;
    Ok((hair, view))
}

const FUSED_VS_STORED_SIZE: (u32, u32) = (256, 192);
const FUSED_VS_STORED_EYE: Vec3 = Vec3::new(0.0, 1.82, 0.62);

/// `hair` generated in the compute rasterizer's kernel (LOD off, its kernel drawing as `fused`
/// says) and `stored` drawn as stored strands (their root width the hair's) through the same
/// rasterizer, in the same opaque scene.
fn fused_and_stored_frames(
    ctx: &gen_gpu::Context,
    hair: hairmesh::asset::HairAsset,
    stored: hairmesh::strands::StrandSet,
    fused: FusedStrands,
) -> anyhow::Result<(RenderedFrame, RenderedFrame)> {
    let (width, height) = FUSED_VS_STORED_SIZE;
    let json = serde_json::json!({
        "output": { "width": width, "height": height },
        "camera": { "eye": FUSED_VS_STORED_EYE.to_array(), "target": [0.0, 1.55, 0.0], "fov_y_degrees": 45 },
        "lights": [ { "directional": { "direction": [0.5, 0.8, 0.6] } } ],
        "characters": [],
        "effects": { "transparency": "opaque", "raster": "compute" }
    });
    let mut settings =
        LoadedScene { path: "fused-vs-stored.json".into(), scene: serde_json::from_value(json)? };
    settings.scene.lod = render::scene::LodDesc::OFF;
    settings.validate_settings()?;
    let frame = |hair: render::instance::CharacterHair| -> anyhow::Result<RenderedFrame> {
        let mut instance = render::instance::SceneInstance::new(settings.clone());
        instance.characters.push(render::instance::CharacterInstance {
            key: "hair".into(),
            hair,
            transform: Mat4::IDENTITY,
            color: render::scene::DEFAULT_HAIR_COLOR,
            color_variation: 0.0,
            occluder: None,
        });
        let renderer = SceneRenderer::from_instance(ctx, &instance, GenerationPath::Compute)?
            .with_fused_strands(ctx, fused)?;
        ensure!(renderer.raster() == RasterPath::Compute, "not the compute rasterizer");
        Ok(renderer.render(ctx)?)
    };
    let width_at_root = hair.style.width as f32;
    let fused = frame(render::instance::CharacterHair::Generated(std::sync::Arc::new(hair)))?;
    let stored = frame(render::instance::CharacterHair::Stored {
        strands: std::sync::Arc::new(stored),
        width: width_at_root,
    })?;
    Ok((fused, stored))
}

/// Two characters with a scene-wide strand LOD α of 2, one near the camera (its LOD keeps every
/// strand: a second front eighth) and one far away (its bundles keep a few widened strands: no
/// second eighth, its rest drawn after the first front), drawn with and without the occlusion
/// tiles: the same image, so each character's strands are drawn once whichever phases it takes
/// (`raster::second_front_pays`, the strand part per character in `record_raster`; verified to
/// fail when the far character's rest is drawn as if it had had a second eighth).
fn second_front_for_some_characters(ctx: &gen_gpu::Context) -> anyhow::Result<()> {
    use hairmesh::asset::{AssetParams, HairAsset, StrandCount};
    use hairmesh::{ExtrudeParams, HairMesh};
    use render::camera::{Camera, Character, character_inputs};
    let scalp = hairmesh::procedural::head_cap(6, 24);
    let mesh =
        HairMesh::extrude(&scalp, &ExtrudeParams { layers: 4, length: 0.25, ..ExtrudeParams::default() })?;
    let params = AssetParams { strands: StrandCount::Total(6000), seed: 3, ..AssetParams::default() };
    let style = hairmesh::style::Style { width: 0.004, ..hairmesh::style::Style::default() };
    let hair = std::sync::Arc::new(HairAsset::build(&mesh, &params, style)?);
    let (width, height) = (192, 128);
    let eye = Vec3::new(0.0, 1.7, 1.2);
    let target = Vec3::new(0.0, 1.55, 0.0);
    let placements = [Mat4::IDENTITY, Mat4::from_translation(Vec3::new(3.5, 0.0, -10.0))];
    let json = serde_json::json!({
        "output": { "width": width, "height": height },
        "camera": { "eye": eye.to_array(), "target": target.to_array(), "fov_y_degrees": 45 },
        "lights": [ { "directional": { "direction": [0.5, 0.8, 0.6] } } ],
        "characters": [],
        "effects": { "transparency": "opaque", "raster": "compute" },
        "lod": { "enabled": true, "strand_alpha": 2, "vertex_alpha": 1 }
    });
    let settings = LoadedScene { path: "second-front.json".into(), scene: serde_json::from_value(json)? };
    settings.validate_settings()?;
    let mut instance = render::instance::SceneInstance::new(settings.clone());
    for (k, &transform) in placements.iter().enumerate() {
        instance.characters.push(render::instance::CharacterInstance {
            key: format!("hair {k}"),
            hair: render::instance::CharacterHair::Generated(hair.clone()),
            transform,
            color: render::scene::DEFAULT_HAIR_COLOR,
            color_variation: 0.0,
            occluder: None,
        });
    }
    let camera = Camera { eye, target, fov_y: 45f32.to_radians() };
    let lod = settings.scene.lod.params();
    let second: Vec<bool> = placements
        .iter()
        .map(|&transform| {
            let inputs = character_inputs(&camera, &Character { hair: 0, transform }, width, height, lod);
            render::raster::second_front_pays(&hair, &inputs)
        })
        .collect();
    let per_bundle = hair.total_strands() as f64 / hair.bundles.len() as f64;
    ensure!(
        second == [true, false],
        "the near character should get a second eighth, the far one not: {second:?} ({per_bundle:.1} strands per bundle)"
    );
    let tiled = SceneRenderer::from_instance(ctx, &instance, GenerationPath::Compute)?.render(ctx)?;
    let single = SceneRenderer::from_instance(ctx, &instance, GenerationPath::Compute)?
        .with_occlusion_tiles(false)
        .render(ctx)?;
    ensure!(
        tiled.passes.iter().any(|p| p.ends_with(": second eighth, tile-culled")),
        "no second eighth: {:?}",
        tiled.passes
    );
    ensure!(mean_alpha(&tiled) > 0.05, "too little hair on screen (mean alpha {})", mean_alpha(&tiled));
    ensure!(tiled.linear == single.linear, "the phases draw another image than one phase");
    Ok(())
}

fn main() -> ExitCode {
    run_gpu_tests(vec![
        GpuTest::new("the_shadow_kernel_matches_its_cpu_port", Requirements::INT64_ATOMICS, |ctx| {
            let shadow = render::shadow::ComputeShadow::new(ctx)?;
            // A point light at z = 1 looking down −z (perspective), a 61² map.
            let size = 61;
            let (near, far) = (0.05f32, 4.0f32);
            let proj = Mat4::perspective_rh(60f32.to_radians(), 1.0, near, far);
            let flip = Mat4::from_scale(Vec3::new(1.0, -1.0, 1.0));
            let eye = Vec3::new(0.0, 0.0, 1.0);
            let view_proj = flip * proj * Mat4::look_at_rh(eye, Vec3::ZERO, Vec3::Y);
            let inputs = FrameInputs {
                view_proj,
                view: hairmesh::reference::ViewParams {
                    eye: eye.as_dvec3(),
                    vertical_resolution: f64::from(size),
                    projection: hairmesh::reference::Projection::Perspective { fov_y: 60f64.to_radians() },
                },
                lod: hairmesh::reference::LodParams::default(),
                viewport: [size, size],
                cull: false,
            };
            let light = render::shadow::LightShadow {
                light_view_proj: view_proj,
                depth_params: [near, far, 1.0, 0.0],
                layer_ends: [0.02, 0.06, 0.16],
                first_texel: 0,
                occluder_bias: 0.0,
            };
            // Several strands over each other (layers), across the map's edge, wide and thin,
            // and through the near plane.
            let mut strands: Vec<(Vec<Vec3>, f32)> = (0..12)
                .map(|k| {
                    let z = -0.03 * k as f32;
                    (
                        line(Vec3::new(-0.6, -0.3 + 0.02 * k as f32, z), Vec3::new(0.5, 0.4, z - 0.1), 17),
                        0.004,
                    )
                })
                .collect();
            strands.push((line(Vec3::new(-2.0, 0.1, -0.2), Vec3::new(2.0, -0.1, -0.2), 9), 0.004));
            strands.push((line(Vec3::new(0.1, -0.5, 0.0), Vec3::new(0.12, 0.5, -0.3), 9), 0.004));
            strands.push((line(Vec3::new(0.05, 0.02, 0.5), Vec3::new(0.08, 0.05, 1.5), 9), 0.004));
            let (depth, opacity) = shadow_kernel_vs_port(ctx, &shadow, &inputs, &light, &strands)?;
            let covered = depth.iter().filter(|&&b| b != 1f32.to_bits()).count();
            ensure!(covered > 300, "the strands cover too little ({covered} texels)");
            // Layers accumulate: where strands overlap, the last layer holds the most.
            ensure!(
                opacity.iter().all(|o| o[0] <= o[1] && o[1] <= o[2] && o[3] == 0),
                "layers must be cumulative"
            );
            ensure!(opacity.iter().any(|o| o[2] > o[0]), "some hair lies beyond the first layer");
            // Hair dense beyond any real groom (9,000 wide strands on one spot): the sums stop at
            // their limit instead of wrapping around.
            let spot = line(Vec3::new(-0.01, 0.0, 0.0), Vec3::new(0.01, 0.0, 0.0), 3);
            let points: Vec<Vec3> = (0..9_000).flat_map(|_| spot.iter().copied()).collect();
            let dense = StoredStrands::upload(ctx, &points, &vec![3; 9_000], 0.05, 1.0)?;
            let (depth, _) = shadow.rasterize_stored(
                ctx,
                &dense,
                &inputs,
                &light,
                render::shadow::ShadowMode::Depth,
                None,
            )?;
            let (_, sums) = shadow.rasterize_stored(
                ctx,
                &dense,
                &inputs,
                &light,
                render::shadow::ShadowMode::Opacity,
                Some(&depth),
            )?;
            let limit = render::shadow::SHADOW_OPACITY_LIMIT;
            let most = sums.iter().map(|o| o[2]).max().unwrap_or(0);
            eprintln!("  dense spot: largest layer sum {most} (limit {limit})");
            ensure!(most >= limit && most < limit + (1 << 20), "the sums stop at the limit: {most}");
            // Nothing of a strand behind the light reaches the maps.
            let behind = [(line(Vec3::new(-0.3, 0.0, 1.5), Vec3::new(0.3, 0.1, 2.0), 9), 0.01)];
            let (depth, opacity) = shadow_kernel_vs_port(ctx, &shadow, &inputs, &light, &behind)?;
            ensure!(
                depth.iter().all(|&b| b == 1f32.to_bits()) && opacity.iter().all(|o| *o == [0; 4]),
                "behind the light"
            );
            Ok(())
        }),
        GpuTest::new("compute_shadow_maps_match_the_triangle_maps", Requirements::INT64_ATOMICS, |ctx| {
            let dir = tempfile::tempdir()?;
            let effects = serde_json::json!({ "transparency": "opaque", "shadows": true, "shadow_map_size": 256, "raster": "compute" });
            let path = scene_with(dir.path(), "one_character", 256, 192, effects.clone())?;
            compute_maps_against_triangle_maps(ctx, "one_character", &path, 0.05)?;
            // Stored strands (the Sintel groom on its bust): the stored-strand kernel.
            let path = sintel_scene(dir.path(), "sintel", effects)?;
            compute_maps_against_triangle_maps(ctx, "sintel", &path, 0.05)
        }),
        GpuTest::new("the_raster_kernel_matches_its_cpu_port", Requirements::INT64_ATOMICS, |ctx| {
            let rasters = KernelPair::new(ctx)?;
            // An odd size (no multiple of any tile), the camera at z = 1 looking down -z.
            let (width, height) = (97, 61);
            let mut inputs = camera_at_z1(width, height);
            let curve: Vec<Vec3> = (0..33)
                .map(|k| {
                    let a = k as f32 / 32.0 * std::f32::consts::FRAC_PI_2;
                    Vec3::new(-0.3 + 0.4 * a.cos(), -0.2 + 0.4 * a.sin(), -0.1 * a)
                })
                .collect();
            let strands = vec![
                // Across the whole view and out over its edges.
                (line(Vec3::new(-2.0, -0.8, -0.5), Vec3::new(2.0, 0.9, 0.0), 17), 0.002),
                (curve, 0.004),
                // Very wide (beyond the 64-pixel cap at its root) and short.
                (line(Vec3::new(0.1, -0.3, 0.3), Vec3::new(0.25, -0.25, 0.3), 3), 3.0),
                // Sub-pixel.
                (line(Vec3::new(-0.4, 0.3, 0.0), Vec3::new(0.4, 0.35, -0.2), 9), 0.0005),
                // Vertical, major axis y.
                (line(Vec3::new(0.35, -0.5, 0.0), Vec3::new(0.36, 0.5, 0.0), 5), 0.01),
                // From in front of the camera through the near plane to behind it.
                (line(Vec3::new(0.05, 0.02, 0.5), Vec3::new(0.08, 0.05, 1.5), 9), 0.003),
            ];
            // Which kernel variant frames take: every strand but the last wholly inside the
            // view volume's depth.
            let clipping: Vec<DepthClipping> = strands
                .iter()
                .map(|(points, _)| {
                    let lo = points.iter().copied().reduce(Vec3::min).unwrap_or(Vec3::ZERO);
                    let hi = points.iter().copied().reduce(Vec3::max).unwrap_or(Vec3::ZERO);
                    DepthClipping::for_bounds(inputs.view_proj, (lo, hi))
                })
                .collect();
            ensure!(
                clipping[..5].iter().all(|&c| c == DepthClipping::Skip) && clipping[5] == DepthClipping::Clip,
                "{clipping:?}"
            );
            let (gpu, _) = kernel_vs_port(ctx, &rasters, &inputs, &strands)?;
            ensure!(gpu.coverage.iter().filter(|&&c| c > 0).count() > 800, "the strands cover too little");
            let widest = (0..gpu.coverage.len()).filter(|&i| gpu.alpha(i) > 0.99).count();
            ensure!(widest > 50, "the wide strand should cover solid pixels ({widest})");

            // Nothing of a zero-width strand or of a strand behind the camera reaches the buffers.
            for (what, strand) in [
                ("zero width", (line(Vec3::new(-0.3, 0.0, 0.0), Vec3::new(0.3, 0.1, 0.0), 9), 0.0)),
                ("behind the camera", (line(Vec3::new(-0.3, 0.0, 1.5), Vec3::new(0.3, 0.1, 2.0), 9), 0.01)),
            ] {
                let (gpu, port) = kernel_vs_port(ctx, &rasters, &inputs, &[strand])?;
                ensure!(
                    gpu.coverage.iter().all(|&c| c == 0) && port.coverage.iter().all(|&c| c == 0),
                    "{what}: nothing should be covered"
                );
                ensure!(gpu.visibility.iter().all(|&w| w == u64::MAX), "{what}: no visible fragment");
            }
            // A 1×1 frame.
            inputs.viewport = [1, 1];
            let (gpu, _) = kernel_vs_port(ctx, &rasters, &inputs, &strands[..2])?;
            ensure!(gpu.coverage[0] > 0, "the diagonal crosses the only pixel");
            Ok(())
        }),
        GpuTest::new("the_k_nearest_slots_match_the_cpu_port", Requirements::INT64_ATOMICS, |ctx| {
            let rasters = KernelPair::new(ctx)?;
            let (width, height) = (61, 45);
            let inputs = camera_at_z1(width, height);
            // 160 strands crossing each other at many depths (a fan around the centre, each
            // tilted in depth), so most pixels hold more fragments than slots and neighbouring
            // invocations insert into the same pixels at once.
            let strands: Vec<(Vec<Vec3>, f32)> = (0..160)
                .map(|i| {
                    let a = i as f32 * 0.039;
                    let (s, c) = a.sin_cos();
                    let z = -0.004 * (i % 17) as f32;
                    (line(Vec3::new(-0.5 * c, -0.5 * s, z), Vec3::new(0.5 * c, 0.5 * s, z - 0.05), 9), 0.02)
                })
                .collect();
            for k in [2, 4, 8, 16] {
                let full = k_nearest_vs_port(ctx, &rasters, &inputs, &strands, k)?;
                ensure!(full > 40, "K = {k}: too few pixels hold K fragments ({full})");
            }
            // 2,000 strands through one spot: the contention of a dense crown.
            let spot: Vec<(Vec<Vec3>, f32)> = (0..2_000)
                .map(|i| {
                    let z = -0.0005 * i as f32;
                    (line(Vec3::new(-0.1, -0.02, z), Vec3::new(0.1, 0.02, z - 0.001), 3), 0.01)
                })
                .collect();
            k_nearest_vs_port(ctx, &rasters, &inputs, &spot, 8)?;
            // And with one slot: 1,000 wide strands through the centre at 53 depths, where the
            // pixels turn opaque after two fragments and the rest skip their atomics.
            let disc: Vec<(Vec<Vec3>, f32)> = (0..1_000)
                .map(|i| {
                    let (s, c) = (i as f32 * 0.37).sin_cos();
                    let z = -0.001 * (i % 53) as f32;
                    (line(Vec3::new(-0.5 * c, -0.5 * s, z), Vec3::new(0.5 * c, 0.5 * s, z - 0.02), 5), 0.03)
                })
                .collect();
            dense_opaque_vs_port(ctx, &rasters, &inputs, &disc)?;
            // Kernels specialized for K as frames make them (the loops over the slots of known
            // length, the code for other K left out) keep the same K nearest, and refuse other
            // slot counts.
            let eight = KernelPair::specialized(ctx, Some(8))?;
            ensure!(eight.referenced.slots() == Some(8), "specialized for 8 slots");
            k_nearest_vs_port(ctx, &eight, &inputs, &strands, 8)?;
            k_nearest_vs_port(ctx, &eight, &inputs, &spot, 8)?;
            let (_, stored) = upload_together(ctx, &inputs, &strands)?;
            ensure!(
                eight
                    .referenced
                    .rasterize_stored_words(ctx, &stored, &inputs, Mat4::IDENTITY, 3, 4, None, None)
                    .is_err(),
                "a kernel specialized for 8 slots must refuse buffers of 4"
            );
            let one = KernelPair::specialized(ctx, Some(1))?;
            dense_opaque_vs_port(ctx, &one, &inputs, &disc)?;
            Ok(())
        }),
        GpuTest::new(
            "compute_raster_matches_the_triangle_raster_opaque",
            Requirements::INT64_ATOMICS,
            |ctx| {
                // The head cap occluder hides the hair behind it; the triangle raster's opaque mode
                // loses the coverage of strands behind sub-pixel ones (its alpha is lower): that is
                // most of the FLIP difference.
                against_triangles(
                    ctx,
                    "one_character",
                    (256, 192),
                    serde_json::json!({ "transparency": "opaque" }),
                    0.1,
                )
            },
        ),
        GpuTest::new(
            "compute_raster_matches_the_triangle_raster_with_shadows",
            Requirements::INT64_ATOMICS,
            |ctx| {
                let effects =
                    serde_json::json!({ "transparency": "opaque", "shadows": true, "shadow_map_size": 256 });
                against_triangles(ctx, "one_character", (256, 192), effects, 0.15)
            },
        ),
        GpuTest::new(
            "compute_raster_draws_a_crowd_with_lod_in_blended_mode",
            Requirements::INT64_ATOMICS,
            |ctx| {
                let effects = serde_json::json!({ "transparency": "blended" });
                against_triangles(ctx, "small_crowd", (256, 160), effects, 0.06)
            },
        ),
        GpuTest::new("compute_raster_oit_matches_the_triangle_oit", Requirements::INT64_ATOMICS, |ctx| {
            // The K nearest fragments per pixel composited front to back, the rest behind them:
            // the goal is a mean FLIP of at most 0.05 against the triangle raster's OIT.
            for (k, budget) in [(8, 0.05), (1, 0.1)] {
                let effects = serde_json::json!({ "transparency": "oit", "oit_k": k });
                let compute = render(ctx, "one_character", (256, 192), effects.clone(), "compute")?;
                let triangles = render(ctx, "one_character", (256, 192), effects, "triangles")?;
                let stats = compare(
                    &format!("raster_oit_k{k}"),
                    &compute.image,
                    &triangles.image,
                    Tolerance { mean: budget, percentile: (0.99, 0.75) },
                )
                .map_err(anyhow::Error::msg)?;
                ensure!(compute.raster_slots == Some(k), "{:?}", compute.raster_slots);
                let overflow = compute.raster_overflow.context("the compute raster counts overflow")?;
                eprintln!(
                    "  k = {k}: FLIP vs triangle OIT mean {:.4} (99th {:.4}); {overflow} pixels hold more than {k} fragments; alpha {:.4} vs {:.4}",
                    stats.mean,
                    stats.percentile,
                    mean_alpha(&compute),
                    mean_alpha(&triangles)
                );
                ensure!(overflow > 0, "dense hair has pixels with more than {k} fragments");
            }
            Ok(())
        }),
        GpuTest::new(
            "a_second_front_for_some_characters_draws_each_strand_once",
            Requirements::INT64_ATOMICS,
            second_front_for_some_characters,
        ),
        GpuTest::new(
            "fused_generation_draws_every_strand_once",
            Requirements::INT64_ATOMICS,
            fused_against_stored,
        ),
        GpuTest::new(
            "straight_strands_for_benchmarks_match_their_port",
            Requirements::INT64_ATOMICS,
            fused_straight_against_port,
        ),
        GpuTest::new("compute_raster_draws_stored_strands", Requirements::INT64_ATOMICS, |ctx| {
            // The artist's Sintel groom (11,400 × 16, TressFX) on its bust, with shadows.
            let dir = tempfile::tempdir()?;
            let mut frames = Vec::new();
            for raster in ["triangles", "compute"] {
                let effects = serde_json::json!({ "transparency": "opaque", "shadows": true, "shadow_map_size": 256, "raster": raster });
                let path = sintel_scene(dir.path(), "sintel", effects)?;
                let frame =
                    SceneRenderer::new(ctx, &load_scene(&path)?, GenerationPath::Compute)?.render(ctx)?;
                render::output::write_png(
                    &output_dir().join(format!("raster-sintel-{raster}.png")),
                    &frame.image,
                )?;
                frames.push(frame);
            }
            let stats = compare(
                "raster_sintel",
                &frames[1].image,
                &frames[0].image,
                Tolerance { mean: 0.1, percentile: (0.99, 0.75) },
            )
            .map_err(anyhow::Error::msg)?;
            eprintln!("  Sintel: FLIP vs triangles mean {:.4} (99th {:.4})", stats.mean, stats.percentile);
            ensure!(frames[1].stats.strands == 11_400, "{:?}", frames[1].stats);
            Ok(())
        }),
        GpuTest::new(
            "compute_raster_is_deterministic_and_exact_under_tile_culling",
            Requirements::INT64_ATOMICS,
            |ctx| {
                // Atomics arrive in any order; the minimum, the K smallest words and the clamped
                // sum do not depend on it.
                let dir = tempfile::tempdir()?;
                // Every character through the raster kernels' variant with depth clipping.
                let clipping_everywhere = |scene: &LoadedScene| -> anyhow::Result<RenderedFrame> {
                    let renderer = SceneRenderer::new(ctx, scene, GenerationPath::Compute)?;
                    Ok(renderer.with_depth_clipping_everywhere(true).render(ctx)?)
                };
                for transparency in ["opaque", "oit"] {
                    let scene = load_scene(&scene_with(
                        dir.path(),
                        "small_crowd",
                        160,
                        100,
                        serde_json::json!({ "transparency": transparency, "oit_k": 4, "raster": "compute", "shadows": true }),
                    )?)?;
                    let renderer = SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?;
                    let a = renderer.render(ctx)?;
                    let b = renderer.render(ctx)?;
                    let c = SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?.render(ctx)?;
                    ensure!(
                        a.linear == b.linear && a.linear == c.linear,
                        "{transparency}: the same scene renders different pixels"
                    );
                    // The occlusion tiles only skip what cannot change a pixel.
                    let single =
                        SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?.with_occlusion_tiles(false);
                    let d = single.render(ctx)?;
                    ensure!(
                        d.passes.iter().all(|p| !p.contains("occlusion tiles"))
                            && a.passes.iter().any(|p| p.contains("occlusion tiles")),
                        "{:?}",
                        d.passes
                    );
                    ensure!(
                        a.linear == d.linear,
                        "{transparency}: drawing without the occlusion tiles changes the image"
                    );
                    // The characters lie wholly inside the view volume's depth: the raster
                    // kernel's variant with depth clipping draws them alike.
                    ensure!(
                        clipping_everywhere(&scene)?.linear == a.linear,
                        "{transparency}: the raster kernel with depth clipping changes the image"
                    );
                    // Buffer references only change how the kernels read (where the device has
                    // them: lavapipe does), never what.
                    let bound = SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?
                        .with_buffer_references(ctx, false)?;
                    ensure!(
                        bound.render(ctx)?.linear == a.linear,
                        "{transparency}: reading through the bindings instead of buffer references changes the image"
                    );
                    // Stored strands (the artist's groom) go through the same two phases: every
                    // eighth slot, then the others.
                    let effects =
                        serde_json::json!({ "transparency": transparency, "oit_k": 4, "raster": "compute" });
                    let stored = load_scene(&sintel_scene(dir.path(), "sintel_tiles", effects)?)?;
                    let (tiled, single) = with_and_without_tiles(ctx, &stored)?;
                    // The raster passes name what they draw: here stored strands only.
                    ensure!(
                        tiled.passes.iter().any(|p| p.contains("occlusion tiles"))
                            && tiled
                                .passes
                                .iter()
                                .any(|p| p == "raster hair (compute raster, stored strands): front strands"),
                        "stored strands: {:?}",
                        tiled.passes
                    );
                    ensure!(
                        tiled.linear == single.linear,
                        "{transparency}: stored strands drawn without the occlusion tiles change the image"
                    );
                    ensure!(
                        clipping_everywhere(&stored)?.linear == tiled.linear,
                        "{transparency}: stored strands drawn with depth clipping change the image"
                    );
                    // With shadows, the shade pass reads the shadow maps through buffer
                    // references too (and the OIT slots before sorting them), and the raster
                    // kernel the groom's stored vertices and the bust's depth: again only how.
                    let effects = serde_json::json!({
                        "transparency": transparency, "oit_k": 4, "raster": "compute", "shadows": true
                    });
                    let shadowed = load_scene(&sintel_scene(dir.path(), "sintel_shadowed", effects)?)?;
                    let referenced =
                        SceneRenderer::new(ctx, &shadowed, GenerationPath::Compute)?.render(ctx)?;
                    let bound = SceneRenderer::new(ctx, &shadowed, GenerationPath::Compute)?
                        .with_buffer_references(ctx, false)?
                        .render(ctx)?;
                    ensure!(
                        referenced.linear == bound.linear,
                        "{transparency}: shading through the bindings instead of buffer references changes the image"
                    );
                }
                Ok(())
            },
        ),
        GpuTest::new("whole_segments_skip_only_behind_closed_tiles", Requirements::INT64_ATOMICS, |ctx| {
            // The close-up with strands 6 mm wide (1.6 pixels here: each fragment nearly
            // solid), so that the front strands close most tiles and the rest phase skips whole
            // segments behind them (segment_behind_tiles): without the tiles every fragment is
            // drawn, and the images must be the same. (Verified to fail when the segment test
            // skips behind any closed square whatever its depth; the small crowd's and Sintel's
            // sub-pixel strands close too few tiles to tell.) Also with a strong vertex LOD,
            // whose few long segments (up to about 40 pixels here) reach out of the hair's
            // surface: the rest phase trims their ends a tile's length at a time where they lie
            // behind the tiles (verified to fail when the trimmed chunks' depth is taken 10 %
            // too far).
            let dir = tempfile::tempdir()?;
            let strong_lod = serde_json::json!({ "enabled": true, "strand_alpha": 1, "vertex_alpha": 2000, "vertex_error_pixels": 0 });
            for (transparency, lod) in
                [("opaque", None), ("oit", None), ("opaque", Some(&strong_lod)), ("oit", Some(&strong_lod))]
            {
                let effects =
                    serde_json::json!({ "transparency": transparency, "oit_k": 4, "raster": "compute" });
                let path = scene_with_edit(dir.path(), "one_character", 256, 192, effects, |json| {
                    for c in json["characters"].as_array_mut().context("characters")? {
                        c["style"] = serde_json::json!({ "width": 0.006 });
                    }
                    if let Some(lod) = lod {
                        json["lod"] = lod.clone();
                    }
                    Ok(())
                })?;
                let (what, file) = match lod {
                    Some(_) => (format!("{transparency}, strong vertex LOD"), format!("{transparency}-lod")),
                    None => (transparency.to_owned(), transparency.to_owned()),
                };
                let scene = load_scene(&path)?;
                let (tiled, single) = with_and_without_tiles(ctx, &scene)?;
                ensure!(
                    tiled.passes.iter().any(|p| p.contains("occlusion tiles"))
                        && single.passes.iter().all(|p| !p.contains("occlusion tiles")),
                    "{:?}",
                    tiled.passes
                );
                render::output::write_png(
                    &output_dir().join(format!("raster-wide-close-up-{file}.png")),
                    &tiled.image,
                )?;
                // Dense hair: most of the frame opaque.
                ensure!(mean_alpha(&tiled) > 0.4, "{what}: mean alpha {}", mean_alpha(&tiled));
                ensure!(
                    tiled.linear == single.linear,
                    "{what}: skipping segments behind the occlusion tiles changes the image"
                );
            }
            Ok(())
        }),
        GpuTest::new(
            "segments_visible_last_frame_go_first_and_change_nothing",
            Requirements::INT64_ATOMICS,
            |ctx| {
                // OIT (K > 1) draws the strand segments that reached the last frame's image first
                // (raster_split.comp), generating only the points their vertices read: only the
                // order changes, so every frame of a renderer with it — the first (no depths to
                // mark against), the second (marks, but no order from them yet), the later ones,
                // and after the camera moved (an order from the other view) — must equal the same
                // frame drawn with every eighth strand first; once without LOD and once with a
                // vertex LOD so strong that most strands morph between levels (whose end tangents
                // read points four away) and change level when the camera moves (marks made at one
                // level, read at another). The order the GPU made must be the CPU port's from the
                // marks the frame before left. (Verified to fail when the split drops a strand from
                // the rest part, when the front phase walks the unmarked segments too, when fewer
                // points around the walked segments are evaluated, and, with the LOD, without the
                // morphing's end points or with a segment partly marked at another level walked in
                // both phases.)
                let dir = tempfile::tempdir()?;
                let strong_lod = serde_json::json!({ "enabled": true, "strand_alpha": 1, "vertex_alpha": 2000, "vertex_error_pixels": 0 });
                for (name, lod) in [("no LOD", None), ("strong vertex LOD", Some(strong_lod))] {
                    let effects =
                        serde_json::json!({ "transparency": "oit", "oit_k": 4, "raster": "compute" });
                    let path = scene_with_edit(dir.path(), "one_character", 256, 192, effects, |json| {
                        for c in json["characters"].as_array_mut().context("characters")? {
                            c["style"] = serde_json::json!({ "width": 0.006 });
                        }
                        if let Some(lod) = &lod {
                            json["lod"] = lod.clone();
                        }
                        Ok(())
                    })?;
                    let scene = load_scene(&path)?;
                    let ordered = SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?;
                    let sparse =
                        SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?.with_slot_order(false);
                    let eye = Vec3::from_array(scene.scene.camera.eye);
                    let moved = eye + Vec3::new(0.25, -0.05, 0.1);
                    let mut marks: Option<Vec<u32>> = None;
                    for (frame, at) in [eye, eye, eye, eye, moved, moved].into_iter().enumerate() {
                        let a = ordered.render_from(ctx, at)?;
                        let b = sparse.render_from(ctx, at)?;
                        ensure!(
                            a.passes.iter().any(|p| p.contains("visible last frame"))
                                && b.passes.iter().all(|p| !p.contains("visible last frame")),
                            "{:?}",
                            a.passes
                        );
                        ensure!(
                            a.linear == b.linear,
                            "{name}, frame {frame}: the strand order changes the image"
                        );
                        let order = ordered.strand_order(ctx, 0)?.context("an order")?;
                        let slots = (a.stats.strands) as usize;
                        ensure!(
                            order.front.len() + order.rest.len() >= slots,
                            "{name}, frame {frame}: strands left out"
                        );
                        if let Some(before) = &marks {
                            let port = cpu::slot_order(before, slots, frame >= 2);
                            ensure!(
                                order == port,
                                "{name}, frame {frame}: the GPU's order is not the port's"
                            );
                        }
                        if let (3, Some(before)) = (frame, &marks) {
                            // By now the front part is the marked strands alone (these wide strands
                            // hide most of the hair: no sparse strands join them), each walking its
                            // marked segments, and the rest walks the others.
                            let marked = before[..slots].iter().filter(|&&m| m != 0).count();
                            let whole = order.front.iter().filter(|e| e[1] == u32::MAX).count();
                            eprintln!(
                                "  {name}, frame {frame}: {} of {slots} strands first ({whole} with every segment), {} in the rest",
                                order.front.len(),
                                order.rest.len()
                            );
                            ensure!(marked * 8 >= slots && order.front.len() == marked, "{marked} marked");
                            ensure!(order.front.len() < slots, "every strand marked");
                        }
                        marks = ordered.strand_marks(ctx, 0)?;
                        ensure!(marks.is_some(), "marks after a frame");
                    }
                    ensure!(sparse.strand_order(ctx, 0)?.is_none(), "no order without it");
                    render::output::write_png(
                        &output_dir().join(format!("raster-slot-order-{}.png", name.replace(' ', "-"))),
                        &sparse.render_from(ctx, moved)?.image,
                    )?;
                }
                Ok(())
            },
        ),
        GpuTest::new("a_frame_after_a_larger_one_renders_the_same", Requirements::INT64_ATOMICS, |ctx| {
            // A frame clears only the pixel words of its hair's screen rectangle: after a
            // close-up, whose words cover the whole frame with near, opaque hair, a view from
            // afar (a smaller rectangle) must render what a fresh renderer does: nothing stale
            // inside the rectangle, and the occlusion tiles over its edge open whatever the
            // stale words around it say. (Fails when the frame clears nothing; the ranges
            // themselves are checked by the_cleared_ranges_are_the_rects_pixel_words.)
            let dir = tempfile::tempdir()?;
            let (near, far) = (Vec3::new(0.0, 1.82, 0.62), Vec3::new(0.3, 1.7, 1.2));
            for transparency in ["opaque", "oit"] {
                let effects =
                    serde_json::json!({ "transparency": transparency, "oit_k": 4, "raster": "compute" });
                let scene = load_scene(&scene_with(dir.path(), "one_character", 384, 192, effects)?)?;
                let renderer = SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?;
                let close = renderer.render_from(ctx, near)?;
                let after = renderer.render_from(ctx, far)?;
                let fresh =
                    SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?.render_from(ctx, far)?;
                let (a, b) = (mean_alpha(&close), mean_alpha(&fresh));
                ensure!(
                    a > 0.25 && b > 0.05 && b < 0.2,
                    "{transparency}: mean alpha {a:.3} near, {b:.3} far"
                );
                render::output::write_png(
                    &output_dir().join(format!("raster-after-close-up-{transparency}.png")),
                    &after.image,
                )?;
                ensure!(
                    after.linear == fresh.linear,
                    "{transparency}: the close-up's words change the far view"
                );
            }
            Ok(())
        }),
        GpuTest::new("dense_hair_reads_as_opaque", Requirements::INT64_ATOMICS, |ctx| {
            // The close-up without its head: where the hair's optical depth reaches the coverage
            // limit (4.5: alpha 1 − 1.1 %), the pixel is opaque, in the resolve as in the CPU
            // port — no background shows through dense hair (without the rule no pixel of hair
            // alone gets above 0.989).
            let limit = cpu::COVERAGE_LIMIT;
            let port = cpu::RasterBuffers {
                width: 2,
                height: 1,
                visibility: vec![u64::MAX; 2],
                coverage: vec![u64::from(limit), u64::from(limit - 1)],
            };
            ensure!(port.alpha(0) == 1.0, "at the limit: alpha {}", port.alpha(0));
            ensure!(port.alpha(1) < 0.99, "under the limit: alpha {}", port.alpha(1));
            let dir = tempfile::tempdir()?;
            let effects = serde_json::json!({ "transparency": "opaque", "raster": "compute" });
            let path = scene_with_edit(dir.path(), "one_character", 256, 192, effects, |json| {
                for c in json["characters"].as_array_mut().context("characters")? {
                    c.as_object_mut().context("character")?.remove("occluder");
                }
                Ok(())
            })?;
            let frame = SceneRenderer::new(ctx, &load_scene(&path)?, GenerationPath::Compute)?.render(ctx)?;
            render::output::write_png(&output_dir().join("raster-dense-hair-no-head.png"), &frame.image)?;
            let alphas: Vec<f32> = frame.linear.rgba.chunks_exact(4).map(|p| p[3]).collect();
            let opaque = alphas.iter().filter(|&&a| a == 1.0).count();
            let partial = alphas.iter().filter(|&&a| a > 0.0 && a < 1.0).count();
            eprintln!("  {opaque} opaque pixels, {partial} partly covered");
            ensure!(
                opaque > alphas.len() / 5,
                "dense hair should be opaque: {opaque} of {} pixels",
                alphas.len()
            );
            ensure!(alphas.iter().all(|a| (0.0..=1.0).contains(a)), "alpha out of [0, 1]");
            // The corner lies outside the hair's rectangle, which alone the resolve writes: the
            // frame's read gives it the background, as a cleared image would.
            let scene = load_scene(&path)?;
            let [r, g, b] = scene.scene.output.background.map(|c| half::f16::from_f32(c).to_f32());
            ensure!(
                frame.linear.rgba[..4] == [r, g, b, 0.0] && frame.linear.depth[0] == 1.0,
                "the background"
            );
            Ok(())
        }),
        GpuTest::new("every_dispatch_order_renders_the_same_image", Requirements::INT64_ATOMICS, |ctx| {
            // The dispatch order (dispatch_order.glsl) only changes which workgroup does which
            // work: every kernel that uses it — the fused raster and shadow kernels, their
            // stored-strand variants, the compute path's generation, the shade pass, the
            // volume's march and ambient occlusion — must give the same pixels for any
            // worker count. A lost or repeated workgroup would change the coverage sums.
            let dir = tempfile::tempdir()?;
            // Each scene file in a folder of its own (scene_with names the file after the scene).
            let folder = |name: &str| -> anyhow::Result<std::path::PathBuf> {
                let path = dir.path().join(name);
                std::fs::create_dir_all(&path)?;
                Ok(path)
            };
            let mut scenes = Vec::new();
            for transparency in ["opaque", "oit"] {
                let effects = serde_json::json!({
                    "transparency": transparency, "oit_k": 4, "raster": "compute", "shadows": true
                });
                let name = format!("one_character_{transparency}");
                scenes.push((name.clone(), scene_with(&folder(&name)?, "one_character", 128, 96, effects)?));
            }
            let effects = serde_json::json!({ "transparency": "oit", "oit_k": 4, "raster": "compute", "shadows": true });
            scenes.push(("sintel".into(), sintel_scene(dir.path(), "sintel_order", effects)?));
            let volume = serde_json::json!({
                "raster": "compute", "volume_lod": true, "volume_lod_pixels": 1.0e6, "ao": true
            });
            scenes
                .push(("volume_ao".into(), scene_with(&folder("volume")?, "one_character", 96, 72, volume)?));
            // The compute path's generation pass feeding the triangle raster (opaque: its depth
            // test breaks ties in slot order, which the dispatch order does not change).
            let triangles = serde_json::json!({ "raster": "triangles", "transparency": "opaque" });
            scenes.push((
                "triangles".into(),
                scene_with(&folder("triangles")?, "one_character", 96, 72, triangles)?,
            ));
            let device_workers = ctx.dispatch_workers();
            eprintln!("  device dispatch workers: {device_workers}");
            for (name, path) in &scenes {
                let scene = load_scene(path)?;
                // (Some pipelines are made at the first frame, with the context it is given.)
                let single = ctx.with_dispatch_workers(1);
                let reference =
                    SceneRenderer::new(&single, &scene, GenerationPath::Compute)?.render(&single)?;
                ensure!(reference.linear.rgba.iter().any(|&a| a > 0.0), "{name}: nothing drawn");
                // (Each count compiles the scene's pipelines again: a few seconds on lavapipe.)
                let mut counts = vec![3, 7];
                if device_workers > 1 && !counts.contains(&device_workers) {
                    counts[0] = device_workers;
                }
                for workers in counts {
                    let ordered = ctx.with_dispatch_workers(workers);
                    let frame =
                        SceneRenderer::new(&ordered, &scene, GenerationPath::Compute)?.render(&ordered)?;
                    ensure!(
                        frame.linear == reference.linear,
                        "{name}: the dispatch order for {workers} workers changes the image"
                    );
                }
            }
            Ok(())
        }),
        GpuTest::new("the_near_plane_through_the_hair", Requirements::INT64_ATOMICS, |ctx| {
            // The eye among the strands: the near plane cuts the character's bounds, so frames
            // take the raster kernel with depth clipping (the one without would draw the strands
            // behind the eye mirrored), and the image follows the triangle raster's.
            let dir = tempfile::tempdir()?;
            // A test scene with the eye among the strands, looking down the back of the head.
            let eye_in_the_hair = |name: &str, effects: serde_json::Value| -> anyhow::Result<LoadedScene> {
                let path = scene_with_edit(dir.path(), name, 128, 96, effects, |json| {
                    json["camera"]["eye"] = serde_json::json!([0.0, 1.62, 0.08]);
                    json["camera"]["target"] = serde_json::json!([0.0, 1.55, -1.0]);
                    Ok(())
                })?;
                Ok(load_scene(&path)?)
            };
            let mut frames = Vec::new();
            for raster in ["compute", "triangles"] {
                let effects = serde_json::json!({ "raster": raster, "transparency": "oit" });
                let scene = eye_in_the_hair("one_character", effects)?;
                let frame = SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?.render(ctx)?;
                render::output::write_png(
                    &output_dir().join(format!("raster-near-plane-{raster}.png")),
                    &frame.image,
                )?;
                if raster == "compute" {
                    let clipped = SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?
                        .with_depth_clipping_everywhere(true)
                        .render(ctx)?;
                    ensure!(frame.linear == clipped.linear, "the near plane cuts the hair: frames must clip");
                }
                frames.push(frame);
            }
            ensure!(frames[0].linear.rgba.iter().all(|c| c.is_finite()), "finite colour");
            // The same eye in the small crowd: the middle character and its neighbours reach
            // through the near plane, the back row does not, so one frame binds both variants
            // (validation on) and still draws what clipping everywhere draws.
            let effects = serde_json::json!({ "raster": "compute", "transparency": "opaque" });
            let crowd = eye_in_the_hair("small_crowd", effects)?;
            let renderer = SceneRenderer::new(ctx, &crowd, GenerationPath::Compute)?;
            let camera = &crowd.scene.camera;
            let view = renderer.frame_view(camera.eye.into(), camera.target.into());
            let variants = renderer.raster_depth_clipping(&view);
            ensure!(
                variants.contains(&DepthClipping::Clip) && variants.contains(&DepthClipping::Skip),
                "the crowd should need both kernel variants, got {variants:?}"
            );
            let mixed = renderer.render(ctx)?;
            render::output::write_png(&output_dir().join("raster-near-plane-crowd.png"), &mixed.image)?;
            let clipped = SceneRenderer::new(ctx, &crowd, GenerationPath::Compute)?
                .with_depth_clipping_everywhere(true)
                .render(ctx)?;
            ensure!(
                mixed.linear == clipped.linear,
                "a crowd with both kernel variants in one frame draws differently"
            );
            let any = Tolerance { mean: 1.0, percentile: (0.99, 1.0) };
            let flip = compare("raster_near_plane", &frames[0].image, &frames[1].image, any)
                .map_err(anyhow::Error::msg)?;
            let (c, t) = (mean_alpha(&frames[0]), mean_alpha(&frames[1]));
            eprintln!("  FLIP mean {:.4} against the triangle raster; mean alpha {c:.4} / {t:.4}", flip.mean);
            ensure!(flip.mean <= 0.1, "FLIP {:.4}", flip.mean);
            Ok(())
        }),
        GpuTest::new("compute_raster_handles_empty_and_tiny_frames", Requirements::INT64_ATOMICS, |ctx| {
            let dir = tempfile::tempdir()?;
            // The camera looking away: every bundle culled, nothing drawn.
            let effects = serde_json::json!({ "raster": "compute" });
            let path = scene_with_edit(dir.path(), "one_character", 64, 48, effects, |json| {
                json["camera"]["target"] = serde_json::json!([0.0, 1.82, 5.0]);
                json["characters"][0].as_object_mut().context("character")?.remove("occluder");
                Ok(())
            })?;
            let frame = SceneRenderer::new(ctx, &load_scene(&path)?, GenerationPath::Compute)?.render(ctx)?;
            ensure!(frame.linear.rgba.chunks_exact(4).all(|p| p[3] == 0.0), "an empty view draws nothing");
            ensure!(frame.linear.depth.iter().all(|&d| d == 1.0), "and writes no depth");
            for (w, h) in [(1, 1), (3, 7), (97, 61)] {
                let scene = load_scene(&scene_with(
                    dir.path(),
                    "one_character",
                    w,
                    h,
                    serde_json::json!({ "raster": "compute" }),
                )?)?;
                let frame = SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?.render(ctx)?;
                ensure!(frame.image.width == w && frame.image.height == h, "{w}×{h}");
                ensure!(frame.linear.rgba.iter().all(|c| c.is_finite()), "{w}×{h}: finite colour");
            }
            Ok(())
        }),
        GpuTest::new("the_raster_choice_follows_the_scene_and_the_device", Requirements::NONE, |ctx| {
            let dir = tempfile::tempdir()?;
            let caps = ctx.capabilities();
            for (effects, expected) in [
                (
                    serde_json::json!({ "transparency": "opaque", "raster": "auto" }),
                    caps.is_cpu() && caps.buffer_int64_atomics,
                ),
                (
                    serde_json::json!({ "transparency": "blended", "raster": "auto" }),
                    caps.is_cpu() && caps.buffer_int64_atomics,
                ),
                (
                    serde_json::json!({ "transparency": "oit", "raster": "auto" }),
                    caps.is_cpu() && caps.buffer_int64_atomics,
                ),
                (serde_json::json!({ "transparency": "opaque", "msaa": 4, "raster": "auto" }), false),
                (serde_json::json!({ "transparency": "opaque", "raster": "triangles" }), false),
            ] {
                let scene = load_scene(&scene_with(dir.path(), "one_character", 32, 24, effects.clone())?)?;
                let renderer = SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?;
                let compute = renderer.raster() == RasterPath::Compute;
                ensure!(compute == expected, "{effects}: {:?}", renderer.raster());
                let graph = renderer.graph();
                let names: Vec<&str> = graph.passes.iter().map(|p| p.name.as_str()).collect();
                ensure!(names.iter().any(|n| n.contains("compute raster")) == compute, "{names:?}");
            }
            // Compute with MSAA is refused when the scene is read, naming the field.
            let effects = serde_json::json!({ "transparency": "opaque", "msaa": 4, "raster": "compute" });
            let err = load_scene(&scene_with(dir.path(), "one_character", 32, 24, effects)?)
                .err()
                .context("should be refused")?;
            ensure!(err.to_string().contains("effects.msaa"), "{err}");
            // A frame whose per-pixel words exceed the storage-buffer range: auto falls back to
            // the triangle raster, compute says why.
            let range = u64::from(caps.max_storage_buffer_range);
            let side = ((range / 16) as f64).sqrt() as u32 + 64;
            if side <= render::scene::MAX_OUTPUT_SIDE {
                for (raster, ok) in [("auto", true), ("compute", false)] {
                    let effects = serde_json::json!({ "transparency": "opaque", "raster": raster });
                    let scene = load_scene(&scene_with(dir.path(), "one_character", side, side, effects)?)?;
                    match SceneRenderer::new(ctx, &scene, GenerationPath::Compute) {
                        Ok(r) => {
                            ensure!(ok && r.raster() == RasterPath::Triangles, "{raster}: {:?}", r.raster());
                        }
                        Err(e) => {
                            ensure!(!ok && e.to_string().contains("storage-buffer range"), "{raster}: {e}");
                        }
                    }
                }
            }
            Ok(())
        }),
    ])
}
