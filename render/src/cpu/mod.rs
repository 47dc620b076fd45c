//! CPU ports of render's GPU kernels, one module per kernel family, as vello keeps them: each
//! follows its shader's formulas in the same order, and the tests compare the GPU's results
//! with them.

pub mod raster;
pub mod volume;
