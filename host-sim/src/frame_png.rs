//! Frames as PNG files: the core's pixel bytes (through the core's codec,
//! `PixelFormat::unpack`) or channel values as 8-bit gray, 16-bit gray
//! scaled to the full 16 bits, or 8-bit RGB; the diff heat map; written a
//! row at a time, so that a frame never has to be held whole.

use crate::harness::decode_all;
use crate::reference::render::RefRow;
use hilcam::scene::PixelFormat;

/// A PNG encoder for `format`'s pixels (or the diff map's, `None`): 8-bit
/// gray, 16-bit gray, or 8-bit RGB.
fn png_encoder<W: std::io::Write>(
    w: W,
    width: usize,
    height: usize,
    format: Option<PixelFormat>,
) -> png::Encoder<'static, W> {
    let mut e = png::Encoder::new(w, width as u32, height as u32);
    let (c, d) = match format {
        Some(PixelFormat::Gray8) => (png::ColorType::Grayscale, png::BitDepth::Eight),
        Some(PixelFormat::Gray16 { .. }) => (png::ColorType::Grayscale, png::BitDepth::Sixteen),
        Some(PixelFormat::Rgb565) | None => (png::ColorType::Rgb, png::BitDepth::Eight),
    };
    e.set_color(c);
    e.set_depth(d);
    e
}

/// A PNG written a row at a time: 8-bit gray, 16-bit gray scaled to the
/// full 16 bits, or 8-bit RGB (`format`), or RGB for the diff map (`None`).
pub fn png_stream<W: std::io::Write + 'static>(
    w: W,
    width: usize,
    height: usize,
    format: Option<PixelFormat>,
) -> Result<png::StreamWriter<'static, W>, String> {
    png_encoder(w, width, height, format)
        .write_header()
        .and_then(|w| w.into_stream_writer())
        .map_err(|e| format!("PNG encoding failed: {e}"))
}

/// One PNG row of channel values.
pub fn png_row(format: PixelFormat, dn: &[[u32; 3]], out: &mut Vec<u8>) {
    out.clear();
    for p in dn {
        match format {
            PixelFormat::Gray8 => out.push(p[0] as u8),
            PixelFormat::Gray16 { bits } => {
                out.extend_from_slice(&((p[0] << (16 - bits as u32)) as u16).to_be_bytes())
            }
            PixelFormat::Rgb565 => out.extend_from_slice(&[
                (p[0] * 255 / 31) as u8,
                (p[1] * 255 / 63) as u8,
                (p[2] * 255 / 31) as u8,
            ]),
        }
    }
}

/// One row of the diff heat map: black where core and reference agree;
/// 1 LSB dark red, 2 red, 4 yellow, 8 or more white; identical edge
/// pixels dark blue.
pub fn diff_row(format: PixelFormat, core: &[[u32; 3]], reference: RefRow<'_>, out: &mut Vec<u8>) {
    out.clear();
    for (k, c) in core.iter().enumerate() {
        let d = (0..format.channels())
            .map(|ch| c[ch].abs_diff(reference.dn[k][ch]))
            .max()
            .unwrap_or(0);
        out.extend_from_slice(&match d {
            0 if reference.edge[k] => [0, 0, 90],
            0 => [0, 0, 0],
            1 => [140, 0, 0],
            2..=3 => [255, 0, 0],
            4..=7 => [255, 255, 0],
            _ => [255, 255, 255],
        });
    }
}

/// Encodes frame bytes (as the core produces them) as a PNG.
pub fn encode_png(format: PixelFormat, w: usize, h: usize, bytes: &[u8]) -> Result<Vec<u8>, String> {
    let bpp = format.bytes_per_pixel();
    if bytes.len() != w * h * bpp || w == 0 || h == 0 {
        return Err(format!(
            "frame of {} bytes is not {w}x{h} {}",
            bytes.len(),
            format.name()
        ));
    }
    let (mut data, mut row) = (Vec::new(), Vec::new());
    for line in bytes.chunks_exact(w * bpp) {
        png_row(format, &decode_all(format, line), &mut row);
        data.extend_from_slice(&row);
    }
    encode(&data, w, h, Some(format))
}

/// Encodes 8-bit RGB rows (`3 w h` bytes, the plot's bitmap) as a PNG.
pub fn encode_rgb8(w: usize, h: usize, rgb: &[u8]) -> Result<Vec<u8>, String> {
    if rgb.len() != 3 * w * h || w == 0 || h == 0 {
        return Err(format!("RGB image of {} bytes is not {w}x{h}", rgb.len()));
    }
    encode(rgb, w, h, None)
}

/// Whole PNG rows (`png_encoder`'s layout for `format`) as a PNG file.
fn encode(data: &[u8], w: usize, h: usize, format: Option<PixelFormat>) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    png_encoder(&mut out, w, h, format)
        .write_header()
        .and_then(|mut png| png.write_image_data(data).and_then(|_| png.finish()))
        .map_err(|e| format!("PNG encoding failed: {e}"))?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    /// The plot's bitmap: its size checked, its pixels back from a decoder.
    #[test]
    fn rgb8_round_trips_and_a_wrong_size_is_refused() {
        let (w, h) = (3usize, 2usize);
        let rgb: Vec<u8> = (0..3 * w * h).map(|i| (i * 13) as u8).collect();
        let png = super::encode_rgb8(w, h, &rgb).expect("encodes");
        let mut reader = png::Decoder::new(std::io::Cursor::new(png)).read_info().expect("header");
        let mut out = vec![0; reader.output_buffer_size().expect("size")];
        let info = reader.next_frame(&mut out).expect("frame");
        assert_eq!((info.width, info.height, info.color_type), (3, 2, png::ColorType::Rgb));
        assert_eq!(&out[..info.buffer_size()], &rgb[..]);
        let err = super::encode_rgb8(w, h, &rgb[1..]).expect_err("one byte short");
        assert!(err.contains("17 bytes is not 3x2"), "{err}");
    }
}
