//! The benchmark's bare crowd renderer: characters whose hair is generated on the fly, drawn
//! with the generator's default fragment stage into one image, without scenes, lights or the
//! frame graph. `hair-bench` measures generation and rasterization with it; scenes go through
//! `render::frame::SceneRenderer`.

use gen_gpu::RenderTarget;
use gen_gpu::{Context, FrameBuffers, FrameTimings, GenerationPath, GenerationStats, Generator, GpuHair};
use render::RgbaImage;
pub use render::camera::{Camera, Character, FAR, FrameView, NEAR, character_inputs, view_proj};

/// What a crowd frame produced.
#[derive(Debug)]
pub struct CrowdFrame {
    pub image: RgbaImage,
    pub timings: FrameTimings,
    pub stats: GenerationStats,
}

/// Generates and draws every character into one image.
pub fn render_crowd(
    ctx: &Context,
    generator: &Generator,
    hairs: &[GpuHair],
    characters: &[Character],
    view: &FrameView,
) -> gen_gpu::Result<CrowdFrame> {
    let frames = prepare_crowd(ctx, generator, hairs, characters, view)?;
    render_prepared(ctx, generator, hairs, characters, &frames, view, true)
}

/// Frame buffers for every character, sized from the LOD the view asks for.
pub fn prepare_crowd(
    ctx: &Context,
    generator: &Generator,
    hairs: &[GpuHair],
    characters: &[Character],
    view: &FrameView,
) -> gen_gpu::Result<Vec<FrameBuffers>> {
    characters
        .iter()
        .map(|c| {
            let inputs = character_inputs(&view.camera, c, view.width, view.height, view.lod);
            generator.prepare(ctx, &hairs[c.hair], &inputs)
        })
        .collect()
}

/// Generates prepared characters on the compute path in a submission of their own (the LOD
/// and generate passes, nothing drawn) and returns the generate pass's GPU time: generation
/// measured apart from a raster pass that takes a hundred times longer and leaves the caches
/// and the machine's speed different from one frame to the next.
pub fn generate_alone(
    ctx: &Context,
    generator: &Generator,
    hairs: &[GpuHair],
    characters: &[Character],
    frames: &[FrameBuffers],
) -> gen_gpu::Result<f64> {
    let ((), timings) = ctx.submit("generation alone", |rec| {
        rec.pass("generate", |rec| {
            for (c, frame) in characters.iter().zip(frames) {
                generator.record_lod(rec, &hairs[c.hair], frame);
            }
            Generator::barrier_after_lod(rec);
            for (c, frame) in characters.iter().zip(frames) {
                generator.record_generate(rec, &hairs[c.hair], frame);
            }
        });
        Ok(())
    })?;
    Ok(timings.pass_ms("generate").unwrap_or(f64::NAN))
}

/// Draws prepared characters. With `regenerate` the strands are generated for this frame
/// (on the fly); without it the strand buffers of an earlier compute-path frame are drawn
/// as stored strands (the baseline that shows what generating every frame costs).
pub fn render_prepared(
    ctx: &Context,
    generator: &Generator,
    hairs: &[GpuHair],
    characters: &[Character],
    frames: &[FrameBuffers],
    view: &FrameView,
    regenerate: bool,
) -> gen_gpu::Result<CrowdFrame> {
    let FrameView { width, height, path, .. } = *view;
    let path = if regenerate { path } else { GenerationPath::Compute };
    let target = RenderTarget::new(ctx, width, height)?;
    let ((), timings) = ctx.submit("crowd frame", |rec| {
        // The compute path generates every character before the raster pass; the mesh path
        // needs the LOD pass only for statistics, and generates while drawing.
        if regenerate {
            rec.pass("generate", |rec| {
                for (c, frame) in characters.iter().zip(frames) {
                    generator.record_lod(rec, &hairs[c.hair], frame);
                }
                Generator::barrier_after_lod(rec);
                if path == GenerationPath::Compute {
                    for (c, frame) in characters.iter().zip(frames) {
                        generator.record_generate(rec, &hairs[c.hair], frame);
                    }
                    Generator::barrier_after_generate(rec);
                }
            });
        }
        target.begin(rec);
        let name = if regenerate { format!("raster ({path})") } else { "raster (stored strands)".to_owned() };
        let drawn = rec.pass(&name, |rec| {
            characters
                .iter()
                .zip(frames)
                .try_for_each(|(c, frame)| generator.record_draw(rec, &hairs[c.hair], frame, path, false))
        });
        rec.end_rendering();
        target.copy_out(rec);
        drawn
    })?;
    let mut stats = GenerationStats::default();
    for (c, frame) in characters.iter().zip(frames) {
        let s = generator.stats(ctx, &hairs[c.hair], frame)?;
        stats += s;
    }
    Ok(CrowdFrame { image: target.read(ctx)?, timings, stats })
}
