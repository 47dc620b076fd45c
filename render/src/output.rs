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

/// Which channels an EXR frame carries besides linear RGB.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ExrChannels {
    /// `A`: coverage of hair and occluders (0 on the background).
    pub coverage: bool,
    /// `Z`: view-space distance (infinity on the background).
    pub depth: bool,
}

/// Writes a frame as OpenEXR (half-float RGB, linear; optional `A` coverage and f32 `Z`
/// depth), atomically. Colour is premultiplied by coverage and includes the scene's
/// background; render with a black background for a layer to composite.
pub fn write_exr(
    path: &Path,
    frame: &crate::target::LinearFrame,
    channels: ExrChannels,
    depth_planes: (f32, f32),
) -> Result<(), OutputError> {
    use exr::prelude::*;
    let pixels = frame.width as usize * frame.height as usize;
    if frame.rgba.len() != pixels * 4 || frame.depth.len() != pixels || pixels == 0 {
        return Err(OutputError::BadImage {
            path: path.to_owned(),
            width: frame.width,
            height: frame.height,
            bytes: frame.rgba.len() * 4,
            expected: pixels * 16,
        });
    }
    let component =
        |c: usize| -> Vec<f16> { frame.rgba.iter().skip(c).step_by(4).map(|&v| f16::from_f32(v)).collect() };
    let mut list = vec![
        AnyChannel::new("R", FlatSamples::F16(component(0))),
        AnyChannel::new("G", FlatSamples::F16(component(1))),
        AnyChannel::new("B", FlatSamples::F16(component(2))),
    ];
    if channels.coverage {
        list.push(AnyChannel::new("A", FlatSamples::F16(component(3))));
    }
    if channels.depth {
        list.push(AnyChannel::new("Z", FlatSamples::F32(frame.linear_depth(depth_planes.0, depth_planes.1))));
    }
    let layer = Layer::new(
        (frame.width as usize, frame.height as usize),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list.into()),
    );
    let mut bytes = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .to_buffered(&mut bytes)
        .map_err(|e| OutputError::Io { path: path.to_owned(), message: e.to_string() })?;
    write_atomic(path, |w| w.write_all(bytes.get_ref()))
}

/// Largest image [`read_png`] accepts (a 16k × 16k frame), so a hostile header cannot make it
/// allocate without bound.
pub const MAX_READ_PIXELS: u64 = 1 << 28;

/// Reads an 8-bit RGB or RGBA PNG (as written by [`write_png`]) into RGBA.
pub fn read_png(path: &Path) -> Result<RgbaImage, OutputError> {
    let err = |message: String| OutputError::Io { path: path.to_owned(), message };
    let file = hairmesh::input::open_regular(path).map_err(|e| err(e.to_string()))?;
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
    fn exr_has_the_asked_channels_and_linear_values() {
        use exr::prelude::*;
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("frame.exr");
        let frame = crate::target::LinearFrame {
            width: 2,
            height: 1,
            rgba: vec![0.25, 0.5, 2.0, 1.0, 0.0, 0.0, 0.0, 0.0],
            depth: vec![0.5, 1.0],
        };
        let channels = ExrChannels { coverage: true, depth: true };
        write_exr(&path, &frame, channels, (0.1, 100.0)).expect("write");
        let image = read_all_flat_layers_from_file(&path).expect("read");
        let layer = &image.layer_data[0];
        let names: Vec<String> = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
        assert_eq!(names, ["A", "B", "G", "R", "Z"]);
        let value = |name: &str, i: usize| {
            let c = layer.channel_data.list.iter().find(|c| c.name.to_string() == name).expect("channel");
            c.sample_data.value_by_flat_index(i).to_f32()
        };
        // Linear, above 1 kept (no sRGB, no clamp).
        assert_eq!((value("R", 0), value("B", 0), value("A", 1)), (0.25, 2.0, 0.0));
        let z = value("Z", 0);
        let expected = 0.1 * 100.0 / (100.0 - 0.5 * 99.9);
        assert!((z - expected).abs() < 1e-4, "{z} vs {expected}");
        assert!(value("Z", 1).is_infinite(), "nothing drawn: infinite depth");
        // Only RGB without the options.
        write_exr(&path, &frame, ExrChannels::default(), (0.1, 100.0)).expect("write");
        let image = read_all_flat_layers_from_file(&path).expect("read");
        assert_eq!(image.layer_data[0].channel_data.list.len(), 3);
    }

    #[test]
    fn srgb_encoding() {
        use crate::target::linear_to_srgb;
        assert_eq!(linear_to_srgb(0.0), 0.0);
        assert!((linear_to_srgb(1.0) - 1.0).abs() < 1e-6);
        // Middle grey: 18% linear is about 46% sRGB.
        assert!((linear_to_srgb(0.18) - 0.4614).abs() < 1e-3);
        assert_eq!(linear_to_srgb(f32::NAN), 0.0);
        assert!((linear_to_srgb(7.0) - 1.0).abs() < 1e-6, "over-range values clamp to white");
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
