//! The frame graph: passes that declare what they read and write, and an executor that records
//! exactly those passes with the barriers and layout transitions their declarations imply, each
//! inside a debug label and a GPU timestamp scope of its own name.
//!
//! The renderer plans a frame as a [`FrameGraph`] (`SceneRenderer::plan`), prints it
//! (`--print-graph`) and runs it with [`GraphRun`]: there is no other way to record a pass, so
//! the graph that is printed is the graph that runs. A pass whose result is cached (shadow maps
//! of a scene whose casters did not change) stays in the graph marked `cached` and is skipped.
//! A graph may span several submissions (crowds are drawn in batches bounded by memory); resource
//! states carry over from one submission to the next, so the barriers stay correct across them.
//!
//! Barriers: per resource the executor remembers the stages and accesses since its last
//! barrier, its image layout and whether it was written. A read after a write, a write after
//! anything, or a layout change gets a barrier; reads after reads in the same layout do not.
//! Buffers are ordered with global memory barriers (what lavapipe and most drivers do anyway),
//! images with image barriers that also move their layout.

use std::collections::HashMap;
use std::fmt;

use gen_gpu::{Buffer, BufferDesc, Context, Image, ImageDesc, Recorder, vk};

/// A resource of a frame graph.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Res(usize);

/// Buffer or image: images get layout transitions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResKind {
    Buffer,
    Image,
}

/// How a pass uses a resource.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Access {
    /// Storage buffer read by compute shaders.
    ComputeRead,
    /// Storage buffer written (and read) by compute shaders.
    ComputeWrite,
    /// Indirect dispatch or draw arguments.
    IndirectRead,
    /// Storage buffer read by the pre-raster stages (vertex pulling, task and mesh shaders).
    PreRasterRead,
    /// Storage buffer read by fragment shaders.
    FragmentRead,
    /// Storage buffer written (and read) by fragment shaders (OIT lists).
    FragmentWrite,
    /// Colour attachment, read and written (blending), or a multisample resolve target.
    ColorAttachment,
    /// Depth attachment, tested and written (or a depth resolve target).
    DepthAttachment,
    /// Depth attachment, tested only.
    DepthTest,
    /// Source of a copy.
    TransferRead,
    /// Destination of a copy, fill or update.
    TransferWrite,
}

impl Access {
    fn is_write(self) -> bool {
        matches!(
            self,
            Self::ComputeWrite
                | Self::FragmentWrite
                | Self::ColorAttachment
                | Self::DepthAttachment
                | Self::TransferWrite
        )
    }

    fn stages(self) -> vk::PipelineStageFlags2 {
        use vk::PipelineStageFlags2 as S;
        match self {
            Self::ComputeRead | Self::ComputeWrite => S::COMPUTE_SHADER,
            Self::IndirectRead => S::DRAW_INDIRECT,
            Self::PreRasterRead => S::VERTEX_SHADER | S::TASK_SHADER_EXT | S::MESH_SHADER_EXT,
            Self::FragmentRead | Self::FragmentWrite => S::FRAGMENT_SHADER,
            Self::ColorAttachment => S::COLOR_ATTACHMENT_OUTPUT,
            // Depth resolves happen in the colour-attachment-output stage.
            Self::DepthAttachment | Self::DepthTest => {
                S::EARLY_FRAGMENT_TESTS | S::LATE_FRAGMENT_TESTS | S::COLOR_ATTACHMENT_OUTPUT
            }
            Self::TransferRead | Self::TransferWrite => S::COPY | S::CLEAR,
        }
    }

    fn access(self) -> vk::AccessFlags2 {
        use vk::AccessFlags2 as A;
        match self {
            Self::ComputeRead | Self::PreRasterRead | Self::FragmentRead => A::SHADER_STORAGE_READ,
            Self::ComputeWrite | Self::FragmentWrite => A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE,
            Self::IndirectRead => A::INDIRECT_COMMAND_READ,
            Self::ColorAttachment => A::COLOR_ATTACHMENT_READ | A::COLOR_ATTACHMENT_WRITE,
            Self::DepthAttachment => A::DEPTH_STENCIL_ATTACHMENT_READ | A::DEPTH_STENCIL_ATTACHMENT_WRITE,
            Self::DepthTest => A::DEPTH_STENCIL_ATTACHMENT_READ,
            Self::TransferRead => A::TRANSFER_READ,
            Self::TransferWrite => A::TRANSFER_WRITE,
        }
    }

    /// The image layout this access needs (images only).
    fn layout(self) -> vk::ImageLayout {
        match self {
            Self::ColorAttachment => vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
            Self::DepthAttachment | Self::DepthTest => vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
            Self::TransferRead => vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            Self::TransferWrite => vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            _ => vk::ImageLayout::GENERAL,
        }
    }

    fn label(self) -> &'static str {
        match self {
            Self::ComputeRead => "compute",
            Self::ComputeWrite => "compute",
            Self::IndirectRead => "indirect",
            Self::PreRasterRead => "pre-raster",
            Self::FragmentRead | Self::FragmentWrite => "fragment",
            Self::ColorAttachment => "colour attachment",
            Self::DepthAttachment => "depth attachment",
            Self::DepthTest => "depth test",
            Self::TransferRead | Self::TransferWrite => "copy",
        }
    }
}

#[derive(Clone, Debug)]
struct ResourceDecl {
    name: String,
    kind: ResKind,
}

/// One pass of a graph: its name, what it touches, and the renderer's payload saying what to
/// record.
#[derive(Clone, Debug)]
pub struct PassNode<P> {
    pub name: String,
    pub reads: Vec<(Res, Access)>,
    pub writes: Vec<(Res, Access)>,
    /// Its result is reused from an earlier frame: shown, not run.
    pub cached: bool,
    /// Which submission of the frame records it.
    pub submission: usize,
    pub payload: P,
}

/// A frame's passes in order and the resources they use.
#[derive(Clone, Debug)]
pub struct FrameGraph<P> {
    resources: Vec<ResourceDecl>,
    pub passes: Vec<PassNode<P>>,
}

impl<P> Default for FrameGraph<P> {
    fn default() -> Self {
        Self { resources: Vec::new(), passes: Vec::new() }
    }
}

/// Adds one pass: chain its reads and writes, then [`PassBuilder::add`] it.
#[derive(Debug)]
#[must_use = "a pass is only added by `add`"]
pub struct PassBuilder<'g, P> {
    graph: &'g mut FrameGraph<P>,
    node: PassNode<()>,
}

impl<P> PassBuilder<'_, P> {
    pub fn read(mut self, res: Res, access: Access) -> Self {
        debug_assert!(!access.is_write(), "{access:?} is a write");
        self.node.reads.push((res, access));
        self
    }

    pub fn write(mut self, res: Res, access: Access) -> Self {
        debug_assert!(access.is_write(), "{access:?} is a read");
        self.node.writes.push((res, access));
        self
    }

    /// [`Self::read`] of each, in order.
    pub fn reads(self, reads: impl IntoIterator<Item = (Res, Access)>) -> Self {
        reads.into_iter().fold(self, |pass, (res, access)| pass.read(res, access))
    }

    /// [`Self::write`] of each, in order.
    pub fn writes(self, writes: impl IntoIterator<Item = (Res, Access)>) -> Self {
        writes.into_iter().fold(self, |pass, (res, access)| pass.write(res, access))
    }

    pub fn cached(mut self, cached: bool) -> Self {
        self.node.cached = cached;
        self
    }

    pub fn submission(mut self, submission: usize) -> Self {
        self.node.submission = submission;
        self
    }

    pub fn add(self, payload: P) {
        let n = self.node;
        self.graph.passes.push(PassNode {
            name: n.name,
            reads: n.reads,
            writes: n.writes,
            cached: n.cached,
            submission: n.submission,
            payload,
        });
    }
}

impl<P> FrameGraph<P> {
    /// Declares a buffer (or a set of buffers used together, such as one character's strands).
    pub fn buffer(&mut self, name: impl Into<String>) -> Res {
        self.resources.push(ResourceDecl { name: name.into(), kind: ResKind::Buffer });
        Res(self.resources.len() - 1)
    }

    /// Declares an image (it gets layout transitions).
    pub fn image(&mut self, name: impl Into<String>) -> Res {
        self.resources.push(ResourceDecl { name: name.into(), kind: ResKind::Image });
        Res(self.resources.len() - 1)
    }

    /// Starts a pass named `name` in submission 0.
    pub fn pass(&mut self, name: impl Into<String>) -> PassBuilder<'_, P> {
        PassBuilder {
            graph: self,
            node: PassNode {
                name: name.into(),
                reads: Vec::new(),
                writes: Vec::new(),
                cached: false,
                submission: 0,
                payload: (),
            },
        }
    }

    pub fn resource_name(&self, res: Res) -> &str {
        &self.resources[res.0].name
    }

    pub fn resource_kind(&self, res: Res) -> ResKind {
        self.resources[res.0].kind
    }

    /// Names of the passes that run (not cached), in order.
    pub fn runnable(&self) -> Vec<String> {
        self.passes.iter().filter(|p| !p.cached).map(|p| p.name.clone()).collect()
    }

    /// Number of submissions the frame uses.
    pub fn submissions(&self) -> usize {
        self.passes.iter().map(|p| p.submission + 1).max().unwrap_or(0)
    }

    /// The graph without payloads (what `--print-graph` and tests look at).
    pub fn outline(&self) -> FrameGraph<()> {
        FrameGraph {
            resources: self.resources.clone(),
            passes: self
                .passes
                .iter()
                .map(|p| PassNode {
                    name: p.name.clone(),
                    reads: p.reads.clone(),
                    writes: p.writes.clone(),
                    cached: p.cached,
                    submission: p.submission,
                    payload: (),
                })
                .collect(),
        }
    }
}

impl<P> fmt::Display for FrameGraph<P> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let list = |uses: &[(Res, Access)]| {
            uses.iter()
                .map(|(r, a)| format!("{} ({})", self.resource_name(*r), a.label()))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let submissions = self.submissions();
        let mut current = usize::MAX;
        for (i, p) in self.passes.iter().enumerate() {
            if submissions > 1 && p.submission != current {
                current = p.submission;
                writeln!(f, "  -- submission {} of {submissions}", current + 1)?;
            }
            let cached = if p.cached { "  [cached: not run]" } else { "" };
            writeln!(f, "{i:>2}. {}{cached}", p.name)?;
            writeln!(f, "      reads  [{}]", list(&p.reads))?;
            writeln!(f, "      writes [{}]", list(&p.writes))?;
        }
        Ok(())
    }
}

/// What the executor knows of a resource between passes.
#[derive(Clone, Copy, Debug)]
struct ResState {
    stages: vk::PipelineStageFlags2,
    access: vk::AccessFlags2,
    layout: vk::ImageLayout,
    written: bool,
    touched: bool,
}

impl Default for ResState {
    fn default() -> Self {
        Self {
            stages: vk::PipelineStageFlags2::NONE,
            access: vk::AccessFlags2::NONE,
            layout: vk::ImageLayout::UNDEFINED,
            written: false,
            touched: false,
        }
    }
}

/// Records a [`FrameGraph`], submission by submission, with derived barriers.
#[derive(Debug)]
pub struct GraphRun<'g, P> {
    graph: &'g FrameGraph<P>,
    states: Vec<ResState>,
    /// Names of the passes recorded so far, in order.
    pub ran: Vec<String>,
    /// Barriers the executor recorded (memory + image), for tests and `--stats`.
    pub barriers: usize,
}

impl<'g, P> GraphRun<'g, P> {
    pub fn new(graph: &'g FrameGraph<P>) -> Self {
        Self { graph, states: vec![ResState::default(); graph.resources.len()], ran: Vec::new(), barriers: 0 }
    }

    /// Whether `res` has not been used yet this frame (a pass that renders into it clears it).
    pub fn untouched(&self, res: Res) -> bool {
        !self.states[res.0].touched
    }

    /// Records submission `submission`'s passes that are not cached: barriers first, then
    /// `record(rec, pass)` inside the pass's label and timestamp scope. `image` gives the image
    /// behind each declared image resource (for layout transitions).
    pub fn record_submission<'r>(
        &mut self,
        rec: &mut Recorder<'_>,
        submission: usize,
        image: &dyn Fn(Res) -> Option<&'r Image>,
        mut record: impl FnMut(&mut Recorder<'_>, &PassNode<P>, &Self) -> gen_gpu::Result<()>,
    ) -> gen_gpu::Result<()> {
        let graph = self.graph;
        for pass in graph.passes.iter().filter(|p| p.submission == submission && !p.cached) {
            self.barriers_for(rec, pass, image);
            let result = rec.pass(&pass.name, |rec| record(rec, pass, self));
            for (res, _) in pass.reads.iter().chain(&pass.writes) {
                self.states[res.0].touched = true;
            }
            self.ran.push(pass.name.clone());
            result?;
        }
        Ok(())
    }

    fn barriers_for<'r>(
        &mut self,
        rec: &Recorder<'_>,
        pass: &PassNode<P>,
        image: &dyn Fn(Res) -> Option<&'r Image>,
    ) {
        let mut memory: Vec<vk::MemoryBarrier2<'static>> = Vec::new();
        let mut images: Vec<vk::ImageMemoryBarrier2<'static>> = Vec::new();
        // A resource may be declared more than once by a pass (read as indirect arguments and as
        // a storage buffer): merge its uses first.
        let mut uses: Vec<(Res, Access, vk::PipelineStageFlags2, vk::AccessFlags2, bool)> = Vec::new();
        for &(res, access) in pass.reads.iter().chain(&pass.writes) {
            match uses.iter_mut().find(|u| u.0 == res) {
                Some(u) => {
                    u.2 |= access.stages();
                    u.3 |= access.access();
                    u.4 |= access.is_write();
                    // The layout of an image follows its write (attachments) when declared twice.
                    if access.is_write() {
                        u.1 = access;
                    }
                }
                None => uses.push((res, access, access.stages(), access.access(), access.is_write())),
            }
        }
        for (res, access, stages, access_flags, writes) in uses {
            let state = &mut self.states[res.0];
            let is_image = self.graph.resource_kind(res) == ResKind::Image;
            let layout = if is_image { access.layout() } else { vk::ImageLayout::UNDEFINED };
            let layout_change = is_image && state.layout != layout;
            let needed = layout_change || state.written || writes;
            if !needed {
                state.stages |= stages;
                state.access |= access_flags;
                continue;
            }
            let (src_stages, src_access) = if state.stages == vk::PipelineStageFlags2::NONE {
                (vk::PipelineStageFlags2::TOP_OF_PIPE, vk::AccessFlags2::NONE)
            } else if state.written {
                (state.stages, state.access)
            } else {
                // Write after reads: an execution dependency is enough.
                (state.stages, vk::AccessFlags2::NONE)
            };
            match (is_image, image(res)) {
                (true, Some(img)) => images.push(
                    vk::ImageMemoryBarrier2::default()
                        .src_stage_mask(src_stages)
                        .src_access_mask(src_access)
                        .dst_stage_mask(stages)
                        .dst_access_mask(access_flags)
                        .old_layout(state.layout)
                        .new_layout(layout)
                        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                        .image(img.raw)
                        .subresource_range(img.full_range()),
                ),
                (true, None) => {}
                (false, _) => {
                    if state.stages != vk::PipelineStageFlags2::NONE {
                        memory.push(
                            vk::MemoryBarrier2::default()
                                .src_stage_mask(src_stages)
                                .src_access_mask(src_access)
                                .dst_stage_mask(stages)
                                .dst_access_mask(access_flags),
                        );
                    }
                }
            }
            *state =
                ResState { stages, access: access_flags, layout, written: writes, touched: state.touched };
        }
        // One global memory barrier carries every buffer's dependency.
        let merged = memory.iter().fold(None, |acc: Option<vk::MemoryBarrier2<'static>>, m| {
            Some(match acc {
                None => *m,
                Some(a) => a
                    .src_stage_mask(a.src_stage_mask | m.src_stage_mask)
                    .src_access_mask(a.src_access_mask | m.src_access_mask)
                    .dst_stage_mask(a.dst_stage_mask | m.dst_stage_mask)
                    .dst_access_mask(a.dst_access_mask | m.dst_access_mask),
            })
        });
        let memory: Vec<_> = merged.into_iter().collect();
        if !memory.is_empty() || !images.is_empty() {
            self.barriers += memory.len() + images.len();
            rec.pipeline_barrier(&memory, &images);
        }
    }
}

/// Transient GPU resources pooled by name and description and reused from frame to frame (the
/// frame's target, OIT lists, light tables): a frame takes what it needs and gives it back at
/// its end, so a steady scene allocates nothing after its first frame.
#[derive(Debug, Default)]
pub struct TransientPool {
    buffers: HashMap<(String, BufferDesc), Vec<Buffer>>,
    images: HashMap<(String, ImageDesc), Vec<Image>>,
    /// Resources created (not reused) since the pool was made, for tests.
    pub created: usize,
}

impl TransientPool {
    pub fn buffer(&mut self, ctx: &Context, name: &str, desc: BufferDesc) -> gen_gpu::Result<Buffer> {
        if let Some(b) = self.buffers.get_mut(&(name.to_owned(), desc)).and_then(Vec::pop) {
            return Ok(b);
        }
        self.created += 1;
        Buffer::new(ctx, name, desc)
    }

    pub fn image(&mut self, ctx: &Context, name: &str, desc: ImageDesc) -> gen_gpu::Result<Image> {
        if let Some(i) = self.images.get_mut(&(name.to_owned(), desc)).and_then(Vec::pop) {
            return Ok(i);
        }
        self.created += 1;
        Image::new(ctx, name, desc)
    }

    /// Returns a buffer for a later frame. Only after the work using it has completed (the
    /// renderer's submissions wait for their fence).
    pub fn give_back_buffer(&mut self, buffer: Buffer) {
        self.buffers.entry((buffer.name().to_owned(), buffer.desc)).or_default().push(buffer);
    }

    pub fn give_back_image(&mut self, image: Image) {
        self.images.entry((image.name().to_owned(), image.desc)).or_default().push(image);
    }
}
