//! CPU ports of the volume kernels (`voxelize`, `volume_resolve`, `volume_bricks`, `volume_ao`), in
//! f64: what the GPU volumes are tested against.

use glam::DVec3;

use crate::volume::{MEAN_SIN, VolumeGrid};

/// The voxelization's sums: per voxel the projected area (voxel units) and area × direction.
#[derive(Clone, Debug)]
pub struct VoxelSums {
    pub area: Vec<f64>,
    pub direction: Vec<DVec3>,
}

/// Samples per segment: one per voxel of its length, at least one (`segment_samples` in
/// `voxelize_common.glsl`). Two per voxel cost a third more voxelization time for the same
/// images (`render/tests/volume.rs` compares the volume with the strands).
pub fn segment_samples(length_voxels: f64) -> u32 {
    length_voxels.ceil().clamp(1.0, 4096.0) as u32
}

/// `hair_voxelize.comp` on strands given as object-space points and full widths: each
/// segment's samples at `(j + ½)/n` add `length/n × width` (the width interpolated) to the
/// voxel they fall in; samples outside the grid are dropped.
pub fn voxelize<'a>(
    grid: &VolumeGrid,
    strands: impl IntoIterator<Item = (&'a [DVec3], &'a [f64])>,
) -> VoxelSums {
    let n = grid.voxels() as usize;
    let mut sums = VoxelSums { area: vec![0.0; n], direction: vec![DVec3::ZERO; n] };
    let origin = grid.origin.as_dvec3();
    let voxel = f64::from(grid.voxel);
    let dims = grid.dims.map(f64::from);
    for (points, widths) in strands {
        for k in 1..points.len().min(widths.len()) {
            let a = (points[k - 1] - origin) / voxel;
            let b = (points[k] - origin) / voxel;
            let length = (b - a).length();
            if length.is_nan() || length <= 0.0 {
                continue;
            }
            let direction = (b - a) / length;
            let samples = segment_samples(length);
            let step = length / f64::from(samples);
            for j in 0..samples {
                let t = (f64::from(j) + 0.5) / f64::from(samples);
                let p = a.lerp(b, t);
                if p.x < 0.0 || p.y < 0.0 || p.z < 0.0 || p.x >= dims[0] || p.y >= dims[1] || p.z >= dims[2] {
                    continue;
                }
                let width = (widths[k - 1] + (widths[k] - widths[k - 1]) * t) / voxel;
                let i = grid.index(p.x as u32, p.y as u32, p.z as u32);
                let area = step * width;
                sums.area[i] += area;
                sums.direction[i] += area * direction;
            }
        }
    }
    sums
}

/// `volume_resolve.comp`: per voxel (mean direction, σ).
pub fn resolve(sums: &VoxelSums) -> Vec<[f64; 4]> {
    sums.area
        .iter()
        .zip(&sums.direction)
        .map(|(&area, &d)| {
            let mean = if area > 0.0 { d / area } else { DVec3::ZERO };
            [mean.x, mean.y, mean.z, area]
        })
        .collect()
}

/// `volume_bricks.comp`: per brick of [`crate::volume::BRICK`]³ voxels, whether it or a voxel
/// next to it (which a trilinear sample inside it reads) has hair.
pub fn occupied_bricks(grid: &VolumeGrid, sigma: &[f64]) -> Vec<bool> {
    let b = i64::from(crate::volume::BRICK);
    let [bx, by, bz] = grid.brick_dims().map(i64::from);
    let [nx, ny, nz] = grid.dims.map(i64::from);
    let mut out = Vec::with_capacity((bx * by * bz) as usize);
    for z in 0..bz {
        for y in 0..by {
            for x in 0..bx {
                let mut any = false;
                for vz in (z * b - 1).max(0)..((z + 1) * b + 1).min(nz) {
                    for vy in (y * b - 1).max(0)..((y + 1) * b + 1).min(ny) {
                        for vx in (x * b - 1).max(0)..((x + 1) * b + 1).min(nx) {
                            any |= sigma[grid.index(vx as u32, vy as u32, vz as u32)] > 0.0;
                        }
                    }
                }
                out.push(any);
            }
        }
    }
    out
}

/// `volume_ao.comp`'s voxel offset of step `s` along neighbour direction `d`.
pub fn step_offset(d: [i64; 3], s: u32) -> [i64; 3] {
    let length = ((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) as f64).sqrt();
    d.map(|c| (c as f64 * f64::from(s) / length).round() as i64)
}

/// `volume_ao.comp`: per voxel the mean over the 26 neighbour directions of
/// `exp(−τ)`, τ the σ of the voxels at steps 1..=`radius` along the direction (leaving
/// the grid ends the path) times `opacity · MEAN_SIN`.
pub fn ambient_occlusion(grid: &VolumeGrid, sigma: &[f64], radius: u32, opacity: f64) -> Vec<f64> {
    let [nx, ny, nz] = grid.dims.map(i64::from);
    let directions: Vec<[i64; 3]> =
        (0..27).map(|k| [k % 3 - 1, (k / 3) % 3 - 1, k / 9 - 1]).filter(|d| *d != [0, 0, 0]).collect();
    let mut out = vec![1.0; sigma.len()];
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let mut sum = 0.0;
                for &d in &directions {
                    let mut depth = 0.0;
                    for s in 1..=radius {
                        let o = step_offset(d, s);
                        let (px, py, pz) = (x + o[0], y + o[1], z + o[2]);
                        if px < 0 || py < 0 || pz < 0 || px >= nx || py >= ny || pz >= nz {
                            break;
                        }
                        depth += sigma[grid.index(px as u32, py as u32, pz as u32)];
                    }
                    sum += (-depth * opacity * MEAN_SIN).exp();
                }
                out[grid.index(x as u32, y as u32, z as u32)] = sum / directions.len() as f64;
            }
        }
    }
    out
}
