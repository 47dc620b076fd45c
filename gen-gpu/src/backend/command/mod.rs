//! Command recording, submission, transfers and per-pass GPU timing.

mod recorder;
mod submit;
mod timing;
mod transfer;
mod upload;

use std::ffi::CString;
use std::time::Instant;

use ash::vk;

use crate::error::VkResultExt;
use crate::{Buffer, BufferDesc, Context, GpuError, Image, ImageDesc, MemoryLocation, Pipeline, Result};

pub use recorder::{Attachments, Recorder};
pub use timing::{FrameTimings, PassSummary, PassTiming, TimingSummary};

/// Most timestamp scopes one submission records (a crowd frame has a few per character); later
/// scopes are labelled but untimed.
const MAX_SCOPES: u32 = 2048;

/// Queries of a submission's pool: each scope's begin and end, then as many settling writes
/// (see `Recorder::write_timestamp`).
const POOL_QUERIES: u32 = 4 * MAX_SCOPES;
