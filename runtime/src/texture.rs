//! The texture system: loads the image files a program's needs name, and samples them.
//!
//! Only the textures a specialized program still references are loaded: a texture on a dead
//! branch is removed by the optimizer before this code ever sees its file name. 8-bit and
//! 16-bit PNGs are decoded from sRGB to linear RGB (alpha stays linear). Lookups are
//! bilinear with repeat wrapping; `uv = (0, 0)` is the bottom-left corner of the image.

use shadenet_graph::ir::{ColorSpace, Sampling, TextureFile};
use shadenet_graph::ops::Real;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A texture that could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum TextureError {
    /// The file is missing or unreadable or not a decodable image.
    #[error("cannot load texture {path}: {reason}")]
    Load {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
}

/// One decoded image: linear RGBA, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// `width * height` texels.
    pub texels: Vec<[f32; 4]>,
}

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        shadenet_graph::ops::math::pow_f32((c + 0.055) / 1.055, 2.4)
    }
}

impl Texture {
    /// Loads an image file, converting its values from the file's color space.
    pub fn load(file: &TextureFile) -> Result<Texture, TextureError> {
        let path = Path::new(&file.path);
        let srgb = match file.colorspace {
            ColorSpace::Auto | ColorSpace::SrgbTexture => true,
            ColorSpace::Raw | ColorSpace::LinRec709 => false,
            other => {
                return Err(TextureError::Load {
                    path: path.to_path_buf(),
                    reason: format!("color space {} is not built yet", other.name()),
                });
            }
        };
        let err = |reason: String| TextureError::Load {
            path: path.to_path_buf(),
            reason,
        };
        // A device, a FIFO or an oversized file never reaches the decoder.
        crate::input::check(path, crate::input::FileKind::Image, "texture").map_err(
            |e| match e {
                // The path is this error's own: only the cause goes into the reason.
                crate::input::InputError::Io { source, .. } => err(source.to_string()),
                other => err(other.to_string()),
            },
        )?;
        let img = image::open(path).map_err(|e| err(e.to_string()))?;
        let rgba = img.to_rgba32f();
        let (width, height) = rgba.dimensions();
        if width == 0 || height == 0 {
            return Err(err("the image is empty".into()));
        }
        let texels = rgba
            .pixels()
            .map(|p| {
                let [r, g, b, a] = p.0;
                if srgb {
                    [srgb_to_linear(r), srgb_to_linear(g), srgb_to_linear(b), a]
                } else {
                    [r, g, b, a]
                }
            })
            .collect();
        Ok(Texture {
            width,
            height,
            texels,
        })
    }

    fn texel<F: Real>(&self, x: i64, y: i64) -> [F; 4] {
        let x = x.rem_euclid(self.width as i64) as usize;
        let y = y.rem_euclid(self.height as i64) as usize;
        self.texels[y * self.width as usize + x].map(|c| F::from_f64(c as f64))
    }

    /// A lookup at `uv` over the footprint `duv` (∂uv/∂x, ∂uv/∂y). This version reads the
    /// finest level bilinearly with repeat wrapping whatever the sampling (the filtered
    /// texture system replaces it).
    pub fn lookup<F: Real>(&self, uv: [F; 2], _duv: [[F; 2]; 2], _s: Sampling) -> [F; 4] {
        self.sample(uv)
    }

    /// Bilinear lookup at `uv` with repeat wrapping (non-finite coordinates read texel 0).
    pub fn sample<F: Real>(&self, uv: [F; 2]) -> [F; 4] {
        let half = F::from_f64(0.5);
        let x = uv[0] * F::from_f64(self.width as f64) - half;
        let y = (F::ONE - uv[1]) * F::from_f64(self.height as f64) - half;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (fx, fy) = (
            if fx.is_finite() { fx } else { F::ZERO },
            if fy.is_finite() { fy } else { F::ZERO },
        );
        let (xi, yi) = (x0.to_i32() as i64, y0.to_i32() as i64);
        let t00 = self.texel::<F>(xi, yi);
        let t10 = self.texel::<F>(xi + 1, yi);
        let t01 = self.texel::<F>(xi, yi + 1);
        let t11 = self.texel::<F>(xi + 1, yi + 1);
        std::array::from_fn(|c| {
            let top = t00[c] + fx * (t10[c] - t00[c]);
            let bottom = t01[c] + fx * (t11[c] - t01[c]);
            top + fy * (bottom - top)
        })
    }
}

/// The loaded textures of one program, by index.
#[derive(Clone, Debug, Default)]
pub struct TextureSet {
    textures: Vec<Arc<Texture>>,
}

impl TextureSet {
    /// Loads every file, in order; the first failure is returned.
    pub fn load(files: &[TextureFile]) -> Result<TextureSet, TextureError> {
        let textures = files
            .iter()
            .map(|f| Texture::load(f).map(Arc::new))
            .collect::<Result<_, _>>()?;
        Ok(TextureSet { textures })
    }

    /// The texture at `index`.
    pub fn get(&self, index: u32) -> Option<&Texture> {
        self.textures.get(index as usize).map(|t| &**t)
    }
}
