//! The texture system: opens the image files a program's needs name, decodes them to the
//! working space, builds their mipmaps, caches them across materials, and filters lookups.
//!
//! Only the textures a specialized program still references are opened: a texture on a dead
//! branch is removed by the optimizer before this code ever sees its file name. The parts,
//! one file each:
//!
//! - [`decode`]: PNG (8/16 bit), JPEG, Radiance HDR, OpenEXR; sizes checked before any
//!   allocation;
//! - [`colorspace`]: stored values → linear Rec.709 by the file's color space;
//! - [`mip`]: the pyramid, exact box averages for any size;
//! - [`filter`]: closest, bilinear, trilinear, anisotropic; wraps periodic, clamp, mirror,
//!   black;
//! - [`udim`]: `<UDIM>` tile sets;
//! - [`cache`]: the process-wide cache, its memory budget and statistics.
//!
//! `docs/textures.md` is the user's description, with measured speeds.

pub mod cache;
pub mod colorspace;
pub mod decode;
pub mod filter;
pub mod mip;
pub mod udim;

pub use cache::{TextureStats, stats};
pub use mip::{Level, Pyramid};

use shadenet_graph::ir::{Filter, Sampling, TextureFile, Wrap};
use shadenet_graph::ops::Real;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use udim::Udim;

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
    /// `SHADENET_TEXTURE_MEMORY_MB` is not a positive number of MiB.
    #[error("SHADENET_TEXTURE_MEMORY_MB=`{value}`: expected a positive number of MiB such as 4096")]
    Budget {
        /// Its value.
        value: String,
    },
}

/// What a texture's lookups read: one image or a UDIM set.
#[derive(Clone, Debug)]
enum Image {
    Single(Arc<Pyramid>),
    Udim(Arc<Udim>),
}

/// One opened texture: a mipmap pyramid of linear RGBA texels (rows top to bottom), or a
/// UDIM set of them, shared with every other material that opened the same file.
#[derive(Clone, Debug)]
pub struct Texture {
    image: Image,
}

impl Texture {
    /// Opens a texture file (a `<UDIM>` pattern opens its tiles) through the process-wide
    /// cache, converting its values from the file's color space.
    pub fn load(file: &TextureFile) -> Result<Texture, TextureError> {
        let image = if udim::is_udim(&file.path) {
            Image::Udim(Arc::new(Udim::open(
                Path::new(&file.path),
                file.colorspace,
            )?))
        } else {
            Image::Single(cache::open(Path::new(&file.path), file.colorspace)?)
        };
        Ok(Texture { image })
    }

    /// A texture of an image already in the working space (`texels.len() == width ×
    /// height`, both at least 1; tests and generated textures).
    pub fn from_texels(width: u32, height: u32, texels: Vec<[f32; 4]>) -> Texture {
        Texture {
            image: Image::Single(Arc::new(Pyramid::build(width, height, texels))),
        }
    }

    /// The pyramid of a single image, or of a UDIM set's lowest tile.
    pub fn pyramid(&self) -> &Pyramid {
        match &self.image {
            Image::Single(p) => p,
            Image::Udim(u) => u.tiles().next().expect("a UDIM set has a tile").1,
        }
    }

    /// The UDIM tiles, by number; `None` for a single image.
    pub fn udim_tiles(&self) -> Option<Vec<(u32, &Pyramid)>> {
        match &self.image {
            Image::Single(_) => None,
            Image::Udim(u) => Some(u.tiles().collect()),
        }
    }

    /// Level 0's width ([`Texture::pyramid`]).
    pub fn width(&self) -> u32 {
        self.pyramid().levels()[0].width
    }

    /// Level 0's height ([`Texture::pyramid`]).
    pub fn height(&self) -> u32 {
        self.pyramid().levels()[0].height
    }

    /// Level 0's texels ([`Texture::pyramid`]), rows top to bottom.
    pub fn texels(&self) -> &[[f32; 4]] {
        &self.pyramid().levels()[0].texels
    }

    /// A filtered lookup at `uv` with screen-space derivatives `duv` (`duv[0]` = ∂uv/∂x,
    /// `duv[1]` = ∂uv/∂y; zero, NaN or huge allowed): see [`filter`]. A UDIM set reads the
    /// tile under `uv`, black where there is none.
    pub fn lookup<F: Real>(&self, uv: [F; 2], duv: [[F; 2]; 2], sampling: Sampling) -> [F; 4] {
        match &self.image {
            Image::Single(p) => filter::lookup(p.levels(), uv, duv, sampling),
            Image::Udim(u) => match u.locate(uv) {
                Some((p, local)) => filter::lookup(p.levels(), local, duv, sampling),
                None => [F::ZERO; 4],
            },
        }
    }

    /// Bilinear lookup at `uv` with periodic wrapping in level 0 (non-finite coordinates
    /// read a fixed texel): [`Texture::lookup`] with zero derivatives.
    pub fn sample<F: Real>(&self, uv: [F; 2]) -> [F; 4] {
        let sampling = Sampling {
            filter: Filter::Bilinear,
            wrap: [Wrap::Periodic; 2],
        };
        self.lookup(uv, [[F::ZERO; 2]; 2], sampling)
    }
}

/// The loaded textures of one program, by index.
#[derive(Clone, Debug, Default)]
pub struct TextureSet {
    textures: Vec<Texture>,
}

impl TextureSet {
    /// Opens every file, in order, through the process-wide cache; the first failure is
    /// returned.
    pub fn load(files: &[TextureFile]) -> Result<TextureSet, TextureError> {
        let textures = files.iter().map(Texture::load).collect::<Result<_, _>>()?;
        Ok(TextureSet { textures })
    }

    /// A set of textures already opened.
    pub fn from_textures(textures: Vec<Texture>) -> TextureSet {
        TextureSet { textures }
    }

    /// The texture at `index`.
    pub fn get(&self, index: u32) -> Option<&Texture> {
        self.textures.get(index as usize)
    }
}
