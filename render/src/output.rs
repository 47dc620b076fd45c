//! Image output. Every file is written to a temporary sibling and renamed into place, so a
//! crash or a full disk never leaves a half-written image where a good one was.

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::RgbaImage;

#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("{path}: {message}")]
    Io { path: PathBuf, message: String },
    #[error("{path}: image is {width}×{height} but holds {bytes} bytes (expected {expected})")]
    BadImage { path: PathBuf, width: u32, height: u32, bytes: usize, expected: usize },
}

/// Writes a file atomically (see [`hairmesh::atomic::write_file_atomic`]), naming the file in
/// the error.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), OutputError> {
    hairmesh::atomic::write_file_atomic(path, write)
        .map_err(|e| OutputError::Io { path: path.to_owned(), message: e.to_string() })
}

/// Writes an 8-bit RGBA image as PNG, atomically.
pub fn write_png(path: &Path, image: &RgbaImage) -> Result<(), OutputError> {
    let expected = image.width as usize * image.height as usize * 4;
    if image.pixels.len() != expected || image.width == 0 || image.height == 0 {
        return Err(OutputError::BadImage {
            path: path.to_owned(),
            width: image.width,
            height: image.height,
            bytes: image.pixels.len(),
            expected,
        });
    }
    write_atomic(path, |w| {
        let mut encoder = png::Encoder::new(w, image.width, image.height);
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(std::io::Error::other)?;
        writer.write_image_data(&image.pixels).map_err(std::io::Error::other)?;
        writer.finish().map_err(std::io::Error::other)
    })
}

/// Largest image [`read_png`] accepts (a 16k × 16k frame), so a hostile header cannot make it
/// allocate without bound.
pub const MAX_READ_PIXELS: u64 = 1 << 28;

/// Reads an 8-bit RGB or RGBA PNG (as written by [`write_png`]) into RGBA.
pub fn read_png(path: &Path) -> Result<RgbaImage, OutputError> {
    let err = |message: String| OutputError::Io { path: path.to_owned(), message };
    let file = std::fs::File::open(path).map_err(|e| err(e.to_string()))?;
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = decoder.read_info().map_err(|e| err(e.to_string()))?;
    let (w, h) = (reader.info().width, reader.info().height);
    if u64::from(w) * u64::from(h) > MAX_READ_PIXELS {
        return Err(err(format!("{w}×{h} pixels is over the {MAX_READ_PIXELS}-pixel limit for reading")));
    }
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).map_err(|e| err(e.to_string()))?;
    let pixels = match info.color_type {
        png::ColorType::Rgba => buf[..info.buffer_size()].to_vec(),
        png::ColorType::Rgb => {
            buf[..info.buffer_size()].chunks_exact(3).flat_map(|c| [c[0], c[1], c[2], 255]).collect()
        }
        other => return Err(err(format!("unsupported PNG colour type {other:?}"))),
    };
    Ok(RgbaImage { width: info.width, height: info.height, pixels })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_round_trip_and_atomic_replace() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("img.png");
        let image = RgbaImage { width: 3, height: 2, pixels: (0..24).collect() };
        write_png(&path, &image).expect("write");
        assert_eq!(read_png(&path).expect("read"), image);
        // A bad image is refused and the good file stays untouched.
        let bad = RgbaImage { width: 3, height: 2, pixels: vec![0; 5] };
        let e = write_png(&path, &bad).expect_err("bad size");
        assert!(e.to_string().contains("expected 24"), "{e}");
        assert_eq!(read_png(&path).expect("read"), image);
        let leftovers: Vec<_> = std::fs::read_dir(dir.path()).expect("list").collect();
        assert_eq!(leftovers.len(), 1, "no temporary files left behind");
    }

    #[test]
    fn unreadable_png_names_the_file() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("garbage.png");
        std::fs::write(&path, b"not a png").expect("write");
        let e = read_png(&path).expect_err("garbage");
        assert!(e.to_string().contains("garbage.png"), "{e}");
    }
}
