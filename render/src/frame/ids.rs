//! The graph's names of a frame's resources ([`FrameIds`]), the planned frame ([`FramePlan`])
//! and what the passes of one submission read ([`FrameState`]).

use super::*;

/// The resources of a planned frame, as the graph names them.
#[derive(Clone, Debug)]
pub(crate) struct FrameIds {
    pub(crate) color: Res,
    pub(crate) depth: Res,
    pub(crate) resolve: Option<(Res, Res)>,
    pub(crate) readback: Res,
    pub(crate) lights: Res,
    pub(crate) oit_lists: Res,
    pub(crate) occluder_meshes: Res,
    /// Compute rasterizer: visibility + coverage, the occluders' depth copy, the resolve's
    /// camera and materials.
    pub(crate) visibility: Res,
    pub(crate) scene_depth: Res,
    pub(crate) raster_frame: Res,
    pub(crate) shaded: Res,
    pub(crate) raster_tiles: Res,
    /// Compute rasterizer: the characters' slot orders, their strand marks, the last frame's
    /// depths ([`crate::raster::SlotOrderHistory`]).
    pub(crate) slot_orders: Res,
    pub(crate) strand_marks: Res,
    pub(crate) final_depth: Res,
    /// Per uploaded hair: its asset.
    pub(crate) hair_uploads: Vec<Res>,
    /// Per generated character: whether its strands get a second front eighth in the compute
    /// rasterizer ([`crate::raster::second_front_pays`]).
    pub(crate) second_front: Vec<bool>,
    /// Hair volumes (with `"ao"`, `"volume_shadows"` or `"volume_lod"`).
    pub(crate) volumes: Option<VolumeIds>,
    /// Per generated character: its hair asset, LOD result and strands.
    pub(crate) hair: Vec<Res>,
    pub(crate) lod: Vec<Res>,
    pub(crate) strands: Vec<Res>,
    pub(crate) stored: Vec<Res>,
    pub(crate) shadow: Option<crate::passes::shadow::ShadowIds>,
}

impl FrameIds {
    /// Whether generated character `i` gets a second front eighth this frame.
    pub(crate) fn second_front(&self, i: usize) -> bool {
        self.second_front.get(i).copied().unwrap_or(false)
    }

    /// What a pass that shades with the scene's lights reads: the light table, and the shadow
    /// maps when the scene has them.
    pub(crate) fn shading_reads(&self) -> Vec<(Res, Access)> {
        self.shading_reads_as(Access::FragmentRead)
    }

    /// What a pass that shades hair reads: [`Self::shading_reads`] and the hair volumes (AO and
    /// volume shadows) when the scene has them.
    pub(crate) fn hair_shading_reads(&self) -> Vec<(Res, Access)> {
        let mut r = self.shading_reads();
        r.extend(self.volume_reads(Access::FragmentRead));
        r
    }

    /// [`Self::hair_shading_reads`] by a compute pass.
    pub(crate) fn compute_hair_shading_reads(&self) -> Vec<(Res, Access)> {
        let mut r = self.shading_reads_as(Access::ComputeRead);
        r.extend(self.volume_reads(Access::ComputeRead));
        r
    }

    fn volume_reads(&self, access: Access) -> Vec<(Res, Access)> {
        self.volumes.iter().flat_map(|v| [(v.volume, access), (v.ao, access), (v.bricks, access)]).collect()
    }

    fn shading_reads_as(&self, access: Access) -> Vec<(Res, Access)> {
        let mut r = vec![(self.lights, access)];
        r.extend(self.shadow.as_ref().map(|s| (s.maps, access)));
        r
    }

    /// The attachments a pass rendering into the scene target writes.
    pub(crate) fn target_writes(&self) -> Vec<(Res, Access)> {
        let mut w = vec![(self.color, Access::ColorAttachment), (self.depth, Access::DepthAttachment)];
        if let Some((c, d)) = self.resolve {
            w.push((c, Access::ColorAttachment));
            w.push((d, Access::DepthAttachment));
        }
        w
    }
}

/// A frame planned for one camera: its graph, the resource names, the batches of characters
/// (one submission each) and the generation inputs.
#[derive(Debug)]
pub struct FramePlan {
    pub graph: FrameGraph<ScenePass>,
    pub(crate) ids: FrameIds,
    /// Generated characters per batch submission, and the submission of the first batch.
    pub(crate) batches: Vec<Vec<usize>>,
    pub(crate) first_batch_submission: usize,
    pub(crate) view: FrameView,
    pub(crate) inputs: Vec<FrameInputs>,
    pub(crate) shadow_cached: bool,
    /// Characters drawn as volumes (in no batch).
    pub(crate) volume_characters: Vec<usize>,
}

impl FramePlan {
    /// The share of character `i`'s pixels its volume draws this frame (0 without one).
    pub(crate) fn volume_fraction(&self, i: usize) -> f32 {
        self.ids.volumes.as_ref().and_then(|v| v.fractions.get(i).copied()).unwrap_or(0.0)
    }
}

/// What the passes of one submission read: the frame's resources and the current batch's
/// generated strands.
pub(crate) struct FrameState<'a> {
    pub(crate) plan: &'a FramePlan,
    pub(crate) target: &'a SceneTarget,
    pub(crate) lighting: [(u32, &'a Buffer); 4],
    pub(crate) oit: Option<&'a OitBuffers>,
    /// The compute rasterizer's buffers.
    pub(crate) raster: Option<&'a RasterBuffers>,
    /// Material index per character (generated, then stored).
    pub(crate) materials: &'a [u32],
    /// This batch's characters and their frame buffers.
    pub(crate) frames: &'a [(usize, FrameBuffers)],
    /// Compute rasterizer: the last frame's depths, each character's marks and slot order.
    pub(crate) slot_history: Option<&'a crate::raster::SlotOrderHistory>,
    /// Parameters of the stored-strand characters (drawn with the last batch).
    pub(crate) stored_params: &'a [Buffer],
    /// The frame's voxelizations and raymarches (first batch).
    pub(crate) volumes: Option<&'a VolumeFrame>,
    /// The hair volumes at the fragment stages' bindings (`FRAGMENT_VOLUME_BINDINGS`; unread
    /// stand-ins without volumes).
    pub(crate) volume_buffers: [(u32, &'a Buffer); 3],
}

/// The OIT lists of one frame.
#[derive(Debug)]
pub(crate) struct OitBuffers {
    pub(crate) heads: Buffer,
    pub(crate) nodes: Buffer,
    pub(crate) counters: Buffer,
    pub(crate) pool: u64,
    /// Words per pixel of `heads`: [`OIT_PIXEL_WORDS`] with the overflow tail, 1 without.
    pub(crate) pixel_words: u32,
    /// The device address the shaders reach `nodes` through (it may exceed the storage-buffer
    /// range); 0: through its binding.
    pub(crate) nodes_address: u64,
}
