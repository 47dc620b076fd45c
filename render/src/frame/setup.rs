//! Setting a scene up on the GPU: pipelines for its effects, one upload per distinct hair and
//! occluder mesh, the rasterizer the device and the effects choose.

use super::*;

impl SceneRenderer {
    /// Loads every file `scene` names ([`SceneInstance::load`]) and sets the scene up on the GPU.
    pub fn new(ctx: &Context, scene: &LoadedScene, path: GenerationPath) -> Result<Self, RenderError> {
        Self::from_instance(ctx, &SceneInstance::load(scene)?, path)
    }

    /// Sets up a scene whose characters are in memory (no file is read): pipelines for its
    /// effects, one upload per distinct hair and occluder mesh.
    pub fn from_instance(
        ctx: &Context,
        instance: &SceneInstance,
        path: GenerationPath,
    ) -> Result<Self, RenderError> {
        let scene = &instance.settings;
        let effects = scene.scene.effects;
        // The fragment stages shade the scene's lights by constant index (lighting.glsl).
        let scene_lights = crate::contract::scene_lights_constant(scene.lights().len());
        let generator = Generator::with_options(
            ctx,
            GeneratorOptions {
                fragment: Some(FragmentStage {
                    shader: &shaders::HAIR_FRAG,
                    push_constant_bytes: size_of::<Shading>() as u32,
                    blend: gen_gpu::Blend::Over,
                    // Blended mode: only the depth prepass writes hair depth; this pass shades
                    // what lies in front of (or is) the nearest solid fragment.
                    depth_write: effects.transparency != Transparency::Blended,
                    depth_compare: if effects.transparency == Transparency::Blended {
                        vk::CompareOp::LESS_OR_EQUAL
                    } else {
                        vk::CompareOp::LESS
                    },
                    color_write: true,
                    extra_bindings: &crate::contract::HAIR_FRAGMENT_BINDINGS,
                    specialization: Some(scene_lights),
                }),
                color_format: Some(SCENE_COLOR_FORMAT),
                samples: effects.msaa,
                ..GeneratorOptions::default()
            },
        )?;
        // Blended mode's depth prepass: fragments a strand covers fully write depth, thinner
        // ones do not, so a sub-pixel strand (alpha = coverage) never hides the strands behind it.
        let depth_prepass = if effects.transparency != Transparency::Blended {
            None
        } else {
            Some(Generator::with_options(
                ctx,
                GeneratorOptions {
                    fragment: Some(FragmentStage {
                        shader: &shaders::HAIR_DEPTH_FRAG,
                        push_constant_bytes: size_of::<Shading>() as u32,
                        blend: gen_gpu::Blend::Replace,
                        depth_write: true,
                        depth_compare: vk::CompareOp::LESS,
                        color_write: false,
                        extra_bindings: &[],
                        specialization: None,
                    }),
                    color_format: Some(SCENE_COLOR_FORMAT),
                    samples: effects.msaa,
                    ..GeneratorOptions::default()
                },
            )?)
        };
        let oit = if effects.transparency == Transparency::Oit {
            let fill = Generator::with_options(
                ctx,
                GeneratorOptions {
                    fragment: Some(FragmentStage {
                        shader: &shaders::HAIR_OIT_FRAG,
                        push_constant_bytes: size_of::<Shading>() as u32,
                        blend: gen_gpu::Blend::Replace,
                        depth_write: false,
                        depth_compare: vk::CompareOp::LESS,
                        color_write: false,
                        extra_bindings: &OIT_FILL_BINDINGS,
                        specialization: Some(scene_lights),
                    }),
                    color_format: Some(SCENE_COLOR_FORMAT),
                    ..GeneratorOptions::default()
                },
            )?;
            // The nearest hair's depth is written (gl_FragDepth) for depth output.
            let resolve = crate::target::composite_pipeline(
                ctx,
                "OIT resolve",
                &shaders::FULLSCREEN_VERT,
                &shaders::OIT_RESOLVE_FRAG,
                &OIT_BINDINGS,
                4,
            )?;
            Some(Oit { fill, resolve, k: effects.oit_k, nodes_per_pixel: effects.oit_nodes_per_pixel })
        } else {
            None
        };
        // One upload per key (asset and style): characters sharing both share the GPU hair.
        let mut keys: HashMap<&str, usize> = HashMap::new();
        let mut hairs = Vec::new();
        let mut characters = Vec::new();
        let mut stored = Vec::new();
        let mut stored_characters = Vec::new();
        let mut mesh_keys: HashMap<&str, usize> = HashMap::new();
        let mut meshes = Vec::new();
        let mut occluders = Vec::new();
        let mut occluder_sources = Vec::new();
        let mut slots = Vec::new();
        for c in &instance.characters {
            let occluder_slot =
                c.occluder.as_ref().map(|o| (occluders.len(), c.transform.inverse() * o.transform));
            if let Some(o) = &c.occluder {
                let mesh = match mesh_keys.get(o.key.as_str()) {
                    Some(&m) => m,
                    None => {
                        meshes.push(OccluderMesh::upload(ctx, &o.geometry)?);
                        mesh_keys.insert(&o.key, meshes.len() - 1);
                        meshes.len() - 1
                    }
                };
                // The hair's volume source is set below, once the uploads are counted.
                occluders.push(SceneOccluder {
                    mesh,
                    transform: o.transform,
                    color: o.color,
                    hair_volume: usize::MAX,
                    hair_transform: c.transform,
                });
            }
            // (Whether this character's hair is stored, and its index among its kind.)
            let source = match &c.hair {
                CharacterHair::Stored { strands, width } => {
                    stored.push(gen_gpu::StoredStrands::upload(
                        ctx,
                        &strands.points,
                        &strands.strand_points,
                        *width,
                        0.3,
                    )?);
                    stored_characters.push(SceneCharacter {
                        hair: stored.len() - 1,
                        transform: c.transform,
                        color: c.color,
                        variation: c.color_variation,
                    });
                    (true, stored.len() - 1)
                }
                CharacterHair::Generated(asset) => {
                    let hair = match keys.get(c.key.as_str()) {
                        Some(&h) => h,
                        None => {
                            hairs.push(GpuHair::upload(ctx, asset, TexturePrecision::Auto)?);
                            keys.insert(&c.key, hairs.len() - 1);
                            hairs.len() - 1
                        }
                    };
                    characters.push(SceneCharacter {
                        hair,
                        transform: c.transform,
                        color: c.color,
                        variation: c.color_variation,
                    });
                    (false, hair)
                }
            };
            if c.occluder.is_some() {
                occluder_sources.push(source);
            }
            let index = if source.0 { stored_characters.len() - 1 } else { characters.len() - 1 };
            slots.push(CharacterSlot { stored: source.0, index, occluder: occluder_slot });
        }
        // Volume sources: the uploaded hairs, then the stored strands.
        for (o, (is_stored, index)) in occluders.iter_mut().zip(occluder_sources) {
            o.hair_volume = if is_stored { hairs.len() + index } else { index };
        }
        let shadow = if scene.shadow_lights().is_empty() { None } else { Some(ShadowPipelines::new(ctx)?) };
        let no_shadow = [
            Buffer::new(ctx, "no shadow depth", BufferDesc::storage(16))?,
            Buffer::new(ctx, "no shadow opacity", BufferDesc::storage(16))?,
            Buffer::new(ctx, "no occluder depth", BufferDesc::storage(16))?,
        ];
        let occluder_pipes = if meshes.is_empty() {
            None
        } else {
            Some(OccluderPipelines::new(ctx, SCENE_COLOR_FORMAT, effects.msaa, scene.lights().len())?)
        };
        let mut renderer = Self {
            generator,
            depth_prepass,
            oit,
            shadow,
            shadow_cache: Mutex::new(None),
            stale_shadows_ok: std::sync::atomic::AtomicBool::new(false),
            pool: Mutex::new(TransientPool::default()),
            slot_history: Mutex::default(),
            no_shadow,
            occluder_pipes,
            meshes,
            occluders,
            hairs,
            hair_keys: keys.into_iter().map(|(k, h)| (k.to_owned(), h)).collect(),
            characters,
            stored,
            stored_characters,
            scene: scene.clone(),
            effects,
            path,
            compute_raster: None,
            raster_materials: Vec::new(),
            character_materials: Vec::new(),
            occlusion_tiles: true,
            slot_order: true,
            depth_clipping_everywhere: false,
            buffer_references: true,
            fused_strands: FusedStrands::Styled,
            volumes: None,
            volumes_everywhere: false,
            batch_bytes: BATCH_BYTES,
            staged: Mutex::new(Vec::new()),
            slots,
            placements: 0,
        };
        renderer.set_up_raster(ctx)?;
        Ok(renderer)
    }

    /// Resolves the scene's rasterizer choice and, for the compute rasterizer, builds its
    /// pipelines and the material table (`auto` keeps triangles when the scene has more
    /// distinct hair materials than the visibility word can name).
    pub(super) fn set_up_raster(&mut self, ctx: &Context) -> Result<(), RenderError> {
        let effects = self.effects;
        let mut raster = resolve_raster(effects.raster, &effects, ctx.capabilities())?;
        let eye = Vec3::from_array(self.scene.scene.camera.eye);
        let mut table: Vec<RasterMaterial> = Vec::new();
        let mut indices = Vec::new();
        for c in self.characters.iter().chain(&self.stored_characters) {
            let s = self.shading(c, eye);
            let m = RasterMaterial {
                hair_color: s.hair_color,
                specular_shift: s.specular_shift,
                specular_strength: s.specular_strength,
                opacity: s.hair_opacity,
                world_to_voxel: Mat4::IDENTITY.to_cols_array(),
                volume: [0; 4],
                volume_info: [0; 4],
            };
            // With AO or volume shadows a material names its character's volume: one per
            // character.
            let per_character = effects.ao || effects.volume_shadows;
            let shared = if per_character { None } else { table.iter().position(|t| *t == m) };
            let index = match shared {
                Some(i) => i,
                None => {
                    table.push(m);
                    table.len() - 1
                }
            };
            indices.push(index as u32);
        }
        // Two words per pixel at least (one slot and the coverage) in one storage buffer.
        let output = self.scene.scene.output;
        let pixels = u64::from(output.width) * u64::from(output.height);
        let range = u64::from(ctx.capabilities().max_storage_buffer_range);
        let why_not = if table.len() > MAX_MATERIALS {
            Some(format!("{} distinct hair materials (at most {MAX_MATERIALS})", table.len()))
        } else if pixels * 16 > range {
            Some(format!(
                "{}×{} needs {} bytes of per-pixel words, over the device's {range}-byte storage-buffer range",
                output.width,
                output.height,
                pixels * 16
            ))
        } else {
            None
        };
        if let (RasterPath::Compute, Some(why)) = (raster, why_not) {
            if effects.raster == crate::scene::Raster::Compute || effects.volume_lod {
                return Err(RenderError::RasterUnavailable { why });
            }
            raster = RasterPath::Triangles;
        }
        if raster == RasterPath::Compute {
            self.compute_raster = Some(ComputeRaster::new(
                ctx,
                self.scene.lights().len(),
                table.len(),
                self.compute_raster_loads(),
                Some(self.frame_slots(ctx)),
                self.fused_strands,
            )?);
            self.raster_materials = table;
            self.character_materials = indices;
            // The deep opacity maps go through the same segment walker.
            if let Some(shadow) = &mut self.shadow {
                shadow.compute = Some(crate::shadow::ComputeShadow::new(ctx)?);
            }
        }
        // `"lod": "auto"` draws characters small enough that the volume keeps the image within
        // its FLIP (crate::scene::AUTO_VOLUME_PIXELS) as volumes wherever the compute rasterizer
        // draws the hair (the volume LOD path writes into its visibility buffer); a scene that
        // asks for `volume_lod` itself keeps its own threshold.
        let mut effects = effects;
        if raster == RasterPath::Compute && self.scene.scene.lod.auto && !effects.volume_lod {
            effects.volume_lod = true;
            effects.volume_lod_pixels = crate::scene::AUTO_VOLUME_PIXELS;
            self.effects = effects;
        }
        // AO and volume shadows work on either rasterizer; the volume LOD path needs the
        // compute rasterizer (the scene is refused otherwise).
        if effects.uses_volumes() {
            let bounds: Vec<(Vec3, Vec3)> =
                (0..self.volume_sources()).map(|v| self.volume_bounds(v)).collect();
            self.volumes = Some(SceneVolumes {
                pipelines: VolumePipelines::new(ctx)?,
                store: VolumeStore::new(ctx, &bounds, effects.volume_resolution)?,
                cache: Mutex::new(vec![None; bounds.len()]),
                opacity: if self.oit.is_some() { 0.7 } else { 1.0 },
            });
        }
        Ok(())
    }
}
