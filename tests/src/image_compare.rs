//! Image comparison with NVIDIA's FLIP perceptual metric, as wgpu's tests do.
//!
//! On failure the actual image, the expected image and a magma-coloured error map are written
//! to `target/test-output/<name>-{actual,expected,difference}.png` for inspection.

use std::path::PathBuf;

use render::RgbaImage;

/// How different two images may be. FLIP values are in [0, 1]: 0 identical, 1 maximally
/// different; a mean of 0.01 is hard to see, 0.05 is visible on close inspection.
#[derive(Clone, Copy, Debug)]
pub struct Tolerance {
    /// Largest allowed mean FLIP error over all pixels.
    pub mean: f32,
    /// `(percentile, largest error at that percentile)`, e.g. `(0.99, 0.1)`.
    pub percentile: (f32, f32),
}

/// FLIP statistics of one comparison.
#[derive(Clone, Copy, Debug)]
pub struct FlipStats {
    pub mean: f32,
    pub percentile: f32,
    pub max: f32,
}

/// Where failed comparisons are written.
pub fn output_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target/test-output")
}

fn rgb(image: &RgbaImage) -> Vec<u8> {
    image.pixels.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect()
}

/// How many pixels of two images of one size differ in any channel.
pub fn differing_pixels(a: &RgbaImage, b: &RgbaImage) -> usize {
    a.pixels.chunks_exact(4).zip(b.pixels.chunks_exact(4)).filter(|(p, q)| p != q).count()
}

/// Compares `actual` to `expected`; `Err` describes the failure after writing the PNGs.
pub fn compare(
    name: &str,
    actual: &RgbaImage,
    expected: &RgbaImage,
    tolerance: Tolerance,
) -> Result<FlipStats, String> {
    if (actual.width, actual.height) != (expected.width, expected.height) {
        return Err(format!(
            "{name}: size {}×{} differs from expected {}×{}",
            actual.width, actual.height, expected.width, expected.height
        ));
    }
    let reference = nv_flip::FlipImageRgb8::with_data(expected.width, expected.height, &rgb(expected));
    let test = nv_flip::FlipImageRgb8::with_data(actual.width, actual.height, &rgb(actual));
    let error_map = nv_flip::flip(reference, test, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    let mut pool = nv_flip::FlipPool::from_image(&error_map);
    let stats = FlipStats {
        mean: pool.mean(),
        percentile: pool.get_percentile(tolerance.percentile.0, true),
        max: pool.max_value(),
    };
    if stats.mean <= tolerance.mean && stats.percentile <= tolerance.percentile.1 {
        return Ok(stats);
    }
    let dir = output_dir();
    let diff = error_map.apply_color_lut(&nv_flip::magma_lut());
    let diff = RgbaImage {
        width: diff.width(),
        height: diff.height(),
        pixels: diff.to_vec().chunks_exact(3).flat_map(|p| [p[0], p[1], p[2], 255]).collect(),
    };
    let mut written = Vec::new();
    for (suffix, image) in [("actual", actual), ("expected", expected), ("difference", &diff)] {
        let path = dir.join(format!("{name}-{suffix}.png"));
        match render::output::write_png(&path, image) {
            Ok(()) => written.push(path.display().to_string()),
            Err(e) => written.push(format!("(could not write: {e})")),
        }
    }
    Err(format!(
        "{name}: FLIP mean {:.4} (allowed {:.4}), {}th percentile {:.4} (allowed {:.4}), max {:.4}; wrote {}",
        stats.mean,
        tolerance.mean,
        tolerance.percentile.0 * 100.0,
        stats.percentile,
        tolerance.percentile.1,
        stats.max,
        written.join(", ")
    ))
}
