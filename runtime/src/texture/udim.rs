//! UDIM texture sets: a path whose file name contains `<UDIM>` names tiles `1001 + ⌊u⌋ +
//! 10·⌊v⌋` (`u` in `[0, 10)`, `v` in `[0, 100)`: tiles 1001 to 1999).
//!
//! The tiles present are found by listing the directory once (file names that are the
//! pattern with four digits in place of `<UDIM>`); each is opened through the cache like any
//! texture. A lookup reads the tile under its uv, with uv taken modulo the tile (the tile's
//! own `(0, 0)` is its bottom-left corner) and the derivatives unchanged; uv on a missing
//! tile, or outside the 10 × 100 grid, reads transparent black. A pattern with no tile at all
//! is an error.

use super::TextureError;
use super::mip::Pyramid;
use shadenet_graph::ir::ColorSpace;
use shadenet_graph::ops::Real;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The marker in a file name.
pub const MARKER: &str = "<UDIM>";

/// Tiles per row of the UDIM grid (u in `[0, 10)`).
const COLUMNS: usize = 10;
/// Rows of the grid (v in `[0, 100)`): tiles 1001 to 1999 (the last row stops at 1999).
const ROWS: usize = 100;

/// The tiles of a UDIM set.
#[derive(Clone, Debug)]
pub struct Udim {
    /// By `tile − 1001`; `None` where the file does not exist.
    tiles: Vec<Option<Arc<Pyramid>>>,
}

/// Whether a path names a UDIM set.
pub fn is_udim(path: &str) -> bool {
    path.contains(MARKER)
}

/// The files of a UDIM pattern present on disk, by tile number, sorted.
pub fn tile_files(pattern: &Path) -> Result<Vec<(u32, PathBuf)>, TextureError> {
    let err = |reason: String| TextureError::Load {
        path: pattern.to_path_buf(),
        reason,
    };
    let name = pattern
        .file_name()
        .and_then(|n| n.to_str())
        .filter(|n| n.contains(MARKER))
        .ok_or_else(|| {
            err(format!(
                "`{MARKER}` must be in the file name, not a directory"
            ))
        })?;
    let (prefix, suffix) = name.split_once(MARKER).expect("checked above");
    let dir = match pattern.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let entries = std::fs::read_dir(&dir)
        .map_err(|e| err(format!("cannot list the directory {}: {e}", dir.display())))?;
    let mut tiles = Vec::new();
    for entry in entries.flatten() {
        let file = entry.file_name();
        let Some(file) = file.to_str() else { continue };
        let Some(digits) = file
            .strip_prefix(prefix)
            .and_then(|r| r.strip_suffix(suffix))
        else {
            continue;
        };
        if digits.len() != 4 || !digits.bytes().all(|b| b.is_ascii_digit()) {
            continue;
        }
        let tile: u32 = digits.parse().expect("four digits");
        if (1001..=1999).contains(&tile) {
            tiles.push((tile, dir.join(file)));
        }
    }
    tiles.sort();
    if tiles.is_empty() {
        return Err(err(format!(
            "no UDIM tile exists (no file {prefix}NNNN{suffix} with NNNN in 1001..1999 in {})",
            dir.display()
        )));
    }
    Ok(tiles)
}

impl Udim {
    /// Opens every tile of a pattern present on disk through the cache.
    pub fn open(pattern: &Path, colorspace: ColorSpace) -> Result<Udim, TextureError> {
        let mut tiles = vec![None; COLUMNS * ROWS];
        for (tile, file) in tile_files(pattern)? {
            tiles[(tile - 1001) as usize] = Some(super::cache::open(&file, colorspace)?);
        }
        Ok(Udim { tiles })
    }

    /// The tiles present, by number.
    pub fn tiles(&self) -> impl Iterator<Item = (u32, &Pyramid)> {
        self.tiles
            .iter()
            .enumerate()
            .filter_map(|(i, t)| Some((1001 + i as u32, &**t.as_ref()?)))
    }

    /// The tile under `uv` and uv within it; `None` off the grid or on a missing tile.
    pub fn locate<F: Real>(&self, uv: [F; 2]) -> Option<(&Pyramid, [F; 2])> {
        let (tu, tv) = (uv[0].floor(), uv[1].floor());
        let inside = |t: F, n: usize| t >= F::ZERO && t < F::from_f64(n as f64);
        if !(inside(tu, COLUMNS) && inside(tv, ROWS)) {
            return None;
        }
        let index = tu.to_i32() as usize + COLUMNS * tv.to_i32() as usize;
        let tile = self.tiles.get(index)?.as_deref()?;
        Some((tile, [uv[0] - tu, uv[1] - tv]))
    }
}
