//! Writing images: PNG previews (8-bit sRGB) and multi-layer f32 EXR, always atomically;
//! reading EXR back ([`read_exr`], for `shadenet diff`) and comparing two images'
//! channels ([`compare`]).
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

use crate::window::Window;
use shadenet_graph::ops::math;
use shadenet_runtime::input::{self, FileKind, InputError};
use shadenet_runtime::texture::colorspace::Transfer;
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
    /// The image file cannot be read as input (missing, not a regular file, over the
    /// image size limit).
    #[error(transparent)]
    Input(#[from] InputError),
    /// Reading an image failed (not an EXR, no f32 samples).
    #[error("cannot read {}: {message}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
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

/// Writes `bytes` to `path` atomically ([`write_atomic`]).
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    write_atomic(path, |tmp| {
        std::fs::write(tmp, bytes).map_err(|e| OutputError::Write {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
    })
}

/// Linear → sRGB transfer function, clamped to [0, 1] (non-finite → 0): the texture
/// system's sRGB curve ([`Transfer::Srgb`]) on the clamped value.
pub fn linear_to_srgb(x: f32) -> f32 {
    let x = if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        0.0
    };
    Transfer::Srgb.encode(x)
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
            let mapped = KNEE + (1.0 - KNEE) * (1.0 - math::exp_f32(-(l - KNEE) / (1.0 - KNEE)));
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
/// compressed: a whole `w × h` frame.
pub fn write_exr(path: &Path, w: u32, h: u32, channels: Vec<Channel>) -> Result<(), OutputError> {
    write_exr_window(path, Window::full(w, h), (w, h), channels)
}

/// [`write_exr`] for a region: the channels hold the `window`'s pixels, which the file
/// records as its data window inside a display window of the full `frame` size. A window
/// that is the whole frame writes the same bytes as [`write_exr`].
pub fn write_exr_window(
    path: &Path,
    window: Window,
    frame: (u32, u32),
    channels: Vec<Channel>,
) -> Result<(), OutputError> {
    use exr::prelude::*;
    if channels.is_empty() {
        return Err(OutputError::Shape("no channels to write".into()));
    }
    if window.x1 > frame.0 || window.y1 > frame.1 || window.pixels() == 0 {
        return Err(OutputError::Shape(format!(
            "the window {window} is not inside the {}×{} frame",
            frame.0, frame.1
        )));
    }
    let (w, h) = (window.width(), window.height());
    for (name, data) in &channels {
        if data.len() != window.pixels() {
            return Err(OutputError::Shape(format!(
                "channel {name} has {} samples, expected {}",
                data.len(),
                window.pixels()
            )));
        }
    }
    let list: SmallVec<[AnyChannel<FlatSamples>; 4]> = channels
        .into_iter()
        .map(|(name, data)| AnyChannel::new(name.as_str(), FlatSamples::F32(data)))
        .collect();
    let attributes = LayerAttributes {
        layer_position: Vec2(window.x0 as i32, window.y0 as i32),
        ..LayerAttributes::default()
    };
    let layer = Layer::new(
        (w as usize, h as usize),
        attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    let display = IntegerBounds::new((0, 0), (frame.0 as usize, frame.1 as usize));
    let image = Image::new(ImageAttributes::new(display), layer);
    write_atomic(path, |tmp| {
        image.write().to_file(tmp).map_err(|e| OutputError::Write {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
    })
}

/// An EXR image read back: its size, where it sits in its frame and its channels (first
/// part), sorted by name.
#[derive(Clone, Debug, PartialEq)]
pub struct ExrImage {
    /// Width in pixels (of the data window).
    pub width: u32,
    /// Height in pixels (of the data window).
    pub height: u32,
    /// The data window, relative to the display window's top-left corner: the whole frame
    /// for a full render, the region for a region render.
    pub window: Window,
    /// The display window's size: the full frame.
    pub frame: (u32, u32),
    /// Every channel, as f32 (f16 and u32 samples converted), sorted by name.
    pub channels: Vec<Channel>,
}

/// Reads the first part of an EXR file, every channel as f32, through the bounded input
/// gate ([`shadenet_runtime::input`]).
pub fn read_exr(path: &Path) -> Result<ExrImage, OutputError> {
    let err = |message: String| OutputError::Read {
        path: path.to_path_buf(),
        message,
    };
    // Through the input gate: a regular file within the image limit, read bounded.
    let bytes = input::read(path, FileKind::Image, "EXR image")?;
    let limit = FileKind::Image.limit().map_err(|e| err(e.to_string()))?;
    let image =
        shadenet_runtime::texture::decode::read_exr_first_layer(&bytes, limit).map_err(err)?;
    let size = image.layer_data.size;
    let mut channels: Vec<Channel> = image
        .layer_data
        .channel_data
        .list
        .iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect();
    channels.sort_by(|a, b| a.0.cmp(&b.0));
    let display = image.attributes.display_window;
    let at = image.layer_data.attributes.layer_position;
    let (x0, y0) = (
        i64::from(at.0) - i64::from(display.position.0),
        i64::from(at.1) - i64::from(display.position.1),
    );
    let frame = (display.size.0 as u64, display.size.1 as u64);
    let (w, h) = (size.0 as u64, size.1 as u64);
    // A data window reaching outside its display window is legal EXR but not one of ours:
    // such an image reads as a whole frame of its data window's size (so `merge` reports
    // its frame as differing from the other parts').
    let inside = x0 >= 0 && y0 >= 0 && x0 as u64 + w <= frame.0 && y0 as u64 + h <= frame.1;
    let (window, frame) = if inside {
        (
            Window {
                x0: x0 as u32,
                y0: y0 as u32,
                x1: (x0 as u64 + w) as u32,
                y1: (y0 as u64 + h) as u32,
            },
            (frame.0 as u32, frame.1 as u32),
        )
    } else {
        (Window::full(w as u32, h as u32), (w as u32, h as u32))
    };
    Ok(ExrImage {
        width: w as u32,
        height: h as u32,
        window,
        frame,
        channels,
    })
}

/// How two images' channel groups differ (`shadenet diff`).
#[derive(Clone, Debug, PartialEq)]
pub struct LayerDiff {
    /// The layer: the channel names' part before the last `.` (`beauty` of `beauty.R`), or
    /// the channel name when it has none.
    pub layer: String,
    /// Samples compared (pixels × channels).
    pub samples: usize,
    /// Largest absolute difference (NaN against a number, or infinities of different
    /// sign, count as infinite).
    pub max_abs: f64,
    /// Root mean square of the differences (infinite when `max_abs` is).
    pub rmse: f64,
    /// Pixel (x, y) and channel of the largest difference.
    pub worst: (u32, u32, String),
    /// Samples whose bits differ.
    pub differing: usize,
}

/// Compares two images channel by channel and sums per layer. Errors when their sizes or
/// channel names differ.
pub fn compare(a: &ExrImage, b: &ExrImage) -> Result<Vec<LayerDiff>, String> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(format!(
            "the images differ in size: {}×{} and {}×{}",
            a.width, a.height, b.width, b.height
        ));
    }
    if (a.window, a.frame) != (b.window, b.frame) {
        return Err(format!(
            "the images cover different windows: {} of a {}×{} frame and {} of a {}×{} frame",
            a.window, a.frame.0, a.frame.1, b.window, b.frame.0, b.frame.1
        ));
    }
    let names = |i: &ExrImage| i.channels.iter().map(|c| c.0.clone()).collect::<Vec<_>>();
    if names(a) != names(b) {
        return Err(format!(
            "the images have different channels: [{}] and [{}]",
            names(a).join(", "),
            names(b).join(", ")
        ));
    }
    let mut out: Vec<(LayerDiff, f64)> = Vec::new();
    for ((name, x), (_, y)) in a.channels.iter().zip(&b.channels) {
        let layer = name
            .rsplit_once('.')
            .map_or(name.as_str(), |s| s.0)
            .to_string();
        if out.last().is_none_or(|(d, _)| d.layer != layer) {
            out.push((
                LayerDiff {
                    layer,
                    samples: 0,
                    max_abs: 0.0,
                    rmse: 0.0,
                    worst: (0, 0, name.clone()),
                    differing: 0,
                },
                0.0,
            ));
        }
        let (d, sq) = out.last_mut().expect("pushed above");
        for (i, (p, q)) in x.iter().zip(y).enumerate() {
            d.samples += 1;
            if p.to_bits() == q.to_bits() {
                continue;
            }
            d.differing += 1;
            let e = if p.is_nan() || q.is_nan() {
                if p.is_nan() && q.is_nan() {
                    0.0
                } else {
                    f64::INFINITY
                }
            } else if p == q {
                0.0
            } else {
                (*p as f64 - *q as f64).abs()
            };
            *sq += e * e;
            if e > d.max_abs {
                d.max_abs = e;
                d.worst = (i as u32 % a.width, i as u32 / a.width, name.clone());
            }
        }
    }
    Ok(out
        .into_iter()
        .map(|(mut d, sq)| {
            d.rmse = (sq / d.samples.max(1) as f64).sqrt();
            d
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A region's EXR keeps its data window inside the full frame; `diff` refuses to
    /// compare images of different windows even when their sizes agree.
    #[test]
    fn exr_regions_keep_their_window_and_frame() {
        let dir = std::env::temp_dir().join(format!("shadenet-window-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (a, b) = (dir.join("a.exr"), dir.join("b.exr"));
        let values = vec![("beauty.R".to_string(), vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0])];
        let wa = Window::new([3, 1, 6, 3], (8, 5)).unwrap();
        let wb = Window::new([0, 0, 3, 2], (8, 5)).unwrap();
        write_exr_window(&a, wa, (8, 5), values.clone()).unwrap();
        write_exr_window(&b, wb, (8, 5), values.clone()).unwrap();
        let (ia, ib) = (read_exr(&a).unwrap(), read_exr(&b).unwrap());
        assert_eq!(
            (ia.width, ia.height, ia.window, ia.frame),
            (3, 2, wa, (8, 5))
        );
        assert_eq!(ia.channels, values);
        assert_eq!(ib.window, wb);
        let e = compare(&ia, &ib).unwrap_err();
        assert!(
            e.contains("different windows: 3,1,6,3 of a 8×5 frame"),
            "{e}"
        );
        // Outside the frame or the wrong size: refused, nothing written.
        let c = dir.join("c.exr");
        let outside = Window {
            x0: 6,
            y0: 0,
            x1: 9,
            y1: 2,
        };
        assert!(write_exr_window(&c, outside, (8, 5), values.clone()).is_err());
        assert!(write_exr_window(&c, wb, (8, 5), vec![("x.R".into(), vec![0.0])]).is_err());
        assert!(!c.exists());
    }

    #[test]
    fn exr_round_trips_and_compares_per_layer() {
        let dir = std::env::temp_dir().join(format!("shadenet-diff-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (a, b) = (dir.join("a.exr"), dir.join("b.exr"));
        let ch = |n: &str, v: Vec<f32>| (n.to_string(), v);
        write_exr(
            &a,
            2,
            2,
            vec![
                ch("beauty.R", vec![0.0, 1.0, 2.0, 3.0]),
                ch("beauty.G", vec![0.5; 4]),
                ch("depth.Z", vec![1.0, f32::NAN, 2.0, 2.0]),
            ],
        )
        .unwrap();
        write_exr(
            &b,
            2,
            2,
            vec![
                ch("beauty.R", vec![0.0, 1.0, 2.0, 3.5]),
                ch("beauty.G", vec![0.5, 0.5, 0.25, 0.5]),
                ch("depth.Z", vec![1.0, f32::NAN, 2.0, 2.0]),
            ],
        )
        .unwrap();
        let (ia, ib) = (read_exr(&a).unwrap(), read_exr(&b).unwrap());
        assert_eq!((ia.width, ia.height), (2, 2));
        assert_eq!(ia.channels[0], ch("beauty.G", vec![0.5; 4]));
        let d = compare(&ia, &ib).unwrap();
        assert_eq!(d.len(), 2);
        assert_eq!(d[0].layer, "beauty");
        assert_eq!((d[0].samples, d[0].differing), (8, 2));
        assert_eq!(d[0].max_abs, 0.5);
        assert_eq!(d[0].worst, (1, 1, "beauty.R".to_string()));
        assert_eq!(d[0].rmse, ((0.25f64 * 0.25 + 0.5 * 0.5) / 8.0).sqrt());
        assert_eq!(
            (d[1].layer.as_str(), d[1].max_abs, d[1].differing),
            ("depth", 0.0, 0)
        );
        // NaN against a number is an infinite difference.
        write_exr(
            &b,
            2,
            2,
            vec![
                ch("beauty.R", vec![f32::NAN, 1.0, 2.0, 3.0]),
                ch("beauty.G", vec![0.5; 4]),
                ch("depth.Z", vec![1.0, f32::NAN, 2.0, 2.0]),
            ],
        )
        .unwrap();
        let d = compare(&ia, &read_exr(&b).unwrap()).unwrap();
        assert!(d[0].max_abs.is_infinite() && d[0].rmse.is_infinite());
        // Different channels or sizes are errors that say so.
        write_exr(&b, 1, 1, vec![ch("beauty.R", vec![0.0])]).unwrap();
        assert!(
            compare(&ia, &read_exr(&b).unwrap())
                .unwrap_err()
                .contains("size")
        );
        write_exr(&b, 2, 2, vec![ch("beauty.R", vec![0.0; 4])]).unwrap();
        assert!(
            compare(&ia, &read_exr(&b).unwrap())
                .unwrap_err()
                .contains("channels")
        );
        // A missing file names the file.
        let e = read_exr(&dir.join("missing.exr")).unwrap_err().to_string();
        assert!(e.contains("missing.exr"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// EXR reads go through the input gate: a device or an oversized file is refused before
    /// exr sees it.
    #[cfg(unix)]
    #[test]
    fn exr_reads_refuse_devices_and_oversized_files() {
        let e = read_exr(Path::new("/dev/zero")).unwrap_err().to_string();
        assert_eq!(
            e,
            "/dev/zero: not a regular file (a character device); image input must be a regular file"
        );
        let dir = std::env::temp_dir().join(format!("shadenet-exr-big-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let big = dir.join("big.exr");
        let f = std::fs::File::create(&big).unwrap();
        f.set_len(FileKind::Image.default_limit() + 1).unwrap();
        let e = read_exr(&big).unwrap_err().to_string();
        assert!(
            e.contains("over the 1073741824-byte limit for image files"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

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
