//! Occluder meshes (a character's scalp or body): drawn opaque with Lambert shading before the
//! hair, so they hide what is behind them; they receive the hair's deep-opacity shadows and cast
//! shadows through their own depth map per light.

use std::path::Path;

use gen_gpu::{Binding, Buffer, BufferDesc, Context, GraphicsPipelineDesc, GraphicsStages, Pipeline, vk};
use glam::{DVec3, Mat4, Vec3};
use hairmesh::scalp::ScalpSelector;

use crate::shaders;

/// Largest occluder accepted (triangles), so a hostile file cannot exhaust GPU memory.
pub const MAX_OCCLUDER_TRIANGLES: usize = 4 << 20;

/// An occluder mesh on the GPU: positions and smooth normals (vec4 each) and a triangle list.
#[derive(Debug)]
pub struct OccluderMesh {
    positions: Buffer,
    normals: Buffer,
    indices: Buffer,
    pub index_count: u32,
    /// Object-space bounds.
    pub bounds: (Vec3, Vec3),
}

/// Push constants of `occluder.vert` / `occluder.frag`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct OccluderPush {
    pub model: [f32; 16],
    pub view_proj: [f32; 16],
    /// xyz world eye; w: number of lights.
    pub eye: [f32; 4],
    /// rgb albedo (linear); w: ambient.
    pub color: [f32; 4],
    /// With `"ao"`: world → voxel coordinates of the character's hair volume, and its grid
    /// (voxels per axis, first voxel; 0 voxels: no AO) — the hair darkens the scalp under it.
    pub world_to_voxel: [f32; 16],
    pub volume: [u32; 4],
}

/// Area-weighted vertex normals of the triangles `indices` over `positions`.
fn smooth_normals(positions: &[DVec3], indices: &[u32]) -> Vec<DVec3> {
    let mut normals = vec![DVec3::ZERO; positions.len()];
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [t[0], t[1], t[2]].map(|i| positions[i as usize]);
        // The cross product's length is twice the area: bigger faces weigh more.
        let n = (b - a).cross(c - a);
        for &i in t {
            normals[i as usize] += n;
        }
    }
    normals.into_iter().map(|n| n.try_normalize().unwrap_or(DVec3::Y)).collect()
}

/// An occluder mesh on the CPU, ready to upload: triangles with smooth normals.
#[derive(Clone, Debug, PartialEq)]
pub struct OccluderGeometry {
    pub positions: Vec<[f32; 4]>,
    pub normals: Vec<[f32; 4]>,
    pub indices: Vec<u32>,
    /// Object-space bounds.
    pub bounds: (Vec3, Vec3),
}

impl OccluderGeometry {
    /// Loads a glTF/GLB or OBJ mesh (every face; polygons fanned into triangles).
    pub fn load(path: &Path) -> Result<Self, crate::RenderError> {
        let asset_error = |source| crate::RenderError::Asset { path: path.to_owned(), source };
        let mesh = hairmesh::import::load_scalp(path, &ScalpSelector::All).map_err(asset_error)?;
        Self::from_mesh(&mesh).map_err(|message| {
            asset_error(hairmesh::HairMeshError::Format { path: path.to_owned(), message })
        })
    }

    /// Fans `mesh`'s faces into triangles and computes smooth normals.
    pub fn from_mesh(mesh: &hairmesh::ScalpMesh) -> Result<Self, String> {
        let triangles: usize = mesh.faces.iter().map(|f| f.len().saturating_sub(2)).sum();
        if triangles > MAX_OCCLUDER_TRIANGLES {
            return Err(format!(
                "{triangles} triangles (an occluder may have at most {MAX_OCCLUDER_TRIANGLES})"
            ));
        }
        let mut indices = Vec::with_capacity(triangles * 3);
        for face in &mesh.faces {
            for k in 1..face.len().saturating_sub(1) {
                indices.extend([face[0], face[k], face[k + 1]]);
            }
        }
        let normals = smooth_normals(&mesh.positions, &indices);
        let vec4s =
            |v: &[DVec3]| -> Vec<[f32; 4]> { v.iter().map(|p| p.as_vec3().extend(1.0).to_array()).collect() };
        let (lo, hi) = mesh.bounds().unwrap_or_default();
        Ok(Self {
            positions: vec4s(&mesh.positions),
            normals: vec4s(&normals),
            indices,
            bounds: (lo.as_vec3(), hi.as_vec3()),
        })
    }
}

impl OccluderMesh {
    /// Loads a glTF/GLB or OBJ mesh (every face; polygons fanned into triangles) and uploads it.
    pub fn load(ctx: &Context, path: &Path) -> Result<Self, crate::RenderError> {
        Ok(Self::upload(ctx, &OccluderGeometry::load(path)?)?)
    }

    /// Uploads a mesh.
    pub fn upload(ctx: &Context, geometry: &OccluderGeometry) -> gen_gpu::Result<Self> {
        let upload = |name: &str, bytes: &[u8]| {
            ctx.create_buffer_with_data(name, BufferDesc::storage(bytes.len().max(4) as u64), bytes)
        };
        Ok(Self {
            positions: upload("occluder positions", bytemuck::cast_slice(&geometry.positions))?,
            normals: upload("occluder normals", bytemuck::cast_slice(&geometry.normals))?,
            indices: upload("occluder indices", bytemuck::cast_slice(&geometry.indices))?,
            index_count: geometry.indices.len() as u32,
            bounds: geometry.bounds,
        })
    }

    fn buffers(&self) -> [(u32, &Buffer); 3] {
        use crate::contract::binding as b;
        [
            (b::OCCLUDER_POSITIONS, &self.positions),
            (b::OCCLUDER_NORMALS, &self.normals),
            (b::OCCLUDER_INDICES, &self.indices),
        ]
    }

    /// Records the draw with `pipeline` (bound here) and the given lighting buffers.
    pub fn record_draw(
        &self,
        rec: &gen_gpu::Recorder<'_>,
        pipeline: &Pipeline,
        push: &OccluderPush,
        lighting: &[(u32, &Buffer)],
    ) {
        rec.bind_pipeline(pipeline);
        let mut buffers: Vec<(u32, &Buffer)> = self.buffers().to_vec();
        buffers.extend_from_slice(lighting);
        rec.push_storage_buffers(pipeline, &buffers);
        rec.push_constants(pipeline, push);
        rec.draw(self.index_count, 1);
    }
}

pub use crate::contract::LIGHTING_BINDINGS;

/// The occluder pipelines: depth-only into the scene target (a prepass), shaded into it where
/// the prepass left each pixel's nearest surface, and depth-only into shadow maps.
pub struct OccluderPipelines {
    pub depth: Pipeline,
    pub shade: Pipeline,
    pub shadow: Pipeline,
}

impl std::fmt::Debug for OccluderPipelines {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OccluderPipelines").finish()
    }
}

impl OccluderPipelines {
    /// The pipelines for a scene of `lights` lights (at most [`crate::scene::MAX_LIGHTS`]; the
    /// shading is specialized for the count).
    pub fn new(
        ctx: &Context,
        color_format: vk::Format,
        samples: u32,
        lights: usize,
    ) -> gen_gpu::Result<Self> {
        let stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        use crate::contract::binding as b;
        let bindings: Vec<Binding> = [b::OCCLUDER_POSITIONS, b::OCCLUDER_NORMALS, b::OCCLUDER_INDICES]
            .into_iter()
            .chain(LIGHTING_BINDINGS)
            .chain([b::VOLUME_AO])
            .map(|b| Binding::storage_buffer(b, stages))
            .collect();
        let light_count = [crate::contract::scene_lights_constant(lights)];
        let desc = |name, fragment, color_format, samples, color_write, depth_compare| GraphicsPipelineDesc {
            name,
            stages: GraphicsStages::Vertex(&shaders::OCCLUDER_VERT),
            fragment,
            bindings: &bindings,
            push_constant_size: size_of::<OccluderPush>() as u32,
            specialization: &light_count,
            color_format,
            depth_format: Some(gen_gpu::DEPTH_FORMAT),
            blend: gen_gpu::Blend::Replace,
            depth_write: true,
            color_write,
            samples,
            depth_compare,
        };
        let less = vk::CompareOp::LESS;
        Ok(Self {
            depth: Pipeline::graphics(
                ctx,
                &desc(
                    "occluder depth prepass",
                    &shaders::SHADOW_DEPTH_FRAG,
                    color_format,
                    samples,
                    false,
                    less,
                ),
            )?,
            // After the prepass only each pixel's nearest surface passes (the same vertex code
            // gives the same depths), so a pixel is lit once however many surfaces cover it.
            shade: Pipeline::graphics(
                ctx,
                &desc(
                    "occluders",
                    &shaders::OCCLUDER_FRAG,
                    color_format,
                    samples,
                    true,
                    vk::CompareOp::LESS_OR_EQUAL,
                ),
            )?,
            shadow: Pipeline::graphics(
                ctx,
                &desc(
                    "occluder shadow depth",
                    &shaders::SHADOW_DEPTH_FRAG,
                    gen_gpu::COLOR_FORMAT,
                    1,
                    false,
                    less,
                ),
            )?,
        })
    }
}

/// The push constants of an occluder drawn with `view_proj` (world → clip).
pub fn occluder_push(
    model: Mat4,
    view_proj: Mat4,
    eye: Vec3,
    lights: usize,
    color: [f32; 3],
) -> OccluderPush {
    OccluderPush {
        model: model.to_cols_array(),
        view_proj: view_proj.to_cols_array(),
        eye: eye.extend(lights as f32).to_array(),
        color: [color[0], color[1], color[2], 0.08],
        world_to_voxel: Mat4::IDENTITY.to_cols_array(),
        volume: [0; 4],
    }
}
