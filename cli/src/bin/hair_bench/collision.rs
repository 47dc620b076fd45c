//! `collision`: what strand-level collision with the head costs: the generate pass with and
//! without the asset's head distance field, and the field's bytes.

use super::*;

/// The benchmark asset with the head field `hairmesh convert` would give it: the head cap it
/// grows from is the head.
fn with_head_field(strands: u64) -> Result<HairAsset> {
    let mut asset = asset(strands)?;
    let head = hairmesh::head::HeadSurface::from_mesh(&hairmesh::procedural::head_cap(8, 32));
    let (lo, hi) = asset.bounds();
    let room = glam::DVec3::splat(0.2 * lo.distance(hi));
    asset.head_field = hairmesh::head_field::HeadField::build(
        &head,
        (lo - room, hi + room),
        hairmesh::convert::strand_clearance(&head),
    )
    .map(std::sync::Arc::new);
    anyhow::ensure!(asset.head_field.is_some(), "the head cap gave no head field");
    Ok(asset)
}

/// The generate pass alone (compute path, strand-coherent, LOD off) on the same hair without and
/// with its head field, the two alternating.
pub(super) fn collision_section(setup: &Setup<'_>, progress: &indicatif::ProgressBar) -> Result<Section> {
    let Setup { ctx, width, height, camera, .. } = *setup;
    let runs = if setup.quick { setup.frames } else { 15 };
    let generator = Generator::new(ctx, Filtering::StrandCoherent)?;
    let lod = LodParams { enabled: false, ..LodParams::default() };
    let view = FrameView { camera, width, height, path: GenerationPath::Compute, lod };
    let mut md = String::new();
    let _ = writeln!(md, "### Strand-level collision: the head field\n");
    let _ = writeln!(
        md,
        "{}; the generation benchmark's hair (head cap, 6 layers, LOD off, compute path, strand-coherent) without and with the head field `hairmesh convert` gives it (the cap as the head, {} points along its longest side): the generate pass alone, median of {runs} submissions each, the two alternating. With the field, every styled vertex inside the field's grid reads its eight texels once, and those near the head again for each push step; vertices outside the grid (here most of the long hair below the cap) cost a comparison.\n",
        setup.provenance,
        hairmesh::head_field::HeadField::MAX_POINTS
    );
    let _ = writeln!(
        md,
        "| strands | field points | field bytes (GPU) | hair bytes without it | generate, no field (ms) | generate, field (ms) | ratio |\n|---|---|---|---|---|---|---|"
    );
    let mut csv = String::from("strands,field_points,field_bytes,hair_bytes,generate_ms,generate_field_ms\n");
    for &strands in setup.sizes {
        progress.set_message(format!("collision: {strands} strands"));
        let with = with_head_field(strands)?;
        let mut without = with.clone();
        without.head_field = None;
        let hairs = [
            GpuHair::upload(ctx, &without, TexturePrecision::Auto)?,
            GpuHair::upload(ctx, &with, TexturePrecision::Auto)?,
        ];
        let buffers: Vec<Vec<gen_gpu::FrameBuffers>> = (0..2)
            .map(|i| prepare_crowd(ctx, &generator, &hairs[i..=i], &setup.character, &view))
            .collect::<gen_gpu::Result<_>>()?;
        let mut times = [Vec::new(), Vec::new()];
        for run in 0..=runs {
            for i in 0..2 {
                let ms = generate_alone(ctx, &generator, &hairs[i..=i], &setup.character, &buffers[i])?;
                // The first run of each compiles and touches the buffers: not counted.
                if run > 0 {
                    times[i].push(ms);
                }
            }
        }
        let [plain, field] = times.map(median);
        let points = with.head_field.as_ref().map_or(0, |f| f.texels());
        let (field_bytes, hair_bytes) = (hairs[1].bytes.head_field, hairs[0].bytes.total());
        let _ = writeln!(
            md,
            "| {} | {points} | {field_bytes} | {hair_bytes} | {plain:.1} | {field:.1} | **{:.2}×** |",
            hairs[0].total_strands(),
            field / plain
        );
        let _ = writeln!(
            csv,
            "{},{points},{field_bytes},{hair_bytes},{plain:.3},{field:.3}",
            hairs[0].total_strands()
        );
    }
    Ok(Section { name: "collision", markdown: md, csv: vec![("bench-collision.csv", csv)] })
}
