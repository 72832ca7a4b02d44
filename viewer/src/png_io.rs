//! Writing and reading RGBA8 PNG files (frames and the reference image).

use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::path::Path;

/// Why a PNG could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum PngIoError {
    /// Opening or creating the file failed.
    #[error("{0}")]
    Io(std::io::Error),
    /// Encoding failed.
    #[error("cannot encode PNG: {0}")]
    Encode(png::EncodingError),
    /// Decoding failed.
    #[error("cannot decode PNG: {0}")]
    Decode(png::DecodingError),
    /// The file is not 8-bit RGBA.
    #[error("not an 8-bit RGBA PNG")]
    UnsupportedFormat,
}

/// Writes `rgba` (`width × height` pixels, rows top to bottom) to `path`.
pub fn write_png(path: &Path, width: u32, height: u32, rgba: &[u8]) -> Result<(), PngIoError> {
    let file = File::create(path).map_err(PngIoError::Io)?;
    let mut encoder = png::Encoder::new(BufWriter::new(file), width, height);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut writer = encoder.write_header().map_err(PngIoError::Encode)?;
    writer.write_image_data(rgba).map_err(PngIoError::Encode)?;
    writer.finish().map_err(PngIoError::Encode)
}

/// Reads an 8-bit RGBA PNG: `(width, height, pixels)`.
pub fn read_png(path: &Path) -> Result<(u32, u32, Vec<u8>), PngIoError> {
    let file = File::open(path).map_err(PngIoError::Io)?;
    let decoder = png::Decoder::new(BufReader::new(file));
    let mut reader = decoder.read_info().map_err(PngIoError::Decode)?;
    let size = reader.output_buffer_size().ok_or(PngIoError::UnsupportedFormat)?;
    let mut buf = vec![0; size];
    let info = reader.next_frame(&mut buf).map_err(PngIoError::Decode)?;
    if info.color_type != png::ColorType::Rgba || info.bit_depth != png::BitDepth::Eight {
        return Err(PngIoError::UnsupportedFormat);
    }
    buf.truncate(info.buffer_size());
    Ok((info.width, info.height, buf))
}
