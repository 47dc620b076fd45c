//! The Vulkan backend: what any GPU program needs and nothing about hair. The instance and
//! device ([`context`]), what the device offers ([`caps`]), resources that own their memory
//! ([`resource`]), pipelines ([`pipeline`], made once per device and desc), recording and
//! submission with per-pass timing ([`command`]) and render targets ([`target`]). Strand generation (`crate::generator`) is
//! built on it; nothing here imports it.

pub mod caps;
pub mod command;
pub mod context;
pub mod pipeline;
mod pipeline_registry;
pub mod resource;
pub mod target;
