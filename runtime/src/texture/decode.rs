//! Decoding texture files: PNG (8 and 16 bit), JPEG, Radiance HDR and OpenEXR (half and
//! float; RGB, RGBA, Y, YA or any single channel), chosen by the file's first bytes.
//!
//! Every file passes the input gate first ([`crate::input::read`]: a regular file within the
//! image limit, read bounded). Each decoder then reads the header's size and checks it
//! ([`check_size`]: at most [`MAX_SIDE`] a side, and a pyramid that fits the texture memory
//! budget) **before** allocating anything for the texels, so a 10⁶ × 10⁶ header is an error,
//! never an allocation. Errors say what is wrong without the file name; the caller
//! ([`super::TextureError::Load`]) names the file.
//!
//! Decoding yields the stored values ([`Samples`]); the conversion to the working space is
//! [`super::colorspace`]'s.

use super::mip::Pyramid;
use crate::input::{self, FileKind};
use std::io::Cursor;
use std::path::Path;

const MIB: f64 = (1u64 << 20) as f64;

/// The longest side a texture may have.
pub const MAX_SIDE: u32 = 1 << 16;

/// The samples of a decoded image, row by row from the top, `channels` per texel.
#[derive(Clone, Debug, PartialEq)]
pub enum Samples {
    /// 8-bit integers (0 → 0.0, 255 → 1.0).
    U8(Vec<u8>),
    /// 16-bit integers (0 → 0.0, 65535 → 1.0).
    U16(Vec<u16>),
    /// Floating point values as stored (EXR half or float, Radiance RGBE).
    F32(Vec<f32>),
}

/// A decoded image.
#[derive(Clone, Debug, PartialEq)]
pub struct Decoded {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Channels per texel: 1 (Y), 2 (Y, A), 3 (RGB) or 4 (RGBA).
    pub channels: usize,
    /// `width × height × channels` samples.
    pub samples: Samples,
}

/// Checks a header's size before anything is allocated for it: not empty, at most
/// [`MAX_SIDE`] a side, and a pyramid of RGBA f32 texels within `budget` bytes.
pub fn check_size(width: u32, height: u32, budget: u64) -> Result<(), String> {
    if width == 0 || height == 0 {
        return Err(format!("the image is empty ({width}×{height} texels)"));
    }
    if width > MAX_SIDE || height > MAX_SIDE {
        return Err(format!(
            "the header says {width}×{height} texels: over the limit of {MAX_SIDE} texels a side"
        ));
    }
    let bytes = Pyramid::bytes_for(width, height);
    if bytes > budget {
        return Err(format!(
            "the header says {width}×{height} texels, whose mipmaps take {:.1} MiB: more than \
             the texture memory budget of {:.1} MiB (set SHADENET_TEXTURE_MEMORY_MB to raise it)",
            bytes as f64 / MIB,
            budget as f64 / MIB
        ));
    }
    Ok(())
}

/// Reads and decodes a texture file whose decoded pyramid must fit `budget` bytes.
pub fn decode(path: &Path, budget: u64) -> Result<Decoded, String> {
    let bytes = read(path)?;
    match format(&bytes) {
        Format::Hdr => decode_hdr(&bytes, budget),
        Format::Exr => decode_exr(&bytes, budget),
        Format::Image => decode_image(&bytes, budget),
    }
}

/// A texture file's bytes; the path is the caller's to name: only the cause goes into the
/// message.
fn read(path: &Path) -> Result<Vec<u8>, String> {
    input::read(path, FileKind::Image, "texture").map_err(|e| match e {
        input::InputError::Io { source, .. } => source.to_string(),
        other => other.to_string(),
    })
}

/// What a texture file is, by its first bytes.
enum Format {
    /// Radiance `.hdr` (`#?`).
    Hdr,
    /// OpenEXR (its magic number).
    Exr,
    /// Anything else: PNG or JPEG for the `image` crate, which says if it is neither.
    Image,
}

fn format(bytes: &[u8]) -> Format {
    if bytes.starts_with(b"#?") {
        Format::Hdr
    } else if bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        Format::Exr
    } else {
        Format::Image
    }
}

/// A texture file's width, height and channel count from its header (a Radiance file is
/// decoded: its header does not say the size in one place), refused as [`decode`] refuses
/// it where it could not load as a texture within `budget` bytes — what OSL's
/// `gettextureinfo` reads.
pub fn header(path: &Path, budget: u64) -> Result<(u32, u32, usize), String> {
    let bytes = read(path)?;
    match format(&bytes) {
        Format::Hdr => {
            let d = decode_hdr(&bytes, budget)?;
            Ok((d.width, d.height, d.channels))
        }
        Format::Exr => {
            let meta = exr_headers(&bytes, budget)?;
            let h = meta.headers.first().ok_or("the file has no image")?;
            let (w, ht) = (side(h.layer_size.0), side(h.layer_size.1));
            Ok((w, ht, h.channels.list.len()))
        }
        Format::Image => {
            let (decoder, width, height) = image_decoder(&bytes, budget)?;
            let channels = image::ImageDecoder::color_type(&decoder).channel_count();
            Ok((width, height, usize::from(channels)))
        }
    }
}

/// A side's length as a `u32` (saturating: a side that large fails the size check).
fn side(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

/// The `image` crate's decoder of a PNG or JPEG, having read its header, with the size
/// checked against `budget`: the decoder, width and height.
fn image_decoder(
    bytes: &[u8],
    budget: u64,
) -> Result<(impl image::ImageDecoder + '_, u32, u32), String> {
    let mut reader = image::ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| e.to_string())?;
    if reader.format().is_none() {
        return Err(
            "not a PNG, JPEG, Radiance HDR or OpenEXR file (unrecognized first bytes)".into(),
        );
    }
    // Our own size check replaces the crate's limits (its default allocation cap refuses
    // legitimate 16-bit 8K textures).
    reader.no_limits();
    let decoder = reader.into_decoder().map_err(|e| e.to_string())?;
    let (width, height) = image::ImageDecoder::dimensions(&decoder);
    check_size(width, height, budget)?;
    Ok((decoder, width, height))
}

/// PNG and JPEG through the `image` crate: the decoder reads the header, the size is
/// checked, then the texels are decoded.
fn decode_image(bytes: &[u8], budget: u64) -> Result<Decoded, String> {
    let (decoder, width, height) = image_decoder(bytes, budget)?;
    let img = image::DynamicImage::from_decoder(decoder).map_err(|e| e.to_string())?;
    use image::DynamicImage as D;
    let (channels, samples) = match img {
        D::ImageLuma8(i) => (1, Samples::U8(i.into_raw())),
        D::ImageLumaA8(i) => (2, Samples::U8(i.into_raw())),
        D::ImageRgb8(i) => (3, Samples::U8(i.into_raw())),
        D::ImageRgba8(i) => (4, Samples::U8(i.into_raw())),
        D::ImageLuma16(i) => (1, Samples::U16(i.into_raw())),
        D::ImageLumaA16(i) => (2, Samples::U16(i.into_raw())),
        D::ImageRgb16(i) => (3, Samples::U16(i.into_raw())),
        D::ImageRgba16(i) => (4, Samples::U16(i.into_raw())),
        D::ImageRgb32F(i) => (3, Samples::F32(i.into_raw())),
        other => (4, Samples::F32(other.into_rgba32f().into_raw())),
    };
    Ok(Decoded {
        width,
        height,
        channels,
        samples,
    })
}

/// Radiance `.hdr` through our RGBE reader ([`crate::rgbe`]).
fn decode_hdr(bytes: &[u8], budget: u64) -> Result<Decoded, String> {
    let (width, height, texels) = crate::rgbe::read(bytes, |w, h| check_size(w, h, budget))?;
    Ok(Decoded {
        width,
        height,
        channels: 3,
        samples: Samples::F32(texels.into_flattened()),
    })
}

/// The most pixel data an EXR file may decode to per byte of file: ZIP's deflate tops out
/// near 1032:1 and RLE at 64:1, so a header that promises more than this lies about its size.
const EXR_MAX_EXPANSION: u64 = 1100;

/// Reads an EXR file's headers and refuses those that promise more decoded f32 samples than
/// `limit` bytes or than the file's bytes could hold, before any decoder allocates for them
/// (a corrupt 600-byte header asked for 8 GiB). Shared with the tracer's EXR reader.
pub fn check_exr_header(bytes: &[u8], limit: u64) -> Result<exr::meta::MetaData, String> {
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false)
        .map_err(|e| e.to_string())?;
    let mut decoded: u64 = 0;
    for h in meta.headers.iter() {
        let (w, ht) = (h.layer_size.0 as u64, h.layer_size.1 as u64);
        let channels = h.channels.list.len() as u64;
        decoded = w
            .checked_mul(ht)
            .and_then(|p| p.checked_mul(channels.max(1) * 4))
            .and_then(|b| b.checked_add(decoded))
            .unwrap_or(u64::MAX);
    }
    let plausible = (bytes.len() as u64).saturating_mul(EXR_MAX_EXPANSION);
    if decoded > limit || decoded > plausible {
        return Err(format!(
            "the headers promise {decoded} bytes of pixels: more than the {limit}-byte image \
             limit or than {} bytes of file can hold ({EXR_MAX_EXPANSION}:1 at most)",
            bytes.len()
        ));
    }
    Ok(meta)
}

/// An EXR image as [`read_exr_first_layer`] reads it: the first valid layer, every channel
/// as flat samples, the attributes kept.
pub type ExrLayerImage =
    exr::prelude::Image<exr::prelude::Layer<exr::prelude::AnyChannels<exr::prelude::FlatSamples>>>;

/// The largest resolution level of the first valid layer of an EXR held in memory, every
/// channel, after [`check_exr_header`] has refused headers that promise more than `limit`
/// bytes: the texture decoder's and the tracer's reader (`shadenet diff`) both.
pub fn read_exr_first_layer(bytes: &[u8], limit: u64) -> Result<ExrLayerImage, String> {
    check_exr_header(bytes, limit)?;
    read_checked_exr(bytes)
}

/// [`read_exr_first_layer`] for bytes whose headers [`check_exr_header`] has passed.
fn read_checked_exr(bytes: &[u8]) -> Result<ExrLayerImage, String> {
    use exr::prelude::{ReadChannels, ReadLayers};
    exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| e.to_string())
}

/// An EXR file's headers, refused where they promise more than the image limit
/// ([`check_exr_header`]) or a layer too large for `budget`.
fn exr_headers(bytes: &[u8], budget: u64) -> Result<exr::meta::MetaData, String> {
    let limit = FileKind::Image.limit().map_err(|e| e.to_string())?;
    let meta = check_exr_header(bytes, limit)?;
    for h in meta.headers.iter() {
        check_size(side(h.layer_size.0), side(h.layer_size.1), budget)?;
    }
    Ok(meta)
}

/// OpenEXR through the `exr` crate: the first valid layer's `R`, `G`, `B` (and `A`), else
/// `Y` (and `A`), else a layer's `NAME.R`, `NAME.G`, `NAME.B`, else its only channel.
fn decode_exr(bytes: &[u8], budget: u64) -> Result<Decoded, String> {
    exr_headers(bytes, budget)?;
    let image = read_checked_exr(bytes)?;
    let (width, height) = (
        image.layer_data.size.0 as u32,
        image.layer_data.size.1 as u32,
    );
    check_size(width, height, budget)?;
    let list = &image.layer_data.channel_data.list;
    let names: Vec<String> = list.iter().map(|c| c.name.to_string()).collect();
    let find = |n: &str| names.iter().position(|c| c == n);
    // A layer's `NAME.R`, `NAME.G`, `NAME.B` (and `NAME.A`).
    let layered = || {
        names.iter().find_map(|n| {
            let layer = n.strip_suffix(".R")?;
            let f = |s: &str| find(&format!("{layer}.{s}"));
            let mut v = vec![f("R")?, f("G")?, f("B")?];
            v.extend(f("A"));
            Some(v)
        })
    };
    let picked: Vec<usize> = match (find("R"), find("G"), find("B"), find("Y")) {
        (Some(r), Some(g), Some(b), _) => {
            let mut v = vec![r, g, b];
            v.extend(find("A"));
            v
        }
        (_, _, _, Some(y)) => {
            let mut v = vec![y];
            v.extend(find("A"));
            v
        }
        _ => match layered() {
            Some(v) => v,
            None if names.len() == 1 => vec![0],
            None => {
                return Err(format!(
                    "no R, G and B, no Y and no single channel to read (channels: {})",
                    names.join(", ")
                ));
            }
        },
    };
    let n = width as usize * height as usize;
    if picked.iter().any(|&c| list[c].sample_data.len() != n) {
        return Err("a channel's sample count does not match the image size".into());
    }
    // Interleaved straight from the channels (half or float), no per-channel copy.
    let channels = picked.len();
    let mut samples = vec![0.0f32; n * channels];
    for (k, &c) in picked.iter().enumerate() {
        let dst = samples[k..].iter_mut().step_by(channels);
        for (d, v) in dst.zip(list[c].sample_data.values_as_f32()) {
            *d = v;
        }
    }
    Ok(Decoded {
        width,
        height,
        channels,
        samples: Samples::F32(samples),
    })
}
