//! Screenshots of an X11 window through `xwd` (x11-apps), for `hair-editor --screenshot`.
//!
//! eframe's own screenshot read-back never completes on lavapipe under Xvfb (measured here:
//! with wgpu's Vulkan backend the frame after the capture blocks inside lavapipe, with its GL
//! backend inside llvmpipe's blit), so the window is captured from outside, as a user's
//! screenshot tool would, and the XWD dump is converted to RGBA here.

use std::path::Path;
use std::process::Command;

/// Captures the window titled `title` (`xwd -name`) as 8-bit RGBA.
pub fn capture_window(title: &str) -> Result<gen_gpu::RgbaImage, String> {
    let out = Command::new("xwd")
        .args(["-silent", "-name", title])
        .output()
        .map_err(|e| format!("cannot run xwd (x11-apps; `cargo xtask setup` installs it): {e}"))?;
    if !out.status.success() {
        return Err(format!("xwd failed ({}): {}", out.status, String::from_utf8_lossy(&out.stderr).trim()));
    }
    decode(&out.stdout)
}

/// Captures the window and writes it as PNG (atomically).
pub fn screenshot(title: &str, path: &Path) -> Result<(), String> {
    let image = capture_window(title)?;
    render::output::write_png(path, &image).map_err(|e| e.to_string())
}

/// Decodes a ZPixmap XWD dump of 24- or 32-bit true colour.
pub fn decode(data: &[u8]) -> Result<gen_gpu::RgbaImage, String> {
    let word = |i: usize| -> Result<u32, String> {
        data.get(4 * i..4 * i + 4)
            .map(|b| u32::from_be_bytes([b[0], b[1], b[2], b[3]]))
            .ok_or_else(|| "XWD dump shorter than its header".to_owned())
    };
    let (header, format, width, height) = (word(0)? as usize, word(2)?, word(4)?, word(5)?);
    let (byte_order, bits_per_pixel, bytes_per_line) = (word(7)?, word(11)?, word(12)? as usize);
    let masks = [word(14)?, word(15)?, word(16)?];
    let colours = word(19)? as usize;
    if format != 2 || !(bits_per_pixel == 32 || bits_per_pixel == 24) {
        return Err(format!(
            "XWD format {format} with {bits_per_pixel} bits per pixel (expected a 24/32-bit ZPixmap)"
        ));
    }
    if width == 0 || height == 0 || width > 16384 || height > 16384 || masks.contains(&0) {
        return Err(format!(
            "XWD image {width}×{height} with colour masks {masks:x?} is not a window capture"
        ));
    }
    let bytes = (bits_per_pixel / 8) as usize;
    let start = header + 12 * colours;
    let needed = start + bytes_per_line * height as usize;
    if data.len() < needed || bytes_per_line < bytes * width as usize {
        return Err(format!("XWD dump has {} bytes, {needed} needed", data.len()));
    }
    let channel = |pixel: u32, mask: u32| -> u8 {
        let shift = mask.trailing_zeros();
        let max = mask >> shift;
        (((pixel & mask) >> shift) * 255 / max.max(1)) as u8
    };
    let mut pixels = Vec::with_capacity(4 * (width * height) as usize);
    for y in 0..height as usize {
        let row = &data[start + y * bytes_per_line..];
        for x in 0..width as usize {
            let b = &row[x * bytes..x * bytes + bytes];
            let mut v = [0u8; 4];
            v[..bytes].copy_from_slice(b);
            let pixel = if byte_order == 0 {
                u32::from_le_bytes(v)
            } else {
                u32::from_be_bytes(v) >> (32 - bits_per_pixel)
            };
            pixels.extend_from_slice(&[
                channel(pixel, masks[0]),
                channel(pixel, masks[1]),
                channel(pixel, masks[2]),
                255,
            ]);
        }
    }
    Ok(gen_gpu::RgbaImage { width, height, pixels })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dump(width: u32, height: u32, pixels: &[u32]) -> Vec<u8> {
        let mut header = [0u32; 25];
        header[0] = 100 + 8;
        header[1] = 7;
        header[2] = 2;
        header[3] = 24;
        header[4] = width;
        header[5] = height;
        header[7] = 0;
        header[11] = 32;
        header[12] = 4 * width;
        header[14] = 0xff0000;
        header[15] = 0xff00;
        header[16] = 0xff;
        let mut d: Vec<u8> = header.iter().flat_map(|w| w.to_be_bytes()).collect();
        d.extend_from_slice(b"window\0\0");
        d.extend(pixels.iter().flat_map(|p| p.to_le_bytes()));
        d
    }

    #[test]
    fn decodes_a_true_colour_dump_and_refuses_short_ones() {
        let d = dump(2, 1, &[0x00ff_8000, 0x0000_00ff]);
        let image = decode(&d).expect("valid");
        assert_eq!(image.pixels, [255, 128, 0, 255, 0, 0, 255, 255]);
        assert!(decode(&d[..d.len() - 1]).is_err());
        assert!(decode(&d[..40]).is_err());
    }
}
