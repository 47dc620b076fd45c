//! Submitting recorded work: one command buffer, its timestamps read back, and the resources it
//! used kept alive until its fence.

use super::*;

/// Owns the per-submission objects and frees them whatever happens.
struct Submission<'a> {
    ctx: &'a Context,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    query_pool: vk::QueryPool,
}

impl Drop for Submission<'_> {
    fn drop(&mut self) {
        let d = self.ctx.device();
        {
            let pool = self.ctx.shared.command_pool.lock().unwrap_or_else(|e| e.into_inner());
            // SAFETY: the fence was waited on (or never submitted), so nothing is in flight.
            unsafe {
                if self.fence != vk::Fence::null() {
                    d.destroy_fence(self.fence, None);
                }
                if self.query_pool != vk::QueryPool::null() {
                    d.destroy_query_pool(self.query_pool, None);
                }
                d.free_command_buffers(*pool, &[self.cmd]);
            }
        }
        // Resources dropped while this submission was recorded or in flight go now.
        self.ctx.shared.close_submission();
    }
}

impl Context {
    /// Records commands with `f`, submits them, waits, and returns `f`'s result with the
    /// per-pass GPU times. Synchronous, so resources may be dropped as soon as it returns; a
    /// buffer or image dropped inside `f` (after a command using it was recorded) is destroyed
    /// only once the submission has completed.
    pub fn submit<R>(
        &self,
        name: &str,
        f: impl FnOnce(&mut Recorder<'_>) -> Result<R>,
    ) -> Result<(R, FrameTimings)> {
        let device = self.device();
        let cmd = {
            let pool = self.shared.command_pool.lock().unwrap_or_else(|e| e.into_inner());
            let info = vk::CommandBufferAllocateInfo::default()
                .command_pool(*pool)
                .level(vk::CommandBufferLevel::PRIMARY)
                .command_buffer_count(1);
            // SAFETY: valid pool, externally synchronized by the mutex.
            unsafe { device.allocate_command_buffers(&info) }.call("vkAllocateCommandBuffers")?[0]
        };
        // From here until the Submission drops (after its fence, or on any error), resources
        // dropped by the caller are kept alive for the commands that may use them.
        self.shared.open_submission();
        let mut sub =
            Submission { ctx: self, cmd, fence: vk::Fence::null(), query_pool: vk::QueryPool::null() };
        self.set_name(cmd, name);
        if self.capabilities().timestamp_period_ns.is_some() {
            let info = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::TIMESTAMP)
                .query_count(POOL_QUERIES);
            // SAFETY: valid device.
            sub.query_pool = unsafe { device.create_query_pool(&info, None) }.call("vkCreateQueryPool")?;
            // SAFETY: host query reset is enabled at device creation.
            unsafe { device.reset_query_pool(sub.query_pool, 0, POOL_QUERIES) };
        }
        let begin = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        // SAFETY: freshly allocated command buffer.
        unsafe { device.begin_command_buffer(cmd, &begin) }.call("vkBeginCommandBuffer")?;
        let mut rec = Recorder {
            ctx: self,
            cmd,
            query_pool: sub.query_pool,
            scopes: Vec::new(),
            depth: 0,
            next_query: 0,
            rendered: std::cell::Cell::new(false),
        };
        let result = rec.pass(name, f);
        // Make every write visible to the host before the fence signals.
        rec.memory_barrier(
            (vk::PipelineStageFlags2::ALL_COMMANDS, vk::AccessFlags2::MEMORY_WRITE),
            (vk::PipelineStageFlags2::HOST, vk::AccessFlags2::HOST_READ),
        );
        let scopes = std::mem::take(&mut rec.scopes);
        // SAFETY: recording state.
        unsafe { device.end_command_buffer(cmd) }.call("vkEndCommandBuffer")?;
        let value = result?;

        // SAFETY: valid device.
        sub.fence =
            unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }.call("vkCreateFence")?;
        let cmds = [cmd];
        let submit = vk::SubmitInfo::default().command_buffers(&cmds);
        let start = Instant::now();
        {
            let queue = self.queue();
            // SAFETY: the queue is externally synchronized by its mutex; the command buffer is
            // executable.
            unsafe { device.queue_submit(*queue, &[submit], sub.fence) }.call("vkQueueSubmit")?;
        }
        // SAFETY: the fence belongs to this submission.
        unsafe { device.wait_for_fences(&[sub.fence], true, u64::MAX) }.call("vkWaitForFences")?;
        let cpu_wait_ms = start.elapsed().as_secs_f64() * 1e3;

        let mut timings = FrameTimings { passes: Vec::new(), cpu_wait_ms };
        let period = self.capabilities().timestamp_period_ns;
        let used = scopes.iter().filter_map(|s| s.end).max().map_or(0, |m| m + 1);
        let mut stamps = vec![0u64; used as usize];
        let have_stamps = used > 0
            // SAFETY: every query below `used` was written in the submission we waited for.
            && unsafe {
                device.get_query_pool_results(sub.query_pool, 0, &mut stamps, vk::QueryResultFlags::TYPE_64)
            }
            .is_ok();
        for s in scopes {
            let gpu_ms = match (have_stamps, s.end, period) {
                (true, Some(end), Some(p)) => {
                    let ticks = stamps[end as usize].saturating_sub(stamps[s.begin as usize]);
                    Some(ticks as f64 * f64::from(p) * 1e-6)
                }
                _ => None,
            };
            timings.passes.push(PassTiming { name: s.name, depth: s.depth, gpu_ms });
        }
        Ok((value, timings))
    }
}
