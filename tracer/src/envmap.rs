//! The files of image environment lights: lat-long maps read from Radiance `.hdr` (RGBE,
//! through the runtime's reader [`shadenet_runtime::rgbe`]) and OpenEXR (through
//! [`crate::output::read_exr`]), and written as `.hdr` by [`write_hdr`] (`shadenet gen
//! sky`, re-exported from the runtime).
//!
//! Every file passes the input gate (a regular file within the image limit), and a map's
//! size is checked against `shadenet_graph::nodes::env_image`'s limits before its texels
//! are allocated. This module owns decoding only: the checks of texel values are
//! `LightDesc::new`'s, the sampling is the runtime's.

use shadenet_graph::nodes::env_image::check_size;
use shadenet_runtime::input::{self, FileKind};
use shadenet_runtime::rgbe;
pub use shadenet_runtime::rgbe::{Decoded, rgb_to_rgbe, write_hdr};
use std::path::Path;

/// Reads a `.hdr` or `.exr` lat-long map (by extension, case-insensitive). The error says
/// what is wrong, without the file name (the caller names it).
pub fn load(path: &Path) -> Result<Decoded, String> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("hdr") => {
            let bytes = input::read(path, FileKind::Image, "environment map")
                .map_err(|e| shadenet_graph::error_chain(&e))?;
            read_hdr(&bytes)
        }
        Some("exr") => read_exr_rgb(path),
        _ => Err("an environment map must be a .hdr (Radiance RGBE) or .exr file".into()),
    }
}

/// The R, G and B channels of an EXR file (`R`, `G`, `B`, else the first layer's
/// `NAME.R`, `NAME.G`, `NAME.B`).
fn read_exr_rgb(path: &Path) -> Result<Decoded, String> {
    let img = crate::output::read_exr(path).map_err(|e| shadenet_graph::error_chain(&e))?;
    check_size(img.width, img.height)?;
    let find = |name: &str| img.channels.iter().position(|c| c.0 == name);
    let rgb = match (find("R"), find("G"), find("B")) {
        (Some(r), Some(g), Some(b)) => [r, g, b],
        _ => img
            .channels
            .iter()
            .filter_map(|c| c.0.strip_suffix(".R"))
            .find_map(|layer| {
                let f = |c: &str| find(&format!("{layer}.{c}"));
                Some([f("R")?, f("G")?, f("B")?])
            })
            .ok_or("the image has no R, G and B channels")?,
    };
    let n = img.width as usize * img.height as usize;
    if rgb.iter().any(|&c| img.channels[c].1.len() != n) {
        return Err("a channel's sample count does not match the image size".into());
    }
    let texels = (0..n).map(|i| rgb.map(|c| img.channels[c].1[i])).collect();
    Ok((img.width, img.height, texels))
}

/// Decodes a Radiance `.hdr` file (the runtime's [`rgbe::read`]) whose size is within an
/// environment map's limits.
pub fn read_hdr(bytes: &[u8]) -> Result<Decoded, String> {
    rgbe::read(bytes, check_size)
}
