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

/// Whether a resource's content outlives the frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lifetime {
    /// Made by this frame's passes and dropped after them: a pass may only read it after an
    /// earlier pass of the frame wrote it, and a pass whose transient outputs nobody reads is
    /// culled.
    Transient,
    /// Exists before the frame or is read after it (uploads, caches, the previous frame's
    /// depth, the readback the host reads): reads need no writer in the frame, and writes to it
    /// are the frame's outputs.
    External,
}

#[derive(Clone, Debug)]
struct ResourceDecl {
    name: String,
    kind: ResKind,
    lifetime: Lifetime,
}

/// A graph that cannot run as declared.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum GraphError {
    /// A pass reads a transient resource no earlier pass of the frame writes.
    #[error("pass `{pass}` reads `{resource}`, which no earlier pass of the frame writes")]
    ReadBeforeWrite { pass: String, resource: String },
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
    /// Nothing reads what it writes ([`FrameGraph::cull`]): shown, not run.
    pub culled: bool,
    /// Which submission of the frame records it.
    pub submission: usize,
    pub payload: P,
}

impl<P> PassNode<P> {
    /// Whether the pass is recorded (neither cached nor culled).
    pub fn runs(&self) -> bool {
        !self.cached && !self.culled
    }
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
            culled: false,
            submission: n.submission,
            payload,
        });
    }
}

impl<P> FrameGraph<P> {
    fn declare(&mut self, name: impl Into<String>, kind: ResKind, lifetime: Lifetime) -> Res {
        self.resources.push(ResourceDecl { name: name.into(), kind, lifetime });
        Res(self.resources.len() - 1)
    }

    /// Declares a transient buffer (or a set of buffers used together, such as one character's
    /// strands): made by the frame's passes.
    pub fn buffer(&mut self, name: impl Into<String>) -> Res {
        self.declare(name, ResKind::Buffer, Lifetime::Transient)
    }

    /// Declares a transient image (it gets layout transitions).
    pub fn image(&mut self, name: impl Into<String>) -> Res {
        self.declare(name, ResKind::Image, Lifetime::Transient)
    }

    /// Declares a buffer whose content outlives the frame ([`Lifetime::External`]).
    pub fn external_buffer(&mut self, name: impl Into<String>) -> Res {
        self.declare(name, ResKind::Buffer, Lifetime::External)
    }

    /// Declares an image whose content outlives the frame ([`Lifetime::External`]).
    pub fn external_image(&mut self, name: impl Into<String>) -> Res {
        self.declare(name, ResKind::Image, Lifetime::External)
    }

    pub fn lifetime(&self, res: Res) -> Lifetime {
        self.resources[res.0].lifetime
    }

    /// Whether every pass that runs reads only what exists when it runs: an external resource,
    /// or a transient one an earlier running pass wrote. The first offence is named.
    pub fn check(&self) -> Result<(), GraphError> {
        let mut written = vec![false; self.resources.len()];
        for pass in self.passes.iter().filter(|p| p.runs()) {
            for &(res, _) in &pass.reads {
                if self.lifetime(res) == Lifetime::Transient && !written[res.0] {
                    return Err(GraphError::ReadBeforeWrite {
                        pass: pass.name.clone(),
                        resource: self.resource_name(res).to_owned(),
                    });
                }
            }
            for &(res, _) in &pass.writes {
                written[res.0] = true;
            }
        }
        Ok(())
    }

    /// Marks the passes nothing needs as culled: a pass is needed when it writes an external
    /// resource or a transient one a later needed pass reads. Returns the culled passes' names.
    pub fn cull(&mut self) -> Vec<String> {
        let mut needed_resources = vec![false; self.resources.len()];
        let mut culled = Vec::new();
        for pass in self.passes.iter_mut().rev() {
            if !pass.runs() {
                continue;
            }
            let needed = pass.writes.iter().any(|&(res, _)| {
                self.resources[res.0].lifetime == Lifetime::External || needed_resources[res.0]
            });
            if !needed {
                pass.culled = true;
                culled.push(pass.name.clone());
                continue;
            }
            for &(res, _) in &pass.reads {
                needed_resources[res.0] = true;
            }
        }
        culled.reverse();
        culled
    }

    /// Per transient resource, the first and last running pass (indices into [`Self::passes`])
    /// that use it: its lifetime within the frame (`None`: unused).
    pub fn transient_spans(&self) -> Vec<Option<(usize, usize)>> {
        let mut spans: Vec<Option<(usize, usize)>> = vec![None; self.resources.len()];
        for (i, pass) in self.passes.iter().enumerate().filter(|(_, p)| p.runs()) {
            for &(res, _) in pass.reads.iter().chain(&pass.writes) {
                if self.lifetime(res) == Lifetime::Transient {
                    let span = spans[res.0].get_or_insert((i, i));
                    span.1 = i;
                }
            }
        }
        spans
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
                culled: false,
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

    /// Names of the passes that run (neither cached nor culled), in order.
    pub fn runnable(&self) -> Vec<String> {
        self.passes.iter().filter(|p| p.runs()).map(|p| p.name.clone()).collect()
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
                    culled: p.culled,
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
            let note = match (p.cached, p.culled) {
                (true, _) => "  [cached: not run]",
                (false, true) => "  [culled: nothing reads what it writes]",
                (false, false) => "",
            };
            writeln!(f, "{i:>2}. {}{note}", p.name)?;
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
        for pass in graph.passes.iter().filter(|p| p.submission == submission && p.runs()) {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Upload → generate → raster → copy out, with a debug pass nobody reads and a pass reading
    /// the previous frame's depth.
    fn frame() -> (FrameGraph<&'static str>, [Res; 6]) {
        let mut g = FrameGraph::default();
        let hair = g.external_buffer("hair");
        let strands = g.buffer("strands");
        let debug = g.buffer("debug counters");
        let colour = g.image("colour");
        let image = g.external_buffer("image");
        let last_depth = g.external_buffer("depth (last frame)");
        g.pass("generate")
            .read(hair, Access::ComputeRead)
            .write(strands, Access::ComputeWrite)
            .add("generate");
        g.pass("count").read(strands, Access::ComputeRead).write(debug, Access::ComputeWrite).add("count");
        g.pass("raster")
            .read(strands, Access::PreRasterRead)
            .read(last_depth, Access::FragmentRead)
            .write(colour, Access::ColorAttachment)
            .add("raster");
        g.pass("copy out").read(colour, Access::TransferRead).write(image, Access::TransferWrite).add("copy");
        (g, [hair, strands, debug, colour, image, last_depth])
    }

    #[test]
    fn a_graph_in_dependency_order_passes_the_check() {
        let (g, _) = frame();
        assert_eq!(g.check(), Ok(()));
    }

    #[test]
    fn a_pass_reading_what_no_earlier_pass_wrote_is_refused_by_name() {
        let (mut g, [_, strands, ..]) = frame();
        // The raster moved before generation: its strands do not exist yet.
        let raster = g.passes.remove(2);
        g.passes.insert(0, raster);
        assert_eq!(
            g.check(),
            Err(GraphError::ReadBeforeWrite { pass: "raster".into(), resource: "strands".into() })
        );
        // A writer that is cached (its result reused) does not count either.
        let (mut g, _) = frame();
        g.passes[0].cached = true;
        let e = g.check().expect_err("generation is not run");
        assert!(e.to_string().contains("`count` reads `strands`"), "{e}");
        // External resources need no writer.
        let mut g: FrameGraph<()> = FrameGraph::default();
        let cache = g.external_buffer("volume cache");
        let out = g.external_buffer("image");
        g.pass("march").read(cache, Access::ComputeRead).write(out, Access::ComputeWrite).add(());
        assert_eq!(g.check(), Ok(()));
        let _ = strands;
    }

    #[test]
    fn passes_whose_outputs_nobody_reads_are_culled() {
        let (mut g, _) = frame();
        assert_eq!(g.cull(), vec!["count".to_owned()]);
        assert_eq!(g.runnable(), ["generate", "raster", "copy out"]);
        assert!(g.to_string().contains("1. count  [culled: nothing reads what it writes]"), "{g}");
        // Culling follows chains back: without the copy out nothing needs the raster, and then
        // nothing needs generation.
        let (mut g, _) = frame();
        g.passes.pop();
        assert_eq!(g.cull(), ["generate", "count", "raster"]);
        assert!(g.runnable().is_empty());
        // Writing an external resource (a cache later frames read) keeps a pass.
        let mut g: FrameGraph<()> = FrameGraph::default();
        let sums = g.buffer("voxel sums");
        let cache = g.external_buffer("volume cache");
        g.pass("voxelize").write(sums, Access::ComputeWrite).add(());
        g.pass("resolve").read(sums, Access::ComputeRead).write(cache, Access::ComputeWrite).add(());
        assert!(g.cull().is_empty());
    }

    #[test]
    fn transient_spans_run_from_first_to_last_use() {
        let (mut g, [hair, strands, debug, colour, image, _]) = frame();
        g.cull();
        let spans = g.transient_spans();
        assert_eq!(spans[strands.0], Some((0, 2)), "generate to raster (count is culled)");
        assert_eq!(spans[colour.0], Some((2, 3)));
        assert_eq!(spans[debug.0], None, "only the culled pass used it");
        assert_eq!((spans[hair.0], spans[image.0]), (None, None), "external resources have no span");
    }
}
