//! The GPU test harness and image comparison shared by hairkit's integration tests.
//!
//! GPU tests run in a custom harness (`harness = false`, libtest-mimic) so that:
//! * one Vulkan context serves the whole test binary, with the Khronos validation layer on;
//! * any validation error reported during a test fails that test;
//! * a test whose device or feature is missing is reported as *ignored* with the reason, never
//!   as passed. In CI, `HAIRKIT_REQUIRE_GPU=1` (and `HAIRKIT_REQUIRE_MESH_SHADER=1` where the
//!   installed Mesa has it) turn those skips into failures, so a broken set-up cannot pass.

pub mod harness;
pub mod image_compare;
pub mod scenes;
