//! Writing images: PNG previews (8-bit sRGB) and multi-layer f32 EXR, always atomically.
//!
//! Every writer fills a temporary file beside the destination and renames it into place, so
//! an existing file is either replaced whole or left untouched — a failed render never
//! damages the previous image. The facade's `shadenet::output` re-exports this module.
//!
//! PNG previews of renders are tone-mapped by [`tonemap`]: a luminance **shoulder** that
//! leaves every pixel whose luminance is at most [`KNEE`] unchanged and compresses brighter
//! luminance `L` to `KNEE + (1 − KNEE)(1 − e^{−(L − KNEE)/(1 − KNEE)})` (continuous with
//! slope 1 at the knee, approaching 1), scaling the pixel's RGB by the same factor so hues
//! survive; channels are then clamped to [0, 1] and encoded with the sRGB transfer function.

use std::path::{Path, PathBuf};

/// An image that could not be written.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The destination is not a file path.
    #[error("{} is not a file path", path.display())]
    NotAFile {
        /// The path.
        path: PathBuf,
    },
    /// Writing or renaming failed.
    #[error("cannot write {}: {message}", path.display())]
    Write {
        /// The destination.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// The pixels do not match the image size, or there is nothing to write.
    #[error("{0}")]
    Shape(String),
}

/// Writes `path` atomically: `write` fills a temporary file in the same directory, which is
/// then renamed over `path`. On error the temporary file is removed and `path` is untouched.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), OutputError>,
) -> Result<(), OutputError> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path.file_name().ok_or_else(|| OutputError::NotAFile {
        path: path.to_path_buf(),
    })?;
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("tmp");
    let tmp = dir.join(format!(
        ".{}.{}.tmp.{ext}",
        name.to_string_lossy(),
        std::process::id()
    ));
    let result = write(&tmp).and_then(|()| {
        std::fs::rename(&tmp, path).map_err(|e| OutputError::Write {
            path: path.to_path_buf(),
            message: format!("cannot move the new image into place: {e}"),
        })
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Linear → sRGB transfer function, clamped to [0, 1] (non-finite → 0).
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

/// Luminance below which [`tonemap`] changes nothing.
pub const KNEE: f32 = 0.8;

/// The preview tone map (see the module doc) of linear RGB triples, in place.
pub fn tonemap(rgb: &mut [f32]) {
    for px in rgb.chunks_exact_mut(3) {
        for c in px.iter_mut() {
            if !c.is_finite() {
                *c = 0.0;
            }
        }
        let l = 0.2126 * px[0] + 0.7152 * px[1] + 0.0722 * px[2];
        if l > KNEE {
            let mapped = KNEE + (1.0 - KNEE) * (1.0 - (-(l - KNEE) / (1.0 - KNEE)).exp());
            let k = mapped / l;
            for c in px.iter_mut() {
                *c *= k;
            }
        }
    }
}

/// Writes linear RGB floats (`w * h * 3`, rows top to bottom) as an 8-bit sRGB PNG
/// (clamped, not tone-mapped).
pub fn write_png(path: &Path, w: u32, h: u32, rgb: &[f32]) -> Result<(), OutputError> {
    if rgb.len() != (w as usize) * (h as usize) * 3 {
        return Err(OutputError::Shape("image size mismatch".into()));
    }
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
        .map_err(|e| OutputError::Write {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
    })
}

/// One EXR channel: its full name (`beauty.R`, `color.diffuse.G`) and `w * h` samples.
pub type Channel = (String, Vec<f32>);

/// Writes f32 channels as one EXR part (channel names carry the layer: `layer.R`), zip
/// compressed.
pub fn write_exr(path: &Path, w: u32, h: u32, channels: Vec<Channel>) -> Result<(), OutputError> {
    use exr::prelude::*;
    if channels.is_empty() {
        return Err(OutputError::Shape("no channels to write".into()));
    }
    for (name, data) in &channels {
        if data.len() != (w as usize) * (h as usize) {
            return Err(OutputError::Shape(format!(
                "channel {name} has {} samples, expected {}",
                data.len(),
                w * h
            )));
        }
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
        image.write().to_file(tmp).map_err(|e| OutputError::Write {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tonemap_keeps_dark_pixels_and_compresses_bright_ones() {
        let mut px = [0.2, 0.5, 0.1, 10.0, 5.0, 2.0, f32::NAN, 0.0, 0.0];
        tonemap(&mut px);
        assert_eq!(&px[..3], &[0.2, 0.5, 0.1]);
        let l = 0.2126 * px[3] + 0.7152 * px[4] + 0.0722 * px[5];
        assert!(l <= 1.0 + 1e-6 && l > KNEE, "{l}");
        // Hue kept: ratios unchanged.
        assert!((px[3] / px[4] - 2.0).abs() < 1e-5);
        assert_eq!(px[6], 0.0);
    }
}
