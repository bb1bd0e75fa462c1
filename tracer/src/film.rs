//! The film: one layer per pass, f32, and its EXR and PNG output.
//!
//! Layers are `beauty` (R, G, B and A: the sum of every component, and coverage), then the
//! scene's passes in order (component passes R, G, B; override passes with their own
//! channels: `normal` X, Y, Z; `depth` Z; `uv` U, V; `occlusion` Y). In the EXR each channel
//! is `layer.channel` (`beauty.R`, `diffuse.G`, `depth.Z`), the naming VFX tools read as
//! layers.
//!
//! A film may hold only a **region** of the frame ([`Window`], `render --crop`): its layers
//! then cover the window's pixels, and the EXR records the window as its data window inside
//! the full frame (the display window), the way compositors and `shadenet merge` read
//! region renders.

pub use crate::window::Window;

use crate::output::{self, OutputError};
use std::path::Path;

/// One layer: interleaved channels, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Layer {
    /// Layer name.
    pub name: String,
    /// Channel names.
    pub channels: Vec<String>,
    /// `width * height * channels.len()` values, interleaved.
    pub data: Vec<f32>,
}

impl Layer {
    /// A layer from interleaved data.
    pub fn new(name: &str, channels: &[&str], data: Vec<f32>) -> Layer {
        Layer {
            name: name.to_string(),
            channels: channels.iter().map(|c| c.to_string()).collect(),
            data,
        }
    }

    /// The value of channel `c` at pixel `i` (row-major index).
    pub fn at(&self, i: usize, c: usize) -> f32 {
        self.data[i * self.channels.len() + c]
    }
}

/// A rendered image: its layers, over the whole frame or a [`Window`] of it.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    /// Width in pixels (of the window).
    pub width: u32,
    /// Height in pixels (of the window).
    pub height: u32,
    /// Where the layers' pixels sit in the frame: the whole frame for a full render.
    pub window: Window,
    /// The full frame's size (the EXR's display window).
    pub frame: (u32, u32),
    /// `beauty` first, then the passes.
    pub layers: Vec<Layer>,
}

impl Film {
    /// The layer called `name`.
    pub fn layer(&self, name: &str) -> Option<&Layer> {
        self.layers.iter().find(|l| l.name == name)
    }

    /// Every channel as `(layer.channel, samples)`.
    pub fn channels(&self) -> Vec<output::Channel> {
        let n = (self.width as usize) * (self.height as usize);
        let mut out = Vec::new();
        for l in &self.layers {
            let nc = l.channels.len();
            for (c, name) in l.channels.iter().enumerate() {
                let data: Vec<f32> = (0..n).map(|i| l.data[i * nc + c]).collect();
                out.push((format!("{}.{name}", l.name), data));
            }
        }
        out
    }

    /// Writes every layer to one multi-layer f32 EXR (atomically); a region's EXR has the
    /// window as its data window and the full frame as its display window.
    pub fn write_exr(&self, path: &Path) -> Result<(), OutputError> {
        output::write_exr_window(path, self.window, self.frame, self.channels())
    }

    /// Writes the beauty layer as a tone-mapped sRGB PNG preview (atomically).
    pub fn write_png(&self, path: &Path) -> Result<(), OutputError> {
        let Some(b) = self.layer("beauty") else {
            return Err(OutputError::Shape("the film has no beauty layer".into()));
        };
        let n = (self.width as usize) * (self.height as usize);
        let mut rgb: Vec<f32> = (0..n)
            .flat_map(|i| [b.at(i, 0), b.at(i, 1), b.at(i, 2)])
            .collect();
        output::tonemap(&mut rgb);
        output::write_png(path, self.width, self.height, &rgb)
    }
}
