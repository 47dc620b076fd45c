//! GPU strands against the f64 CPU reference (vello's `compare_gpu_cpu`, for hair): the oracle
//! behind the generation tests and the accuracy table of `hair-bench`.

use hairmesh::asset::HairAsset;
use hairmesh::reference::bundle_lod;

use crate::{Capture, FrameInputs, GpuError, Result};

/// How far a capture is from the reference.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Accuracy {
    pub strands: usize,
    pub vertices: usize,
    /// Position error in strand widths (the style's root width).
    pub max_position_widths: f64,
    pub mean_position_widths: f64,
    /// Position error as a fraction of the longest bundle's hair length.
    pub max_position_of_length: f64,
    pub max_tangent_degrees: f64,
    /// Largest relative width error.
    pub max_width_relative: f64,
}

/// Compares every captured strand with the reference strand of the same bundle and index at
/// the same LOD; strand counts per bundle must be identical (culling off, or nothing culled).
pub fn compare_to_reference(asset: &HairAsset, inputs: &FrameInputs, capture: &Capture) -> Result<Accuracy> {
    let mismatch = |m: String| GpuError::Mismatch(m);
    let mut counts = vec![0u32; asset.bundles.len()];
    for s in &capture.strands {
        let slot = counts
            .get_mut(s.bundle as usize)
            .ok_or_else(|| mismatch(format!("bundle {} does not exist", s.bundle)))?;
        *slot += 1;
    }
    for (b, &n) in counts.iter().enumerate() {
        let expected = bundle_lod(asset, b as u32, &inputs.view, &inputs.lod).strands;
        if n != expected {
            return Err(mismatch(format!("bundle {b}: GPU generated {n} strands, the reference {expected}")));
        }
    }
    let width = asset.style.width;
    let length = asset.bundles.iter().map(|b| b.length).fold(0.0, f64::max).max(f64::MIN_POSITIVE);
    let mut a = Accuracy { strands: capture.strands.len(), ..Accuracy::default() };
    let mut sum = 0.0;
    for s in &capture.strands {
        let l = bundle_lod(asset, s.bundle, &inputs.view, &inputs.lod);
        let r = asset.generate_strand(s.bundle, s.index, &l);
        if s.positions.len() != r.positions.len() {
            return Err(mismatch(format!(
                "bundle {} strand {}: {} vertices, reference {}",
                s.bundle,
                s.index,
                s.positions.len(),
                r.positions.len()
            )));
        }
        for k in 0..r.positions.len() {
            let d = s.positions[k].as_dvec3().distance(r.positions[k]);
            if !d.is_finite() {
                return Err(mismatch(format!(
                    "bundle {} strand {} vertex {k} is not finite",
                    s.bundle, s.index
                )));
            }
            a.max_position_widths = a.max_position_widths.max(d / width);
            a.max_position_of_length = a.max_position_of_length.max(d / length);
            sum += d / width;
            a.vertices += 1;
            let cos = s.tangents[k].as_dvec3().normalize_or_zero().dot(r.tangents[k]).clamp(-1.0, 1.0);
            a.max_tangent_degrees = a.max_tangent_degrees.max(cos.acos().to_degrees());
            a.max_width_relative =
                a.max_width_relative.max((f64::from(s.widths[k]) - r.widths[k]).abs() / r.widths[k]);
        }
    }
    a.mean_position_widths = sum / a.vertices.max(1) as f64;
    Ok(a)
}
