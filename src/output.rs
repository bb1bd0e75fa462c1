//! Writing images: PNG previews (sRGB, clamped) and multi-layer f32 EXR.
//!
//! Every writer writes to a temporary file beside the destination and renames it into place,
//! so an existing file is either replaced whole or left untouched.

use anyhow::{Context, Result};
use std::path::Path;

/// Writes `path` atomically: `write` fills a temporary file in the same directory, which is
/// then renamed over `path`. On error the temporary file is removed and `path` is untouched.
pub fn write_atomic(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .with_context(|| format!("{} is not a file path", path.display()))?;
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("tmp");
    let tmp = dir.join(format!(
        ".{}.{}.tmp.{ext}",
        name.to_string_lossy(),
        std::process::id()
    ));
    let result = write(&tmp).and_then(|()| {
        std::fs::rename(&tmp, path)
            .with_context(|| format!("cannot move the new image into {}", path.display()))
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Linear → sRGB transfer function, clamped to [0, 1].
pub fn linear_to_srgb(x: f32) -> f32 {
    let x = if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        0.0
    };
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// Writes linear RGB floats (`w * h * 3`, rows top to bottom) as an 8-bit sRGB PNG.
pub fn write_png(path: &Path, w: u32, h: u32, rgb: &[f32]) -> Result<()> {
    anyhow::ensure!(rgb.len() == (w * h * 3) as usize, "image size mismatch");
    let bytes: Vec<u8> = rgb
        .iter()
        .map(|x| (linear_to_srgb(*x) * 255.0 + 0.5) as u8)
        .collect();
    write_atomic(path, |tmp| {
        image::save_buffer_with_format(
            tmp,
            &bytes,
            w,
            h,
            image::ExtendedColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .with_context(|| format!("cannot write {}", path.display()))
    })
}

/// One EXR channel: its full name (`color.R`, `color.diffuse.G`) and `w * h` samples.
pub type Channel = (String, Vec<f32>);

/// Writes f32 channels as one EXR part (channel names carry the layer: `layer.R`), zip
/// compressed.
pub fn write_exr(path: &Path, w: u32, h: u32, channels: Vec<Channel>) -> Result<()> {
    use exr::prelude::*;
    anyhow::ensure!(!channels.is_empty(), "no channels to write");
    for (name, data) in &channels {
        anyhow::ensure!(
            data.len() == (w * h) as usize,
            "channel {name} has {} samples, expected {}",
            data.len(),
            w * h
        );
    }
    let list: SmallVec<[AnyChannel<FlatSamples>; 4]> = channels
        .into_iter()
        .map(|(name, data)| AnyChannel::new(name.as_str(), FlatSamples::F32(data)))
        .collect();
    let layer = Layer::new(
        (w as usize, h as usize),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    let image = Image::from_layer(layer);
    write_atomic(path, |tmp| {
        image
            .write()
            .to_file(tmp)
            .with_context(|| format!("cannot write {}", path.display()))
    })
}
